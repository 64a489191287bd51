// Building impacts and penetrations against geometric closed forms.
#include <gtest/gtest.h>

#include "core/run/run.h"
#include "scenario_fixtures.h"

namespace fragsim::validation {
namespace {

run::Scenario fan_at_boxes(double fan_deg, std::int64_t samples) {
  run::Scenario sc = flat_site_scenario(200.0, 10.0);
  sc.gravity_mps2 = 0.0;  // straight horizontal paths: the subtended angle is exact
  scene::MaterialSpec wall, roof;
  wall.penetration_ke_per_area_j_per_m2 = 1.0e5;
  roof.penetration_ke_per_area_j_per_m2 = 1.0e5;
  sc.site.materials["wall"] = wall;
  sc.site.materials["roof"] = roof;
  auto g = sphere_group(Vec3(0.0, 0.0, 3.0), 0.2, 800.0, 1000.0, samples);
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = 0.0;
  g.direction.azimuth_min_deg = -fan_deg / 2;
  g.direction.azimuth_max_deg = fan_deg / 2;
  sc.groups = {g};
  return sc;
}

// A horizontal fan aimed at a box whose front face spans y in [-5, 5] at x = 50: the box subtends
// 2 atan(5/50) (its back corners are inside that angle), so the expected impacts are
// N * 2 atan(5/50) / dphi; binomial statistics give the standard error, and the run's own
// standard error must agree with it.
TEST(BuildingImpacts, FanAtABoxHitsInProportionToTheSubtendedAngle) {
  const double fan_deg = 40.0;
  run::Scenario sc = fan_at_boxes(fan_deg, 40000);
  sc.site.buildings = {box_building("front", 50, -5, 60, 5, 10.0)};
  const run::RunResult r = run::run(sc);
  ASSERT_EQ(r.buildings.size(), 1u);
  const double p = 2.0 * std::atan(5.0 / 50.0) / (fan_deg * kDegToRad);
  const double expected = 1000.0 * p;
  const auto& b = r.buildings[0];
  EXPECT_NEAR(b.impacts.mean, expected, 3.0 * b.impacts.std_error);
  // Standard error of a weighted binomial count: w sqrt(n p (1-p)), w = 1000/40000.
  const double se_binomial = (1000.0 / 40000.0) * std::sqrt(40000.0 * p * (1 - p));
  EXPECT_NEAR(b.impacts.std_error, se_binomial, 0.05 * se_binomial);
  // All hits are on walls (horizontal paths at 3 m under a 10 m roof).
  const auto wall = static_cast<std::size_t>(scene::SurfaceType::kWall);
  EXPECT_DOUBLE_EQ(b.impacts_by_surface[wall].mean, b.impacts.mean);
  // Penetration: KE_n/A = 0.5*0.2*800^2*cos^2(theta)/A with A = pi r^2 (r = 18.3 mm for 0.2 kg
  // steel) ~ 6e7 J/m^2 >> 1e5 at every angle here: every impact penetrates.
  EXPECT_DOUBLE_EQ(b.penetrations.mean, b.impacts.mean);
  EXPECT_GT(b.residual_ke_j.mean, 0.0);
}

// A box behind a taller box, within its shadow, is never hit.
TEST(BuildingImpacts, BoxBehindATallerBoxIsShielded) {
  run::Scenario sc = fan_at_boxes(40.0, 20000);
  sc.site.buildings = {box_building("front", 50, -5, 60, 5, 10.0),
                       box_building("behind", 80, -4, 90, 4, 6.0)};
  const run::RunResult r = run::run(sc);
  ASSERT_EQ(r.buildings.size(), 2u);
  EXPECT_GT(r.buildings[0].impacts.mean, 0.0);
  EXPECT_EQ(r.buildings[1].impacts.mean, 0.0);
  EXPECT_EQ(r.buildings[1].impacts.std_error, 0.0);
}

// The penetration criterion is on the normal component: a threshold between the normal energies
// of head-on and oblique impacts separates them.
TEST(BuildingImpacts, PenetrationUsesTheNormalKineticEnergyPerArea) {
  run::Scenario sc = fan_at_boxes(40.0, 20000);
  // Head-on KE/A for 0.2 kg at 800 m/s: A = pi r^2, r = (3 m / (4 pi rho))^(1/3).
  const double r_m = std::cbrt(3.0 * 0.2 / (4.0 * kPi * 7850.0));
  const double ke_per_area = 0.5 * 0.2 * 800.0 * 800.0 / (kPi * r_m * r_m);
  // Threshold at cos^2(theta) = 0.995 of head-on: only hits within ~4.05 deg of the normal
  // penetrate; on the front face (x = 50) theta = azimuth, so the fraction of impacts that
  // penetrate is atan(50 tan(4.05 deg)/50)... = 4.05 / atan(5/50) in angle terms.
  sc.site.materials["wall"].penetration_ke_per_area_j_per_m2 = 0.995 * ke_per_area;
  sc.site.buildings = {box_building("front", 50, -5, 60, 5, 10.0)};
  const run::RunResult r = run::run(sc);
  const auto& b = r.buildings[0];
  const double theta_max = std::acos(std::sqrt(0.995));
  const double expected_ratio = theta_max / std::atan(5.0 / 50.0);
  const double ratio = b.penetrations.mean / b.impacts.mean;
  // Binomial uncertainty of the ratio with ~1000 impacts in the sample: sqrt(p(1-p)/n) ~ 0.016.
  const double n_impacts = b.impacts.mean / (1000.0 / 20000.0);
  const double se = std::sqrt(expected_ratio * (1 - expected_ratio) / n_impacts);
  EXPECT_NEAR(ratio, expected_ratio, 3.0 * se);
}

}  // namespace
}  // namespace fragsim::validation
