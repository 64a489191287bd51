// Buildings from OGR layers (gis/vector_buildings.h; docs/gis.md "Buildings"): reprojection to
// 1 mm, courtyards as holes, multipolygons split, heights and materials from attributes, and
// every feature that cannot be imported reported by its id.
#include "gis/vector_buildings.h"

#include <gtest/gtest.h>

#include <memory>

#include "api/test_support.h"
#include "core/common/error.h"
#include "gis_fixtures.h"

namespace fragsim::gis {
namespace {

using testing::FeatureFixture;
using testing::write_layer;
using OJson = nlohmann::ordered_json;

// The terrain: 452000-452400 E, 3839000-3839400 N (UTM 11N).
const std::vector<Vec2> kOutline = {
    {452000, 3839000}, {452400, 3839000}, {452400, 3839400}, {452000, 3839400}};

std::string square(double x, double y, double s) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "POLYGON ((%.3f %.3f,%.3f %.3f,%.3f %.3f,%.3f %.3f,%.3f %.3f))", x,
                y, x + s, y, x + s, y + s, x, y + s, x, y);
  return buf;
}

class VectorBuildings : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = api::testing::fresh_test_dir("fragsim_gis_vector_");
    site_ = crs_from_text("EPSG:32611", "crs");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  BuildingsImport spec(const std::string& file = "b.gpkg") {
    BuildingsImport b;
    b.path = (dir_ / file).string();
    b.id_attribute = "name";
    b.height_attribute = "h";
    return b;
  }
  std::string error_of(const BuildingsImport& b) {
    try {
      import_buildings(b, site_, kOutline);
    } catch (const InputError& e) {
      return e.field() + ": " + e.message();
    }
    return "<no error>";
  }

  std::filesystem::path dir_;
  OGRSpatialReference site_;
};

TEST_F(VectorBuildings, FootprintsWithHeightsAndMaterials) {
  write_layer(
      dir_ / "b.gpkg", "EPSG:32611", {"name", "h", "wall"},
      {{square(452100, 3839100, 20), {{"name", "B1"}, {"h", "6.5"}, {"wall", "brick"}}},
       {square(452200, 3839200, 10), {{"name", "B2"}, {"h", "3"}, {"wall", std::nullopt}}}});
  BuildingsImport b = spec();
  b.wall_attribute = "wall";
  b.roof = "tin";
  const OJson out = import_buildings(b, site_, kOutline);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0]["id"], "B1");
  EXPECT_EQ(out[0]["height_m"], 6.5);
  EXPECT_EQ(out[0]["wall"], "brick");
  EXPECT_EQ(out[1]["wall"], "concrete_wall");  // null attribute: the default
  EXPECT_EQ(out[0]["roof"], "tin");
  EXPECT_FALSE(out[0].contains("holes_m"));
  EXPECT_FALSE(out[0].contains("base_elevation_m"));
  // The ring without its closing vertex.
  EXPECT_EQ(out[0]["footprint_m"], OJson({{452100.0, 3839100.0},
                                          {452120.0, 3839100.0},
                                          {452120.0, 3839120.0},
                                          {452100.0, 3839120.0}}));
}

TEST_F(VectorBuildings, AnotherCrsIsReprojectedToTheMillimetre) {
  // Footprint corners known in UTM 11N, written in WGS 84 (lon, lat): imported back to UTM.
  const OGRSpatialReference utm = crs_from_text("EPSG:32611", "x");
  const OGRSpatialReference wgs = crs_from_text("EPSG:4326", "x");
  std::unique_ptr<OGRCoordinateTransformation> to_wgs(
      OGRCreateCoordinateTransformation(&utm, &wgs));
  const std::vector<std::array<double, 2>> corners = {
      {452150.125, 3839150.5}, {452180.25, 3839150.5}, {452180.25, 3839190.75}};
  std::string wkt = "POLYGON ((";
  for (std::size_t k = 0; k <= corners.size(); ++k) {
    double x = corners[k % corners.size()][0], y = corners[k % corners.size()][1];
    ASSERT_TRUE(to_wgs->Transform(1, &x, &y));
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s%.12f %.12f", k ? "," : "", x, y);
    wkt += buf;
  }
  wkt += "))";
  write_layer(dir_ / "b.gpkg", "EPSG:4326", {"name", "h"}, {{wkt, {{"name", "W"}, {"h", "5"}}}});
  const OJson out = import_buildings(spec(), site_, kOutline);
  ASSERT_EQ(out.size(), 1u);
  ASSERT_EQ(out[0]["footprint_m"].size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(out[0]["footprint_m"][k][0].get<double>(), corners[k][0], 1e-3);
    EXPECT_NEAR(out[0]["footprint_m"][k][1].get<double>(), corners[k][1], 1e-3);
  }
}

TEST_F(VectorBuildings, CourtyardsAreHolesAndMultipolygonsArePartsOfTheirOwn) {
  const std::string courtyard =
      "POLYGON ((452100 3839100,452150 3839100,452150 3839150,452100 3839150,452100 3839100),"
      "(452120 3839120,452130 3839120,452130 3839130,452120 3839130,452120 3839120))";
  const std::string two =
      "MULTIPOLYGON (((452200 3839200,452210 3839200,452210 3839210,"
      "452200 3839200)),((452250 3839250,452260 3839250,452260 3839260,"
      "452250 3839250)))";
  write_layer(dir_ / "b.gpkg", "EPSG:32611", {"name", "h"},
              {{courtyard, {{"name", "C"}, {"h", "8"}}}, {two, {{"name", "M"}, {"h", "4"}}}});
  const OJson out = import_buildings(spec(), site_, kOutline);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0]["id"], "C");
  ASSERT_EQ(out[0]["holes_m"].size(), 1u);
  EXPECT_EQ(out[0]["holes_m"][0].size(), 4u);
  EXPECT_EQ(out[1]["id"], "M-1");
  EXPECT_EQ(out[2]["id"], "M-2");
  EXPECT_EQ(out[2]["height_m"], 4.0);
}

TEST_F(VectorBuildings, EveryBadFeatureIsReportedByItsIdTogether) {
  write_layer(dir_ / "b.gpkg", "EPSG:32611", {"name", "h"},
              {{square(452100, 3839100, 20), {{"name", "ok"}, {"h", "5"}}},
               {"POLYGON ((452100 3839200,452120 3839220,452120 3839200,452100 3839220,452100 "
                "3839200))",
                {{"name", "bowtie"}, {"h", "5"}}},
               {square(452500, 3839100, 20), {{"name", "far"}, {"h", "5"}}},
               {"LINESTRING (452100 3839100,452120 3839120)", {{"name", "line"}, {"h", "5"}}},
               {square(452300, 3839300, 1e-3), {{"name", "speck"}, {"h", "5"}}},
               {square(452200, 3839100, 20), {{"name", "flat"}, {"h", std::nullopt}}},
               {square(452250, 3839100, 20), {{"name", "neg"}, {"h", "-2"}}},
               {square(452300, 3839100, 20), {{"name", "ok"}, {"h", "5"}}}});
  const std::string e = error_of(spec());
  const std::string where = (dir_ / "b.gpkg").string() + ", layer \"footprints\"";
  EXPECT_EQ(e.rfind("buildings: " + where + ": 7 of 8 features cannot be imported:", 0), 0u) << e;
  for (const char* expected :
       {"feature 2 (id \"bowtie\"): invalid polygon", "Self-intersection",
        "feature 3 (id \"far\"): lies outside the terrain (vertex 0 at (452500.000, 3839100.000))",
        "feature 4 (id \"line\"): is a LINESTRING, not a polygon",
        "feature 5 (id \"speck\"): degenerate footprint",
        "feature 6 (id \"flat\"): attribute \"h\" is null and no default_height_m is given",
        "feature 7 (id \"neg\"): height -2.000000 m: must be > 0",
        "feature 8 (id \"ok\"): duplicate id \"ok\""})
    EXPECT_NE(e.find(expected), std::string::npos) << expected << "\n" << e;
}

TEST_F(VectorBuildings, ADefaultHeightFillsNulls) {
  write_layer(dir_ / "b.gpkg", "EPSG:32611", {"name", "h"},
              {{square(452200, 3839100, 20), {{"name", "flat"}, {"h", std::nullopt}}}});
  BuildingsImport b = spec();
  b.default_height_m = 7.0;
  EXPECT_EQ(import_buildings(b, site_, kOutline)[0]["height_m"], 7.0);
}

TEST_F(VectorBuildings, LayerAndAttributeErrorsNameWhatExists) {
  write_layer(dir_ / "b.gpkg", "EPSG:32611", {"name", "height"},
              {{square(452200, 3839100, 20), {{"name", "x"}, {"height", "3"}}}});
  const std::string where = (dir_ / "b.gpkg").string();
  EXPECT_EQ(error_of(spec()), "buildings.height_attribute: " + where +
                                  ", layer \"footprints\": no attribute \"h\" (its attributes: "
                                  "\"name\", \"height\")");
  BuildingsImport b = spec();
  b.height_attribute = "height";
  b.layer = "roads";
  EXPECT_EQ(error_of(b), "buildings.layer: " + where +
                             ": no layer \"roads\" (its layers: "
                             "\"footprints\")");
  b.layer = "";
  b.path = (dir_ / "missing.gpkg").string();
  EXPECT_EQ(error_of(b).rfind("buildings.path: " + b.path + ": cannot be opened as a vector", 0),
            0u);
}

TEST_F(VectorBuildings, ShapefilesAndGeoJsonToo) {
  write_layer(dir_ / "b.shp", "EPSG:32611", {"name", "h"},
              {{square(452100, 3839100, 20), {{"name", "S"}, {"h", "5"}}}}, "ESRI Shapefile", "b");
  EXPECT_EQ(import_buildings(spec("b.shp"), site_, kOutline)[0]["id"], "S");
  write_layer(dir_ / "b.geojson", "EPSG:32611", {"name", "h"},
              {{square(452100, 3839100, 20), {{"name", "G"}, {"h", "5"}}}}, "GeoJSON", "b");
  EXPECT_EQ(import_buildings(spec("b.geojson"), site_, kOutline)[0]["id"], "G");
}

}  // namespace
}  // namespace fragsim::gis
