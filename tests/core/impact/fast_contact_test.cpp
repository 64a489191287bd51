// The fast-contact law (core/impact/fast_contact.h; F1-F6 in core/scene/site_spec.h) against its
// closed forms, written out here rather than taken from the code under test:
//   theta_c = C / sqrt(rho_f / rho_s), at most 90 deg                                  (F2)
//   v_out^2 = (v^2 + v_s^2) exp(-4 (D/L) theta_e) - v_s^2, theta_e = theta + roughness (F3-F4)
//   theta_out = ratio * theta_e, raised to asin(floor / v_out) while v_out >= v_s     (F5-F6)
// The exit velocity lies in the plane of v and n with v's tangential direction; the spin is
// scaled by v_out / v. Tolerances: these are a few floating-point operations, so 1e-12 relative
// (angles 1e-10 deg after asin/acos near their flat ends) unless said otherwise.
#include "core/impact/fast_contact.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace fragsim::impact {
namespace {

constexpr double kSteel = 7850.0;
constexpr double kFloor = 0.5;  // bounce_limits.min_rebound_speed_mps default

// The defaults: rho_s 1700, v_s 30 m/s, C 18 deg, D/L 1, roughness 2 deg, exit ratio 1.
scene::FastContactSpec soil() {
  return scene::FastContactSpec{};
}

double rad(double deg) {
  return deg * kDegToRad;
}

// A velocity of `speed` along +x (turned by `azimuth_deg` about z) going down at `theta_deg`.
Vec3 incoming(double speed, double theta_deg, double azimuth_deg = 0.0) {
  const double th = rad(theta_deg), az = rad(azimuth_deg);
  return speed * Vec3(std::cos(th) * std::cos(az), std::cos(th) * std::sin(az), -std::sin(th));
}

// The closed form of F4 (site_spec.h), written independently of ricochet_speed2.
double closed_form_speed(double v, double theta_deg, double vs, double dl, double rough_deg) {
  const double out2 =
      (v * v + vs * vs) * std::exp(-4.0 * dl * rad(theta_deg + rough_deg)) - vs * vs;
  return out2 > 0.0 ? std::sqrt(out2) : 0.0;
}

FastContactOutcome flat(const scene::FastContactSpec& law, double density, const Vec3& v,
                        const Vec3& omega = Vec3::Zero()) {
  return fast_contact(law, density, v, omega, Vec3::UnitZ(), kFloor);
}

// F2 for steel on 1700 kg/m^3 soil: sigma = 7850 / 1700 = 4.6176, theta_c = 18 / 2.14887.
TEST(FastContact, CriticalAngleOfSteelOnSoil) {
  const double expected_deg = 18.0 / std::sqrt(7850.0 / 1700.0);
  EXPECT_NEAR(expected_deg, 8.3765, 5e-5);  // the issue quotes it truncated, 8.376
  EXPECT_NEAR(critical_angle_rad(soil(), kSteel) / kDegToRad, expected_deg, 1e-12);
  EXPECT_NEAR(flat(soil(), kSteel, incoming(300, 1)).critical_deg, expected_deg, 1e-12);
}

// Just above theta_c it embeds; just below (1e-6 deg) it ricochets.
TEST(FastContact, EmbedsAtTheCriticalAngleAndRicochetsBelowIt) {
  const double theta_c = 18.0 / std::sqrt(7850.0 / 1700.0);
  for (double v : {300.0, 700.0}) {
    EXPECT_EQ(flat(soil(), kSteel, incoming(v, theta_c + 1e-6)).end, FastContactEnd::kEmbedded);
    EXPECT_EQ(flat(soil(), kSteel, incoming(v, theta_c - 1e-6)).end, FastContactEnd::kRicochet);
  }
}

// Below v_s the law does not apply: kSlow, and the outcome is left at its defaults.
TEST(FastContact, SlowerThanTheSwitchSpeedIsNotThisLaw) {
  const FastContactOutcome f = flat(soil(), kSteel, incoming(29.999, 3));
  EXPECT_EQ(f.end, FastContactEnd::kSlow);
  EXPECT_EQ(f.speed_ratio, 1.0);
  EXPECT_EQ(flat(soil(), kSteel, incoming(30.001, 3)).end, FastContactEnd::kRicochet);
  EXPECT_EQ(flat(soil(), 0.0, incoming(300, 3)).end, FastContactEnd::kSlow);  // no density
}

// F4 at fragment speeds and grazing angles, against the closed form above; also through
// ricochet_speed2 itself.
TEST(FastContact, SpeedRatioIsTheClosedForm) {
  for (double v : {31.0, 100.0, 300.0, 700.0}) {
    for (double theta : {0.5, 2.0, 5.0, 8.0}) {
      const FastContactOutcome f = flat(soil(), kSteel, incoming(v, theta));
      ASSERT_EQ(f.end, FastContactEnd::kRicochet) << v << " m/s, " << theta << " deg";
      const double expected = closed_form_speed(v, theta, 30.0, 1.0, 2.0);
      EXPECT_NEAR(f.speed_ratio, expected / v, 1e-12 * expected / v) << v << ", " << theta;
      EXPECT_NEAR(f.velocity_mps.norm(), expected, 1e-12 * expected);
      EXPECT_NEAR(std::sqrt(ricochet_speed2(soil(), v, rad(theta))), expected, 1e-12 * expected);
    }
  }
  // A hand value: 300 m/s at 2 deg, theta_e 4 deg: (90900 e^{-0.279253} - 900)^{1/2} = 260.48.
  EXPECT_NEAR(flat(soil(), kSteel, incoming(300, 2)).velocity_mps.norm(), 260.48, 0.01);
}

// The strength term (v_s) stops a slow contact that the inertial term alone would let through:
// at 31 m/s, 5 deg, D/L = 5: (31^2 + 30^2) e^{-20 * 7 deg} = 161.6 < 900 -> stopped; at 700 m/s
// the same angle and soil leave it 204 m/s.
TEST(FastContact, StrengthTermStopsASlowContact) {
  scene::FastContactSpec law = soil();
  law.drag_to_lift_ratio = 5.0;
  EXPECT_LE(ricochet_speed2(law, 31.0, rad(5)), 0.0);
  EXPECT_EQ(flat(law, kSteel, incoming(31.0, 5)).end, FastContactEnd::kStopped);
  const FastContactOutcome fast = flat(law, kSteel, incoming(700.0, 5));
  EXPECT_EQ(fast.end, FastContactEnd::kRicochet);
  EXPECT_NEAR(fast.velocity_mps.norm(), closed_form_speed(700, 5, 30, 5, 2), 1e-9);
  // Without the strength term (v_s = 0) the 31 m/s contact keeps e^{-2 (D/L) theta_e} of it.
  law.switch_speed_mps = 0.0;
  EXPECT_NEAR(flat(law, kSteel, incoming(31.0, 5)).speed_ratio, std::exp(-10.0 * rad(7)), 1e-12);
}

// F5: theta_out = ratio * theta_e, measured from the exit velocity itself.
TEST(FastContact, ExitAngleIsRatioTimesEffectiveAngle) {
  for (double ratio : {0.5, 1.0, 2.0}) {
    scene::FastContactSpec law = soil();
    law.exit_angle_ratio = ratio;
    for (double theta : {2.0, 5.0, 8.0}) {
      const FastContactOutcome f = flat(law, kSteel, incoming(300, theta));
      const double expected = ratio * (theta + 2.0);
      EXPECT_NEAR(f.exit_deg, expected, 1e-10);
      const Vec3& u = f.velocity_mps;
      EXPECT_NEAR(std::asin(u.z() / u.norm()) / kDegToRad, expected, 1e-10);
    }
  }
}

// F6: still at least v_s fast, it leaves with at least the floor's normal speed; slowed below
// v_s it keeps ratio * theta_e (the caller then lets it slide or bounce rigidly).
TEST(FastContact, ExitAngleFloorAppliesOnlyWhileFast) {
  scene::FastContactSpec law = soil();
  law.roughness_deg = 0.0;
  const FastContactOutcome fast = flat(law, kSteel, incoming(300, 0.05));
  const double v_out = closed_form_speed(300, 0.05, 30, 1, 0);
  ASSERT_GT(std::asin(kFloor / v_out) / kDegToRad, 0.05);  // the floor is the larger here
  EXPECT_NEAR(fast.exit_deg, std::asin(kFloor / v_out) / kDegToRad, 1e-9);
  // At the floor, raised by the law's 1e-9 margin (so that rounding never lets it slide).
  EXPECT_GE(fast.velocity_mps.z(), kFloor);
  EXPECT_NEAR(fast.velocity_mps.z(), kFloor, 2e-9 * kFloor);

  law.drag_to_lift_ratio = 5.0;  // 31 m/s at 0.1 deg leaves 29.95 m/s < v_s
  const FastContactOutcome slowed = flat(law, kSteel, incoming(31.0, 0.1));
  ASSERT_EQ(slowed.end, FastContactEnd::kRicochet);
  ASSERT_LT(slowed.velocity_mps.norm(), 30.0);
  EXPECT_NEAR(slowed.exit_deg, 0.1, 1e-10);
  EXPECT_LT(slowed.velocity_mps.z(), kFloor);
}

// The tangential direction is kept: the azimuth on a level surface is unchanged.
TEST(FastContact, AzimuthIsKept) {
  for (double az : {-170.0, -45.0, 0.0, 33.0, 90.0, 179.0}) {
    const Vec3 u = flat(soil(), kSteel, incoming(400, 4, az)).velocity_mps;
    EXPECT_NEAR(std::atan2(u.y(), u.x()) / kDegToRad, az, 1e-10);
  }
}

// On a tilted surface the exit velocity lies in the plane of v and n, on v's tangential side,
// at theta_out from the surface.
TEST(FastContact, ExitLiesInThePlaneOfVelocityAndNormal) {
  const Vec3 n = Vec3(0.3, -0.2, 1.0).normalized();
  const Vec3 v(250.0, 80.0, -80.0);  // 4.1 deg into the surface
  const double theta_deg = std::asin(-v.dot(n) / v.norm()) / kDegToRad;
  ASSERT_GT(theta_deg, 0.0);
  ASSERT_LT(theta_deg, 8.0);
  const FastContactOutcome f = fast_contact(soil(), kSteel, v, Vec3::Zero(), n, kFloor);
  ASSERT_EQ(f.end, FastContactEnd::kRicochet);
  const Vec3& u = f.velocity_mps;
  EXPECT_NEAR(u.dot(v.cross(n).normalized()), 0.0, 1e-12 * u.norm());  // in the plane
  const Vec3 vt = v - v.dot(n) * n, ut = u - u.dot(n) * n;
  EXPECT_NEAR(ut.normalized().dot(vt.normalized()), 1.0, 1e-14);  // same tangent side
  EXPECT_NEAR(std::asin(u.dot(n) / u.norm()) / kDegToRad, theta_deg + 2.0, 1e-10);
  EXPECT_NEAR(f.incidence_deg, theta_deg, 1e-10);
}

// Energy: translational and rotational kinetic energy never rise (the speed ratio <= 1 scales
// both), and nothing is NaN, over 10,000 random contacts (directions, normals, spins, soil
// constants across their documented brackets, densities 50-20,000 kg/m^3, speeds 0-1500 m/s).
TEST(FastContact, EnergyNeverRisesOverARandomSweep) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> u01(0.0, 1.0), sym(-1.0, 1.0);
  const auto unit = [&] {
    Vec3 d;
    do d = Vec3(sym(rng), sym(rng), sym(rng));
    while (d.squaredNorm() > 1.0 || d.squaredNorm() < 1e-6);
    return d.normalized();
  };
  int ricochets = 0, embedded = 0;
  for (int i = 0; i < 10000; ++i) {
    scene::FastContactSpec law;
    law.bulk_density_kg_m3 = 1200.0 + 1000.0 * u01(rng);
    law.switch_speed_mps = 60.0 * u01(rng);
    law.drag_to_lift_ratio = 0.5 + 1.5 * u01(rng);
    law.exit_angle_ratio = 0.5 + 1.5 * u01(rng);
    law.roughness_deg = 5.0 * u01(rng);
    const double density = 50.0 + 19950.0 * u01(rng);
    const Vec3 v = 1500.0 * u01(rng) * unit(), omega = 500.0 * u01(rng) * unit(), n = unit();
    const FastContactOutcome f = fast_contact(law, density, v, omega, n, kFloor);
    ASSERT_TRUE(f.velocity_mps.allFinite() && f.omega_radps.allFinite()) << i;
    ASSERT_TRUE(std::isfinite(f.exit_deg) && std::isfinite(f.speed_ratio)) << i;
    if (f.end != FastContactEnd::kRicochet) {
      embedded += f.end != FastContactEnd::kSlow;
      continue;
    }
    ++ricochets;
    ASSERT_LE(f.velocity_mps.squaredNorm(), v.squaredNorm() * (1 + 1e-12)) << i;
    ASSERT_LE(f.omega_radps.squaredNorm(), omega.squaredNorm() * (1 + 1e-12)) << i;
    ASSERT_GE(f.velocity_mps.dot(n), 0.0) << i;  // it leaves (or runs along) the surface
  }
  // Both branches were exercised (half the directions leave the surface: grazing 0, ricochet).
  EXPECT_GT(ricochets, 1000);
  EXPECT_GT(embedded, 1000);
}

// Degenerate inputs give finite, sensible results.
TEST(FastContact, DegenerateInputsAreFinite) {
  // Exactly along the surface: theta = 0, theta_e = roughness.
  const FastContactOutcome along = flat(soil(), kSteel, Vec3(300, 0, 0));
  EXPECT_EQ(along.end, FastContactEnd::kRicochet);
  EXPECT_EQ(along.incidence_deg, 0.0);
  EXPECT_NEAR(along.exit_deg, 2.0, 1e-10);
  EXPECT_NEAR(along.velocity_mps.norm(), closed_form_speed(300, 0, 30, 1, 2), 1e-9);
  // Leaving the surface: treated as grazing (theta clamped to 0), it leaves.
  const FastContactOutcome leaving = flat(soil(), kSteel, Vec3(300, 0, 10));
  EXPECT_EQ(leaving.end, FastContactEnd::kRicochet);
  EXPECT_EQ(leaving.incidence_deg, 0.0);
  EXPECT_TRUE(leaving.velocity_mps.allFinite());
  EXPECT_GT(leaving.velocity_mps.z(), 0.0);
  // Normal incidence (no tangent: any tangent is used). A light fragment (50 kg/m^3: sigma
  // 0.029, 18 / sqrt(sigma) = 105 deg) has theta_c capped at 90 deg: it embeds at 90 deg and
  // ricochets at 89 deg (at 1500 m/s: theta_e = 91 deg leaves (2.25e6 + 900) e^{-6.35} - 900 =
  // 3,020 m^2/s^2; at 300 m/s it would stop) with theta_out capped at 90 deg.
  const FastContactOutcome normal = flat(soil(), 50.0, Vec3(0, 0, -300));
  EXPECT_NEAR(normal.critical_deg, 90.0, 1e-12);
  EXPECT_EQ(normal.end, FastContactEnd::kEmbedded);
  const FastContactOutcome steep = flat(soil(), 50.0, incoming(1500, 89));
  ASSERT_EQ(steep.end, FastContactEnd::kRicochet);
  EXPECT_NEAR(steep.exit_deg, 90.0, 1e-12);
  EXPECT_TRUE(steep.velocity_mps.allFinite());
  EXPECT_NEAR(steep.velocity_mps.normalized().z(), 1.0, 1e-12);
  // Zero velocity: below v_s.
  EXPECT_EQ(flat(soil(), kSteel, Vec3::Zero()).end, FastContactEnd::kSlow);
}

// Spin is scaled with the speed (F5).
TEST(FastContact, SpinScalesWithTheSpeed) {
  const Vec3 omega(10.0, -40.0, 3.0);
  const FastContactOutcome f = flat(soil(), kSteel, incoming(500, 3), omega);
  ASSERT_EQ(f.end, FastContactEnd::kRicochet);
  const double ratio = closed_form_speed(500, 3, 30, 1, 2) / 500;
  EXPECT_NEAR((f.omega_radps - ratio * omega).norm(), 0.0, 1e-12 * omega.norm());
}

}  // namespace
}  // namespace fragsim::impact
