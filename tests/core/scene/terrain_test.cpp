// Terrain meshing, local frame, heights, and materials.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "scene_test_util.h"

namespace fragsim::scene {
namespace {

using testing::grid_site;
using testing::make_grid;
using testing::plane_site;

double total_area(const Site& s) {
  double a = 0;
  for (std::uint32_t t = 0; t < s.terrain_triangle_count(); ++t) a += s.terrain_triangle_area(t);
  return a;
}

TEST(PlaneTerrain, MeshingFitsTheExtent) {
  const auto site = Site::build(plane_site({-200, -200, 200, 200}, 10, 0));
  EXPECT_TRUE(site->terrain_is_plane());
  EXPECT_EQ(site->terrain_triangle_count(), 2u * 40 * 40);
  EXPECT_EQ(site->terrain_vertices().size(), 41u * 41);
  EXPECT_NEAR(total_area(*site), 400.0 * 400.0, 1e-12 * 400.0 * 400.0);
  for (std::uint32_t t = 0; t < site->terrain_triangle_count(); ++t)
    ASSERT_EQ(site->terrain_triangle_normal(t), Vec3::UnitZ()) << t;
  EXPECT_EQ(site->terrain_bounds().lo, Vec3(-200, -200, 0));
  EXPECT_EQ(site->terrain_bounds().hi, Vec3(200, 200, 0));
  EXPECT_EQ(site->terrain_index().nx, 40);
  EXPECT_EQ(site->terrain_index().ny, 40);
}

TEST(PlaneTerrain, NonDivisibleExtentGetsCeilCells) {
  // 105 x 47 m with 10 m cells: ceil gives 11 x 5 cells of 9.545... x 9.4 m.
  const auto site = Site::build(plane_site({0, 0, 105, 47}, 10, 3.25));
  EXPECT_EQ(site->terrain_triangle_count(), 2u * 11 * 5);
  EXPECT_NEAR(total_area(*site), 105.0 * 47.0, 1e-12 * 105.0 * 47.0);
  EXPECT_NEAR(site->terrain_index().cell.x(), 105.0 / 11, 1e-12);
  EXPECT_NEAR(site->terrain_index().cell.y(), 47.0 / 5, 1e-12);
  // Local origin: extent centre (52.5, 23.5) and the elevation, rounded to whole metres.
  EXPECT_EQ(site->local_origin(), Vec3(53, 24, 3));
  EXPECT_DOUBLE_EQ(site->plane_elevation(), 0.25);
  EXPECT_DOUBLE_EQ(site->altitude_offset_m(), 3.0);
  // A ratio that rounds to just above an integer (2.1 / 0.3 = 7.000000000000001) stays 7 cells.
  const auto small = Site::build(plane_site({0, 0, 2.1, 2.1}, 0.3, 0));
  EXPECT_EQ(small->terrain_triangle_count(), 2u * 7 * 7);
}

TEST(PlaneTerrain, HeightInsideAndOutside) {
  auto spec = plane_site({0, 0, 100, 50}, 10, 12.5);
  spec.origin = SiteOrigin{"local", 0, 0, 250.0};
  const auto site = Site::build(spec);
  const Vec3 o = site->local_origin();
  EXPECT_EQ(site->terrain_height(10 - o.x(), 10 - o.y()), 12.5 - o.z());
  EXPECT_EQ(site->terrain_height(100 - o.x(), 50 - o.y()), 12.5 - o.z());  // corner: inside
  EXPECT_TRUE(std::isnan(site->terrain_height(100.001 - o.x(), 10 - o.y())));
  EXPECT_TRUE(std::isnan(site->terrain_height(std::nan(""), 0)));
  // Altitude above sea level = local z + offset = input z + origin.elevation_m.
  EXPECT_DOUBLE_EQ(site->plane_elevation() + site->altitude_offset_m(), 12.5 + 250.0);
}

// Grid heights are piecewise planar on the (i,j)-(i+1,j+1) diagonal of each cell, not bilinear.
TEST(GridTerrain, HeightsArePiecewisePlanarOnTheChosenDiagonal) {
  GridTerrainSpec g;
  g.origin_m = {100, 200};
  g.spacing_m = 10;
  g.nx = 2;
  g.ny = 2;
  g.elevation_m = {0, 0, 0, 4};  // only (1,1) raised
  const auto site = Site::build(grid_site(g));
  const Vec3 o = site->local_origin();
  EXPECT_EQ(o, Vec3(105, 205, 0));
  const auto h = [&](double u, double v) {
    return site->terrain_height(100 + 10 * u - o.x(), 200 + 10 * v - o.y());
  };
  EXPECT_DOUBLE_EQ(h(0, 0), 0);
  EXPECT_DOUBLE_EQ(h(1, 1), 4);
  EXPECT_DOUBLE_EQ(h(1, 0), 0);
  EXPECT_DOUBLE_EQ(h(0, 1), 0);
  // On the diagonal the height is linear from (0,0) to (1,1): 2 at the centre (bilinear: 1;
  // the other diagonal: 0).
  EXPECT_NEAR(h(0.5, 0.5), 2.0, 1e-12);
  // Lower-right triangle (u >= v): z = 4 v. Upper-left (v > u): z = 4 u.
  EXPECT_NEAR(h(0.75, 0.25), 1.0, 1e-12);  // bilinear would give 0.75
  EXPECT_NEAR(h(0.25, 0.75), 1.0, 1e-12);
  EXPECT_NEAR(h(0.9, 0.1), 0.4, 1e-12);
  EXPECT_EQ(site->terrain_triangle_count(), 2u);
  EXPECT_FALSE(site->terrain_is_plane());
}

TEST(GridTerrain, RandomHeightsMatchTheTriangleFormula) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> zd(-20, 20);
  const int nx = 17, ny = 11;
  const double s = 7.5;
  auto g = make_grid(-3000.5, 1234.25, s, nx, ny, [&](double, double) { return zd(rng); });
  const auto site = Site::build(grid_site(g));
  ASSERT_EQ(site->terrain_triangle_count(), 2u * (nx - 1) * (ny - 1));
  const Vec3 o = site->local_origin();
  std::uniform_real_distribution<double> ud(0, 1);
  for (int k = 0; k < 2000; ++k) {
    const int i = static_cast<int>(ud(rng) * (nx - 1)), j = static_cast<int>(ud(rng) * (ny - 1));
    const double u = ud(rng), v = ud(rng);
    const auto z = [&](int a, int b) {
      return g.elevation_m[static_cast<std::size_t>(b) * nx + a];
    };
    const double expected =
        u >= v ? z(i, j) + u * (z(i + 1, j) - z(i, j)) + v * (z(i + 1, j + 1) - z(i + 1, j))
               : z(i, j) + u * (z(i + 1, j + 1) - z(i, j + 1)) + v * (z(i, j + 1) - z(i, j));
    const double x = g.origin_m[0] + (i + u) * s - o.x(), y = g.origin_m[1] + (j + v) * s - o.y();
    ASSERT_NEAR(site->terrain_height(x, y) + o.z(), expected, 1e-9) << i << " " << j;
  }
  // Exactly at every vertex.
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      ASSERT_NEAR(
          site->terrain_height(g.origin_m[0] + i * s - o.x(), g.origin_m[1] + j * s - o.y()) +
              o.z(),
          g.elevation_m[static_cast<std::size_t>(j) * nx + i], 1e-12);
  EXPECT_TRUE(
      std::isnan(site->terrain_height(g.origin_m[0] - 0.01 - o.x(), g.origin_m[1] - o.y())));
  // Normals up and unit; areas positive.
  for (std::uint32_t t = 0; t < site->terrain_triangle_count(); ++t) {
    EXPECT_GT(site->terrain_triangle_normal(t).z(), 0);
    EXPECT_NEAR(site->terrain_triangle_normal(t).norm(), 1.0, 1e-14);
  }
}

TEST(MeshTerrain, DownwardTrianglesAreFlipped) {
  MeshSpec m;
  m.vertices_m = {{0, 0, 1}, {10, 0, 2}, {10, 10, 3}, {0, 10, 4}};
  m.triangles = {{0, 1, 2}, {0, 3, 2}};  // the second is wound clockwise from above (normal down)
  SiteSpec spec = plane_site();
  spec.terrain.geometry = m;
  const auto site = Site::build(spec);
  EXPECT_FALSE(site->terrain_is_plane());
  EXPECT_EQ(site->local_origin(), Vec3(5, 5, 1));
  for (std::uint32_t t = 0; t < 2; ++t) EXPECT_GT(site->terrain_triangle_normal(t).z(), 0) << t;
  EXPECT_EQ(site->terrain_triangles()[1], (std::array<std::uint32_t, 3>{0, 2, 3}));
  const Vec3 c = site->terrain_triangle_centroid(1);
  EXPECT_NEAR(site->terrain_height(c.x(), c.y()), c.z(), 1e-12);
  const double a0 = 0.5 * Vec3(10, 0, 1).cross(Vec3(10, 10, 2)).norm();
  EXPECT_NEAR(site->terrain_triangle_area(0), a0, 1e-12);
}

TEST(MeshTerrain, OverhangReportsTheHighestSurface) {
  MeshSpec m;
  // Two stacked, overlapping triangles (a ledge): heights 0 and 5 over the same xy.
  m.vertices_m = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0, 5}, {10, 0, 5}, {0, 10, 5}};
  m.triangles = {{0, 1, 2}, {3, 4, 5}};
  SiteSpec spec = plane_site();
  spec.terrain.geometry = m;
  const auto site = Site::build(spec);
  const Vec3 o = site->local_origin();
  EXPECT_NEAR(site->terrain_height(2 - o.x(), 2 - o.y()) + o.z(), 5.0, 1e-12);
}

// ---- the terrain's boundary (Site::terrain_boundary_triangles, issue 22) ----

// Brute force: triangles with a vertex (matched by position) on an edge no other triangle
// shares.
std::vector<std::uint32_t> boundary_by_brute_force(const Site& s) {
  const auto& v = s.terrain_vertices();
  const auto& tris = s.terrain_triangles();
  const auto same_edge = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
    return (v[a] == v[c] && v[b] == v[d]) || (v[a] == v[d] && v[b] == v[c]);
  };
  std::vector<Vec3> rim;
  for (std::size_t t = 0; t < tris.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = tris[t][k], b = tris[t][(k + 1) % 3];
      int uses = 0;
      for (const auto& u : tris)
        for (int m = 0; m < 3; ++m) uses += same_edge(a, b, u[m], u[(m + 1) % 3]) ? 1 : 0;
      if (uses == 1) {
        rim.push_back(v[a]);
        rim.push_back(v[b]);
      }
    }
  }
  std::vector<std::uint32_t> out;
  for (std::uint32_t t = 0; t < tris.size(); ++t) {
    bool touches = false;
    for (const auto i : tris[t])
      touches = touches || std::find(rim.begin(), rim.end(), v[i]) != rim.end();
    if (touches) out.push_back(t);
  }
  return out;
}

TEST(TerrainBoundary, APlaneOrGridHasItsOuterRingOfCells) {
  // 12 x 7 cells: 2 (12 + 12 + 5 + 5) = 68 triangles in the ring.
  const auto plane = Site::build(plane_site({0, 0, 120, 70}, 10, 0));
  EXPECT_EQ(plane->terrain_boundary_triangles().size(), 68u);
  EXPECT_EQ(plane->terrain_boundary_triangles(), boundary_by_brute_force(*plane));
  const auto grid =
      Site::build(grid_site(make_grid(0, 0, 5, 9, 4, [](double x, double y) { return x * y; })));
  EXPECT_EQ(grid->terrain_boundary_triangles().size(), 2u * (8 + 8 + 1 + 1));
  EXPECT_EQ(grid->terrain_boundary_triangles(), boundary_by_brute_force(*grid));
  // One cell wide: everything is boundary.
  const auto strip = Site::build(plane_site({0, 0, 100, 10}, 10, 0));
  EXPECT_EQ(strip->terrain_boundary_triangles().size(), strip->terrain_triangle_count());
}

TEST(TerrainBoundary, AMeshHasItsRimAndTheRimsOfItsHoles) {
  // A 6 x 6 vertex jittered lattice with the triangles of one inner cell removed: a hole.
  MeshSpec m = testing::jittered_mesh(7, 6, 10.0);
  m.triangles.erase(m.triangles.begin() + 2 * (2 * 5 + 2),
                    m.triangles.begin() + 2 * (2 * 5 + 2) + 2);
  SiteSpec spec = plane_site();
  spec.terrain.geometry = m;
  const auto site = Site::build(spec);
  const auto& b = site->terrain_boundary_triangles();
  EXPECT_EQ(b, boundary_by_brute_force(*site));
  EXPECT_TRUE(std::is_sorted(b.begin(), b.end()));
  EXPECT_LT(b.size(), site->terrain_triangle_count()) << "the centre of a 5 x 5-cell mesh is not";

  // The same triangles with every vertex repeated per triangle (an unwelded mesh, as STL files
  // are): the same boundary.
  MeshSpec loose;
  for (const auto& t : m.triangles) {
    const auto base = static_cast<std::int64_t>(loose.vertices_m.size());
    for (const auto i : t) loose.vertices_m.push_back(m.vertices_m[static_cast<std::size_t>(i)]);
    loose.triangles.push_back({base, base + 1, base + 2});
  }
  spec.terrain.geometry = loose;
  EXPECT_EQ(Site::build(spec)->terrain_boundary_triangles(), b);
}

TEST(LocalFrame, UtmCoordinatesGiveTheSameLocalGeometry) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> zd(0, 30);
  std::vector<double> z(41 * 31);
  for (double& v : z) v = zd(rng);
  auto near = make_grid(-200, -150, 10, 41, 31, [](double, double) { return 0.0; });
  near.elevation_m = z;
  auto far = near;
  far.origin_m = {500000.0 - 200, 5.0e6 - 150};
  for (double& v : far.elevation_m) v += 1200.0;
  auto far_spec = grid_site(far);
  far_spec.origin = SiteOrigin{"EPSG:32633", 0, 0, 15.0};
  const auto a = Site::build(grid_site(near));
  const auto b = Site::build(far_spec);
  EXPECT_EQ(b->local_origin() - a->local_origin(), Vec3(500000, 5.0e6, 1200));
  EXPECT_DOUBLE_EQ(b->altitude_offset_m(), b->local_origin().z() + 15.0);
  ASSERT_EQ(a->terrain_vertices().size(), b->terrain_vertices().size());
  for (std::size_t v = 0; v < a->terrain_vertices().size(); ++v)
    ASSERT_LE((a->terrain_vertices()[v] - b->terrain_vertices()[v]).norm(), 1e-9) << v;
  EXPECT_LE((b->to_input(b->terrain_vertices()[5]) - Vec3(500000.0 - 150, 5.0e6 - 150, z[5] + 1200))
                .norm(),
            1e-9);
}

TEST(Materials, RestitutionTableAndNames) {
  const auto site = Site::build(plane_site());
  const auto& mats = site->materials();
  ASSERT_EQ(mats.size(), 4u);
  // Numbered in name order.
  EXPECT_EQ(mats[0].name, "concrete_wall");
  EXPECT_EQ(mats[1].name, "glass");
  EXPECT_EQ(mats[2].name, "metal_roof");
  EXPECT_EQ(mats[3].name, "soil");
  EXPECT_EQ(site->terrain_material(), 3);
  const Material& c = mats[0];                   // speeds {3, 30, 300}, e {0.5, 0.3, 0.1}
  EXPECT_DOUBLE_EQ(c.restitution_at(0.0), 0.5);  // clamped below
  EXPECT_DOUBLE_EQ(c.restitution_at(3.0), 0.5);
  EXPECT_DOUBLE_EQ(c.restitution_at(16.5), 0.4);  // halfway between 3 and 30
  EXPECT_DOUBLE_EQ(c.restitution_at(30.0), 0.3);
  EXPECT_DOUBLE_EQ(c.restitution_at(165.0), 0.2);
  EXPECT_DOUBLE_EQ(c.restitution_at(1e4), 0.1);  // clamped above
  EXPECT_DOUBLE_EQ(mats[3].restitution_at(123.0), 0.2);
  EXPECT_DOUBLE_EQ(mats[2].penetration_ke_per_area_j_per_m2, 1.5e5);
  EXPECT_TRUE(std::isinf(mats[3].penetration_ke_per_area_j_per_m2));
  EXPECT_STREQ(surface_type_name(SurfaceType::kTerrain), "terrain");
  EXPECT_STREQ(surface_type_name(SurfaceType::kWall), "wall");
  EXPECT_STREQ(surface_type_name(SurfaceType::kRoof), "roof");
  EXPECT_STREQ(surface_type_name(SurfaceType::kWindow), "window");
  EXPECT_EQ(site->embree_error(), "");
}

// Johnson & Reid (1975): theta_c = 18 deg / sqrt(sigma). Steel (7850) on soil of 1700 kg/m^3:
// sigma = 4.618, theta_c = 8.376 deg. A fragment at least min_speed fast and at least that steep
// embeds; more grazing or slower it does not; nor does anything without the model.
TEST(Materials, EmbedmentFollowsTheCriticalGrazingAngle) {
  SiteSpec spec = plane_site();
  spec.materials["soil"].embedment = EmbedmentSpec{};
  const auto site = Site::build(spec);
  const Material& soil = site->materials()[site->terrain_material()];
  const double theta_c = 18.0 / std::sqrt(7850.0 / 1700.0);
  EXPECT_NEAR(theta_c, 8.376, 1e-3);
  const Vec3 n = Vec3::UnitZ();
  const auto v = [](double speed, double deg) {
    return Vec3(speed * std::cos(deg * kDegToRad), 0.0, -speed * std::sin(deg * kDegToRad));
  };
  EXPECT_TRUE(soil.embeds(v(300.0, theta_c + 0.01), n, 7850.0));
  EXPECT_FALSE(soil.embeds(v(300.0, theta_c - 0.01), n, 7850.0));
  EXPECT_TRUE(soil.embeds(v(20.0, 60.0), n, 7850.0));     // min_speed 20: included
  EXPECT_FALSE(soil.embeds(v(19.9, 60.0), n, 7850.0));    // slower: a rigid contact
  EXPECT_FALSE(soil.embeds(-v(300.0, 60.0), n, 7850.0));  // moving away
  // Lighter fragments have a larger critical angle: aluminium (2700) 15.2 deg.
  EXPECT_FALSE(soil.embeds(v(300.0, 14.0), n, 2700.0));
  EXPECT_TRUE(soil.embeds(v(300.0, 16.0), n, 2700.0));
  // On a tilted surface the angle is taken to that surface.
  const Vec3 tilted = Vec3(-std::sin(0.2), 0.0, std::cos(0.2));
  EXPECT_TRUE(soil.embeds(Vec3(300.0, 0.0, 0.0), tilted, 7850.0));       // 11.5 deg into it
  EXPECT_FALSE(site->materials()[0].embeds(v(300.0, 80.0), n, 7850.0));  // no model: never
  // Bad values are refused with the field named.
  spec.materials["soil"].embedment->bulk_density_kg_m3 = 0.0;
  try {
    (void)Site::build(spec);
    FAIL() << "accepted a zero bulk density";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "site.materials.soil.embedment.bulk_density_kg_m3");
  }
}

// Material ranges (settings.ground_bracket): a range of a constant the material does not have, a
// low end above the high end and an end that is no valid value are refused, each named by the
// range (an end by its index); a valid range builds.
TEST(Materials, RangesAreCheckedWithTheRangeNamed) {
  const auto field_of = [](const SiteSpec& s) {
    try {
      (void)Site::build(s);
    } catch (const InputError& e) {
      return e.field() + ": " + e.message();
    }
    return std::string("<built>");
  };
  SiteSpec spec = plane_site();
  spec.materials["soil"].ranges["roughness_deg"] = {0.0, 5.0};  // no fast_contact
  EXPECT_EQ(field_of(spec).rfind("site.materials.soil.ranges.roughness_deg: ", 0), 0u);
  spec.materials["soil"].fast_contact = FastContactSpec{};
  EXPECT_EQ(field_of(spec), "<built>");
  spec.materials["soil"].ranges["friction"] = {0.9, 0.5};
  EXPECT_EQ(field_of(spec), "site.materials.soil.ranges.friction: low end above the high end");
  spec.materials["soil"].ranges["friction"] = {0.5, 0.9};
  spec.materials["soil"].ranges["restitution"] = {0.1, 1.5};
  EXPECT_EQ(field_of(spec).rfind("site.materials.soil.ranges.restitution[1]: ", 0), 0u);
}

// ---- Materials by zone (TerrainSpec: zones over triangle_material over material) ----

namespace zone_tests {

using testing::expect_input_error;

// The material name of terrain triangle t.
std::string material_of(const Site& site, std::uint32_t t) {
  return site.materials()[site.terrain_triangle_material(t)].name;
}

// A 400 m plane in 10 m cells: cell k = j * 40 + i holds triangles 2k and 2k + 1.
TEST(MaterialZones, ZonesTakeTheTrianglesWhoseCentroidTheyHoldAndTheLastWins) {
  SiteSpec spec = plane_site();
  spec.terrain.zones = {{"metal_roof", {{0, -200}, {200, -200}, {200, 200}, {0, 200}}},
                        {"glass", {{100, -200}, {200, -200}, {200, 200}, {100, 200}}}};
  const auto site = Site::build(spec);
  ASSERT_TRUE(site->terrain_has_zones());
  for (std::uint32_t t = 0; t < site->terrain_triangle_count(); ++t) {
    const double x = site->to_input(site->terrain_triangle_centroid(t)).x();
    const std::string want = x > 100 ? "glass" : x > 0 ? "metal_roof" : "soil";
    ASSERT_EQ(material_of(*site, t), want) << t;
  }
  EXPECT_EQ(site->terrain_material(), 3);  // the base material stays "soil"
}

// Queries report the material of the triangle hit: the analytic plane, Embree on a grid, and
// the exact terrain guard all go through terrain_triangle_material.
TEST(MaterialZones, HitsCarryTheMaterialOfTheTriangleHit) {
  for (const bool grid : {false, true}) {
    SiteSpec spec = plane_site();
    if (grid)
      spec.terrain.geometry = make_grid(-200, -200, 10, 41, 41, [](double, double) { return 0.0; });
    spec.terrain.zones = {{"glass", {{0, -200}, {200, -200}, {200, 200}, {0, 200}}}};
    const auto site = Site::build(spec);
    for (const double x : {-55.0, -3.0, 3.0, 55.0}) {
      const Vec3 org = site->to_local(Vec3(x, 7.0, 20.0));
      const auto hit = site->intersect(org, Vec3(0.1, 0.05, -1.0), 0.0, 100.0);
      ASSERT_TRUE(hit && hit->terrain) << x;
      EXPECT_EQ(site->materials()[hit->material].name, x > 0 ? "glass" : "soil") << x;
      EXPECT_EQ(hit->material, site->terrain_triangle_material(hit->triangle));
    }
  }
}

// A mesh's per-triangle materials, in its order; zones override them.
TEST(MaterialZones, TriangleMaterialsOfAMeshAndZonesOverThem) {
  SiteSpec spec = plane_site();
  MeshSpec mesh;
  mesh.vertices_m = {{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {0, 10, 0}, {20, 0, 0}, {20, 10, 0}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}, {1, 4, 5}, {1, 5, 2}};
  spec.terrain.geometry = mesh;
  spec.terrain.triangle_material_names = {"glass", "metal_roof"};
  spec.terrain.triangle_material = {0, 1, 1, 0};
  auto site = Site::build(spec);
  EXPECT_EQ(material_of(*site, 0), "glass");
  EXPECT_EQ(material_of(*site, 1), "metal_roof");
  EXPECT_EQ(material_of(*site, 2), "metal_roof");
  EXPECT_EQ(material_of(*site, 3), "glass");
  spec.terrain.zones = {{"soil", {{12, -1}, {21, -1}, {21, 11}, {12, 11}, {12, -1}}}};
  site = Site::build(spec);
  EXPECT_EQ(material_of(*site, 1), "metal_roof");
  EXPECT_EQ(material_of(*site, 2), "soil");
  EXPECT_EQ(material_of(*site, 3), "soil");
}

// Zones that change nothing leave the single-material site (no per-triangle table).
TEST(MaterialZones, ZonesOfTheBaseMaterialOrOverNothingChangeNothing) {
  SiteSpec spec = plane_site();
  spec.terrain.zones = {{"soil", {{-50, -50}, {50, -50}, {50, 50}}},
                        {"glass", {{500, 500}, {600, 500}, {600, 600}}}};
  const auto site = Site::build(spec);
  EXPECT_FALSE(site->terrain_has_zones());
  EXPECT_EQ(site->terrain_triangle_material(7), site->terrain_material());
}

TEST(MaterialZones, BadZonesAndIndicesAreNamed) {
  SiteSpec spec = plane_site();
  spec.terrain.zones = {{"soil", {{0, 0}, {10, 0}, {10, 10}}}, {"mud", {{0, 0}, {1, 0}, {0, 1}}}};
  expect_input_error(spec, "site.terrain.zones[1].material", "unknown material \"mud\"");
  spec.terrain.zones = {{"glass", {{0, 0}, {10, 10}, {10, 0}, {0, 10}}}};  // a bow tie
  EXPECT_THROW(Site::build(spec), InputError);
  try {
    Site::build(spec);
  } catch (const InputError& e) {
    EXPECT_EQ(e.field().rfind("site.terrain.zones[0].polygon_m", 0), 0u) << e.field();
  }
  spec.terrain.zones.clear();
  spec.terrain.triangle_material_names = {"glass"};
  spec.terrain.triangle_material = {0, 0};
  expect_input_error(spec, "site.terrain.triangle_materials.index",
                     "has 2 entries; the terrain has 3200 triangles");
  spec.terrain.triangle_material.assign(3200, 0);
  spec.terrain.triangle_material[17] = 1;
  expect_input_error(spec, "site.terrain.triangle_materials.index[17]",
                     "must be in [0, 0] (got 1)");
  spec.terrain.triangle_material_names.clear();
  expect_input_error(spec, "site.terrain.triangle_materials.names",
                     "is empty (name the materials the index refers to)");
}

}  // namespace zone_tests

}  // namespace
}  // namespace fragsim::scene
