// Slide, roll and rest on the terrain against the closed forms of a body on an inclined plane.
#include "core/impact/ground_motion.h"

#include <gtest/gtest.h>

#include <cmath>

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

GroundMotionInput start(const scene::Site& site, double x, double y, const Vec3& v) {
  GroundMotionInput in;
  in.position_m = Vec3(x, y, site.terrain_height(x, y) + 0.1);
  in.velocity_mps = v;
  in.clearance_m = 0.1 * site.terrain_triangle_normal(0).z();  // 0.1 m above, vertically
  in.t_max_s = 1000.0;
  return in;
}

auto no_stop = [](const Vec3&, const Vec3&, double, double, const Vec3&, const Vec3&) {
  return false;
};

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

TEST(GroundMotion, CallbackStopsAndEverySegmentIsReported) {
  const auto site = slope_site(0.0, 0.5, 0.1);
  GroundMotionInput in = start(*site, 0.0, 0.0, Vec3(20.0, 0.0, 0.0));
  double covered = 0.0;
  int calls = 0;
  const auto stop_after_10m = [&](const Vec3& a, const Vec3& b, double ta, double tb, const Vec3&,
                                  const Vec3&) {
    EXPECT_LT(ta, tb);
    covered += (b - a).norm();
    ++calls;
    return covered > 10.0;
  };
  const GroundMotionResult r = move_on_ground(*site, in, stop_after_10m);
  EXPECT_EQ(r.end, GroundEnd::kStoppedByCaller);
  EXPECT_NEAR(r.path_m, covered, 1e-12);
  EXPECT_GT(calls, 1);
  // A step cap always ends the motion.
  in.max_steps = 3;
  EXPECT_EQ(move_on_ground(*site, in, no_stop).end, GroundEnd::kStepCap);
}

}  // namespace
}  // namespace fragsim::impact
