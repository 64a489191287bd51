// Every class of site input error, with the exact field path the user sees.
#include "core/scene/validation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "scene_test_util.h"

namespace fragsim::scene {
namespace {

using testing::box_building;
using testing::expect_input_error;
using testing::grid_site;
using testing::make_grid;
using testing::plane_site;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A valid 5 x 10 vertex mesh terrain (50 vertices, 72 triangles) to break in various ways.
MeshSpec mesh_terrain() {
  MeshSpec m;
  for (int j = 0; j < 10; ++j)
    for (int i = 0; i < 5; ++i) m.vertices_m.emplace_back(i * 10.0, j * 10.0, 0.1 * i);
  for (int j = 0; j < 9; ++j) {
    for (int i = 0; i < 4; ++i) {
      const std::int64_t v = j * 5 + i;
      m.triangles.push_back({v, v + 1, v + 6});
      m.triangles.push_back({v, v + 6, v + 5});
    }
  }
  return m;
}

SiteSpec mesh_site(const MeshSpec& m) {
  SiteSpec s = plane_site();
  s.terrain.geometry = m;
  return s;
}

GridTerrainSpec flat_grid() {
  return make_grid(0, 0, 10, 6, 5, [](double, double) { return 1.0; });
}

TEST(SiteValidation, ValidSitesBuild) {
  EXPECT_NO_THROW(Site::build(plane_site()));
  EXPECT_NO_THROW(Site::build(grid_site(flat_grid())));
  EXPECT_NO_THROW(Site::build(mesh_site(mesh_terrain())));
}

TEST(SiteValidation, GridElevationNotFinite) {
  auto g = flat_grid();
  g.elevation_m[17] = kNaN;
  expect_input_error(grid_site(g), "site.terrain.grid.elevation_m[17]", "not finite");
  g.elevation_m[17] = std::numeric_limits<double>::infinity();
  expect_input_error(grid_site(g), "site.terrain.grid.elevation_m[17]", "not finite");
}

TEST(SiteValidation, GridShape) {
  auto g = flat_grid();
  g.spacing_m = 0;
  expect_input_error(grid_site(g), "site.terrain.grid.spacing_m", "must be > 0 (got 0)");
  g = flat_grid();
  g.spacing_m = -2;
  expect_input_error(grid_site(g), "site.terrain.grid.spacing_m", "must be > 0 (got -2)");
  g = flat_grid();
  g.nx = 1;
  expect_input_error(grid_site(g), "site.terrain.grid.nx", "must be at least 2 (got 1)");
  g = flat_grid();
  g.ny = 0;
  expect_input_error(grid_site(g), "site.terrain.grid.ny", "must be at least 2 (got 0)");
  g = flat_grid();
  g.elevation_m.pop_back();
  expect_input_error(grid_site(g), "site.terrain.grid.elevation_m", "has 29 values; nx * ny = 30");
  g = flat_grid();
  g.origin_m[1] = kNaN;
  expect_input_error(grid_site(g), "site.terrain.grid.origin_m[1]", "not finite");
}

TEST(SiteValidation, PlaneShape) {
  expect_input_error(plane_site({10, 0, 10, 5}), "site.terrain.plane.extent_m",
                     "xmax must be greater than xmin (got xmin 10, xmax 10)");
  expect_input_error(plane_site({0, 5, 10, -5}), "site.terrain.plane.extent_m",
                     "ymax must be greater than ymin");
  expect_input_error(plane_site({0, 0, kNaN, 5}), "site.terrain.plane.extent_m[2]", "not finite");
  expect_input_error(plane_site({0, 0, 10, 10}, 0.0), "site.terrain.plane.cell_m", "must be > 0");
  expect_input_error(plane_site({0, 0, 10, 10}, -1.0), "site.terrain.plane.cell_m", "must be > 0");
  expect_input_error(plane_site({0, 0, 1e5, 1e5}, 1e-2), "site.terrain.plane.cell_m",
                     "too small for the extent");
  expect_input_error(plane_site({0, 0, 10, 10}, 1.0, kNaN), "site.terrain.plane.elevation_m",
                     "not finite");
}

TEST(SiteValidation, MeshTerrainIndexOutOfRange) {
  auto m = mesh_terrain();
  ASSERT_EQ(m.vertices_m.size(), 50u);
  m.triangles[12][1] = 99;
  expect_input_error(mesh_site(m), "site.terrain.mesh.triangles[12][1]",
                     "vertex index 99 out of range (vertices: 50)");
  m = mesh_terrain();
  m.triangles[3][2] = -1;
  expect_input_error(mesh_site(m), "site.terrain.mesh.triangles[3][2]",
                     "vertex index -1 out of range (vertices: 50)");
}

TEST(SiteValidation, MeshTerrainZeroArea) {
  auto m = mesh_terrain();
  m.triangles[12] = {0, 1, 2};  // three collinear vertices along y = 0
  expect_input_error(mesh_site(m), "site.terrain.mesh.triangles[12]", "zero-area triangle");
  m = mesh_terrain();
  m.triangles[12] = {7, 7, 8};  // repeated vertex
  expect_input_error(mesh_site(m), "site.terrain.mesh.triangles[12]", "zero-area triangle");
}

TEST(SiteValidation, ZeroAreaThresholdIsRelative) {
  // Height / longest edge = 2 area / L^2: 1e-13 is below the 2e-12 threshold, 1e-9 above it,
  // whatever the absolute size.
  for (const double scale : {1e-3, 1.0, 1e4}) {
    const Vec3 a(0, 0, 0), b(scale, 0, 0);
    EXPECT_TRUE(detail::is_zero_area(a, b, Vec3(0.5 * scale, 1e-13 * scale, 0))) << scale;
    EXPECT_FALSE(detail::is_zero_area(a, b, Vec3(0.5 * scale, 1e-9 * scale, 0))) << scale;
  }
}

TEST(SiteValidation, MeshTerrainVerticesAndEmpty) {
  auto m = mesh_terrain();
  m.vertices_m[4].y() = kNaN;
  expect_input_error(mesh_site(m), "site.terrain.mesh.vertices_m[4][1]", "not finite");
  m = mesh_terrain();
  m.triangles.clear();
  expect_input_error(mesh_site(m), "site.terrain", "empty terrain");
  expect_input_error(mesh_site(MeshSpec{}), "site.terrain", "empty terrain");
  m = mesh_terrain();
  m.surface.assign(m.triangles.size(), SurfaceType::kWall);
  expect_input_error(mesh_site(m), "site.terrain.mesh.surface", "building meshes only");
}

TEST(SiteValidation, MeshTerrainVerticalTriangle) {
  auto m = mesh_terrain();
  m.vertices_m.emplace_back(0, 0, 10);  // above vertex 0: triangle (0, 1, 50) is vertical
  m.triangles.push_back({0, 1, 50});
  expect_input_error(mesh_site(m), "site.terrain.mesh.triangles[72]", "vertical triangle");
}

TEST(SiteValidation, TerrainMaterial) {
  auto s = plane_site();
  s.terrain.material = "mud";
  expect_input_error(s, "site.terrain.material", "unknown material \"mud\"");
  s.terrain.material.clear();
  expect_input_error(s, "site.terrain.material", "missing material");
}

TEST(SiteValidation, Materials) {
  auto s = plane_site();
  s.materials["soil"].friction = -0.1;
  expect_input_error(s, "site.materials.soil.friction", "must be >= 0 (got -0.1)");
  s = plane_site();
  s.materials["soil"].restitution.constant = 1.5;
  expect_input_error(s, "site.materials.soil.restitution", "must be in [0, 1] (got 1.5)");
  s = plane_site();
  s.materials["concrete_wall"].restitution.e[1] = 1.2;
  expect_input_error(s, "site.materials.concrete_wall.restitution.e[1]", "must be in [0, 1]");
  s = plane_site();
  s.materials["concrete_wall"].restitution.normal_speed_mps[2] = 30;
  expect_input_error(s, "site.materials.concrete_wall.restitution.normal_speed_mps[2]",
                     "strictly increasing");
  s = plane_site();
  s.materials["concrete_wall"].restitution.e.pop_back();
  expect_input_error(s, "site.materials.concrete_wall.restitution", "differ in length (3 vs 2)");
  s = plane_site();
  s.materials["metal_roof"].penetration_ke_per_area_j_per_m2 = 0.0;
  expect_input_error(s, "site.materials.metal_roof.penetration.ke_per_area_j_per_m2",
                     "must be > 0");
  s = plane_site();
  s.materials["red brick"] = s.materials["soil"];
  s.materials["red brick"].friction = kNaN;
  expect_input_error(s, "site.materials[\"red brick\"].friction", "not finite");
}

TEST(SiteValidation, Origin) {
  auto s = plane_site();
  s.origin = SiteOrigin{"EPSG:32633", kNaN, 0, 0};
  expect_input_error(s, "site.origin.easting_m", "not finite");
}

TEST(SiteValidation, BuildingMaterials) {
  auto s = plane_site();
  s.buildings.push_back(box_building("B1", 60, -10, 80, 10, 6));
  s.buildings[0].wall = "brick";
  expect_input_error(s, "site.buildings[0].wall", "unknown material \"brick\"");
  s.buildings[0].wall = "concrete_wall";
  s.buildings[0].roof.clear();
  expect_input_error(s, "site.buildings[0].roof", "missing material");
  s.buildings[0].roof = "metal_roof";
  s.buildings[0].window = "plexiglass";  // named but unused: still checked
  expect_input_error(s, "site.buildings[0].window", "unknown material \"plexiglass\"");
}

TEST(SiteValidation, BuildingIdsAndForms) {
  auto s = plane_site();
  s.buildings.push_back(box_building("B1", 60, -10, 80, 10, 6));
  s.buildings.push_back(box_building("B1", -80, -10, -60, 10, 6));
  expect_input_error(s, "site.buildings[1].id", "duplicate id \"B1\" (also site.buildings[0])");
  s.buildings[1].id.clear();
  expect_input_error(s, "site.buildings[1].id", "missing id");
  s.buildings[1].id = "B2";
  s.buildings[1].mesh = MeshSpec{};
  expect_input_error(s, "site.buildings[1]", "either footprint_m or mesh");
}

TEST(SiteValidation, FootprintSelfCrossing) {
  auto s = plane_site();
  s.buildings.push_back(box_building("A", 0, 0, 5, 5, 3));
  s.buildings.push_back(box_building("B", 20, 0, 25, 5, 3));
  s.buildings.push_back(box_building("C", 40, 0, 50, 10, 3));
  // Bow tie: edge 1 (10,0)->(0,10) crosses edge 3 (10,10)->(0,0).
  s.buildings[2].footprint_m = {{40, 0}, {50, 0}, {40, 10}, {50, 10}};
  expect_input_error(s, "site.buildings[2].footprint_m",
                     "self-crossing polygon (edges 1 and 3 cross)");
  // A vertex touching a non-adjacent edge also makes the polygon non-simple.
  s.buildings[2].footprint_m = {{40, 0}, {50, 0}, {50, 10}, {45, 0}, {40, 10}};
  expect_input_error(s, "site.buildings[2].footprint_m",
                     "self-crossing polygon (edges 0 and 2 cross)");
  // Folding back along an edge.
  s.buildings[2].footprint_m = {{40, 0}, {50, 0}, {45, 0}, {45, 5}};
  expect_input_error(s, "site.buildings[2].footprint_m",
                     "self-crossing polygon (edges 0 and 1 overlap)");
}

TEST(SiteValidation, FootprintShape) {
  auto s = plane_site();
  s.buildings.push_back(box_building("A", 0, 0, 5, 5, 3));
  s.buildings[0].footprint_m = {{0, 0}, {5, 0}};
  expect_input_error(s, "site.buildings[0].footprint_m", "at least 3 vertices (got 2)");
  s.buildings[0].footprint_m = {{0, 0}, {5, 0}, {5, 0}, {0, 5}};
  expect_input_error(s, "site.buildings[0].footprint_m[2]", "repeats the previous vertex");
  s.buildings[0].footprint_m = {{0, 0}, {kNaN, 0}, {0, 5}};
  expect_input_error(s, "site.buildings[0].footprint_m[1][0]", "not finite");
  // A simple polygon has positive area, so only a numerically flat one is zero-area: height
  // 1e-12 over a 10 m base.
  s.buildings[0].footprint_m = {{0, 0}, {10, 0}, {5, 1e-12}};
  expect_input_error(s, "site.buildings[0].footprint_m", "zero-area footprint");
  // Collinear vertices fold back on themselves.
  s.buildings[0].footprint_m = {{0, 0}, {5, 0}, {10, 0}};
  expect_input_error(s, "site.buildings[0].footprint_m",
                     "self-crossing polygon (edges 1 and 2 overlap)");
  s = plane_site();
  s.buildings.push_back(box_building("A", 0, 0, 5, 5, 0.0));
  expect_input_error(s, "site.buildings[0].height_m", "must be > 0");
  s.buildings[0].height_m = -3;
  expect_input_error(s, "site.buildings[0].height_m", "must be > 0");
  s.buildings[0].height_m = 3;
  s.buildings[0].base_elevation_m = kNaN;
  expect_input_error(s, "site.buildings[0].base_elevation_m", "not finite");
  // Entirely outside the terrain and no base given.
  s = plane_site();
  s.buildings.push_back(box_building("A", 500, 500, 510, 510, 3));
  expect_input_error(s, "site.buildings[0].footprint_m", "outside the terrain");
  s.buildings[0].base_elevation_m = 2.0;
  EXPECT_NO_THROW(Site::build(s));
  // A GIS-style closed ring (last vertex = first) is accepted.
  s = plane_site();
  s.buildings.push_back(box_building("A", 0, 0, 5, 5, 3));
  s.buildings[0].footprint_m.push_back(s.buildings[0].footprint_m.front());
  EXPECT_NO_THROW(Site::build(s));
}

// Three footprints; the third (40..60 x 0..20) gets the holes under test.
SiteSpec courtyard_site(std::vector<std::vector<std::array<double, 2>>> holes) {
  auto s = plane_site();
  s.buildings.push_back(box_building("A", 0, 0, 5, 5, 3));
  s.buildings.push_back(box_building("B", 20, 0, 25, 5, 3));
  s.buildings.push_back(box_building("C", 40, 0, 60, 20, 3));
  s.buildings[2].holes_m = std::move(holes);
  return s;
}

TEST(SiteValidation, HoleShape) {
  const std::string h0 = "site.buildings[2].holes_m[0]";
  // Bow tie: edge 0 (42,2)->(48,8) crosses edge 2 (48,2)->(42,8).
  expect_input_error(courtyard_site({{{42, 2}, {48, 8}, {48, 2}, {42, 8}}}), h0,
                     "self-crossing polygon (edges 0 and 2 cross)");
  expect_input_error(courtyard_site({{{42, 2}, {48, 2}}}), h0,
                     "a hole needs at least 3 vertices (got 2)");
  expect_input_error(courtyard_site({{{42, 2}, {48, 2}, {48, 2}, {42, 8}}}), h0 + "[2]",
                     "repeats the previous vertex");
  expect_input_error(courtyard_site({{{42, 2}, {48, 2}, {45, 2 + 1e-12}}}), h0, "zero-area hole");
  expect_input_error(courtyard_site({{{42, 2}, {kNaN, 2}, {42, 8}}}), h0 + "[1][0]", "not finite");
  // Either orientation, and a GIS-style closed ring, are accepted.
  EXPECT_NO_THROW(Site::build(courtyard_site({{{42, 2}, {48, 2}, {42, 8}}})));
  EXPECT_NO_THROW(Site::build(courtyard_site({{{42, 8}, {48, 2}, {42, 2}, {42, 8}}})));
}

TEST(SiteValidation, HoleInsideTheFootprint) {
  const std::string h1 = "site.buildings[2].holes_m[1]";
  const std::vector<std::array<double, 2>> ok = {{42, 2}, {48, 2}, {48, 8}, {42, 8}};
  // Wholly outside, and around the whole footprint.
  expect_input_error(courtyard_site({ok, {{70, 2}, {78, 2}, {78, 8}}}), h1,
                     "not inside the footprint");
  expect_input_error(courtyard_site({ok, {{30, -10}, {70, -10}, {70, 30}, {30, 30}}}), h1,
                     "not inside the footprint");
  // Crossing the outline: its edge 1 (58,12)->(65,12) meets the footprint's east edge 1.
  expect_input_error(courtyard_site({ok, {{52, 12}, {58, 12}, {65, 18}, {52, 18}}}), h1,
                     "not inside the footprint (its edge 1 meets footprint_m edge 1)");
  // Touching it: a vertex on the east edge; a vertex on a footprint vertex.
  expect_input_error(courtyard_site({ok, {{52, 12}, {60, 15}, {52, 18}}}), h1,
                     "not inside the footprint (its edge 0 meets footprint_m edge 1)");
  expect_input_error(courtyard_site({ok, {{52, 12}, {60, 20}, {52, 18}}}), h1,
                     "not inside the footprint (its edge 0 meets footprint_m edge 1)");
  EXPECT_NO_THROW(Site::build(courtyard_site({ok, {{52, 12}, {59.999, 15}, {52, 18}}})));
  // Edges are numbered as given: clockwise, the south edge (60,0)->(40,0) is edge 2.
  auto cw = courtyard_site({});
  cw.buildings[2] = box_building("C", 40, 0, 60, 20, 3, /*clockwise=*/true);
  cw.buildings[2].holes_m = {{{50, -2}, {55, 5}, {45, 5}}};
  expect_input_error(cw, "site.buildings[2].holes_m[0]",
                     "not inside the footprint (its edge 0 meets footprint_m edge 2)");
}

TEST(SiteValidation, HolesDisjoint) {
  const std::string h1 = "site.buildings[2].holes_m[1]";
  const std::vector<std::array<double, 2>> square = {{42, 2}, {48, 2}, {48, 8}, {42, 8}};
  // Crossing: holes_m[1]'s edge 0 (45,5)->(55,5) leaves the square through its edge 1.
  expect_input_error(courtyard_site({square, {{45, 5}, {55, 5}, {55, 10}}}), h1,
                     "crosses holes_m[0] (its edge 0 meets holes_m[0] edge 1)");
  // Touching at one point (a corner of the square).
  expect_input_error(courtyard_site({square, {{48, 8}, {55, 9}, {55, 15}}}), h1,
                     "crosses holes_m[0] (its edge 0 meets holes_m[0] edge 1)");
  // Nested, either way round.
  const std::vector<std::array<double, 2>> inner = {{44, 4}, {46, 4}, {46, 6}};
  expect_input_error(courtyard_site({square, inner}), h1, "lies inside holes_m[0]");
  expect_input_error(courtyard_site({inner, square}), h1, "contains holes_m[0]");
  // Apart, they build.
  EXPECT_NO_THROW(Site::build(courtyard_site({square, {{50, 5}, {55, 5}, {55, 10}}})));
}

TEST(SiteValidation, HolesCountAsFootprintVertices) {
  // Limits (site_limits.h): coordinates in range, and at most 1000 vertices, holes included.
  auto s = courtyard_site({{{42, 2}, {1e9, 2}, {42, 8}}});
  expect_input_error(s, "site.buildings[2].holes_m[0][1][0]", "must be in [-1e+08, 1e+08]");
  std::vector<std::array<double, 2>> round;
  for (int k = 0; k < 600; ++k) {
    const double a = -2 * kPi * k / 600;  // clockwise
    round.push_back({50 + 4 * std::cos(a), 10 + 4 * std::sin(a)});
  }
  s = courtyard_site({round});
  EXPECT_NO_THROW(Site::build(s));
  s.buildings[2].holes_m.push_back(round);                 // 4 + 600 + 600 vertices
  for (auto& p : s.buildings[2].holes_m[1]) p[1] += 1000;  // (limits come first)
  expect_input_error(s, "site.buildings[2].holes_m[1]",
                     "brings the footprint's vertices to 1204 (footprint_m and holes_m "
                     "together); at most 1000 are allowed");
}

// Closed unit-cube mesh (outward winding), 8 vertices, 12 triangles.
MeshSpec cube_mesh(double x0, double y0, double z0, double size) {
  MeshSpec m;
  for (int k = 0; k < 8; ++k)
    m.vertices_m.emplace_back(x0 + size * (k & 1), y0 + size * ((k >> 1) & 1),
                              z0 + size * ((k >> 2) & 1));
  m.triangles = {{0, 2, 3}, {0, 3, 1},   // bottom (-z)
                 {4, 5, 7}, {4, 7, 6},   // top (+z)
                 {0, 1, 5}, {0, 5, 4},   // y = 0 (-y)
                 {2, 6, 7}, {2, 7, 3},   // y = 1 (+y)
                 {0, 4, 6}, {0, 6, 2},   // x = 0 (-x)
                 {1, 3, 7}, {1, 7, 5}};  // x = 1 (+x)
  m.surface.assign(12, SurfaceType::kWall);
  m.surface[2] = m.surface[3] = SurfaceType::kRoof;
  return m;
}

BuildingSpec mesh_building(const MeshSpec& m) {
  BuildingSpec b;
  b.id = "M";
  b.mesh = m;
  b.wall = "concrete_wall";
  b.roof = "metal_roof";
  return b;
}

TEST(SiteValidation, BuildingMesh) {
  auto s = plane_site();
  s.buildings.push_back(mesh_building(cube_mesh(0, 0, 0, 10)));
  EXPECT_NO_THROW(Site::build(s));
  s.buildings[0].mesh->surface.pop_back();
  expect_input_error(s, "site.buildings[0].mesh.surface", "has 11 entries; triangles: 12");
  s.buildings[0].mesh = cube_mesh(0, 0, 0, 10);
  s.buildings[0].mesh->surface[3] = SurfaceType::kTerrain;
  expect_input_error(s, "site.buildings[0].mesh.surface[3]", "not a building surface type");
  s.buildings[0].mesh = cube_mesh(0, 0, 0, 10);
  s.buildings[0].mesh->triangles[5][2] = 8;
  expect_input_error(s, "site.buildings[0].mesh.triangles[5][2]",
                     "vertex index 8 out of range (vertices: 8)");
  s.buildings[0].mesh = cube_mesh(0, 0, 0, 10);
  s.buildings[0].mesh->triangles[5] = {0, 1, 0};
  expect_input_error(s, "site.buildings[0].mesh.triangles[5]", "zero-area triangle");
  s.buildings[0].mesh = cube_mesh(0, 0, 0, 10);
  s.buildings[0].mesh->triangles.pop_back();
  s.buildings[0].mesh->surface.pop_back();
  expect_input_error(s, "site.buildings[0].mesh", "not closed");
  s.buildings[0].mesh = cube_mesh(0, 0, 0, 10);
  std::swap(s.buildings[0].mesh->triangles[0][1], s.buildings[0].mesh->triangles[0][2]);
  expect_input_error(s, "site.buildings[0].mesh", "inconsistent winding");
  s.buildings[0].mesh = cube_mesh(0, 0, 0, 10);
  s.buildings[0].mesh->surface[7] = SurfaceType::kWindow;  // window triangles need a material
  expect_input_error(s, "site.buildings[0].window", "missing material");
  s.buildings[0].window = "glass";
  EXPECT_NO_THROW(Site::build(s));
  s.buildings[0].mesh = MeshSpec{};
  expect_input_error(s, "site.buildings[0].mesh", "empty building mesh");
}

}  // namespace
}  // namespace fragsim::scene
