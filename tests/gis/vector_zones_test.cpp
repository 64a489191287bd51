// Material zones from a GIS layer (gis/vector_zones.h) through the import file: each polygon a
// zone in layer order, each part of a multipolygon one zone; holes and unknown materials refused
// naming the feature.
#include "gis/vector_zones.h"

#include <gtest/gtest.h>

#include "api/test_support.h"
#include "core/common/error.h"
#include "gis/site_import.h"
#include "gis_fixtures.h"
#include "mesh_fixtures.h"

namespace fragsim::gis {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using testing::write_layer;

class VectorZonesTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_gis_zones_"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(VectorZonesTest, PolygonsBecomeZonesInLayerOrder) {
  write_layer(dir_ / "z.gpkg", "EPSG:32611", {"material"},
              {{"POLYGON ((452000 3839000,452010 3839000,452010 3839010,452000 3839000))",
                {{"material", "rock"}}},
               {"MULTIPOLYGON (((452001 3839001,452004 3839001,452004 3839004,452001 3839001)),"
                "((452006 3839001,452009 3839001,452009 3839004,452006 3839001)))",
                {{"material", "hard"}}}},
              "GPKG", "zones");
  // A mesh terrain in the same CRS under them (coordinates unchanged).
  const testing::MeshFixture ground = {
      {{452000, 3839000, 10}, {452010, 3839000, 10}, {452010, 3839010, 11}, {452000, 3839010, 11}},
      {{0, 1, 2}, {0, 2, 3}},
      {}};
  testing::write_mesh(dir_ / "ground", ground, testing::MeshFormat::kPlyAscii);
  const Json j = {
      {"schema", "fragsim.site_import/1"},
      {"terrain",
       {{"meshes", {{{"path", "ground.ply"}, {"material", "soil"}}}}, {"crs", "EPSG:32611"}}},
      {"zones", {{"path", "z.gpkg"}, {"layer", "zones"}, {"material_attribute", "material"}}},
      {"materials", {{"soil", {{"friction", 0.8}}}, {"rock", {{"friction", 0.6}}}}}};
  const ImportedSite s = import_site(parse_site_import(j, dir_));
  EXPECT_EQ(s.zones, 3u);
  EXPECT_EQ(s.site["origin"]["crs"], "EPSG:32611");
  const Json zones = Json::parse(s.site["terrain"]["zones"].dump());
  EXPECT_EQ(zones, Json::parse(R"([
    {"material": "rock", "polygon_m": [[452000, 3839000], [452010, 3839000], [452010, 3839010]]},
    {"material": "hard", "polygon_m": [[452001, 3839001], [452004, 3839001], [452004, 3839004]]},
    {"material": "hard", "polygon_m": [[452006, 3839001], [452009, 3839001], [452009, 3839004]]}
  ])"));

  // A hole, and a material that is not in the import.
  write_layer(dir_ / "bad.gpkg", "EPSG:32611", {"material"},
              {{"POLYGON ((452000 3839000,452010 3839000,452010 3839010,452000 3839010,452000 "
                "3839000),(452002 3839002,452004 3839002,452004 3839004,452002 3839002))",
                {{"material", "rock"}}}},
              "GPKG", "zones");
  const std::vector<std::string> names = {"hard", "soft", "rock"};
  OGRSpatialReference srs = crs_from_text("EPSG:32611", "crs");
  const ZonesImport bad{(dir_ / "bad.gpkg").string(), "zones", "material", ""};
  try {
    import_zones(bad, srs, names);
    ADD_FAILURE() << "a hole was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.what(), "zones: " + bad.path +
                            ", layer \"zones\": feature 1: has a hole (interior ring); zones have "
                            "none: give the hole its own zone after this one (a later zone wins)");
  }
  try {
    import_zones({(dir_ / "z.gpkg").string(), "zones", "material", ""}, srs, {"hard", "soft"});
    ADD_FAILURE() << "an unknown material was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.what(), "zones: " + (dir_ / "z.gpkg").string() +
                            ", layer \"zones\": feature 1: material \"rock\" is not a key of "
                            "materials (nor \"hard\" or \"soft\")");
  }
}

}  // namespace
}  // namespace fragsim::gis
