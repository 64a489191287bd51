// PTN density (paper eqs. 37-39) against closed forms.
#include <gtest/gtest.h>

#include <array>

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
    // Every history contributes the same, so the standard error is zero up to the cancellation
    // in Q - S^2/n (~sqrt(machine epsilon) relative to the mean).
    EXPECT_LE(r.ptn_std_error_per_m2[t], 1e-7 * r.ptn_density_per_m2[t]);
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

// A slow fragment in a strong wind is not written off as harmless: drag can accelerate it to
// near the wind speed, above the hazardous energy. (A bound that ignored the wind stopped it at
// launch: 1 kg, at rest 1.5 m up, KE + m g h = 14.7 J < 79 J.)
TEST(PtnDensity, WindCanMakeASlowFragmentHazardous) {
  run::Scenario sc = flat_site_scenario(200.0, 10.0);
  fragments::FragmentGroupSpec g;
  g.name = "plates";
  g.count = 10.0;
  g.samples = 10;
  g.frame.origin_m = Vec3(-150.0, 0.0, 1.5);
  g.shape.type = fragments::ShapeType::kPoint;
  g.area_m2 = 0.5;  // k = rho Cd A / 2m = 0.31 /m: reaches ~34 m/s (578 J) within 0.5 s
  g.mass_kg = fragments::Distribution::fixed(1.0);
  g.speed_mps = fragments::Distribution::fixed(0.0);
  g.cd.constant = 1.0;
  sc.groups = {g};
  const run::RunResult still = run::run(sc);
  EXPECT_EQ(still.outcome_histories[static_cast<int>(run::Outcome::kHarmless)], 10);
  EXPECT_EQ(still.max_ptn_density_per_m2, 0.0);
  sc.atmosphere.wind_mps = Vec3(40.0, 0.0, 0.0);
  const run::RunResult windy = run::run(sc);
  EXPECT_EQ(windy.outcome_histories[static_cast<int>(run::Outcome::kHarmless)], 0);
  EXPECT_GT(windy.max_ptn_density_per_m2, 0.0);  // hazardous on its way downwind
}

// A horizontal fan of fast fragments at height < H over a flat plane, gravity off. A fragment
// leaving at azimuth phi (uniform over the fan dphi) crosses the prism of triangle T iff phi lies
// in T's angular span as seen from the origin, and then adds w / (H width_T(phi)) (A_PTN of a
// horizontal path: H times the triangle's width across it). So the expected density is
//   E[D_T] = N / (dphi H) * integral over T's span of dphi' / width_T(phi'),
// which for a small far triangle is the textbook D(r) = N / (r dphi H). The integral is evaluated
// here by the midpoint rule directly from the triangle's vertices (independent of the code under
// test), and every triangle well inside the fan is compared with the run within 3 standard errors.
constexpr double kFanCount = 5000.0, kFanDeg = 60.0, kFanH = 1.8;

run::Scenario horizontal_fan(std::int64_t samples) {
  run::Scenario sc = flat_site_scenario(100.0, 2.0);
  sc.gravity_mps2 = 0.0;
  auto g = sphere_group(Vec3(0.0, 0.0, 0.9), 0.1, 1000.0, kFanCount, samples);
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = 0.0;
  g.direction.azimuth_min_deg = -kFanDeg / 2;
  g.direction.azimuth_max_deg = kFanDeg / 2;
  sc.groups = {g};
  sc.settings.person_height_m = kFanH;
  return sc;
}

// `nets`: the standard errors come from few independent units (Sobol nets: 15 degrees of
// freedom here), so a triangle's z-score has heavier tails than a normal one's; the check is then
// on the z-scores as a whole: mean ~0 (unbiased), rms ~1 (honest), >= 97 % within 3 se.
void expect_inverse_radius_density(const run::Scenario& sc, bool nets = false) {
  const double n = kFanCount, dphi_deg = kFanDeg, h = kFanH;
  const run::RunResult r = run::run(sc);
  auto site = scene::Site::build(sc.site);
  const Vec3 o = site->to_local(Vec3(0.0, 0.0, 0.9));
  const double dphi = dphi_deg * kDegToRad;
  int tested = 0, within = 0;
  double worst_z = 0.0, sum_z = 0.0, sum_z2 = 0.0, worst_textbook = 0.0;
  for (std::uint32_t t = 0; t < r.ptn_density_per_m2.size(); ++t) {
    std::array<Vec2, 3> v;
    for (int k = 0; k < 3; ++k) {
      const Vec3& p =
          site->terrain_vertices()[site->terrain_triangles()[t][static_cast<std::size_t>(k)]];
      v[static_cast<std::size_t>(k)] = Vec2(p.x() - o.x(), p.y() - o.y());
    }
    double a_lo = 1e9, a_hi = -1e9, r_min = 1e9;
    for (const Vec2& q : v) {
      a_lo = std::min(a_lo, std::atan2(q.y(), q.x()));
      a_hi = std::max(a_hi, std::atan2(q.y(), q.x()));
      r_min = std::min(r_min, q.norm());
    }
    // Triangles wholly inside the fan, away from the origin.
    if (r_min < 30.0 || r_min > 90.0 || a_lo < -dphi / 2 || a_hi > dphi / 2) continue;
    const int m = 400;
    double integral = 0.0;
    for (int i = 0; i < m; ++i) {
      const double phi = a_lo + (a_hi - a_lo) * (i + 0.5) / m;
      const Vec2 across(-std::sin(phi), std::cos(phi));
      double w_lo = 1e9, w_hi = -1e9;
      for (const Vec2& q : v) {
        w_lo = std::min(w_lo, across.dot(q));
        w_hi = std::max(w_hi, across.dot(q));
      }
      integral += (a_hi - a_lo) / m / (w_hi - w_lo);
    }
    const double expected = n / (dphi * h) * integral;
    const Vec3 c = site->terrain_triangle_centroid(t) - o;
    worst_textbook = std::max(
        worst_textbook, std::abs(expected / (n / (std::hypot(c.x(), c.y()) * dphi * h)) - 1.0));
    const double se = r.ptn_std_error_per_m2[t];
    ASSERT_GT(se, 0.0);
    const double z = (r.ptn_density_per_m2[t] - expected) / se;
    worst_z = std::max(worst_z, std::abs(z));
    sum_z += z;
    sum_z2 += z * z;
    ++tested;
    if (std::abs(z) <= 3.0) ++within;
  }
  ASSERT_GT(tested, 500);
  // The exact expectation is the textbook N / (r dphi H) to within a few percent here.
  EXPECT_LT(worst_textbook, 0.05);
  ::testing::Test::RecordProperty("worst_z", std::to_string(worst_z));
  ::testing::Test::RecordProperty("rms_z", std::to_string(std::sqrt(sum_z2 / tested)));
  ::testing::Test::RecordProperty("outside_3se", std::to_string(tested - within));
  // No bias in the mean z-score (a systematic error would shift many the same way).
  EXPECT_LT(std::abs(sum_z / tested), 0.2) << "mean z-score";
  if (nets) {
    EXPECT_GE(within, static_cast<int>(0.97 * tested)) << "tested " << tested;
    EXPECT_GT(std::sqrt(sum_z2 / tested), 0.6);
    EXPECT_LT(std::sqrt(sum_z2 / tested), 1.5);
    return;
  }
  // ~99.7% of triangles should lie within 3 se; allow 1% outside (chance), no triangle beyond 5 se.
  EXPECT_GE(within, static_cast<int>(0.99 * tested)) << "tested " << tested;
  EXPECT_LT(worst_z, 5.0);
}

TEST(PtnDensity, HorizontalFanGivesInverseRadiusDensity) {
  expect_inverse_radius_density(horizontal_fan(200000));
}

// The same closed form through the variance reductions (docs/precision.md): stratified launch
// directions, and importance sampling aimed at the density near the HFD with stratification,
// 4 tallied batches of 50,000 after the pilot. Every triangle's estimate stays within its
// standard errors of the exact expectation. This one-dimensional fan of identical fragments is
// the hard case for the stratified standard error: a triangle's estimate is exact but for the
// two strata its edges cut, and two histories in such a stratum often fall on the same side.
TEST(PtnDensity, HorizontalFanThroughStratifiedAndImportanceSampling) {
  run::Scenario stratified = horizontal_fan(200000);
  stratified.settings.stratified_launch.emplace();
  expect_inverse_radius_density(stratified);

  run::Scenario both = horizontal_fan(50000);
  both.settings.stratified_launch.emplace();
  run::PrecisionSettings p;
  p.max_batches = 5;
  p.min_batches = 5;
  p.ptn_rel_error_at_hfd = 1e-9;  // names the density near the HFD; never met
  p.direction_importance.emplace();
  both.settings.precision = p;
  expect_inverse_radius_density(both);
}

// And through scrambled Sobol nets (docs/precision.md, "Scrambled Sobol launch"): 16 nets of
// 12,500 in one batch, then importance sampling with 4 nets in each of 4 tallied batches. The
// errors have 15 and 12 degrees of freedom, so single triangles can sit many se out where the
// nets' spread happened to be small (measured with importance sampling: 22 of 1,854 beyond 3 se,
// the worst 7.8 se with an se 0.4 x its value over other seeds; rms z 1.11); the whole is checked.
TEST(PtnDensity, HorizontalFanThroughSobolNets) {
  run::StratifiedLaunchSettings sobol;
  sobol.method = run::LaunchStratification::kSobol;
  run::Scenario one_batch = horizontal_fan(200000);
  one_batch.settings.stratified_launch = sobol;
  expect_inverse_radius_density(one_batch, true);

  run::Scenario both = horizontal_fan(50000);
  sobol.replicates = 4;
  both.settings.stratified_launch = sobol;
  run::PrecisionSettings p;
  p.max_batches = 5;
  p.min_batches = 5;
  p.ptn_rel_error_at_hfd = 1e-9;
  p.direction_importance.emplace();
  both.settings.precision = p;
  expect_inverse_radius_density(both, true);
}

}  // namespace
}  // namespace fragsim::validation
