// Importance sampling of launch directions (settings.precision.direction_importance): the
// estimates stay unbiased, their standard errors are honest, and they are smaller than plain
// Monte Carlo's for the figures the targets name (docs/precision.md, "Importance sampling").
#include "core/run/importance.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "core/run/precision.h"
#include "core/run/run.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

// One group on one thread with `seed`, and `p` as settings.precision (direction importance
// sampling with `cells` when `importance`).
Scenario one_group(Scenario sc, const fragments::FragmentGroupSpec& g, std::uint64_t seed,
                   PrecisionSettings p, bool importance, const DirectionImportanceSettings& cells) {
  sc.groups = {g};
  sc.settings.seed = seed;
  sc.settings.threads = 1;
  if (importance) p.direction_importance = cells;
  sc.settings.precision = p;
  return sc;
}

// A fan of fragments over a flat site with a small building 60 m away: the building subtends a
// few per cent of the launch directions, the case importance sampling is for.
Scenario fan_scenario(std::uint64_t seed, bool importance) {
  Scenario sc = validation::flat_site_scenario(300.0, 10.0);
  validation::add_wall_and_roof(sc, 2.0e6);
  sc.site.buildings = {validation::box_building("small", 55, -4, 63, 4, 5.0)};
  auto g = validation::sphere_group(Vec3(0, 0, 1.0), 0.05, 150.0, 100.0, 500);
  g.direction.elevation_min_deg = 0.0;
  g.direction.elevation_max_deg = 30.0;
  PrecisionSettings p;
  p.max_batches = 8;  // batch 0 is plain: over 8 batches the variance ratio can reach 8
  p.min_batches = 8;
  p.building_rel_error = 0.01;  // names the building as the figure; never met in 8 batches
  return one_group(sc, g, seed, p, importance, DirectionImportanceSettings{6, 36, 1, 0.3, 1});
}

struct Spread {
  double mean = 0, sd = 0, mean_se = 0;
};
Spread spread(const std::vector<Estimate>& e) {
  Spread s;
  for (const auto& x : e) {
    s.mean += x.mean;
    s.mean_se += x.std_error * x.std_error;
  }
  const double n = static_cast<double>(e.size());
  s.mean /= n;
  s.mean_se = std::sqrt(s.mean_se / n);  // rms of the reported se
  for (const auto& x : e) s.sd += (x.mean - s.mean) * (x.mean - s.mean);
  s.sd = std::sqrt(s.sd / (n - 1.0));
  return s;
}

TEST(DirectionImportance, UnbiasedHonestAndMoreEfficientThanPlainMonteCarlo) {
  constexpr int kSeeds = 16;
  std::vector<Estimate> plain, is;
  for (int k = 0; k < kSeeds; ++k) {
    plain.push_back(run(fan_scenario(100 + k, false)).buildings[0].impacts);
    is.push_back(run(fan_scenario(100 + k, true)).buildings[0].impacts);
  }
  const Spread p = spread(plain), q = spread(is);
  ASSERT_GT(p.mean, 0.0);
  // Unbiased: the two means over the seeds agree within 3 standard errors of their difference.
  const double se_diff = std::hypot(p.sd, q.sd) / std::sqrt(kSeeds);
  EXPECT_LE(std::abs(q.mean - p.mean), 3.0 * se_diff)
      << "plain " << p.mean << " IS " << q.mean << " se of the difference " << se_diff;
  // Honest: the spread across seeds matches the reported standard error (16 seeds: the sample
  // sd is within about +-35 % of the true one at 2 sigma; the bounds allow a little more).
  EXPECT_GT(q.sd / q.mean_se, 0.55) << q.sd << " vs reported " << q.mean_se;
  EXPECT_LT(q.sd / q.mean_se, 1.6) << q.sd << " vs reported " << q.mean_se;
  EXPECT_GT(p.sd / p.mean_se, 0.55);
  EXPECT_LT(p.sd / p.mean_se, 1.6);
  // More efficient for the named figure: the variance (same histories simulated, the pilot
  // included) at least 15 times smaller (24 measured with the site-derived pilot and the shrunk
  // hit rates; 9 when the pilot was plain Monte Carlo).
  const double ratio = (p.mean_se * p.mean_se) / (q.mean_se * q.mean_se);
  RecordProperty("variance_ratio", std::to_string(ratio));
  EXPECT_GT(ratio, 15.0) << "plain se " << p.mean_se << ", IS se " << q.mean_se;
}

// Without targets every figure is learnt for, the PTN ring included, so nearly every history
// counts as evidence; the small building gets a hit or two in the pilot. Its learnt rates must
// not concentrate the next batch on those hits' neighbourhoods: a hit from another facing cell
// then carries a likelihood ratio of 1/delta and holds most of the variance (the demo's B08 on
// seed 7, docs/benchmarks.md §8). Per seed, the variance of the building's impacts (same
// histories, pilot included) against plain Monte Carlo's over all seeds.
TEST(DirectionImportance, ARareBuildingGainsOnEverySeedWithoutTargets) {
  constexpr int kSeeds = 16;
  auto scenario = [](std::uint64_t seed, bool importance) {
    Scenario sc = fan_scenario(seed, importance);
    sc.settings.precision->building_rel_error.reset();  // no target: every figure is learnt
    return sc;
  };
  std::vector<Estimate> plain, is;
  for (int k = 0; k < kSeeds; ++k) {
    plain.push_back(run(scenario(300 + k, false)).buildings[0].impacts);
    is.push_back(run(scenario(300 + k, true)).buildings[0].impacts);
  }
  const Spread p = spread(plain), q = spread(is);
  const double se_diff = std::hypot(p.sd, q.sd) / std::sqrt(kSeeds);
  EXPECT_LE(std::abs(q.mean - p.mean), 3.0 * se_diff) << "plain " << p.mean << " IS " << q.mean;
  EXPECT_GT(q.sd / q.mean_se, 0.6) << q.sd << " vs reported " << q.mean_se;
  EXPECT_LT(q.sd / q.mean_se, 1.5) << q.sd << " vs reported " << q.mean_se;
  double worst = 1e300;
  for (const Estimate& e : is)
    worst = std::min(worst, p.mean_se * p.mean_se / (e.std_error * e.std_error));
  RecordProperty("worst_seed_variance_ratio", std::to_string(worst));
  EXPECT_GT(worst, 3.0) << "the worst seed's variance ratio against plain Monte Carlo";
}

TEST(DirectionImportance, ReproducibleAtAnyThreadCountAndThePilotIsNotTallied) {
  Scenario a = fan_scenario(7, true);
  Scenario b = a;
  b.settings.threads = 2;
  b.settings.chunk_histories = 33;
  const RunResult ra = run(a), rb = run(b);
  EXPECT_EQ(ra.buildings[0].impacts.mean, rb.buildings[0].impacts.mean);
  EXPECT_EQ(ra.buildings[0].impacts.std_error, rb.buildings[0].impacts.std_error);
  EXPECT_EQ(ra.ptn_density_per_m2, rb.ptn_density_per_m2);
  // Batch 0 is the pilot: simulated and learnt from, not in the estimates.
  EXPECT_EQ(ra.batches, 8);
  EXPECT_EQ(ra.pilot_histories, 500);
  EXPECT_EQ(ra.histories_done, 8 * 500);
  EXPECT_EQ(ra.samples, 7 * 500);
  std::int64_t outcomes = 0;
  for (const auto n : ra.outcome_histories) outcomes += n;
  EXPECT_EQ(outcomes, 7 * 500);
}

// Spheres thrown all round with drag over a flat site: the density near the HFD comes from the
// narrow band of elevations that land there, and the HFD ring is the only figure a target names.
Scenario ring_scenario(std::uint64_t seed, bool importance, std::int64_t batches) {
  Scenario sc = validation::flat_site_scenario(400.0, 50.0);
  auto g = validation::sphere_group(Vec3(0, 0, 1.0), 0.05, 100.0, 2.0e5, 20000);
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = 0.0;
  g.direction.elevation_max_deg = 80.0;
  PrecisionSettings p;
  p.max_batches = p.min_batches = batches;
  p.ptn_rel_error_at_hfd = 1e-9;  // names the ring; never met
  return one_group(sc, g, seed, p, importance, DirectionImportanceSettings{16, 12, 1, 0.3, 1});
}

double ring_rel_error(const RunResult& r) {
  for (const TargetStatus& t : r.precision->targets)
    if (t.figure == "ptn_rel_error_at_hfd") return t.value;
  return 0.0;
}

// The first learnt batch aims at the ring already: the pilot's own density (folded for this and
// cleared, not in the estimates) places it. Before, batch 1 knew no HFD and was drawn as without
// importance sampling, and on the demo it held most of a 10-batch run's variance at the HFD.
TEST(DirectionImportance, TheFirstLearntBatchAimsAtThePilotsRing) {
  constexpr int kSeeds = 4;
  double plain = 0.0, is = 0.0;
  for (int k = 0; k < kSeeds; ++k) {
    const RunResult p = run(ring_scenario(500 + k, false, 1)),
                    q = run(ring_scenario(500 + k, true, 2));
    ASSERT_GT(p.hazardous_fragment_distance_m, 50.0);
    ASSERT_EQ(q.samples, p.samples);  // batch 1 alone against plain's batch 0
    plain += ring_rel_error(p) * ring_rel_error(p);
    is += ring_rel_error(q) * ring_rel_error(q);
  }
  // Measured 3.6 (0.94 with the first ring left unplaced, as before).
  RecordProperty("variance_ratio", std::to_string(plain / is));
  EXPECT_GT(plain / is, 2.0) << "rms relative error at the HFD, plain against batch 1";

  // The pilot's density is folded as the histories arrive and cleared at its boundary: the
  // same bits at any thread count and chunk size, and nothing of the pilot in the estimates.
  Scenario a = ring_scenario(500, true, 3), b = a;
  b.settings.threads = 2;
  b.settings.chunk_histories = 777;
  const RunResult ra = run(a), rb = run(b);
  EXPECT_EQ(ra.ptn_density_per_m2, rb.ptn_density_per_m2);
  EXPECT_EQ(ra.ptn_std_error_per_m2, rb.ptn_std_error_per_m2);
  EXPECT_EQ(ra.pilot_histories, 20000);
  EXPECT_EQ(ra.samples, 2 * 20000);
  // Left in, the pilot's density would add half of it again.
  const RunResult plain2 = run(ring_scenario(500, false, 2));
  auto total = [](const RunResult& r) {
    return std::accumulate(r.ptn_density_per_m2.begin(), r.ptn_density_per_m2.end(), 0.0);
  };
  EXPECT_NEAR(total(ra) / total(plain2), 1.0, 0.1);
  std::int64_t outcomes = 0;
  for (const auto n : ra.outcome_histories) outcomes += n;
  EXPECT_EQ(outcomes, 2 * 20000);
}

// The pilot's density comes from the site: the cells whose launch azimuths face the building
// (azimuth 0 +- 4.2 deg from the origin; cells of 10 deg) get the building's share, the others
// the defensive share only.
TEST(DirectionImportance, ThePilotFacesTheBuildingsSeenFromTheLaunchOrigin) {
  const Scenario sc = fan_scenario(1, true);
  const auto site = scene::Site::build(sc.site);
  const DirectionLearner learner(sc, *site, std::vector<double>(site->terrain_triangle_count()));
  const auto pilot = learner.pilot();
  ASSERT_EQ(pilot.size(), 1u);
  const auto& q = pilot[0];
  ASSERT_FALSE(q.uniform());
  const double n = q.cells();
  for (int i = 0; i < 6; ++i) {
    // Azimuth cells 17 and 18 span [-10, 0] and [0, 10] deg: the building's.
    for (const int j : {17, 18})
      EXPECT_NEAR(q.probability(static_cast<std::uint32_t>(i * 36 + j)), 0.3 / n + 0.7 / 12.0,
                  1e-12);  // 12 cells share the building
    for (const int j : {0, 10, 16, 19, 30})
      EXPECT_NEAR(q.probability(static_cast<std::uint32_t>(i * 36 + j)), 0.3 / n, 1e-12);
  }
}

// A study that names both kinds of target: the ring's figure is the relative variance of one
// triangle's density (what ptn_rel_error_at_hfd reads), T times that of the ring's total when T
// triangles share the ring. Synthetic histories, all with likelihood ratio 1: the building's 12
// facing cells (azimuth cells 17 and 18) each see n_w histories and h_w hits; cell B (elevation
// 2, azimuth 0) sees n_B histories, each adding x = 1 to two neighbouring ring triangles (of
// 50, in turn: the squares are summed per triangle, 2 per history, not per distance bin). Then
//   a_w = rho / E[hit]^2,  rho = lambda h_w / n_w + (1 - lambda) E[hit] N / 12,
//   lambda = 12 h_w / (12 h_w + 5),  E[hit] = 12 h_w / n,
//   a_B = T sum_t E[x_t^2 | B] / E[x_ring]^2 = 2 T / (2 n_B / n)^2,
// and above the defensive share q_B : q_w = sqrt(a_B) : sqrt(a_w) (neither is raised by a
// neighbour: docs/precision.md, "Learning q").
TEST(DirectionImportance, TheRingIsWeighedPerTriangleAgainstTheBuildings) {
  Scenario sc = fan_scenario(1, true);
  sc.settings.precision->ptn_rel_error_at_hfd = 0.01;
  const auto site = scene::Site::build(sc.site);
  constexpr std::uint32_t kRing = 50;  // triangles 0 .. 49 at the HFD, the others far out
  std::vector<double> distance(site->terrain_triangle_count(), 5.0e4);
  std::fill(distance.begin(), distance.begin() + kRing, 100.0);
  constexpr int kNw = 40, kHw = 2, kNb = 60;
  const std::uint32_t cell_b = 2 * 36 + 0;
  for (const double ring_triangles : {1.0, 10.0, 50.0}) {
    DirectionLearner learner(sc, *site, distance);
    for (int i = 0; i < 6; ++i)
      for (const std::uint32_t j : {17u, 18u})
        for (int k = 0; k < kNw; ++k)
          learner.add(0, static_cast<std::uint32_t>(i * 36) + j, 1.0, k < kHw ? 0 : -1, nullptr,
                      nullptr);
    for (int k = 0; k < kNb; ++k) {
      const std::uint32_t t = static_cast<std::uint32_t>(k) % kRing;
      const PtnContribution c[2] = {{t, 1.0}, {(t + 1) % kRing, 1.0}};
      learner.add(0, cell_b, 1.0, -1, c, c + 2);
    }
    const auto q = learner.plan(100.0, ring_triangles)[0];
    const double n = 12.0 * kNw + kNb, cells = q.cells(), hits = 12.0 * kHw;
    const double mean = hits / n, lambda = hits / (hits + 5.0);
    const double a_w = (lambda * kHw / kNw + (1.0 - lambda) * mean * cells / 12.0) / (mean * mean);
    const double a_b = ring_triangles * 2.0 / ((2.0 * kNb / n) * (2.0 * kNb / n));
    const double touching = hits + kNb;
    const double floor = (1.0 - 0.7 * touching / (touching + 5.0)) / cells;
    const double ratio = (q.probability(cell_b) - floor) / (q.probability(17) - floor);
    EXPECT_NEAR(ratio, std::sqrt(a_b / a_w), 1e-9 * std::sqrt(a_b / a_w)) << ring_triangles;
  }
}

// The ring's second moments are shrunk toward the neighbourhood's, as the buildings' hit rates
// are: with the HFD target alone and ring contributions from one cell B only, B keeps its own
// value (its neighbourhood's average is its own), a neighbour of B that no history visited takes
// B's, and a cell two steps away (no history in its neighbourhood) only the neighbour floor, half
// of its neighbours' s (docs/precision.md, "Learning q").
TEST(DirectionImportance, AnUnvisitedCellTakesItsNeighbourhoodsRingMoments) {
  Scenario sc = fan_scenario(1, true);
  sc.settings.precision->building_rel_error.reset();
  sc.settings.precision->ptn_rel_error_at_hfd = 0.01;
  const auto site = scene::Site::build(sc.site);
  std::vector<double> distance(site->terrain_triangle_count(), 5.0e4);
  std::fill(distance.begin(), distance.begin() + 10, 100.0);
  DirectionLearner learner(sc, *site, distance);
  const std::uint32_t cell_b = 2 * 36 + 5;
  for (int k = 0; k < 30; ++k) {
    const PtnContribution c{static_cast<std::uint32_t>(k % 10), 1.0 + 0.1 * k};
    learner.add(0, cell_b, 1.0, -1, &c, &c + 1);
  }
  const auto q = learner.plan(100.0, 10.0)[0];
  const double touching = 30.0;
  const double floor = (1.0 - 0.7 * touching / (touching + 5.0)) / q.cells();
  const double b = q.probability(cell_b) - floor;
  ASSERT_GT(b, 0.0);
  EXPECT_NEAR(q.probability(cell_b + 1) - floor, b, 1e-12);        // azimuth neighbour
  EXPECT_NEAR(q.probability(cell_b + 36) - floor, b, 1e-12);       // elevation neighbour
  EXPECT_NEAR(q.probability(cell_b + 2) - floor, 0.5 * b, 1e-12);  // two steps: the floor
  EXPECT_NEAR(q.probability(cell_b + 10), floor, 1e-12);           // beyond: the defensive share
}

// A building no history can reach (behind a forward fan): its zero-count bound allows for the
// defensive share, since importance sampling may have sent only delta of the plain share of
// histories its way: 3 count / (K s delta), not 3 count / (K s).
TEST(DirectionImportance, TheZeroCountBoundAllowsForTheDefensiveShare) {
  Scenario sc = fan_scenario(3, true);
  sc.groups[0].direction.azimuth_min_deg = -10.0;
  sc.groups[0].direction.azimuth_max_deg = 10.0;
  sc.site.buildings.push_back(validation::box_building("behind", -63, -4, -55, 4, 5.0));
  PrecisionSettings& p = *sc.settings.precision;
  p.building_rel_error.reset();
  p.building_abs_error = 1e-6;  // never met: the run does its 8 batches
  p.buildings = {"behind"};
  const RunResult r = run(sc);
  ASSERT_EQ(r.buildings[1].impacts.mean, 0.0);
  ASSERT_TRUE(r.precision);
  int checked = 0;
  for (const auto& t : r.precision->targets) {
    if (t.building != "behind") continue;
    EXPECT_EQ(t.basis, "zero_count_bound");
    EXPECT_NEAR(t.value, 3.0 * 100.0 / (7.0 * 500.0 * 0.3), 1e-12);  // 7 tallied batches
    ++checked;
  }
  EXPECT_EQ(checked, 2);  // impacts and penetrations
}

// ---- the cells ----

TEST(DirectionCells, UniformCellsReportTheCellAndChangeNothing) {
  const fragments::DirectionCells u(4, 10);
  const auto d = u.draw(0.3, 0.95, 0.7, 0.123);
  EXPECT_EQ(d.u_elevation, 0.3);
  EXPECT_EQ(d.u_azimuth, 0.95);
  EXPECT_EQ(d.u_speed, 0.7);
  EXPECT_EQ(d.likelihood_ratio, 1.0);
  EXPECT_EQ(d.cell, 1u * 10u + 9u);
  const fragments::DirectionCells with_speed(4, 10, 3);
  EXPECT_EQ(with_speed.draw(0.3, 0.95, 0.7, 0.5).cell, (1u * 10u + 9u) * 3u + 2u);
}

TEST(DirectionCells, DrawsEachCellWithItsProbabilityAndTheMatchingRatio) {
  std::vector<double> q = {1.0, 3.0, 0.5, 0.5};  // 2 x 2, normalised to 0.2, 0.6, 0.1, 0.1
  const fragments::DirectionCells c(2, 2, 1, q);
  EXPECT_DOUBLE_EQ(c.probability(1), 0.6);
  std::vector<int> count(4, 0);
  constexpr int kN = 10000;
  for (int k = 0; k < kN; ++k) {
    const double u = (k + 0.5) / kN;  // stratified u_cell: counts exact to +-1
    const auto d = c.draw(0.25, 0.75, 0.5, u);
    ++count[d.cell];
    EXPECT_DOUBLE_EQ(d.likelihood_ratio, 0.25 / c.probability(d.cell));
    // The point lies inside its cell.
    EXPECT_EQ(c.cell_of(d.u_elevation, d.u_azimuth, d.u_speed), d.cell);
  }
  EXPECT_NEAR(count[0], 2000, 1);
  EXPECT_NEAR(count[1], 6000, 1);
  EXPECT_NEAR(count[2], 1000, 1);
  EXPECT_NEAR(count[3], 1000, 1);
  // E_q[ratio] = 1: the weights keep every expectation.
  double mean_ratio = 0.0;
  for (int cell = 0; cell < 4; ++cell)
    mean_ratio += c.probability(static_cast<std::uint32_t>(cell)) * 0.25 /
                  c.probability(static_cast<std::uint32_t>(cell));
  EXPECT_DOUBLE_EQ(mean_ratio, 1.0);
  EXPECT_THROW(fragments::DirectionCells(2, 2, 1, {1.0, 0.0, 1.0, 1.0}), std::invalid_argument);
}

}  // namespace
}  // namespace fragsim::run
