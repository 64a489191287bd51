// A site as GIS files and back (gis/site_to_gis.h; docs/gis.md): `site export-gis` then
// `site import` gives the same terrain samples to the bit and the same footprints, heights,
// courtyards and materials, moved from site-local to absolute CRS coordinates; the demo's shipped
// GIS files (examples/demo/gis) still match the demo.
#include "gis/site_to_gis.h"

#include <gtest/gtest.h>

#include "api/site_document.h"
#include "api/test_support.h"
#include "core/common/error.h"
#include "gis/site_import.h"

namespace fragsim::gis {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

Json demo_site() {
  return Json::parse(api::testing::read_text(fs::path(FRAGSIM_SOURCE_DIR) /
                                             "examples/demo/scenario.json"))["site"];
}

Json import_back(const fs::path& import_json) {
  const Json j = Json::parse(api::testing::read_text(import_json));
  const ImportedSite s = import_site(parse_site_import(j, import_json.parent_path()));
  return Json::parse(s.site.dump());
}

// `back` (absolute coordinates) is `site` (local coordinates + origin offset).
void expect_same_site(const Json& site, const Json& back) {
  const double e = site["origin"]["easting_m"], n = site["origin"]["northing_m"];
  EXPECT_EQ(back["origin"]["crs"], site["origin"]["crs"]);
  EXPECT_EQ(back["origin"]["easting_m"], 0.0);
  EXPECT_EQ(back["origin"]["elevation_m"], site["origin"]["elevation_m"]);
  const Json& g0 = site["terrain"]["grid"];
  const Json& g1 = back["terrain"]["grid"];
  EXPECT_EQ(g1["nx"], g0["nx"]);
  EXPECT_EQ(g1["ny"], g0["ny"]);
  EXPECT_EQ(g1["spacing_m"].get<double>(), g0["spacing_m"].get<double>());
  EXPECT_EQ(g1["origin_m"][0].get<double>(), g0["origin_m"][0].get<double>() + e);
  EXPECT_EQ(g1["origin_m"][1].get<double>(), g0["origin_m"][1].get<double>() + n);
  ASSERT_EQ(g1["elevation_m"].size(), g0["elevation_m"].size());
  for (std::size_t k = 0; k < g0["elevation_m"].size(); ++k)
    ASSERT_EQ(g1["elevation_m"][k].get<double>(), g0["elevation_m"][k].get<double>()) << k;
  EXPECT_EQ(back["terrain"]["material"], site["terrain"]["material"]);
  EXPECT_EQ(back["materials"], site["materials"]);
  ASSERT_EQ(back["buildings"].size(), site["buildings"].size());
  for (std::size_t b = 0; b < site["buildings"].size(); ++b) {
    const Json& s = site["buildings"][b];
    const Json& t = back["buildings"][b];
    EXPECT_EQ(t["id"], s["id"]);
    EXPECT_EQ(t["height_m"].get<double>(), s["height_m"].get<double>());
    EXPECT_EQ(t.contains("base_elevation_m"), s.contains("base_elevation_m"));
    for (const char* k : {"wall", "roof", "window"}) EXPECT_EQ(t.value(k, ""), s.value(k, "")) << k;
    ASSERT_EQ(t["footprint_m"].size(), s["footprint_m"].size()) << s["id"];
    for (std::size_t v = 0; v < s["footprint_m"].size(); ++v) {
      EXPECT_NEAR(t["footprint_m"][v][0].get<double>(), s["footprint_m"][v][0].get<double>() + e,
                  1e-9);
      EXPECT_NEAR(t["footprint_m"][v][1].get<double>(), s["footprint_m"][v][1].get<double>() + n,
                  1e-9);
    }
    EXPECT_EQ(t.contains("holes_m"), s.contains("holes_m"));
  }
  EXPECT_NO_THROW(api::build_site(api::parse_site_document(back)));
}

class SiteToGis : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_gis_to_gis_"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(SiteToGis, TheDemoSiteComesBackFromItsGisFiles) {
  const Json site = demo_site();
  const SiteGisReport r = write_site_gis(site, dir_ / "gis");
  EXPECT_EQ(r.files, (std::vector<std::string>{"terrain.tif", "buildings.gpkg", "import.json"}));
  expect_same_site(site, import_back(dir_ / "gis" / "import.json"));
}

TEST_F(SiteToGis, TheShippedDemoGisFilesMatchTheDemo) {
  // examples/demo/gis/make.sh made them; rerun it after changing the demo site.
  expect_same_site(demo_site(),
                   import_back(fs::path(FRAGSIM_SOURCE_DIR) / "examples/demo/gis" / "import.json"));
}

TEST_F(SiteToGis, ACourtyardGoesOutAsAHoleAndComesBack) {
  Json site = demo_site();
  Json& b = site["buildings"][0];
  b.erase("holes_m");
  // A courtyard in the middle of the first footprint's bounding box, a tenth of its size.
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& p : b["footprint_m"]) {
    x0 = std::min(x0, p[0].get<double>()), x1 = std::max(x1, p[0].get<double>());
    y0 = std::min(y0, p[1].get<double>()), y1 = std::max(y1, p[1].get<double>());
  }
  const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1), hx = 0.05 * (x1 - x0),
               hy = 0.05 * (y1 - y0);
  b["holes_m"] = {{{cx - hx, cy - hy}, {cx + hx, cy - hy}, {cx + hx, cy + hy}, {cx - hx, cy + hy}}};
  ASSERT_NO_THROW(api::build_site(api::parse_site_document(site)));
  write_site_gis(site, dir_ / "gis");
  const Json back = import_back(dir_ / "gis" / "import.json");
  expect_same_site(site, back);
  ASSERT_EQ(back["buildings"][0]["holes_m"].size(), 1u);
  EXPECT_EQ(back["buildings"][0]["holes_m"][0].size(), 4u);
}

TEST_F(SiteToGis, ASiteWithoutCrsOrGridIsRefused) {
  Json site = demo_site();
  site["origin"]["crs"] = "";
  EXPECT_THROW(write_site_gis(site, dir_ / "a"), InputError);
  site = api::testing::minimal_example()["site"];  // a plane
  site["origin"]["crs"] = "EPSG:32611";
  try {
    write_site_gis(site, dir_ / "b");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "site.terrain");
  }
  EXPECT_FALSE(fs::exists(dir_ / "a"));
  EXPECT_FALSE(fs::exists(dir_ / "b"));
}

}  // namespace
}  // namespace fragsim::gis
