// A fragment's bounce off a terrain triangle: contact point of the oriented body + impulse.
#include "core/impact/bounce.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <optional>
#include <random>
#include <vector>

#include "core/fragments/sampling.h"

namespace fragsim::impact {
namespace {

fragments::ContactBody cube(double half, double mass) {
  fragments::ContactBody b;
  b.type = fragments::ShapeType::kCuboid;
  b.half_m = Vec3::Constant(half);
  b.inertia_kg_m2 = Vec3::Constant(mass * (2 * half) * (2 * half) / 6.0);
  return b;
}

scene::Material ground(double e, double mu) {
  scene::Material m;
  m.friction = mu;
  m.restitution.constant = e;
  return m;
}

// A cube landing flat with no spin and no tangential speed: the impulse acts under the centre of
// mass (the face's centre), so it bounces straight up with u_z' = -e u_z and gains no spin,
// whichever of its symmetric face-down attitudes it lands in.
TEST(Bounce, CubeLandingFlatGainsNoSpin) {
  const fragments::ContactBody b = cube(0.1, 2.0);
  for (const Quat& q : {Quat::Identity(), Quat(Eigen::AngleAxisd(kPi / 2, Vec3::UnitZ())),
                        Quat(Eigen::AngleAxisd(kPi, Vec3::UnitX())),
                        Quat(Eigen::AngleAxisd(kPi / 2, Vec3::UnitY()))}) {
    const TerrainBounce r = bounce_on_terrain(b, 2.0, q, Vec3(0, 0, -6.0), Vec3::Zero(),
                                              Vec3::UnitZ(), ground(0.4, 0.7), 1e-9);
    ASSERT_TRUE(r.collision.impact);
    EXPECT_LT(r.collision.omega_radps.norm(), 1e-12);
    EXPECT_NEAR(r.collision.velocity_mps.z(), 0.4 * 6.0, 1e-9);
    EXPECT_NEAR(r.collision.velocity_mps.head<2>().norm(), 0.0, 1e-12);
    EXPECT_NEAR(r.normal_speed_mps, 6.0, 1e-12);
  }
}

// The restitution comes from the material's table at the contact point's normal approach speed.
TEST(Bounce, RestitutionFromTheTableAtTheNormalSpeed) {
  fragments::ContactBody sphere;
  sphere.type = fragments::ShapeType::kSphere;
  sphere.half_m = Vec3::Constant(0.05);
  sphere.inertia_kg_m2 = Vec3::Constant(0.4 * 1.0 * 0.05 * 0.05);
  scene::Material m = ground(0.0, 0.5);
  m.restitution.normal_speed_mps = {0.0, 10.0};
  m.restitution.e = {0.6, 0.2};
  const TerrainBounce r = bounce_on_terrain(sphere, 1.0, Quat::Identity(), Vec3(3.0, 0.0, -5.0),
                                            Vec3::Zero(), Vec3::UnitZ(), m, 1e-9);
  EXPECT_NEAR(r.restitution, 0.4, 1e-12);                      // halfway along the table
  EXPECT_NEAR(r.collision.velocity_mps.z(), 0.4 * 5.0, 1e-9);  // Newton's law for a sphere
  // Tilted terrain: the normal is what counts, not the vertical.
  const Vec3 n = Vec3(0.3, 0.0, 1.0).normalized();
  const TerrainBounce t =
      bounce_on_terrain(sphere, 1.0, Quat::Identity(), -5.0 * n, Vec3::Zero(), n, m, 1e-9);
  EXPECT_NEAR(t.collision.velocity_mps.dot(n), 0.4 * 5.0, 1e-9);
  EXPECT_NEAR((t.r_m + 0.05 * n).norm(), 0.0, 1e-15);
}

// A cuboid given as its 8 corners (a polyhedron) bounces as the cuboid shape: for 1000 random
// attitudes, incoming velocities, spins, normals, restitutions and friction coefficients the
// post-impact velocity and spin agree to 1e-9 (relative to the incoming speed, and for the spin to
// it over the half-diagonal); flat and on-edge landings included.
TEST(Bounce, CubePolyhedronBouncesAsTheCuboid) {
  const Vec3 half(0.05, 0.03, 0.012);
  const double mass = 0.9;
  std::vector<Vec3> corners;
  for (int k = 0; k < 8; ++k)
    corners.emplace_back(k & 1 ? half.x() : -half.x(), k & 2 ? half.y() : -half.y(),
                         k & 4 ? half.z() : -half.z());
  const fragments::ShapeSpec spec = fragments::polyhedron_shape(corners, std::nullopt);
  const fragments::ContactBody poly = fragments::contact_body(
      fragments::ShapeType::kPolyhedron, fragments::mass_properties(spec, mass, std::nullopt));
  fragments::ShapeSpec box_spec;
  box_spec.type = fragments::ShapeType::kCuboid;
  box_spec.dims_m = {2 * half.x(), 2 * half.y(), 2 * half.z()};
  const fragments::ContactBody box = fragments::contact_body(
      fragments::ShapeType::kCuboid, fragments::mass_properties(box_spec, mass, std::nullopt));
  std::mt19937_64 rng(53);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g;
  double worst_v = 0.0, worst_w = 0.0;
  int impacts = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    Quat q = fragments::uniform_rotation(u(rng), u(rng), u(rng));
    if (trial % 10 == 0) q = Quat(Eigen::AngleAxisd(trial % 20 ? kPi / 4 : kPi, Vec3::UnitX()));
    const Vec3 n =
        trial % 3 == 0 ? Vec3::UnitZ() : Vec3(0.3 * g(rng), 0.3 * g(rng), 1).normalized();
    const Vec3 v = Vec3(3 * g(rng), 3 * g(rng), -2 - 8 * u(rng));
    const Vec3 w = Vec3(g(rng), g(rng), g(rng)) * 30.0 * u(rng);
    const scene::Material m = ground(u(rng), 1.2 * u(rng));
    const TerrainBounce a = bounce_on_terrain(poly, mass, q, v, w, n, m, 1e-9);
    const TerrainBounce b = bounce_on_terrain(box, mass, q, v, w, n, m, 1e-9);
    ASSERT_EQ(a.collision.impact, b.collision.impact) << trial;
    impacts += a.collision.impact;
    const double scale = v.norm() + w.norm() * half.norm();
    worst_v =
        std::max(worst_v, (a.collision.velocity_mps - b.collision.velocity_mps).norm() / scale);
    worst_w = std::max(
        worst_w, (a.collision.omega_radps - b.collision.omega_radps).norm() * half.norm() / scale);
  }
  std::printf(
      "[ measured ] cube polyhedron vs cuboid, %d impacts: worst |dv| %.3g, |dw| r %.3g "
      "(relative)\n",
      impacts, worst_v, worst_w);
  EXPECT_GT(impacts, 900);
  EXPECT_LE(worst_v, 1e-9);
  EXPECT_LE(worst_w, 1e-9);
}

}  // namespace
}  // namespace fragsim::impact
