// Terrain from GDAL rasters (gis/raster_terrain.h; docs/gis.md "Terrain"): the vertices are the
// raster's cell centres to the last bit, nodata refused or filled, windows, resampling, CRS
// checks, units. Fixtures are written with GDAL in each test.
#include "gis/raster_terrain.h"

#include <gtest/gtest.h>

#include <cmath>

#include "api/test_support.h"
#include "core/common/error.h"
#include "gis_fixtures.h"

namespace fragsim::gis {
namespace {

using testing::RasterFixture;
using testing::write_geotiff;

class RasterTerrain : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_gis_raster_"); }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  TerrainImport spec_for(const RasterFixture& f, const std::string& name = "dem.tif") {
    write_geotiff(dir_ / name, f);
    TerrainImport t;
    t.path = (dir_ / name).string();
    t.material = "soil";
    return t;
  }
  // field and message of the InputError import_terrain throws ("<no error>" if none)
  std::pair<std::string, std::string> error_of(const TerrainImport& t) {
    try {
      import_terrain(t);
    } catch (const InputError& e) {
      return {e.field(), e.message()};
    }
    return {"<no error>", ""};
  }

  std::filesystem::path dir_;
};

TEST_F(RasterTerrain, NorthUpSquareCellsBecomeAGridOfTheCellCentres) {
  RasterFixture f;  // 5 x 4 cells of 10 m, upper-left corner (452000, 3839040), EPSG:32611
  const ImportedTerrain t = import_terrain(spec_for(f));
  ASSERT_TRUE(t.as_grid);
  EXPECT_EQ(crs_name(t.srs), "EPSG:32611");
  const auto& g = t.terrain["grid"];
  EXPECT_EQ(g["nx"], 5);
  EXPECT_EQ(g["ny"], 4);
  EXPECT_EQ(g["spacing_m"], 10.0);
  // Vertex (0, 0) is the south-west cell's centre: column 0, row 3.
  EXPECT_EQ(g["origin_m"], nlohmann::ordered_json({452005.0, 3839005.0}));
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 5; ++i)
      EXPECT_EQ(g["elevation_m"][j * 5 + i].get<double>(), f.z(i, 3 - j)) << i << "," << j;
  EXPECT_EQ(t.terrain["material"], "soil");
  ASSERT_EQ(t.outline_m.size(), 4u);
  EXPECT_EQ(t.outline_m[0], Vec2(452005, 3839005));  // counter-clockwise from the south-west
  EXPECT_EQ(t.outline_m[2], Vec2(452045, 3839035));
}

TEST_F(RasterTerrain, AGridRunningEastToWestOrSouthToNorthIsTurnedRoundExactly) {
  RasterFixture f;
  f.geotransform = {452050, -10, 0, 3839000, 0, 10};  // columns run west, rows north
  const ImportedTerrain t = import_terrain(spec_for(f));
  ASSERT_TRUE(t.as_grid);
  const auto& g = t.terrain["grid"];
  EXPECT_EQ(g["origin_m"], nlohmann::ordered_json({452005.0, 3839005.0}));
  // Vertex (i, j): x = 452005 + 10 i is column 4 - i; y = 3839005 + 10 j is row j.
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 5; ++i) EXPECT_EQ(g["elevation_m"][j * 5 + i].get<double>(), f.z(4 - i, j));
}

double signed_area(const nlohmann::ordered_json& v, const nlohmann::ordered_json& tri) {
  const auto p = [&](int k) { return v[tri[k].get<std::size_t>()]; };
  const double ax = p(0)[0], ay = p(0)[1];
  return 0.5 * ((p(1)[0].get<double>() - ax) * (p(2)[1].get<double>() - ay) -
                (p(2)[0].get<double>() - ax) * (p(1)[1].get<double>() - ay));
}

TEST_F(RasterTerrain, RectangularOrRotatedCellsBecomeAMeshOfTheCellCentres) {
  const double c = std::cos(0.3), s = std::sin(0.3);
  for (const auto& gt :
       {std::array<double, 6>{452000, 10, 0, 3839040, 0, -5},
        std::array<double, 6>{452000, 10 * c, -10 * s, 3839040, -10 * s, -10 * c}}) {
    RasterFixture f;
    f.geotransform = gt;
    const ImportedTerrain t = import_terrain(spec_for(f));
    ASSERT_FALSE(t.as_grid);
    const auto& v = t.terrain["mesh"]["vertices_m"];
    const auto& tris = t.terrain["mesh"]["triangles"];
    ASSERT_EQ(v.size(), 20u);
    ASSERT_EQ(tris.size(), 2u * 4 * 3);
    for (int row = 0; row < 4; ++row)
      for (int col = 0; col < 5; ++col) {
        const auto& p = v[row * 5 + col];
        // The centre through the geotransform, to 1 mm (the same formula: equal to the bit).
        EXPECT_NEAR(p[0].get<double>(), gt[0] + (col + 0.5) * gt[1] + (row + 0.5) * gt[2], 1e-3);
        EXPECT_NEAR(p[1].get<double>(), gt[3] + (col + 0.5) * gt[4] + (row + 0.5) * gt[5], 1e-3);
        EXPECT_EQ(p[2].get<double>(), f.z(col, row));
      }
    double area = 0;
    for (const auto& tri : tris) {
      EXPECT_GT(signed_area(v, tri), 0) << "counter-clockwise from above";
      area += signed_area(v, tri);
    }
    EXPECT_NEAR(area, 4 * 3 * std::abs(gt[1] * gt[5] - gt[2] * gt[4]), 1e-6);
  }
}

TEST_F(RasterTerrain, NodataIsRefusedWithWhereOrFilled) {
  RasterFixture f;
  f.nodata = -9999;
  f.z = [](int col, int row) {
    return (col == 2 && row == 1) || (col == 3 && row == 2) ? -9999 : 400.0 + col;
  };
  TerrainImport t = spec_for(f);
  const auto [field, message] = error_of(t);
  EXPECT_EQ(field, "terrain.nodata");
  EXPECT_NE(message.find("2 cells have no data (the first: column 2, row 1 at (452025, 3839025))"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("\"nodata\": \"fill\""), std::string::npos) << message;

  t.nodata = TerrainImport::Nodata::kFill;
  const ImportedTerrain filled = import_terrain(t);
  EXPECT_EQ(filled.filled_cells, 2);
  const auto& z = filled.terrain["grid"]["elevation_m"];
  // Row 1 is j = 2, row 2 is j = 1. Filled from neighbours between 401 and 404.
  for (const double v : {z[2 * 5 + 2].get<double>(), z[1 * 5 + 3].get<double>()}) {
    EXPECT_GE(v, 400.0);
    EXPECT_LE(v, 404.0);
  }
  EXPECT_EQ(z[0].get<double>(), 400.0);  // the others untouched
}

TEST_F(RasterTerrain, NodataEverywhereIsAnErrorEvenWhenFilling) {
  RasterFixture f;
  f.nodata = -1;
  f.z = [](int, int) { return -1.0; };
  TerrainImport t = spec_for(f);
  t.nodata = TerrainImport::Nodata::kFill;
  const auto [field, message] = error_of(t);
  EXPECT_EQ(field, "terrain.path");
  EXPECT_NE(message.find("every cell is nodata"), std::string::npos) << message;
}

TEST_F(RasterTerrain, AWindowTakesTheCellsWhoseCentresFallInside) {
  RasterFixture f;
  f.cols = 20;
  f.rows = 20;  // x 452000-452200, y 3838840-3839040
  TerrainImport t = spec_for(f);
  t.window_m = std::array<double, 4>{452031, 3838900, 452080, 3838950};
  const ImportedTerrain w = import_terrain(t);
  const auto& g = w.terrain["grid"];
  // Centres 452035 ... 452075 (5) and 3838905 ... 3838945 (5).
  EXPECT_EQ(g["nx"], 5);
  EXPECT_EQ(g["ny"], 5);
  EXPECT_EQ(g["origin_m"], nlohmann::ordered_json({452035.0, 3838905.0}));
  // Row of y = 3838905 is (3839040 - 3838905) / 10 - 0.5 = 13; column of x = 452035 is 3.
  EXPECT_EQ(g["elevation_m"][0].get<double>(), f.z(3, 13));

  t.window_m = std::array<double, 4>{500000, 0, 500100, 100};
  EXPECT_EQ(error_of(t).first, "terrain.window_m");
}

TEST_F(RasterTerrain, ResamplingGivesSquareCellsOfTheSpacingAskedFor) {
  RasterFixture f;
  f.cols = 21;
  f.rows = 11;
  f.geotransform = {452000, 10, 0, 3839040, 0, -20};  // rectangular cells
  f.z = [](int col, int row) { return 400 + 0.5 * col - 0.25 * row; };
  TerrainImport t = spec_for(f);
  t.spacing_m = 5.0;
  t.window_m = std::array<double, 4>{452050, 3838880, 452150, 3838980};
  const ImportedTerrain r = import_terrain(t);
  ASSERT_TRUE(r.as_grid);
  const auto& g = r.terrain["grid"];
  EXPECT_EQ(g["spacing_m"], 5.0);
  EXPECT_EQ(g["nx"], 20);
  EXPECT_EQ(g["ny"], 20);
  // Bilinear resampling reproduces a linear field: z = 400 + 0.5 (x - x0)/10 - 0.25 (y0 - y)/20
  // at cell centres (col = (x - 452000)/10 - 0.5, row = (3839040 - y)/20 - 0.5).
  const double x0 = g["origin_m"][0], y0 = g["origin_m"][1];
  for (int j = 2; j < 18; j += 5)
    for (int i = 2; i < 18; i += 5) {
      const double x = x0 + 5 * i, y = y0 + 5 * j;
      const double col = (x - 452000) / 10 - 0.5, row = (3839040 - y) / 20 - 0.5;
      EXPECT_NEAR(g["elevation_m"][j * 20 + i].get<double>(), 400 + 0.5 * col - 0.25 * row, 1e-9);
    }
}

TEST_F(RasterTerrain, AGeographicRasterIsRefusedUnlessReprojected) {
  RasterFixture f;
  f.crs = "EPSG:4326";
  f.cols = 40;
  f.rows = 40;
  f.geotransform = {-117.52, 0.001, 0, 34.72, 0, -0.001};  // about 90 m x 110 m cells
  TerrainImport t = spec_for(f);
  const auto [field, message] = error_of(t);
  EXPECT_EQ(field, "terrain.path");
  EXPECT_NE(message.find("WGS 84, a geographic CRS (degrees)"), std::string::npos) << message;
  EXPECT_NE(message.find("terrain.crs"), std::string::npos) << message;

  t.crs = "EPSG:32611";
  t.spacing_m = 50;
  // Inside the raster's footprint in UTM 11N (it spans about 452-456 km E, 3838-3842 km N).
  t.window_m = std::array<double, 4>{453000, 3839000, 455000, 3841000};
  const ImportedTerrain r = import_terrain(t);
  EXPECT_EQ(crs_name(r.srs), "EPSG:32611");
  EXPECT_EQ(r.terrain["grid"]["nx"], 40);
  EXPECT_EQ(r.filled_cells, 0);
}

TEST_F(RasterTerrain, NoCrsNeedsSourceCrs) {
  RasterFixture f;
  f.crs = "";
  TerrainImport t = spec_for(f);
  const auto [field, message] = error_of(t);
  EXPECT_EQ(field, "terrain.path");
  EXPECT_NE(message.find("no coordinate reference system; give terrain.source_crs"),
            std::string::npos);
  t.source_crs = "EPSG:32611";
  EXPECT_EQ(crs_name(import_terrain(t).srs), "EPSG:32611");
  t.source_crs = "EPSG:999999";
  EXPECT_EQ(error_of(t).first, "terrain.source_crs");
}

TEST_F(RasterTerrain, FeetAndScaledValuesBecomeMetres) {
  RasterFixture f;
  f.unit = "ft";
  f.type = GDT_Int16;
  f.scale = 0.5;
  f.offset = 100;
  f.z = [](int col, int) { return 2.0 * col; };  // stored; value = 0.5 * stored + 100 ft
  const ImportedTerrain t = import_terrain(spec_for(f));
  EXPECT_DOUBLE_EQ(t.terrain["grid"]["elevation_m"][3].get<double>(), (0.5 * 6 + 100) * 0.3048);
  f.unit = "fathom";
  EXPECT_NE(error_of(spec_for(f, "fathoms.tif")).second.find("\"fathom\""), std::string::npos);
}

TEST_F(RasterTerrain, MissingOrUnreadableFilesNameTheFile) {
  TerrainImport t;
  t.path = (dir_ / "nope.tif").string();
  auto [field, message] = error_of(t);
  EXPECT_EQ(field, "terrain.path");
  EXPECT_EQ(message.rfind(t.path + ": cannot be opened as a raster", 0), 0u) << message;
  std::ofstream(dir_ / "text.tif") << "not a raster\n";
  t.path = (dir_ / "text.tif").string();
  std::tie(field, message) = error_of(t);
  EXPECT_EQ(field, "terrain.path");
  EXPECT_NE(message.find("cannot be opened as a raster"), std::string::npos);
  RasterFixture f;
  TerrainImport banded = spec_for(f);
  banded.band = 2;
  EXPECT_EQ(error_of(banded),
            (std::pair<std::string, std::string>{
                "terrain.band", "must be in [1, 1] (" + banded.path + " has 1 bands)"}));
}

}  // namespace
}  // namespace fragsim::gis
