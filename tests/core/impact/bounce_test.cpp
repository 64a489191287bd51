// A fragment's bounce off a terrain triangle: contact point of the oriented body + impulse.
#include "core/impact/bounce.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace fragsim::impact
