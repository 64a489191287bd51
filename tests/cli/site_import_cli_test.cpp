// `fragsim site import` from the command line (docs/gis.md): the site file appears only when the
// import succeeds, and bad GIS input exits 2 with a message naming the file, layer and feature.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "api/site_document.h"
#include "api/test_support.h"
#include "cli/cli_process.h"
#include "gis/gis_fixtures.h"
#include "gis/mesh_fixtures.h"

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using fragsim::gis::testing::RasterFixture;

using Result = fragsim::cli::testing::CliResult;

class SiteImportCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fragsim::api::testing::fresh_test_dir("fragsim_cli_site_import_");
    RasterFixture f;
    f.cols = 30;
    f.rows = 30;  // 452000-452300 E, 3838740-3839040 N
    fragsim::gis::testing::write_geotiff(dir_ / "dem.tif", f);
    fragsim::gis::testing::write_layer(
        dir_ / "b.gpkg", "EPSG:32611", {"name", "h"},
        {{"POLYGON ((452100 3838800,452120 3838800,452120 3838820,452100 3838820,452100 "
          "3838800))",
          {{"name", "B1"}, {"h", "6"}}}});
    import_ = R"({"schema": "fragsim.site_import/1",
      "terrain": {"path": "dem.tif", "material": "soft"},
      "buildings": {"path": "b.gpkg", "id_attribute": "name", "height_attribute": "h",
                    "wall": "w", "roof": "w"},
      "materials": {"w": {"friction": 0.5}}})";
  }
  void TearDown() override { fs::remove_all(dir_); }

  Result run(const std::vector<std::string>& args) {
    return fragsim::cli::testing::wait_cli(dir_, fragsim::cli::testing::spawn_cli(dir_, args));
  }

  Result import(const std::string& text) {
    std::ofstream(dir_ / "import.json") << text;
    return run({"site", "import", (dir_ / "import.json").string(), "--out",
                (dir_ / "site.json").string()});
  }

  fs::path dir_;
  std::string import_;
};

TEST_F(SiteImportCli, WritesASiteThatParsesAndBuilds) {
  const Result r = import(import_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("CRS: EPSG:32611 (WGS 84 / UTM zone 11N)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("terrain: grid 30 x 30 vertices, 1682 triangles"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("buildings: 1"), std::string::npos) << r.out;
  const Json site = Json::parse(fragsim::api::testing::read_text(dir_ / "site.json"));
  EXPECT_NO_THROW(fragsim::api::build_site(fragsim::api::parse_site_document(site)));
}

TEST_F(SiteImportCli, BadGisInputExits2NamingTheFileAndWritesNothing) {
  Json j = Json::parse(import_);
  j["buildings"]["height_attribute"] = "height";
  Result r = import(j.dump());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "error: buildings.height_attribute: " + (dir_ / "b.gpkg").string() +
                       ", layer \"footprints\": no attribute \"height\" (its attributes: \"name\", "
                       "\"h\")\n");
  EXPECT_FALSE(fs::exists(dir_ / "site.json"));

  j = Json::parse(import_);
  j["terrain"]["path"] = "nope.tif";
  r = import(j.dump());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err.rfind("error: terrain.path: " + (dir_ / "nope.tif").string() +
                            ": cannot be opened as a raster",
                        0),
            0u)
      << r.err;
  // A building whose material the import file does not define: the site check names it.
  j = Json::parse(import_);
  j["buildings"]["wall"] = "granite";
  r = import(j.dump());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(
      r.err.find(
          "the imported site is not valid: buildings[0].wall (building \"B1\"): unknown material"),
      std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "site.json"));

  r = run({"site", "import", (dir_ / "import.json").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("site import needs --out SITE.json"), std::string::npos);
}

TEST_F(SiteImportCli, AMeshThatIsNoHeightSurfaceExits2NamingTheFacetAndWritesNothing) {
  using fragsim::gis::testing::MeshFixture;
  // A y-up pyramid (file y = elevation) with a vertical facet added (facet 4).
  const MeshFixture wall = {{{0, 0, 0}, {4, 0, 0}, {4, 0, -4}, {0, 0, -4}, {2, 3, -2}, {4, 2, -4}},
                            {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}, {1, 2, 5}},
                            {}};
  fragsim::gis::testing::write_mesh(dir_ / "wall", wall,
                                    fragsim::gis::testing::MeshFormat::kStlBinary);
  const Result r = import(R"({"schema": "fragsim.site_import/1",
      "terrain": {"meshes": [{"path": "wall.stl", "material": "soft"}], "axes": "y_up"}})");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err.rfind("error: terrain.meshes[0]: wall.stl: facet 4: vertical", 0), 0u) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "site.json"));
}

TEST_F(SiteImportCli, ShapeImportPrintsAPolyhedronCentredOnItsVertices) {
  using fragsim::gis::testing::MeshFixture;
  // A y-up tetrahedron: site (x, y, z) = file (x, -z, y).
  const MeshFixture tet = {{{0, 0, 0}, {2, 0, 0}, {0, 4, 0}, {0, 0, -6}},
                           {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}},
                           {}};
  const fs::path path = fragsim::gis::testing::write_mesh(
      dir_ / "tet", tet, fragsim::gis::testing::MeshFormat::kStlAscii);
  const Result r = run({"shape", "import", path.string(), "--axes", "y_up"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json shape = Json::parse(r.out);
  EXPECT_EQ(shape["type"], "polyhedron");
  ASSERT_EQ(shape["vertices_m"].size(), 4u);  // 12 STL corners, 4 distinct
  // Mean of the site vertices (0,0,0), (2,0,0), (0,0,4), (0,6,0): (0.5, 1.5, 1).
  const std::vector<std::array<double, 3>> expected = {
      {-0.5, -1.5, -1}, {-0.5, -1.5, 3}, {1.5, -1.5, -1}, {-0.5, 4.5, -1}};  // first seen first
  for (std::size_t v = 0; v < 4; ++v)
    for (std::size_t c = 0; c < 3; ++c)
      EXPECT_NEAR(shape["vertices_m"][v][c].get<double>(), expected[v][c], 1e-12);
  const Result mirror = run({"shape", "import", path.string(), "--axes", "y,x,z"});
  EXPECT_EQ(mirror.exit_code, 2);
  EXPECT_NE(mirror.err.find("--axes: is a mirror"), std::string::npos) << mirror.err;
}

}  // namespace
