// Building meshes: ear clipping, winding, base elevation, explicit meshes, inside_building.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <string>

#include "core/scene/polygon.h"
#include "scene_test_util.h"

namespace fragsim::scene {
namespace {

using testing::box_building;
using testing::grid_site;
using testing::make_grid;
using testing::plane_site;

double triangulated_area(const std::vector<Vec2>& poly,
                         const std::vector<std::array<std::uint32_t, 3>>& tris) {
  double a = 0;
  for (const auto& t : tris) {
    const double ta = 0.5 * detail::orient2d(poly[t[0]], poly[t[1]], poly[t[2]]);
    EXPECT_GT(ta, 0.0);  // counter-clockwise, non-degenerate
    a += ta;
  }
  return a;
}

TEST(EarClipping, LShapeAndCollinearVertices) {
  // L: 7 vertices including a collinear one at (10, 0).
  const std::vector<Vec2> l = {{0, 0}, {10, 0}, {20, 0}, {20, 5}, {5, 5}, {5, 15}, {0, 15}};
  const double area = detail::signed_area(l);
  EXPECT_DOUBLE_EQ(area, 20 * 5 + 5 * 10);
  const auto tris = detail::triangulate_polygon(l);
  EXPECT_EQ(tris.size(), l.size() - 2);
  EXPECT_NEAR(triangulated_area(l, tris), area, 1e-12 * area);
}

TEST(EarClipping, RandomStarPolygons) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> r(0.2, 1.0), jit(-0.4, 0.4);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 3 + trial % 40;
    std::vector<Vec2> poly;
    for (int k = 0; k < n; ++k) {
      const double phi = 2 * kPi * (k + 0.5 + jit(rng)) / n, rad = 30 * r(rng);
      poly.emplace_back(rad * std::cos(phi), rad * std::sin(phi));
    }
    const double area = detail::signed_area(poly);
    ASSERT_GT(area, 0);
    const auto tris = detail::triangulate_polygon(poly);
    ASSERT_EQ(tris.size(), static_cast<std::size_t>(n - 2)) << trial;
    ASSERT_NEAR(triangulated_area(poly, tris), area, 1e-12 * area) << trial;
  }
}

TEST(Buildings, BoxMeshIsClosedAndOutward) {
  for (const bool cw : {false, true}) {
    auto spec = plane_site();
    spec.buildings.push_back(box_building("B1", 60, -10, 80, 10, 6, cw));
    const auto site = Site::build(spec);
    ASSERT_EQ(site->buildings().size(), 1u);
    const Building& b = site->buildings()[0];
    EXPECT_EQ(b.id, "B1");
    EXPECT_EQ(b.triangle_count, 8u + 2u + 2u);  // walls, roof, floor
    EXPECT_EQ(b.floor_triangle_count, 2u);
    EXPECT_NEAR(b.surface_area_m2[static_cast<int>(SurfaceType::kWall)], 4 * 20 * 6, 1e-9);
    EXPECT_NEAR(b.surface_area_m2[static_cast<int>(SurfaceType::kRoof)], 400, 1e-9);
    EXPECT_EQ(b.surface_area_m2[static_cast<int>(SurfaceType::kWindow)], 0);
    const Vec3 o = site->local_origin();
    EXPECT_LE((b.bounds.lo - (Vec3(60, -10, 0) - o)).norm(), 1e-12);
    EXPECT_LE((b.bounds.hi - (Vec3(80, 10, 6) - o)).norm(), 1e-12);
    const Vec3 centre = 0.5 * (b.bounds.lo + b.bounds.hi);
    for (std::uint32_t t = b.first_triangle; t < b.first_triangle + b.triangle_count; ++t) {
      const auto& v = site->building_triangles()[t].v;
      const Vec3 c = (site->building_vertices()[v[0]] + site->building_vertices()[v[1]] +
                      site->building_vertices()[v[2]]) /
                     3.0;
      EXPECT_GT((c - centre).dot(site->building_triangle_normal(t)), 0)
          << "cw " << cw << " t " << t;
    }
    // Closed: every directed edge has its reverse.
    std::multiset<std::pair<std::uint32_t, std::uint32_t>> edges;
    for (const auto& t : site->building_triangles())
      for (int k = 0; k < 3; ++k) edges.insert({t.v[k], t.v[(k + 1) % 3]});
    for (const auto& [a, c] : edges) EXPECT_EQ(edges.count({c, a}), 1u);
  }
}

TEST(Buildings, ConcaveRoofAreaEqualsFootprintArea) {
  for (const bool cw : {false, true}) {
    auto spec = plane_site();
    BuildingSpec b = box_building("L", 0, 0, 1, 1, 9);
    b.footprint_m = {{10, 10}, {40, 10}, {40, 20}, {20, 20}, {20, 50}, {10, 50}};
    if (cw) std::reverse(b.footprint_m.begin(), b.footprint_m.end());
    spec.buildings.push_back(b);
    const auto site = Site::build(spec);
    const Building& out = site->buildings()[0];
    const double area = 30 * 10 + 10 * 30;
    EXPECT_NEAR(out.surface_area_m2[static_cast<int>(SurfaceType::kRoof)], area, 1e-12 * area);
    double floor = 0;
    for (std::uint32_t t = out.first_triangle; t < out.first_triangle + out.triangle_count; ++t) {
      const Vec3& n = site->building_triangle_normal(t);
      if (site->building_triangles()[t].surface == SurfaceType::kRoof) {
        EXPECT_NEAR(n.z(), 1, 1e-15);
      }
      if (t >= out.first_triangle + out.triangle_count - out.floor_triangle_count) {
        EXPECT_NEAR(n.z(), -1, 1e-15);
        floor += site->building_triangle_area(t);
      }
    }
    EXPECT_NEAR(floor, area, 1e-12 * area);
    EXPECT_EQ(out.floor_triangle_count, 4u);
  }
}

TEST(Buildings, BaseIsTheLowestGroundUnderTheFootprint) {
  // Sloped ground z = 0.1 x: the lowest point is on the footprint's west edge.
  {
    const auto g = make_grid(0, 0, 10, 21, 21, [](double x, double) { return 0.1 * x; });
    auto spec = grid_site(g);
    spec.buildings.push_back(box_building("S", 33, 41, 57, 62, 5));
    const auto site = Site::build(spec);
    const Building& b = site->buildings()[0];
    EXPECT_NEAR(b.bounds.lo.z() + site->local_origin().z(), 3.3, 1e-12);
    EXPECT_NEAR(b.bounds.hi.z() + site->local_origin().z(), 8.3, 1e-12);
  }
  // A pit at terrain vertex (30, 30) inside the footprint.
  {
    auto g = make_grid(0, 0, 10, 6, 6, [](double, double) { return 2.0; });
    g.elevation_m[3 * 6 + 3] = -4.0;
    auto spec = grid_site(g);
    spec.buildings.push_back(box_building("P", 24, 24, 36, 36, 5));
    const auto site = Site::build(spec);
    EXPECT_NEAR(site->buildings()[0].bounds.lo.z() + site->local_origin().z(), -4.0, 1e-12);
  }
  // A valley along the grid line x = 10 that no footprint vertex or enclosed terrain vertex
  // touches: only the footprint edges' crossings of terrain edges find its depth (-5; the
  // footprint vertices are at -4).
  {
    const auto g = make_grid(0, 0, 10, 4, 3, [](double x, double) { return x == 10 ? -5.0 : 0.0; });
    auto spec = grid_site(g);
    spec.buildings.push_back(box_building("V", 8, 3, 12, 7, 5));
    const auto site = Site::build(spec);
    const Vec3 o = site->local_origin();
    EXPECT_NEAR(site->terrain_height(8 - o.x(), 3 - o.y()) + o.z(), -4.0, 1e-12);
    EXPECT_NEAR(site->buildings()[0].bounds.lo.z() + o.z(), -5.0, 1e-12);
    // No gap: along every wall bottom the ground is at or above the base.
    const auto& fp = spec.buildings[0].footprint_m;
    for (std::size_t k = 0; k < fp.size(); ++k)
      for (int q = 0; q <= 100; ++q) {
        const double x = fp[k][0] + (fp[(k + 1) % 4][0] - fp[k][0]) * q / 100.0;
        const double y = fp[k][1] + (fp[(k + 1) % 4][1] - fp[k][1]) * q / 100.0;
        EXPECT_GE(site->terrain_height(x - o.x(), y - o.y()),
                  site->buildings()[0].bounds.lo.z() - 1e-12);
      }
  }
  // An explicit base overrides the terrain.
  {
    auto spec = plane_site();
    spec.buildings.push_back(box_building("E", 0, 0, 10, 10, 5));
    spec.buildings[0].base_elevation_m = -2.0;
    const auto site = Site::build(spec);
    EXPECT_NEAR(site->buildings()[0].bounds.lo.z() + site->local_origin().z(), -2.0, 1e-12);
  }
}

TEST(Buildings, ExplicitMeshWoundInwardIsFlipped) {
  // Tetrahedron wound inward (normals toward the centroid) with a window face.
  MeshSpec m;
  m.vertices_m = {{100, 100, 0}, {110, 100, 0}, {100, 110, 0}, {100, 100, 10}};
  m.triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  m.surface = {SurfaceType::kWall, SurfaceType::kWall, SurfaceType::kWindow, SurfaceType::kRoof};
  // Check the input really is inward: face 0 (z = 0) has normal +z.
  ASSERT_GT((m.vertices_m[1] - m.vertices_m[0]).cross(m.vertices_m[2] - m.vertices_m[0]).z(), 0);
  auto spec = plane_site();
  BuildingSpec b;
  b.id = "T";
  b.mesh = m;
  b.wall = "concrete_wall";
  b.roof = "metal_roof";
  b.window = "glass";
  spec.buildings.push_back(b);
  const auto site = Site::build(spec);
  const Building& out = site->buildings()[0];
  EXPECT_EQ(out.floor_triangle_count, 0u);
  const Vec3 centre =
      (Vec3(100, 100, 0) + Vec3(110, 100, 0) + Vec3(100, 110, 0) + Vec3(100, 100, 10)) / 4 -
      site->local_origin();
  for (std::uint32_t t = 0; t < 4; ++t) {
    const auto& bt = site->building_triangles()[t];
    const Vec3 c = (site->building_vertices()[bt.v[0]] + site->building_vertices()[bt.v[1]] +
                    site->building_vertices()[bt.v[2]]) /
                   3.0;
    EXPECT_GT((c - centre).dot(site->building_triangle_normal(t)), 0) << t;
    EXPECT_EQ(bt.surface, m.surface[t]);
  }
  EXPECT_EQ(site->materials()[site->building_triangles()[2].material].name, "glass");
  EXPECT_EQ(site->materials()[site->building_triangles()[3].material].name, "metal_roof");
  EXPECT_NEAR(out.surface_area_m2[static_cast<int>(SurfaceType::kWindow)], 50, 1e-9);
}

TEST(Buildings, InsideBuilding) {
  auto spec = plane_site();
  spec.buildings.push_back(box_building("B1", 60, -10, 80, 10, 6));
  BuildingSpec l = box_building("L", 0, 0, 1, 1, 9);
  l.footprint_m = {{10, 10}, {40, 10}, {40, 20}, {20, 20}, {20, 50}, {10, 50}};
  spec.buildings.push_back(l);
  const auto site = Site::build(spec);
  const auto inside = [&](double x, double y, double z) {
    return site->inside_building(site->to_local(Vec3(x, y, z)));
  };
  EXPECT_TRUE(inside(70, 0, 3));
  EXPECT_TRUE(inside(60.01, -9.99, 0.01));
  EXPECT_TRUE(inside(70, 0, 3.0));
  EXPECT_FALSE(inside(70, 0, 6.01));   // above the roof
  EXPECT_FALSE(inside(70, 0, -0.01));  // below the floor
  EXPECT_FALSE(inside(59.99, 0, 3));
  EXPECT_FALSE(inside(0, 0, 3));
  EXPECT_TRUE(inside(35, 15, 4));   // in the L's foot
  EXPECT_TRUE(inside(15, 45, 4));   // in its stem
  EXPECT_FALSE(inside(30, 30, 4));  // in the notch (inside the bounding box, outside the L)
  // Just under the roof, above the roof's diagonal (70, 0 lies on it in xy).
  EXPECT_TRUE(inside(70, 0, 5.999));
  // A tall L whose notch faces the lower left: from a point in the notch, a ray going up and
  // towards +x+y enters the building and leaves it again (two crossings: outside).
  auto tall_spec = plane_site();
  BuildingSpec tall = box_building("T", 0, 0, 1, 1, 100);
  tall.footprint_m = {{30, 10}, {50, 10}, {50, 50}, {10, 50}, {10, 30}, {30, 30}};
  tall_spec.buildings.push_back(tall);
  const auto tall_site = Site::build(tall_spec);
  std::mt19937_64 trng(6);
  std::uniform_real_distribution<double> nxy(10.5, 29.5), nz(0.5, 20);
  for (int k = 0; k < 200; ++k)
    ASSERT_FALSE(
        tall_site->inside_building(tall_site->to_local(Vec3(nxy(trng), nxy(trng), nz(trng)))));
  EXPECT_TRUE(tall_site->inside_building(tall_site->to_local(Vec3(40, 40, 50))));
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> ux(5, 45), uy(5, 55), uz(-1, 10);
  for (int k = 0; k < 2000; ++k) {
    const double x = ux(rng), y = uy(rng), z = uz(rng);
    const bool in_l =
        z > 0 && z < 9 &&
        ((x > 10 && x < 40 && y > 10 && y < 20) || (x > 10 && x < 20 && y > 10 && y < 50));
    ASSERT_EQ(inside(x, y, z), in_l) << x << " " << y << " " << z;
  }
}

// The building's triangles as "a b c s" (vertex indices relative to the building's first vertex,
// surface type number), one per triangle in order, joined by ';'.
std::string triangles_text(const Site& site, std::size_t building) {
  const Building& b = site.buildings()[building];
  std::uint32_t v0 = std::numeric_limits<std::uint32_t>::max();
  for (std::uint32_t t = b.first_triangle; t < b.first_triangle + b.triangle_count; ++t)
    for (const std::uint32_t v : site.building_triangles()[t].v) v0 = std::min(v0, v);
  std::string out;
  for (std::uint32_t t = b.first_triangle; t < b.first_triangle + b.triangle_count; ++t) {
    const BuildingTriangle& bt = site.building_triangles()[t];
    if (!out.empty()) out += ';';
    out += std::to_string(bt.v[0] - v0) + ' ' + std::to_string(bt.v[1] - v0) + ' ' +
           std::to_string(bt.v[2] - v0) + ' ' + std::to_string(static_cast<int>(bt.surface));
  }
  return out;
}

TEST(Buildings, FootprintWithoutHolesIsUnchanged) {
  // Recorded before holes_m existed: a building without holes keeps its vertices and its
  // triangles, in the same order (results and exposed areas do not move).
  auto spec = plane_site();
  BuildingSpec l = box_building("L", 0, 0, 1, 1, 9, /*clockwise=*/false);
  l.footprint_m = {{10, 50}, {20, 50}, {20, 20}, {40, 20}, {40, 10}, {10, 10}};  // clockwise
  spec.buildings.push_back(l);
  BuildingSpec comb = box_building("C", 0, 0, 1, 1, 4);
  comb.footprint_m = {{60, 0}, {70, 0}, {80, 0}, {80, 5}, {75, 5}, {75, 2},
                      {70, 2}, {70, 5}, {60, 5}, {60, 0}};  // collinear vertex, GIS closing vertex
  spec.buildings.push_back(comb);
  const auto site = Site::build(spec);
  EXPECT_EQ(triangles_text(*site, 0),
            "0 1 7 1;0 7 6 1;1 2 8 1;1 8 7 1;2 3 9 1;2 9 8 1;3 4 10 1;3 10 9 1;4 5 11 1;4 11 10 1;"
            "5 0 6 1;5 6 11 1;6 7 8 2;6 8 9 2;6 9 10 2;6 10 11 2;0 2 1 1;0 3 2 1;0 4 3 1;0 5 4 1");
  EXPECT_EQ(triangles_text(*site, 1),
            "0 1 10 1;0 10 9 1;1 2 11 1;1 11 10 1;2 3 12 1;2 12 11 1;3 4 13 1;3 13 12 1;4 5 14 1;"
            "4 14 13 1;5 6 15 1;5 15 14 1;6 7 16 1;6 16 15 1;7 8 17 1;7 17 16 1;8 0 9 1;8 9 17 1;"
            "17 9 10 2;11 12 13 2;11 13 14 2;11 14 15 2;15 16 17 2;15 17 10 2;15 10 11 2;8 1 0 1;"
            "2 4 3 1;2 5 4 1;2 6 5 1;6 8 7 1;6 1 8 1;6 2 1 1");
  // Vertices: the footprint made counter-clockwise (the L reversed), at the base then the top.
  const std::vector<std::array<double, 2>> ccw_l = {{10, 10}, {40, 10}, {40, 20},
                                                    {20, 20}, {20, 50}, {10, 50}};
  const Vec3 o = site->local_origin();
  ASSERT_EQ(site->building_vertices().size(), 2 * ccw_l.size() + 2 * 9);
  for (std::size_t k = 0; k < 2 * ccw_l.size(); ++k) {
    const auto& p = ccw_l[k % ccw_l.size()];
    EXPECT_EQ(site->building_vertices()[k], Vec3(p[0], p[1], k < ccw_l.size() ? 0 : 9) - o) << k;
  }
}

// ---- Footprints with holes (courtyards) ----

using Ring = std::vector<std::array<double, 2>>;

double ring_area(const Ring& r) {  // signed, shoelace
  double a = 0;
  for (std::size_t k = 0; k < r.size(); ++k) {
    const auto& p = r[k];
    const auto& q = r[(k + 1) % r.size()];
    a += p[0] * q[1] - q[0] * p[1];
  }
  return 0.5 * a;
}

double ring_perimeter(const Ring& r) {
  double l = 0;
  for (std::size_t k = 0; k < r.size(); ++k)
    l += std::hypot(r[(k + 1) % r.size()][0] - r[k][0], r[(k + 1) % r.size()][1] - r[k][1]);
  return l;
}

double net_area(const BuildingSpec& b) {
  double a = std::abs(ring_area(b.footprint_m));
  for (const auto& h : b.holes_m) a -= std::abs(ring_area(h));
  return a;
}

// A 60 x 40 m block on the plane (x 100..160, y 20..60) around three courtyards: a square, a
// triangle and an L, in mixed orientations.
BuildingSpec courtyard_block() {
  BuildingSpec b = box_building("Y", 100, 20, 160, 60, 12, /*clockwise=*/true);
  b.holes_m = {{{105, 25}, {120, 25}, {120, 40}, {105, 40}},  // counter-clockwise
               {{130, 50}, {140, 30}, {125, 30}},             // clockwise
               {{145, 25}, {155, 25}, {155, 55}, {130, 55}, {130, 52}, {145, 52}}};
  return b;
}

// Checks the extruded building: a closed 2-manifold (every directed edge used once, its reverse
// once: each edge shared by exactly two triangles of opposite orientation), enclosing net area x
// height (divergence theorem), every normal pointing out of the solid (a point just outside along
// the normal is outside every building, one just inside is inside), roof and wall areas, and the
// triangle count the site limits assume.
void expect_closed_extrusion(const Site& site, std::size_t index, const BuildingSpec& spec) {
  const Building& b = site.buildings()[index];
  const auto& tris = site.building_triangles();
  const auto& verts = site.building_vertices();
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  double volume6 = 0;
  const Vec3 ref = b.bounds.lo;
  for (std::uint32_t t = b.first_triangle; t < b.first_triangle + b.triangle_count; ++t) {
    const auto& v = tris[t].v;
    for (int k = 0; k < 3; ++k) ++directed[{v[k], v[(k + 1) % 3]}];
    volume6 += (verts[v[0]] - ref).dot((verts[v[1]] - ref).cross(verts[v[2]] - ref));
  }
  for (const auto& [e, uses] : directed) {
    ASSERT_EQ(uses, 1) << "edge " << e.first << "-" << e.second;
    const auto back = directed.find({e.second, e.first});
    ASSERT_TRUE(back != directed.end()) << "edge " << e.first << "-" << e.second << " is open";
  }
  const double area = net_area(spec);
  EXPECT_NEAR(volume6 / 6, area * spec.height_m, 1e-9 * area * spec.height_m);
  for (std::uint32_t t = b.first_triangle; t < b.first_triangle + b.triangle_count; ++t) {
    const auto& v = tris[t].v;
    const Vec3 c = (verts[v[0]] + verts[v[1]] + verts[v[2]]) / 3.0;
    const Vec3& n = site.building_triangle_normal(t);
    const double d = 1e-3;
    if (tris[t].surface == SurfaceType::kRoof) {
      EXPECT_NEAR(n.z(), 1, 1e-15);
    }
    // The floor lies on the plane z = 0: only its inner side is checked.
    if (c.z() > b.bounds.lo.z() + 1e-9) {
      EXPECT_FALSE(site.inside_building(c + d * n)) << t;
    }
    EXPECT_TRUE(site.inside_building(c - d * n)) << t;
  }
  double perimeter = ring_perimeter(spec.footprint_m);
  std::size_t vertices = spec.footprint_m.size();
  for (const auto& h : spec.holes_m) {
    perimeter += ring_perimeter(h);
    vertices += h.size();
  }
  EXPECT_NEAR(b.surface_area_m2[static_cast<int>(SurfaceType::kRoof)], area, 1e-9 * area);
  EXPECT_NEAR(b.surface_area_m2[static_cast<int>(SurfaceType::kWall)], perimeter * spec.height_m,
              1e-9 * perimeter * spec.height_m);
  EXPECT_EQ(b.triangle_count, 4 * vertices + 4 * spec.holes_m.size() - 4);
  EXPECT_EQ(b.floor_triangle_count, vertices + 2 * spec.holes_m.size() - 2);
}

TEST(Courtyards, ExtrudedBlockIsClosedAndOutward) {
  auto spec = plane_site();
  spec.buildings.push_back(courtyard_block());
  const auto site = Site::build(spec);
  expect_closed_extrusion(*site, 0, spec.buildings[0]);
  // Materials as for any footprint.
  for (const auto& t : site->building_triangles()) {
    const std::string& name = site->materials()[t.material].name;
    EXPECT_EQ(name, t.surface == SurfaceType::kRoof ? "metal_roof" : "concrete_wall");
    EXPECT_NE(t.surface, SurfaceType::kWindow);
  }
}

TEST(Courtyards, ManyHolesAndAConcaveOutline) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> jit(-1.5, 1.5);
  auto spec = plane_site();
  // A U-shaped block (x -90..-10, y -80..-20) with courtyards in both arms and the base.
  BuildingSpec u = box_building("U", 0, 0, 1, 1, 7.5);
  u.footprint_m = {{-90, -80}, {-10, -80}, {-10, -20}, {-30, -20},
                   {-30, -55}, {-70, -55}, {-70, -20}, {-90, -20}};
  for (const double cx : {-80.0, -20.0})
    for (const double cy : {-45.0, -30.0})
      u.holes_m.push_back({{cx - 4 + jit(rng), cy - 4},
                           {cx + 4, cy - 4 + jit(rng)},
                           {cx + 4 + jit(rng), cy + 4},
                           {cx - 4, cy + 4 + jit(rng)}});
  u.holes_m.push_back({{-50, -75}, {-40, -65}, {-50, -60}, {-60, -65}});
  ASSERT_EQ(u.holes_m.size(), 5u);
  spec.buildings.push_back(u);
  spec.buildings.push_back(courtyard_block());
  const auto site = Site::build(spec);
  expect_closed_extrusion(*site, 0, spec.buildings[0]);
  expect_closed_extrusion(*site, 1, spec.buildings[1]);
}

TEST(Courtyards, RaysFallIntoTheCourtyardAndOntoTheRoof) {
  auto spec = plane_site();
  spec.buildings.push_back(courtyard_block());
  const auto site = Site::build(spec);
  const Vec3 down(0, 0, -1);
  const auto drop = [&](double x, double y) {
    return site->intersect(site->to_local(Vec3(x, y, 50)), down, 0, 100);
  };
  // Into each courtyard: the ground, 50 m down.
  for (const auto& [x, y] : {std::pair{112.5, 32.5}, {131.0, 33.0}, {150.0, 40.0}, {140.0, 54.0}}) {
    const auto hit = drop(x, y);
    ASSERT_TRUE(hit) << x << " " << y;
    EXPECT_TRUE(hit->terrain) << x << " " << y;
    EXPECT_NEAR(hit->t, 50, 1e-9);
    EXPECT_FALSE(site->inside_building(site->to_local(Vec3(x, y, 6)))) << x << " " << y;
  }
  // Onto the roof between them: 12 m high.
  for (const auto& [x, y] : {std::pair{102.5, 50.0}, {122.5, 45.0}, {150.0, 22.5}, {140.0, 50.0}}) {
    const auto hit = drop(x, y);
    ASSERT_TRUE(hit) << x << " " << y;
    EXPECT_FALSE(hit->terrain) << x << " " << y;
    EXPECT_EQ(hit->surface, SurfaceType::kRoof);
    EXPECT_NEAR(hit->t, 38, 1e-9);
    EXPECT_TRUE(site->inside_building(site->to_local(Vec3(x, y, 6)))) << x << " " << y;
  }
  // Across the square courtyard at half height: its east wall, facing into the courtyard.
  const auto across = site->intersect(site->to_local(Vec3(110, 32.5, 6)), Vec3(1, 0, 0), 0, 100);
  ASSERT_TRUE(across);
  EXPECT_EQ(across->surface, SurfaceType::kWall);
  EXPECT_NEAR(across->t, 10, 1e-9);
  EXPECT_NEAR(across->normal.x(), -1, 1e-12);
}

TEST(Courtyards, BaseIsTheLowestGroundUnderTheBuildingNotInTheCourtyard) {
  // A pit at terrain vertex (30, 30), -4 m in ground at 2 m. In the courtyard, it is not under
  // the building, but the courtyard's walls stand on its slope: the ground under the hole's west
  // edge x = 25 falls to 2 - 0.6 * 5 = -1 m (the outline's edges stay on flat ground).
  auto g = make_grid(0, 0, 10, 7, 7, [](double, double) { return 2.0; });
  g.elevation_m[3 * 7 + 3] = -4.0;
  auto spec = grid_site(g);
  BuildingSpec b = box_building("P", 12, 12, 48, 48, 5);
  b.holes_m = {{{25, 25}, {35, 25}, {35, 35}, {25, 35}}};
  spec.buildings.push_back(b);
  const auto site = Site::build(spec);
  EXPECT_NEAR(site->buildings()[0].bounds.lo.z() + site->local_origin().z(), -1.0, 1e-12);
  // The courtyard elsewhere: the pit is under the building.
  spec.buildings[0].holes_m = {{{15, 15}, {22, 15}, {22, 22}, {15, 22}}};
  const auto moved = Site::build(spec);
  EXPECT_NEAR(moved->buildings()[0].bounds.lo.z() + moved->local_origin().z(), -4.0, 1e-12);
}

TEST(Courtyards, AMeshHasNoHoles) {
  auto spec = plane_site();
  BuildingSpec b = box_building("M", 0, 0, 1, 1, 1);
  b.footprint_m.clear();
  b.mesh = MeshSpec{};
  b.holes_m = {{{0, 0}, {1, 0}, {0, 1}}};
  spec.buildings.push_back(b);
  testing::expect_input_error(spec, "site.buildings[0].holes_m", "only a footprint has holes");
}

}  // namespace
}  // namespace fragsim::scene
