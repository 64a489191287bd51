// PTN density (paper eqs. 37-39) against closed forms.
#include <gtest/gtest.h>

#include "core/run/run.h"
#include "scenario_fixtures.h"

namespace fragsim::validation {
namespace {

// Fragments falling vertically onto one flat triangle: D = count / A for that triangle (exact:
// A_PTN of a vertical path is the triangle's area), zero everywhere else.
TEST(PtnDensity, VerticalFallGivesCountOverArea) {
  run::Scenario sc = flat_site_scenario(50.0, 10.0);
  // Point (2.5, 1.0) lies strictly inside one triangle of the cell [0,10]^2.
  auto g = sphere_group(Vec3(2.5, 1.0, 100.0), 0.5, 50.0, 300.0, 100);
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = -90.0;
  g.direction.azimuth_min_deg = g.direction.azimuth_max_deg = 0.0;
  sc.groups = {g};
  const run::RunResult r = run::run(sc);
  ASSERT_EQ(r.outcome_histories[static_cast<int>(run::Outcome::kGround)], 100);
  int hit = 0;
  for (std::size_t t = 0; t < r.ptn_density_per_m2.size(); ++t) {
    if (r.ptn_density_per_m2[t] == 0.0) continue;
    ++hit;
    // Cells are 10 m squares split in two: each triangle has area 50 m^2.
    EXPECT_NEAR(r.ptn_density_per_m2[t], 300.0 / 50.0, 1e-9);
    EXPECT_NEAR(r.ptn_std_error_per_m2[t], 0.0, 1e-9);  // every history contributes the same
  }
  EXPECT_EQ(hit, 1);
  EXPECT_NEAR(r.max_ptn_density_per_m2, 6.0, 1e-9);
}

// A fragment below the hazardous kinetic energy contributes nothing.
TEST(PtnDensity, NonHazardousFragmentContributesNothing) {
  run::Scenario sc = flat_site_scenario(50.0, 10.0);
  // 0.01 kg at 20 m/s from 100 m, cd 0: KE at impact = 0.5*0.01*(400 + 2*9.81*100) = 11.8 J < 79.
  auto g = sphere_group(Vec3(2.5, 1.0, 100.0), 0.01, 20.0, 300.0, 50);
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = -90.0;
  sc.groups = {g};
  const run::RunResult r = run::run(sc);
  EXPECT_EQ(r.max_ptn_density_per_m2, 0.0);
  // With no buildings the run does not even fly them (documented skip).
  EXPECT_EQ(r.outcome_histories[static_cast<int>(run::Outcome::kHarmless)], 50);
}

// A horizontal fan of fast fragments at height < H over a flat plane, gravity off: the expected
// density at radius r is D(r) = N / (r * dphi * H) (N fragments spread over the arc r dphi, each
// crossing a prism with A_PTN = H * width). Tested per triangle within 3 standard errors, on
// small triangles (2 m cells) far enough out (r >= 30 m) that the centroid approximation of
// 1/r over a triangle is good to (cell/r)^2 < 0.5%, well below the statistical tolerance.
TEST(PtnDensity, HorizontalFanGivesInverseRadiusDensity) {
  run::Scenario sc = flat_site_scenario(100.0, 2.0);
  sc.gravity_mps2 = 0.0;
  const double n = 5000.0;
  const double dphi_deg = 60.0;
  auto g = sphere_group(Vec3(0.0, 0.0, 0.9), 0.1, 1000.0, n, 200000);
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = 0.0;
  g.direction.azimuth_min_deg = -dphi_deg / 2;
  g.direction.azimuth_max_deg = dphi_deg / 2;
  sc.groups = {g};
  sc.settings.person_height_m = 1.8;
  const run::RunResult r = run::run(sc);
  auto site = scene::Site::build(sc.site);
  const double dphi = dphi_deg * kDegToRad;
  int tested = 0, within = 0;
  double worst_z = 0.0;
  for (std::uint32_t t = 0; t < r.ptn_density_per_m2.size(); ++t) {
    const Vec3 c = site->to_input(site->terrain_triangle_centroid(t));
    const double rr = std::hypot(c.x(), c.y());
    const double az = std::atan2(c.y(), c.x());
    // Well inside the fan (a triangle straddling its edge sees only part of the flux).
    if (rr < 30.0 || rr > 90.0 || std::abs(az) > dphi / 2 - 3.0 / rr) continue;
    const double expected = n / (rr * dphi * 1.8);
    const double se = r.ptn_std_error_per_m2[t];
    ASSERT_GT(se, 0.0);
    const double z = (r.ptn_density_per_m2[t] - expected) / se;
    worst_z = std::max(worst_z, std::abs(z));
    ++tested;
    if (std::abs(z) <= 3.0) ++within;
  }
  ASSERT_GT(tested, 500);
  // Individually ~99.7% of triangles should lie within 3 se; allow 1% outside (chance), and no
  // triangle beyond 5 se (a systematic error would push many out).
  EXPECT_GE(within, static_cast<int>(0.99 * tested)) << "tested " << tested;
  EXPECT_LT(worst_z, 5.0);
}

}  // namespace
}  // namespace fragsim::validation
