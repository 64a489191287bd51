// Slide, roll and rest on the terrain against the closed forms of a body on an inclined plane.
#include "core/impact/ground_motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace fragsim::impact {
namespace {

// A grid terrain z = slope * x over [-200, 200]^2 (10 m cells): one plane, many triangles.
std::shared_ptr<const scene::Site> slope_site(double slope, double friction, double rolling) {
  scene::SiteSpec spec;
  scene::GridTerrainSpec grid;
  grid.origin_m = {-200.0, -200.0};
  grid.spacing_m = 10.0;
  grid.nx = grid.ny = 41;
  for (int j = 0; j < grid.ny; ++j)
    for (int i = 0; i < grid.nx; ++i) grid.elevation_m.push_back(slope * (-200.0 + 10.0 * i));
  spec.terrain.geometry = grid;
  spec.terrain.material = "ground";
  scene::MaterialSpec m;
  m.friction = friction;
  m.rolling_resistance = rolling;
  spec.materials["ground"] = m;
  return scene::Site::build(spec);
}

// A bumpy grid terrain over [-200, 200]^2 (10 m cells), and the same surface given as a general
// mesh (vertices and triangles listed as the grid builder lists them).
scene::SiteSpec bumpy_spec(bool as_mesh) {
  scene::SiteSpec spec;
  const int n = 41;
  const auto z = [](int i, int j) { return 3.0 * std::sin(0.21 * i) * std::cos(0.17 * j) + 0.05 * i; };
  if (as_mesh) {
    scene::MeshSpec mesh;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) mesh.vertices_m.emplace_back(-200.0 + 10.0 * i, -200.0 + 10.0 * j, z(i, j));
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        const std::int64_t v00 = j * n + i, v10 = v00 + 1, v01 = v00 + n, v11 = v01 + 1;
        mesh.triangles.push_back({v00, v10, v11});
        mesh.triangles.push_back({v00, v11, v01});
      }
    spec.terrain.geometry = mesh;
  } else {
    scene::GridTerrainSpec grid;
    grid.origin_m = {-200.0, -200.0};
    grid.spacing_m = 10.0;
    grid.nx = grid.ny = n;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) grid.elevation_m.push_back(z(i, j));
    spec.terrain.geometry = grid;
  }
  spec.terrain.material = "ground";
  scene::MaterialSpec m;
  m.friction = 0.3;
  spec.materials["ground"] = m;
  return spec;
}

// Barycentric coordinates of (x, y) in the xy-projection of terrain triangle t.
Vec3 barycentric(const scene::Site& site, std::uint32_t t, double x, double y) {
  const auto& tri = site.terrain_triangles()[t];
  const Vec3& a = site.terrain_vertices()[tri[0]];
  const Vec3& b = site.terrain_vertices()[tri[1]];
  const Vec3& c = site.terrain_vertices()[tri[2]];
  const auto orient = [](const Vec3& p, const Vec3& q, double px, double py) {
    return (q.x() - p.x()) * (py - p.y()) - (q.y() - p.y()) * (px - p.x());
  };
  const double area2 = orient(a, b, c.x(), c.y());
  const double la = orient(b, c, x, y) / area2, lb = orient(c, a, x, y) / area2;
  return Vec3(la, lb, 1.0 - la - lb);
}

GroundMotionInput start(const scene::Site& site, double x, double y, const Vec3& v) {
  GroundMotionInput in;
  in.position_m = Vec3(x, y, site.terrain_height(x, y) + 0.1);
  in.velocity_mps = v;
  in.clearance_m = 0.1 * site.terrain_triangle_normal(0).z();  // 0.1 m above, vertically
  in.t_max_s = 1000.0;
  return in;
}

auto no_stop = [](const GroundSegment&) { return false; };

// Flat ground, sliding from v0: stops after v0^2 / (2 mu g) in time v0 / (mu g), exactly.
TEST(GroundMotion, SlideOnFlatGroundStopsAtTheCoulombDistance) {
  const auto site = slope_site(0.0, 0.5, 0.1);
  const double v0 = 12.0, g = kStandardGravity_mps2, mu = 0.5;
  GroundMotionInput in = start(*site, 0.3, 0.7, Vec3(v0 * 0.6, v0 * 0.8, 0.0));
  const GroundMotionResult r = move_on_ground(*site, in, no_stop);
  EXPECT_EQ(r.end, GroundEnd::kRest);
  const double d = v0 * v0 / (2 * mu * g);
  EXPECT_NEAR(r.path_m, d, 1e-9 * d);
  EXPECT_NEAR((r.position_m - in.position_m).norm(), d, 1e-9 * d);
  EXPECT_NEAR(r.t_s, v0 / (mu * g), 1e-12);
  EXPECT_NEAR(r.position_m.z(), in.position_m.z(), 1e-12);  // stays at its clearance
}

// A sphere rolling on flat ground decelerates at 5/7 mu_r g (rolling resistance).
TEST(GroundMotion, RollOnFlatGroundStopsAtTheRollingDistance) {
  const auto site = slope_site(0.0, 0.5, 0.1);
  const double v0 = 8.0, g = kStandardGravity_mps2, a = 5.0 / 7.0 * 0.1 * g;
  GroundMotionInput in = start(*site, 0.0, 0.0, Vec3(v0, 0.0, 0.0));
  in.rolling = true;
  const GroundMotionResult r = move_on_ground(*site, in, no_stop);
  EXPECT_EQ(r.end, GroundEnd::kRest);
  EXPECT_NEAR(r.path_m, v0 * v0 / (2 * a), 1e-9 * v0 * v0 / (2 * a));
  EXPECT_NEAR(r.t_s, v0 / a, 1e-9 * v0 / a);
}

// A slope below the friction angle (tan theta < mu): a body put down at rest stays there.
TEST(GroundMotion, RestsOnASlopeBelowItsFrictionAngle) {
  const auto site = slope_site(0.4, 0.5, 0.1);  // tan theta 0.4 < 0.5
  GroundMotionInput in = start(*site, 1.0, 2.0, Vec3::Zero());
  const GroundMotionResult r = move_on_ground(*site, in, no_stop);
  EXPECT_EQ(r.end, GroundEnd::kRest);
  EXPECT_EQ(r.path_m, 0.0);
  EXPECT_EQ(r.position_m, in.position_m);
}

// Above it (tan theta > mu) it slides down with a = g (sin theta - mu cos theta): distance after
// t is a t^2 / 2, until it leaves the terrain at the low edge.
TEST(GroundMotion, SlidesDownASlopeAboveItsFrictionAngle) {
  const double slope = 0.6, mu = 0.5, g = kStandardGravity_mps2;
  const auto site = slope_site(slope, mu, 0.1);
  const double th = std::atan(slope);
  const double a = g * (std::sin(th) - mu * std::cos(th));
  GroundMotionInput in = start(*site, 150.0, 0.0, Vec3::Zero());
  const double T = 4.0;
  in.t_max_s = T;
  const GroundMotionResult r = move_on_ground(*site, in, no_stop);
  EXPECT_EQ(r.end, GroundEnd::kMaxTime);
  EXPECT_NEAR(r.path_m, 0.5 * a * T * T, 1e-9 * 0.5 * a * T * T);
  EXPECT_LT(r.position_m.x(), in.position_m.x());  // downhill is -x
  EXPECT_NEAR(r.position_m.y(), 0.0, 1e-9);
  EXPECT_NEAR(r.velocity_mps.norm(), a * T, 1e-9 * a * T);
  // Left alone, it slides off the low edge.
  in.t_max_s = 1000.0;
  EXPECT_EQ(move_on_ground(*site, in, no_stop).end, GroundEnd::kLeftSite);
}

// Moving up a slope it decelerates at g (sin + mu cos), stops, and rests (below the friction
// angle) without sliding back.
TEST(GroundMotion, SlidingUphillStopsAndStays) {
  const double slope = 0.2, mu = 0.5, g = kStandardGravity_mps2;
  const auto site = slope_site(slope, mu, 0.1);
  const double th = std::atan(slope);
  const double v0 = 10.0;
  const Vec3 up = Vec3(std::cos(th), 0.0, std::sin(th));
  GroundMotionInput in = start(*site, -50.0, 3.0, v0 * up);
  const GroundMotionResult r = move_on_ground(*site, in, no_stop);
  EXPECT_EQ(r.end, GroundEnd::kRest);
  const double a = g * (std::sin(th) + mu * std::cos(th));
  EXPECT_NEAR(r.path_m, v0 * v0 / (2 * a), 1e-9 * v0 * v0 / (2 * a));
  // Energy: never more than it started with (kinetic + potential).
  EXPECT_LT(g * (r.position_m.z() - in.position_m.z()), 0.5 * v0 * v0);
}

// Steps go edge to edge: every segment lies over its triangle, and every one but the last (the
// stop) ends on that triangle's boundary. Sliding straight up the fall line the acceleration is
// exactly constant, so at every step end the travelled distance is v0 t - a t^2 / 2 and the
// speed v0 - a t (a = g (sin theta + mu cos theta)), and the stop is at t = v0 / a.
TEST(GroundMotion, StepsEndOnTriangleEdgesAndFollowTheClosedForm) {
  const double slope = 0.2, mu = 0.5, g = kStandardGravity_mps2;
  const auto site = slope_site(slope, mu, 0.1);
  const double th = std::atan(slope);
  const double a = g * (std::sin(th) + mu * std::cos(th));
  const double v0 = 25.0;
  const Vec3 dir = Vec3(std::cos(th), 0.0, std::sin(th));
  GroundMotionInput in = start(*site, -150.0, 3.3, v0 * dir);
  int segments = 0, on_edge = 0;
  double worst_s = 0.0, worst_v = 0.0, last_tb = 0.0;
  const auto check = [&](const GroundSegment& sg) {
    ++segments;
    for (const Vec3* q : {&sg.a, &sg.b}) {
      const Vec3 l = barycentric(*site, sg.triangle, q->x(), q->y());
      EXPECT_GE(l.minCoeff(), -1e-9) << "segment " << segments;
    }
    if (barycentric(*site, sg.triangle, sg.b.x(), sg.b.y()).minCoeff() < 1e-9) ++on_edge;
    const double t = sg.tb - in.t_s;
    const double s = (sg.b - in.position_m).norm();
    worst_s = std::max(worst_s, std::abs(s - (v0 * t - 0.5 * a * t * t)));
    worst_v = std::max(worst_v, std::abs(sg.vb.norm() - (v0 - a * t)));
    last_tb = sg.tb;
    return false;
  };
  const GroundMotionResult r = move_on_ground(*site, in, check);
  EXPECT_EQ(r.end, GroundEnd::kRest);
  EXPECT_LT(worst_s, 1e-9 * v0 * v0 / a);
  EXPECT_LT(worst_v, 1e-9 * v0);
  EXPECT_NEAR(last_tb, v0 / a, 1e-12 * v0 / a);
  EXPECT_NEAR(r.path_m, v0 * v0 / (2 * a), 1e-9 * v0 * v0 / (2 * a));
  // 44 m up the slope along y = 3.3: every cell boundary and every diagonal is an edge.
  EXPECT_GE(segments, 8);
  EXPECT_EQ(on_edge, segments - 1);
}

// The lattice walk (cell arithmetic) and the general-mesh walk (edge equations from the
// vertices, next triangle looked up past the exit) follow the same path over the same surface.
TEST(GroundMotion, LatticeAndMeshWalksAgree) {
  const auto grid = scene::Site::build(bumpy_spec(false));
  const auto mesh = scene::Site::build(bumpy_spec(true));
  ASSERT_TRUE(grid->terrain_is_lattice());
  ASSERT_FALSE(mesh->terrain_is_lattice());
  for (const Vec3& v : {Vec3(30.0, 11.0, 0.0), Vec3(-7.0, 26.0, 0.0), Vec3(-40.0, -40.0, 0.0)}) {
    std::vector<std::uint32_t> tris[2];
    GroundMotionResult r[2];
    int k = 0;
    for (const auto* site : {grid.get(), mesh.get()}) {
      GroundMotionInput in = start(*site, 12.3, -4.56, v);
      in.clearance_m = 0.05;
      r[k] = move_on_ground(*site, in, [&](const GroundSegment& sg) {
        tris[k].push_back(sg.triangle);
        return false;
      });
      ++k;
    }
    EXPECT_EQ(r[0].end, r[1].end);
    EXPECT_EQ(tris[0], tris[1]);
    EXPECT_NEAR((r[0].position_m - r[1].position_m).norm(), 0.0, 1e-6);
    EXPECT_NEAR(r[0].t_s, r[1].t_s, 1e-9);
    EXPECT_GT(tris[0].size(), 3u);
  }
}

TEST(GroundMotion, CallbackStopsAndEverySegmentIsReported) {
  const auto site = slope_site(0.0, 0.5, 0.1);
  GroundMotionInput in = start(*site, 0.0, 0.0, Vec3(20.0, 0.0, 0.0));
  double covered = 0.0;
  int calls = 0;
  const auto stop_after_15m = [&](const GroundSegment& sg) {
    EXPECT_LT(sg.ta, sg.tb);
    covered += (sg.b - sg.a).norm();
    ++calls;
    return covered > 15.0;  // steps end at the 10 m cell edges
  };
  const GroundMotionResult r = move_on_ground(*site, in, stop_after_15m);
  EXPECT_EQ(r.end, GroundEnd::kStoppedByCaller);
  EXPECT_NEAR(r.path_m, covered, 1e-12);
  EXPECT_GT(calls, 1);
  // A step cap always ends the motion.
  in.max_steps = 3;
  EXPECT_EQ(move_on_ground(*site, in, no_stop).end, GroundEnd::kStepCap);
}

}  // namespace
}  // namespace fragsim::impact
