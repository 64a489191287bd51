// Import files and whole sites (gis/site_import.h; docs/gis.md): the imported site is an ordinary
// site document that a scenario and POST /v1/sites accept, and a run on it works.
#include "gis/site_import.h"

#include <gtest/gtest.h>

#include "api/scenario_json.h"
#include "api/site_document.h"
#include "api/test_support.h"
#include "core/run/run.h"
#include "gis_fixtures.h"

namespace fragsim::gis {
namespace {

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

}  // namespace
}  // namespace fragsim::gis
