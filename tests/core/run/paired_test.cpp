// Paired comparisons (core/run/paired.h) against closed forms: a horizontal fan (no gravity, so
// straight paths) at a building, with and without a narrow wall in front of it.
#include "core/run/paired.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/common/error.h"
#include "core/common/types.h"
#include "run_fixtures.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

constexpr double kFanDeg = 40.0;
constexpr double kRealFragments = 1000.0;

// Spheres fanned over +-20 deg at 3 m height with no gravity, at a target whose front face spans
// y in +-100 tan(10 deg) at x = 100: it subtends +-10 deg, a probability 0.5 per history.
Scenario fan_at_target(std::int64_t samples, std::uint64_t seed) {
  Scenario sc = validation::flat_site_scenario(200.0, 10.0);
  sc.gravity_mps2 = 0.0;
  validation::add_wall_and_roof(sc, 1.0e5);
  const double half = 100.0 * std::tan(10.0 * kDegToRad);
  sc.site.buildings = {validation::box_building("target", 100, -half, 110, half, 10.0)};
  auto g = validation::sphere_group(Vec3(0.0, 0.0, 3.0), 0.2, 800.0, kRealFragments, samples);
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = 0.0;
  g.direction.azimuth_min_deg = -kFanDeg / 2;
  g.direction.azimuth_max_deg = kFanDeg / 2;
  sc.groups = {g};
  sc.settings.seed = seed;
  return sc;
}

// The variant: a 10 m high wall at x = 50 whose face spans y in +-50 tan(0.2 deg), subtending
// +-0.2 deg (probability p_w = 0.4/40 = 0.01) and entirely inside the target's shadow cone.
Scenario with_wall(Scenario sc) {
  const double half = 50.0 * std::tan(0.2 * kDegToRad);
  sc.site.buildings.push_back(validation::box_building("wall", 50, -half, 51, half, 10.0));
  return sc;
}

PairedRun run_pair(const Scenario& base, const Scenario& variant) {
  return run_paired(base, scene::Site::build(base.site), variant, scene::Site::build(variant.site));
}

// Closed form: the wall takes N p_w real fragments from the target and gets them itself. The
// paired difference is within 3 se of it for each seed; its se matches the binomial count of
// the blocked histories, w sqrt(n p_w (1 - p_w)), to 10 %; and it is >= 5x smaller than the
// unpaired sqrt(se_base^2 + se_variant^2) (the closed forms give 7.1x).
TEST(Paired, WallInFrontOfABuildingAgainstTheClosedForm) {
  const std::int64_t n = 20000;
  const double p_w = 0.4 / kFanDeg;
  const double expected = -kRealFragments * p_w;
  const double se_closed = kRealFragments / n * std::sqrt(n * p_w * (1.0 - p_w));
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Scenario base = fan_at_target(n, seed);
    const PairedRun r = run_pair(base, with_wall(base));
    ASSERT_FALSE(r.cancelled);
    const PairedDifference& d = r.difference;
    ASSERT_EQ(d.buildings.size(), 2u);
    const BuildingDifference& target = d.buildings[0];
    EXPECT_EQ(target.id, "target");
    EXPECT_TRUE(target.in_base && target.in_variant);
    EXPECT_NEAR(target.impacts.mean, expected, 3.0 * target.impacts.std_error) << seed;
    EXPECT_NEAR(target.impacts.std_error, se_closed, 0.1 * se_closed) << seed;
    // The difference is exactly the variant's figure minus the base's.
    EXPECT_NEAR(target.impacts.mean,
                r.variant.buildings[0].impacts.mean - r.base.buildings[0].impacts.mean, 1e-12);
    const double unpaired =
        std::hypot(r.base.buildings[0].impacts.std_error, r.variant.buildings[0].impacts.std_error);
    EXPECT_GT(unpaired, 5.0 * target.impacts.std_error) << seed;
    const BuildingDifference& wall = d.buildings[1];
    EXPECT_EQ(wall.id, "wall");
    EXPECT_FALSE(wall.in_base);
    EXPECT_TRUE(wall.in_variant);
    EXPECT_NEAR(wall.impacts.mean, -expected, 3.0 * wall.impacts.std_error) << seed;
    EXPECT_NEAR(wall.impacts.mean, -target.impacts.mean, 1e-9);  // every blocked one hits it
  }
}

// With stratified launch the difference is tallied in the run's own variance strata: still
// within 3 se of the closed form on each seed, and its se no larger than the independent draws'
// closed form (the strata cut the fan by direction, so the wall's cone is nearly one stratum).
TEST(Paired, StratifiedLaunchStaysUnbiased) {
  const std::int64_t n = 20000;
  const double p_w = 0.4 / kFanDeg;
  const double se_closed = kRealFragments / n * std::sqrt(n * p_w * (1.0 - p_w));
  for (std::uint64_t seed : {4u, 5u}) {
    Scenario base = fan_at_target(n, seed);
    base.settings.stratified_launch.emplace();
    const PairedRun r = run_pair(base, with_wall(base));
    const Estimate& d = r.difference.buildings[0].impacts;
    EXPECT_NEAR(d.mean, -kRealFragments * p_w, 3.0 * d.std_error) << seed;
    EXPECT_GT(d.std_error, 0.0);
    EXPECT_LT(d.std_error, 1.1 * se_closed) << seed;
  }
}

// With Sobol nets the difference is tallied per net (16 per batch): within 3 se of the closed
// form on each seed, and far below the independent draws' se (in this one-dimensional fan a
// net of 1,250 points puts nearly its exact share in the wall's cone). Bit-identical at 1 and 2
// threads, and the HFD's jackknife, taking whole nets, is finite.
TEST(Paired, SobolLaunchStaysUnbiased) {
  const std::int64_t n = 20000;
  const double p_w = 0.4 / kFanDeg;
  const double se_closed = kRealFragments / n * std::sqrt(n * p_w * (1.0 - p_w));
  for (std::uint64_t seed : {6u, 7u, 8u}) {
    Scenario base = fan_at_target(n, seed);
    StratifiedLaunchSettings sobol;
    sobol.method = LaunchStratification::kSobol;
    base.settings.stratified_launch = sobol;
    base.settings.threads = 1;
    const PairedRun r = run_pair(base, with_wall(base));
    const Estimate& d = r.difference.buildings[0].impacts;
    EXPECT_NEAR(d.mean, -kRealFragments * p_w, 3.0 * d.std_error) << seed;
    EXPECT_GT(d.std_error, 0.0);
    EXPECT_LT(d.std_error, 0.5 * se_closed) << seed;
    EXPECT_TRUE(std::isfinite(r.difference.hfd.hfd_m.std_error));
    base.settings.threads = 2;
    const PairedRun r2 = run_pair(base, with_wall(base));
    EXPECT_EQ(r2.difference.buildings[0].impacts.mean, d.mean);
    EXPECT_EQ(r2.difference.buildings[0].impacts.std_error, d.std_error);
  }
}

// The same site twice: every difference is exactly 0 with se 0, and each run is bit-identical
// to a plain run (pairing only observes the chunks).
TEST(Paired, IdenticalSitesGiveExactlyZero) {
  const Scenario sc = testing::mixed_scenario(1501, 999);
  const PairedRun r = run_pair(sc, sc);
  const PairedDifference& d = r.difference;
  ASSERT_TRUE(d.same_terrain);
  for (std::size_t t = 0; t < d.density_per_m2.size(); ++t) {
    ASSERT_EQ(d.density_per_m2[t], 0.0) << t;
    ASSERT_EQ(d.density_std_error_per_m2[t], 0.0) << t;
  }
  EXPECT_EQ(d.max_abs_triangle, -1);
  for (const auto& b : d.buildings) {
    EXPECT_EQ(b.impacts.mean, 0.0);
    EXPECT_EQ(b.impacts.std_error, 0.0);
    EXPECT_EQ(b.penetrations.std_error, 0.0);
  }
  for (const auto& o : d.outcome_fragments) EXPECT_EQ(o.std_error, 0.0);
  EXPECT_EQ(d.hfd.hfd_m.mean, 0.0);
  EXPECT_EQ(d.hfd.hfd_m.std_error, 0.0);
  EXPECT_GT(r.base.hazardous_fragment_distance_m, 0.0);
  const RunResult plain = run::run(sc);
  EXPECT_EQ(plain.ptn_density_per_m2, r.base.ptn_density_per_m2);
  EXPECT_EQ(plain.ptn_std_error_per_m2, r.variant.ptn_std_error_per_m2);
  EXPECT_EQ(plain.buildings[0].impacts.mean, r.variant.buildings[0].impacts.mean);
}

// Bit-identical whatever the thread count and chunk size; with a building moved, the density
// difference per triangle is paired (same terrain) and the HFD's jackknife se is finite.
TEST(Paired, ReproducibleAcrossThreadsAndChunks) {
  Scenario base = testing::mixed_scenario(1501, 999);
  Scenario variant = base;
  variant.site.buildings[0] = validation::box_building("a", 30, -10, 50, 10, 8.0);
  base.settings.threads = variant.settings.threads = 1;
  const PairedRun one = run_pair(base, variant);
  base.settings.threads = variant.settings.threads = 2;
  base.settings.chunk_histories = variant.settings.chunk_histories = 37;
  const PairedRun two = run_pair(base, variant);
  EXPECT_EQ(one.difference.density_per_m2, two.difference.density_per_m2);
  EXPECT_EQ(one.difference.density_std_error_per_m2, two.difference.density_std_error_per_m2);
  EXPECT_EQ(one.difference.buildings[0].impacts.mean, two.difference.buildings[0].impacts.mean);
  EXPECT_EQ(one.difference.hfd.hfd_m.std_error, two.difference.hfd.hfd_m.std_error);
  EXPECT_TRUE(one.difference.same_terrain);
  EXPECT_GT(one.difference.max_abs_density_per_m2, 0.0);
  EXPECT_TRUE(std::isfinite(one.difference.hfd.hfd_m.std_error));
  EXPECT_NE(one.difference.buildings[0].impacts.mean, 0.0);
}

TEST(Paired, RefusesWhatCannotBePaired) {
  const Scenario base = fan_at_target(100, 1);
  Scenario v = base;
  v.settings.seed = 2;
  EXPECT_THROW(check_pairable(base, v), InputError);
  v = base;
  v.groups[0].samples = 101;
  EXPECT_THROW(check_pairable(base, v), InputError);
  v = base;
  v.settings.precision.emplace();
  EXPECT_THROW(check_pairable(base, v), InputError);
}

}  // namespace
}  // namespace fragsim::run
