// Import files and whole sites (gis/site_import.h; docs/gis.md): the imported site is an ordinary
// site document that a scenario and POST /v1/sites accept, and a run on it works.
#include "gis/site_import.h"

#include <gtest/gtest.h>

#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "api/site_document.h"
#include "api/test_support.h"
#include "core/run/run.h"
#include "formats/results_h5.h"
#include "gis/results_export.h"
#include "gis_fixtures.h"

namespace fragsim::gis {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using testing::RasterFixture;
using testing::write_geotiff;
using testing::write_layer;

class SiteImportTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_gis_site_"); }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  Json import_file() const {
    return Json::parse(R"({
      "schema": "fragsim.site_import/1",
      "terrain": {"path": "dem.tif", "material": "soil", "nodata": "fill"},
      "buildings": {"path": "b.gpkg", "id_attribute": "name", "height_attribute": "h",
                    "wall": "concrete_wall", "roof": "concrete_wall"},
      "materials": {"soil": {"friction": 0.6},
                    "concrete_wall": {"friction": 0.5, "penetration": {"ke_per_area_j_per_m2": 1e6}}},
      "origin_elevation_m": 0
    })");
  }

  std::pair<std::string, std::string> parse_error(const Json& j) {
    try {
      parse_site_import(j, dir_);
    } catch (const InputError& e) {
      return {e.field(), e.message()};
    }
    return {"<no error>", ""};
  }

  std::filesystem::path dir_;
};

TEST_F(SiteImportTest, AnImportedSiteRunsLikeAnyOther) {
  RasterFixture f;
  f.cols = 40;
  f.rows = 40;  // 452000-452400 E, 3838640-3839040 N, with one nodata cell
  f.nodata = -9999;
  f.z = [](int col, int row) { return col == 7 && row == 9 ? -9999 : 400 + 0.1 * col; };
  write_geotiff(dir_ / "dem.tif", f);
  write_layer(dir_ / "b.gpkg", "EPSG:32611", {"name", "h"},
              {{"POLYGON ((452250 3838800,452270 3838800,452270 3838820,452250 3838820,452250 "
                "3838800))",
                {{"name", "B1"}, {"h", "6"}}}});
  const SiteImport spec = parse_site_import(import_file(), dir_);
  EXPECT_EQ(spec.terrain.path, (dir_ / "dem.tif").string());
  const ImportedSite imported = import_site(spec);
  EXPECT_EQ(imported.site["origin"]["crs"], "EPSG:32611");
  EXPECT_EQ(imported.terrain.filled_cells, 1);
  EXPECT_EQ(imported.buildings, 1u);

  // A scenario on it: launched at the middle of the site, in the CRS's coordinates.
  Json scenario = api::testing::minimal_example();
  scenario["site"] = Json::parse(imported.site.dump());
  scenario["fragment_groups"][0]["frame"]["origin_m"] = {452200, 3838840, 405};
  scenario["fragment_groups"][0]["samples"] = 200;
  const api::ScenarioDocument doc = api::parse_scenario_document(scenario);
  const auto site = api::validate_scenario(doc.scenario);
  EXPECT_EQ(site->terrain_triangle_count(), 2u * 39 * 39);
  EXPECT_EQ(site->buildings().size(), 1u);
  const run::RunResult r = run::run(doc.scenario);
  EXPECT_EQ(r.histories_done, 200);
  // And the daemon's form: a site document.
  EXPECT_NO_THROW(api::build_site(api::parse_site_document(scenario["site"])));
}

TEST_F(SiteImportTest, TheImportFileIsCheckedLikeAScenario) {
  Json j = import_file();
  j["terrain"]["nodata"] = "guess";
  EXPECT_EQ(parse_error(j),
            (std::pair<std::string, std::string>{
                "terrain.nodata", "must be \"refuse\" or \"fill\" (got \"guess\")"}));
  j = import_file();
  j["terrain"]["spacing"] = 5;
  EXPECT_EQ(parse_error(j).first, "terrain.spacing");
  EXPECT_EQ(parse_error(j).second, "unknown key (did you mean \"spacing_m\"?)");
  j = import_file();
  j["schema"] = "fragsim.scenario/1";
  EXPECT_EQ(parse_error(j).first, "schema");
  j = import_file();
  j["terrain"]["window_m"] = {{"center_m", {452200, 3838840}}, {"radius_m", 100}};
  EXPECT_EQ(*parse_site_import(j, dir_).terrain.window_m,
            (std::array<double, 4>{452100, 3838740, 452300, 3838940}));
  j["terrain"]["window_m"] = {452300, 0, 452100, 10};
  EXPECT_EQ(parse_error(j).first, "terrain.window_m");
  j = import_file();
  j["buildings"].erase("height_attribute");
  const SiteImport no_height = parse_site_import(j, dir_);
  EXPECT_TRUE(no_height.buildings->height_attribute.empty());
}

TEST_F(SiteImportTest, ADemImportedRunAndExportedComesBackOnItsOwnCellsAndCrs) {
  // The round trip of docs/gis.md: a GeoTIFF DEM -> site -> run -> ptn_density.tif with the
  // DEM's CRS and geotransform (each output cell centred on its DEM sample), and the fragments
  // per m2 conserved: sum over cells of mean x covered area = sum over triangles.
  RasterFixture f;
  f.cols = 41;
  f.rows = 41;  // 10 m cells, 452000-452410 E, 3838630-3839040 N
  f.z = [](int col, int row) { return 400 + 0.05 * col + 0.02 * row; };
  write_geotiff(dir_ / "dem.tif", f);
  Json imp = import_file();
  imp.erase("buildings");
  const ImportedSite imported = import_site(parse_site_import(imp, dir_));
  Json scenario = api::testing::minimal_example();
  scenario["site"] = Json::parse(imported.site.dump());
  scenario["site"]["materials"]["concrete_wall"] = {{"friction", 0.5}};
  scenario["site"]["materials"]["metal_roof"] = {{"friction", 0.5}};
  auto& g = scenario["fragment_groups"][0];
  g["frame"]["origin_m"] = {452205, 3838835, 412};
  g["speed_mps"] = {{"dist", "normal"}, {"mean", 60}, {"sigma", 5}};
  g["direction"]["elevation_deg"] = {40, 80};
  const api::ScenarioDocument doc = api::parse_scenario_document(scenario);
  const auto site = api::validate_scenario(doc.scenario);
  formats::OutputDir out(dir_ / "run");
  api::stage_run_outputs(out, run::run(doc.scenario), *site, doc, api::build_provenance());
  out.commit();
  const fs::path h5 = dir_ / "run" / "results.h5";
  export_results({h5, dir_ / "gis", std::nullopt});

  GDALDatasetUniquePtr dem(GDALDataset::Open((dir_ / "dem.tif").c_str(), GDAL_OF_RASTER));
  GDALDatasetUniquePtr ptn(
      GDALDataset::Open((dir_ / "gis/ptn_density.tif").c_str(), GDAL_OF_RASTER));
  ASSERT_TRUE(dem && ptn);
  EXPECT_TRUE(ptn->GetSpatialRef()->IsSame(dem->GetSpatialRef()));
  double a[6], b[6];
  dem->GetGeoTransform(a);
  ptn->GetGeoTransform(b);
  EXPECT_EQ(std::vector<double>(a, a + 6), std::vector<double>(b, b + 6));
  ASSERT_EQ(ptn->GetRasterXSize(), 41);
  ASSERT_EQ(ptn->GetRasterYSize(), 41);
  std::vector<double> v(41 * 41);
  ASSERT_EQ(
      ptn->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, 41, 41, v.data(), 41, 41, GDT_Float64, 0, 0),
      CE_None);
  double cells = 0;  // interior cells are covered whole, edge cells half, corners a quarter
  for (int row = 0; row < 41; ++row)
    for (int col = 0; col < 41; ++col) {
      const double cover =
          (col == 0 || col == 40 ? 0.5 : 1.0) * (row == 0 || row == 40 ? 0.5 : 1.0);
      cells += v[row * 41 + col] * cover * 100.0;
    }
  const auto d = formats::read_dataset_double(h5, "/ptn/density_per_m2");
  double triangles = 0;  // each of the 2 x 40 x 40 triangles covers 50 m2 in plan
  for (const double x : d) triangles += 50.0 * x;
  ASSERT_GT(triangles, 0.0);
  EXPECT_NEAR(cells, triangles, 1e-9 * triangles);
}

}  // namespace
}  // namespace fragsim::gis
