// Mesh terrain (gis/mesh_terrain.h) through the import file (gis/site_import.h): a known mesh in
// every format and under every axis map lands where it should; materials per file and per
// group; meshes that are no height surface are refused naming the file and facet; a grid
// resampled from a mesh holds the highest surface at its nodes.
#include "gis/mesh_terrain.h"

#include <gtest/gtest.h>

#include "api/test_support.h"
#include "core/common/error.h"
#include "gis/site_import.h"
#include "mesh_fixtures.h"

namespace fragsim::gis {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using testing::MeshFixture;
using testing::MeshFormat;
using testing::write_mesh;

// A square pyramid (base 4 m x 4 m at z = 0, apex 3 m up), its faces in groups 7, 7, 9, 9.
MeshFixture pyramid() {
  return {{{0, 0, 0}, {4, 0, 0}, {4, 4, 0}, {0, 4, 0}, {2, 2, 3}},
          {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}},
          {7, 7, 9, 9}};
}

double plane_z(double x, double y) {
  return 1 + 0.25 * x + 0.5 * y;
}

// The tilted plane z = 1 + x/4 + y/2 over [x0, x1] x [0, 4], two triangles.
MeshFixture plane(double x0, double x1) {
  return {{{x0, 0, plane_z(x0, 0)},
           {x1, 0, plane_z(x1, 0)},
           {x1, 4, plane_z(x1, 4)},
           {x0, 4, plane_z(x0, 4)}},
          {{0, 1, 2}, {0, 2, 3}},
          {}};
}

// The file coordinates that `m` maps onto the site coordinates p.
MeshFixture in_file_axes(MeshFixture f, const AxisMap& m) {
  for (auto& p : f.vertices) {
    std::array<double, 3> q{};
    for (int k = 0; k < 3; ++k) q[m.from[k]] = m.sign[k] * p[k];
    p = q;
  }
  return f;
}

class MeshTerrainTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_gis_mesh_terrain_"); }
  void TearDown() override { fs::remove_all(dir_); }

  // An import file with these meshes ([{"path", "material", ...}]) and terrain keys.
  Json import_file(const Json& meshes, const Json& extra = Json::object()) const {
    Json j = {{"schema", "fragsim.site_import/1"},
              {"terrain", {{"meshes", meshes}}},
              {"materials", {{"vegetated", {{"friction", 0.8}}}, {"rock", {{"friction", 0.6}}}}}};
    for (const auto& [k, v] : extra.items()) j["terrain"][k] = v;
    return j;
  }
  ImportedSite import(const Json& j) const { return import_site(parse_site_import(j, dir_)); }
  std::string error_of(const Json& j) const {
    try {
      import(j);
    } catch (const InputError& e) {
      return e.what();
    }
    return "<no error>";
  }

  fs::path dir_;
};

TEST_F(MeshTerrainTest, APyramidLandsWhereItShouldInEveryFormatAndAxisMap) {
  const MeshFixture site = pyramid();
  const std::vector<Json> maps = {
      "z_up", "y_up", {"y", "z", "x"}, {"-x", "-y", "z"}, {"x", "z", "-y"}, {"-z", "y", "x"}};
  for (const Json& axes : maps) {
    const AxisMap m = parse_axes(axes, "axes");
    for (const MeshFormat f : testing::kMeshFormats) {
      const fs::path path = write_mesh(dir_ / "p", in_file_axes(site, m), f);
      SCOPED_TRACE(axes.dump() + " " + path.string());
      const ImportedSite s = import(
          import_file({{{"path", path.filename()}, {"material", "vegetated"}}}, {{"axes", axes}}));
      const auto& mesh = s.site["terrain"]["mesh"];
      ASSERT_EQ(mesh["vertices_m"].size(), 5u);  // STL's 12 corners welded
      ASSERT_EQ(mesh["triangles"].size(), 4u);
      for (std::size_t t = 0; t < 4; ++t)
        for (int k = 0; k < 3; ++k) {
          const auto& v = mesh["vertices_m"][mesh["triangles"][t][k].get<std::size_t>()];
          for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(v[c].get<double>(), site.vertices[site.triangles[t][k]][c], 1e-9);
        }
      EXPECT_EQ(s.site["terrain"]["material"], "vegetated");
    }
  }
}

TEST_F(MeshTerrainTest, MaterialsGoPerFileAndPerGroup) {
  write_mesh(dir_ / "p", pyramid(), MeshFormat::kObj);
  write_mesh(dir_ / "p", pyramid(), MeshFormat::kPlyBinary);
  write_mesh(dir_ / "side", plane(10, 14), MeshFormat::kStlBinary);
  ImportedSite s = import(import_file({{{"path", "p.obj"}, {"material", "vegetated"}},
                                       {{"path", "side.stl"}, {"material", "rock"}}}));
  Json expected = {{"names", {"vegetated", "rock"}}, {"index", {0, 0, 0, 0, 1, 1}}};
  EXPECT_EQ(Json::parse(s.site["terrain"]["triangle_materials"].dump()), expected);
  s = import(import_file(
      {{{"path", "p.obj"}, {"material", "vegetated"}, {"material_by_group", {{"g9", "hard"}}}},
       {{"path", "side.stl"}, {"material", "rock"}}}));
  expected = {{"names", {"vegetated", "hard", "rock"}}, {"index", {0, 0, 1, 1, 2, 2}}};
  EXPECT_EQ(Json::parse(s.site["terrain"]["triangle_materials"].dump()), expected);
  s = import(import_file(
      {{{"path", "p.ply"}, {"material", "vegetated"}, {"material_by_group", {{"7", "rock"}}}}}));
  expected = {{"names", {"vegetated", "rock"}}, {"index", {1, 1, 0, 0}}};
  EXPECT_EQ(Json::parse(s.site["terrain"]["triangle_materials"].dump()), expected);

  const Json typo = import_file(
      {{{"path", "p.obj"}, {"material", "vegetated"}, {"material_by_group", {{"g8", "rock"}}}}});
  EXPECT_EQ(error_of(typo),
            "terrain.meshes[0].material_by_group.g8: p.obj has no group of that "
            "name (its groups: \"g7\", \"g9\")");
  const Json unknown = import_file({{{"path", "p.obj"}, {"material", "gravel"}}});
  EXPECT_EQ(error_of(unknown),
            "terrain.meshes[0].material: \"gravel\" is not a key of materials "
            "(nor \"hard\" or \"soft\")");
}

TEST_F(MeshTerrainTest, AMeshThatIsNoHeightSurfaceIsRefusedNamingTheFacet) {
  const std::string hint =
      ": the terrain must be a height surface; \"grid_spacing_m\" resamples such a mesh to a "
      "grid terrain of the highest surface (a cliff then becomes a steep slope one grid cell "
      "wide)";
  MeshFixture p = pyramid();
  p.vertices.push_back({4, 4, 2});
  p.triangles.push_back({1, 2, 5});  // a vertical facet on the east edge
  p.group.push_back(9);
  write_mesh(dir_ / "wall", p, MeshFormat::kStlAscii);
  EXPECT_EQ(error_of(import_file({{{"path", "wall.stl"}, {"material", "rock"}}})),
            "terrain.meshes[0]: wall.stl: facet 4: vertical (its plan projection has no area; 1 "
            "vertical facets in all)" +
                hint);
  p = pyramid();
  p.vertices.push_back({2, 1, 5});
  p.triangles.push_back({0, 1, 5});  // over face 0: an overhang
  p.group.push_back(9);
  write_mesh(dir_ / "fold", p, MeshFormat::kObj);
  write_mesh(dir_ / "ok", plane(10, 14), MeshFormat::kPlyAscii);
  EXPECT_EQ(error_of(import_file({{{"path", "ok.ply"}, {"material", "rock"}},
                                  {{"path", "fold.obj"}, {"material", "rock"}}})),
            "terrain.meshes[1]: fold.obj: facet 0: overlaps facet 4 of fold.obj in plan near "
            "(2.000, 0.667) (an overhang or a fold; 1 overlapping pairs in all)" +
                hint);
  // Two files over the same ground overlap too.
  write_mesh(dir_ / "ok2", plane(12, 16), MeshFormat::kPlyAscii);
  EXPECT_EQ(error_of(import_file({{{"path", "ok.ply"}, {"material", "rock"}},
                                  {{"path", "ok2.ply"}, {"material", "rock"}}})),
            "terrain.meshes[0]: ok.ply: facet 0: overlaps facet 0 of ok2.ply in plan near "
            "(12.667, 1.333) (an overhang or a fold; 3 overlapping pairs in all)" +
                hint);
  // Welding that leaves a facet without area.
  const MeshFixture sliver = {{{0, 0, 0}, {5e-7, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}, {}};
  write_mesh(dir_ / "sliver", sliver, MeshFormat::kObj);
  EXPECT_EQ(error_of(import_file({{{"path", "sliver.obj"}, {"material", "rock"}}})),
            "terrain.meshes[0]: sliver.obj: facet 0: welding (weld_m = 1e-06 m) leaves it without "
            "area (two of its vertices merge); give a smaller weld_m");
  EXPECT_EQ(
      error_of(import_file({{{"path", "sliver.obj"}, {"material", "rock"}}}, {{"weld_m", 1e-8}})),
      "<no error>");
}

TEST_F(MeshTerrainTest, TheImportFileIsChecked) {
  write_mesh(dir_ / "p", pyramid(), MeshFormat::kObj);
  const Json meshes = {{{"path", "p.obj"}, {"material", "rock"}}};
  EXPECT_EQ(error_of(import_file(meshes, {{"axes", {"y", "x", "z"}}})),
            "terrain.axes: is a mirror (determinant -1), which would turn the terrain inside out: "
            "flip the sign of one axis (e.g. \"y_up\" is [\"x\", \"-z\", \"y\"])");
  EXPECT_EQ(error_of(import_file(meshes, {{"axes", {"x", "-x", "z"}}})),
            "terrain.axes: names the file's x axis twice (each axis once)");
  EXPECT_EQ(
      error_of(import_file(meshes, {{"axes", {"x", "w", "z"}}})),
      "terrain.axes[1]: must be one of \"x\", \"-x\", \"y\", \"-y\", \"z\", \"-z\" (got \"w\")");
  EXPECT_EQ(error_of(import_file(meshes, {{"path", "dem.tif"}})),
            "terrain: give either \"path\" (a raster) or \"meshes\" (mesh files), not both");
  EXPECT_EQ(error_of(import_file(meshes, {{"weld", 0}})),
            "terrain.weld: unknown key (did you mean \"weld_m\"?)");
  // y_up is x, -z, y.
  const AxisMap m = parse_axes("y_up", "axes");
  EXPECT_EQ(m.apply(Vec3(1, 2, 3)), Vec3(1, -3, 2));
}

TEST_F(MeshTerrainTest, AGridResampledFromATiltedPlaneIsExactAtItsNodes) {
  write_mesh(dir_ / "west", plane(0, 4), MeshFormat::kStlAscii);
  write_mesh(dir_ / "east", plane(4, 8), MeshFormat::kPlyBinary);
  const ImportedSite s = import(import_file({{{"path", "west.stl"}, {"material", "vegetated"}},
                                             {{"path", "east.ply"}, {"material", "rock"}}},
                                            {{"grid_spacing_m", 0.5}}));
  const auto& g = s.site["terrain"]["grid"];
  EXPECT_EQ(g["origin_m"], (nlohmann::ordered_json{0.0, 0.0}));
  ASSERT_EQ(g["nx"], 17);
  ASSERT_EQ(g["ny"], 9);
  for (int j = 0; j < 9; ++j)
    for (int i = 0; i < 17; ++i)
      EXPECT_NEAR(g["elevation_m"][j * 17 + i].get<double>(), plane_z(0.5 * i, 0.5 * j), 1e-9);
  const auto& index = s.site["terrain"]["triangle_materials"]["index"];
  ASSERT_EQ(index.size(), 2u * 16 * 8);
  for (int k = 0; k < 16 * 8; ++k)  // cell k = j * 16 + i: vegetated west of x = 4
    for (int h = 0; h < 2; ++h) EXPECT_EQ(index[2 * k + h], k % 16 < 8 ? 0 : 1) << k;
}

TEST_F(MeshTerrainTest, AGridTakesTheHighestSurfaceAndACliffBecomesASlope) {
  // A 5 m cliff at x = 4 (two vertical facets) and a ledge overhanging it to x = 3.
  const MeshFixture cliff = {
      {{0, 0, 0},
       {4, 0, 0},
       {4, 4, 0},
       {0, 4, 0},  // low ground
       {4, 0, 5},
       {8, 0, 5},
       {8, 4, 5},
       {4, 4, 5},  // high ground
       {3, 0, 5},
       {3, 4, 5}},  // the ledge
      {{0, 1, 2}, {0, 2, 3}, {4, 5, 6}, {4, 6, 7}, {1, 4, 7}, {1, 7, 2}, {8, 4, 7}, {8, 7, 9}},
      {}};
  write_mesh(dir_ / "cliff", cliff, MeshFormat::kObj);
  const Json meshes = {{{"path", "cliff.obj"}, {"material", "rock"}}};
  EXPECT_NE(error_of(import_file(meshes)).find("facet 4: vertical"), std::string::npos);
  const ImportedSite s = import(import_file(meshes, {{"grid_spacing_m", 0.5}}));
  const auto& g = s.site["terrain"]["grid"];
  ASSERT_EQ(g["nx"], 17);
  for (int i = 0; i < 17; ++i)  // under the ledge (x >= 3) the ledge's top, 5 m
    EXPECT_EQ(g["elevation_m"][17 * 4 + i].get<double>(), i >= 6 ? 5.0 : 0.0) << i;

  // A mesh that does not cover its plan box (a survey's outline): the lattice cells with all
  // four corners covered, as a mesh terrain. The right triangle (0,0)-(4,0)-(4,4) at 1 m covers
  // the nodes with y <= x: the cells below the diagonal, (i, j) with j < i, 6 cells.
  const MeshFixture half = {{{0, 0, 0}, {4, 0, 0}, {4, 4, 4}}, {{0, 1, 2}}, {}};
  write_mesh(dir_ / "half", half, MeshFormat::kObj);
  const ImportedSite h =
      import(import_file({{{"path", "half.obj"}, {"material", "rock"}}}, {{"grid_spacing_m", 1}}));
  ASSERT_FALSE(h.site["terrain"].contains("grid"));
  const auto& m = h.site["terrain"]["mesh"];
  EXPECT_EQ(m["triangles"].size(), 12u);
  EXPECT_EQ(h.site["terrain"]["triangle_materials"]["index"].size(), 12u);
  for (const auto& v : m["vertices_m"]) {  // nodes on the plane z = y, all covered
    EXPECT_LE(v[1].get<double>(), v[0].get<double>());
    EXPECT_EQ(v[2].get<double>(), v[1].get<double>());
  }
  // Too coarse to keep a cell: refused.
  EXPECT_NE(
      error_of(import_file({{{"path", "half.obj"}, {"material", "rock"}}}, {{"grid_spacing_m", 3}}))
          .find("terrain.grid_spacing_m: no grid cell has mesh above all four corners"),
      std::string::npos);
}

TEST_F(MeshTerrainTest, AFineSurfaceInCrsCoordinatesIsAHeightSurface) {
  // 60 x 60 cells of 0.37 m at UTM-sized coordinates, rough: no shared edge or vertex may be
  // taken for an overlap. 7,200 triangles.
  MeshFixture m;
  const int n = 61;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      m.vertices.push_back({452000.13 + 0.37 * i, 3839000.71 + 0.37 * j,
                            400 + 0.3 * std::sin(1.7 * i) + 0.2 * std::cos(2.3 * j)});
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int v = j * n + i;
      m.triangles.push_back({v, v + 1, v + n + 1});
      m.triangles.push_back({v, v + n + 1, v + n});
    }
  write_mesh(dir_ / "utm", in_file_axes(m, parse_axes("y_up", "axes")), MeshFormat::kPlyBinary);
  const ImportedSite s =
      import(import_file({{{"path", "utm.ply"}, {"material", "rock"}}}, {{"axes", "y_up"}}));
  EXPECT_EQ(s.site["terrain"]["mesh"]["triangles"].size(), 7200u);
  EXPECT_EQ(s.site["terrain"]["mesh"]["vertices_m"].size(), 3721u);
}

}  // namespace
}  // namespace fragsim::gis
