// settings.precision: batches, the stop at the first boundary where the targets hold, and
// bit-reproducibility of where and how a run stops (docs/precision.md).
#include "core/run/precision.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "core/run/run.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

// A flat site with two buildings, two groups: a small case with PTN, HFD and building hits.
Scenario batched_scenario() {
  Scenario sc = validation::flat_site_scenario(300.0, 5.0);
  validation::add_wall_and_roof(sc, 2.0e6);
  sc.site.buildings = {validation::box_building("near", 40, -10, 60, 10, 8.0),
                       validation::box_building("far", -140, 20, -120, 50, 12.0)};
  auto g = validation::mixed_sphere_group(Vec3(0, 0, 1.0), 0.5, 400.0, 200.0, 300);
  auto g2 = g;
  g2.count = 50.0;
  g2.samples = 101;
  sc.groups = {g, g2};
  return sc;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

bool same_bits(const Estimate& a, const Estimate& b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

void expect_identical(const RunResult& a, const RunResult& b) {
  EXPECT_EQ(a.batches, b.batches);
  EXPECT_EQ(a.histories_done, b.histories_done);
  EXPECT_TRUE(same_bits(a.ptn_density_per_m2, b.ptn_density_per_m2));
  EXPECT_TRUE(same_bits(a.ptn_std_error_per_m2, b.ptn_std_error_per_m2));
  EXPECT_EQ(a.hazardous_fragment_distance_m, b.hazardous_fragment_distance_m);
  EXPECT_EQ(a.hfd_lower_m, b.hfd_lower_m);
  EXPECT_EQ(a.hfd_upper_m, b.hfd_upper_m);
  ASSERT_EQ(a.buildings.size(), b.buildings.size());
  for (std::size_t i = 0; i < a.buildings.size(); ++i) {
    EXPECT_TRUE(same_bits(a.buildings[i].impacts, b.buildings[i].impacts));
    EXPECT_TRUE(same_bits(a.buildings[i].penetrations, b.buildings[i].penetrations));
  }
  for (std::size_t o = 0; o < kOutcomeCount; ++o) {
    EXPECT_TRUE(same_bits(a.outcome_fragments[o], b.outcome_fragments[o]));
    EXPECT_EQ(a.outcome_histories[o], b.outcome_histories[o]);
  }
}

PrecisionSettings targets() {
  PrecisionSettings p;
  p.building_rel_error = 0.1;
  p.building_abs_error = 0.5;
  p.hfd_half_band_m = 20.0;
  p.max_batches = 60;
  return p;
}

TEST(Precision, WithoutPrecisionTheRunIsOneBatchAndEqualsMaxBatchesOne) {
  Scenario sc = batched_scenario();
  const RunResult plain = run(sc);
  EXPECT_EQ(plain.batches, 1);
  EXPECT_EQ(plain.stop_reason, StopReason::kSamples);
  EXPECT_EQ(plain.precision, nullptr);
  PrecisionSettings one;
  one.max_batches = 1;
  one.min_batches = 1;
  sc.settings.precision = one;
  const RunResult batched = run(sc);
  EXPECT_EQ(batched.stop_reason, StopReason::kMaxBatches);
  expect_identical(plain, batched);
}

TEST(Precision, StopsAtTheFirstBoundaryWhereAllTargetsHoldAndEqualsAFixedRunOfThatLength) {
  Scenario sc = batched_scenario();
  sc.settings.precision = targets();
  sc.settings.threads = 2;
  const RunResult r = run(sc);
  ASSERT_NE(r.precision, nullptr);
  for (const auto& t : r.precision->targets)
    EXPECT_TRUE(t.met) << t.figure << " " << t.building << ": " << t.basis << " " << t.value
                       << " > " << t.allowed;
  ASSERT_EQ(r.stop_reason, StopReason::kTargetsMet);
  EXPECT_TRUE(r.precision->all_met);
  EXPECT_EQ(r.precision->batches, r.batches);
  EXPECT_EQ(r.samples, r.batches * (300 + 101));
  EXPECT_EQ(r.histories_done, r.samples);
  // The case is not trivial: the targets did not hold at the first boundaries.
  ASSERT_GE(r.batches, 4) << "targets met too early to test the stop";
  RecordProperty("batches", static_cast<int>(r.batches));

  // The same scenario with max_batches = K and no targets: bit-identical, at 1 thread and with
  // other chunks.
  Scenario fixed = sc;
  PrecisionSettings k;
  k.max_batches = r.batches;
  fixed.settings.precision = k;
  fixed.settings.threads = 1;
  fixed.settings.chunk_histories = 37;
  const RunResult f = run(fixed);
  EXPECT_EQ(f.stop_reason, StopReason::kMaxBatches);
  expect_identical(r, f);

  // One batch less: some target did not hold (so the stop was the first possible one).
  k.max_batches = r.batches - 1;
  fixed.settings.precision = k;
  const RunResult before = run(fixed);
  PrecisionSnapshot s;
  s.batches = before.batches;
  s.histories = before.histories_done;
  s.hfd_m = before.hazardous_fragment_distance_m;
  s.hfd_lower_m = before.hfd_lower_m;
  s.hfd_upper_m = before.hfd_upper_m;
  for (const auto& b : before.buildings) s.buildings.push_back({b.id, b.impacts, b.penetrations});
  for (const auto& g : sc.groups)
    s.zero_count_bound += 3.0 * g.count / static_cast<double>(g.samples * before.batches);
  const auto checked = check_targets(*sc.settings.precision, s);
  EXPECT_FALSE(std::all_of(checked.begin(), checked.end(), [](const auto& t) { return t.met; }));
}

TEST(Precision, BatchedEstimatesEqualThoseOfOneRunOverTheSameHistories) {
  // Batch b runs histories [b s, (b + 1) s) of each group: K batches are the histories of one
  // run with K s samples. The means agree to rounding; the standard errors (within-batch
  // variance) agree statistically.
  Scenario sc = batched_scenario();
  PrecisionSettings k;
  k.max_batches = 6;
  sc.settings.precision = k;
  const RunResult batched = run(sc);
  Scenario one = batched_scenario();
  for (auto& g : one.groups) g.samples *= 6;
  const RunResult plain = run(one);
  ASSERT_EQ(batched.histories_done, plain.histories_done);
  for (std::size_t i = 0; i < plain.buildings.size(); ++i) {
    const Estimate& a = batched.buildings[i].impacts;
    const Estimate& b = plain.buildings[i].impacts;
    ASSERT_GT(b.mean, 0.0);
    EXPECT_NEAR(a.mean, b.mean, 1e-12 * b.mean);
    EXPECT_NEAR(a.std_error, b.std_error, 0.1 * b.std_error);
  }
  for (std::size_t o = 0; o < kOutcomeCount; ++o) {
    EXPECT_EQ(batched.outcome_histories[o], plain.outcome_histories[o]);
    EXPECT_NEAR(batched.outcome_fragments[o].mean, plain.outcome_fragments[o].mean,
                1e-12 * std::max(1.0, plain.outcome_fragments[o].mean));
  }
  double max_diff = 0.0;
  for (std::size_t t = 0; t < plain.ptn_density_per_m2.size(); ++t)
    max_diff =
        std::max(max_diff, std::abs(batched.ptn_density_per_m2[t] - plain.ptn_density_per_m2[t]));
  EXPECT_LE(max_diff, 1e-12 * plain.max_ptn_density_per_m2);
  EXPECT_GT(plain.hazardous_fragment_distance_m, 0.0);
}

TEST(Precision, CapsStopTheRunWithTheirReason) {
  Scenario sc = batched_scenario();
  PrecisionSettings p = targets();
  p.building_rel_error = 1e-4;  // out of reach
  p.building_abs_error.reset();
  p.max_batches = 3;
  sc.settings.precision = p;
  const RunResult r = run(sc);
  EXPECT_EQ(r.stop_reason, StopReason::kMaxBatches);
  EXPECT_EQ(r.batches, 3);
  ASSERT_NE(r.precision, nullptr);
  EXPECT_FALSE(r.precision->all_met);
  EXPECT_GT(r.precision->histories_needed, static_cast<double>(r.histories_done));
  EXPECT_GT(r.precision->eta_s, 0.0);

  p.max_batches = 1000;
  p.max_wall_s = 1e-9;  // reached at the first boundary
  sc.settings.precision = p;
  const RunResult w = run(sc);
  EXPECT_EQ(w.stop_reason, StopReason::kMaxWallTime);
  EXPECT_EQ(w.batches, 1);
}

TEST(Precision, MinBatchesHoldsBackAnEarlyStop) {
  Scenario sc = batched_scenario();
  PrecisionSettings p;
  p.building_abs_error = 1e6;  // met at once
  p.min_batches = 5;
  sc.settings.precision = p;
  const RunResult r = run(sc);
  EXPECT_EQ(r.stop_reason, StopReason::kTargetsMet);
  EXPECT_EQ(r.batches, 5);
}

// Issue 22: a bound cannot meet a precision target. With the HFD cut by the site boundary even
// at the band's lower end, the HFD targets are unmeetable, say why, and the run stops at the
// first boundary after min_batches where nothing else is left to meet: targets_unmeetable, not
// max_batches 40 batches later, and never targets_met. On a plane large enough the same targets
// are met or not, as before.
TEST(Precision, AnHfdTargetOnAnHfdCutByTheSiteBoundaryIsUnmeetableAndStopsTheRun) {
  Scenario sc = validation::fan_scenario(200.0, 500);
  PrecisionSettings p;
  p.hfd_half_band_m = 1000.0;  // met by any band: only the boundary stands in the way
  p.ptn_rel_error_at_hfd = 1.0;
  p.max_batches = 40;
  sc.settings.precision = p;
  const RunResult r = run(sc);
  EXPECT_TRUE(r.site_boundary.band_lower_cut);
  EXPECT_EQ(r.stop_reason, StopReason::kTargetsUnmeetable);
  EXPECT_EQ(r.batches, p.min_batches);
  ASSERT_NE(r.precision, nullptr);
  EXPECT_FALSE(r.precision->all_met);
  EXPECT_TRUE(r.precision->any_unmeetable);
  EXPECT_TRUE(std::isinf(r.precision->eta_s));
  ASSERT_EQ(r.precision->targets.size(), 2u);
  for (const TargetStatus& t : r.precision->targets) {
    EXPECT_FALSE(t.met) << t.figure;
    EXPECT_TRUE(t.unmeetable) << t.figure;
    EXPECT_NE(t.note.find("reaches the site boundary"), std::string::npos) << t.note;
    EXPECT_NE(t.note.find("extend the terrain"), std::string::npos) << t.note;
    EXPECT_TRUE(std::isinf(t.histories_needed)) << t.figure;
  }
  EXPECT_STREQ(stop_reason_name(r.stop_reason), "targets_unmeetable");

  // A building target still unmet keeps the run going (to its cap here).
  sc.site.materials["wall"] = scene::MaterialSpec{};
  sc.site.materials["roof"] = scene::MaterialSpec{};
  sc.site.buildings = {validation::box_building("B", 60, -10, 80, 10, 6.0)};
  p.building_rel_error = 1e-6;
  p.max_batches = 4;
  sc.settings.precision = p;
  EXPECT_EQ(run(sc).stop_reason, StopReason::kMaxBatches);

  Scenario big = validation::fan_scenario(600.0, 500);
  p = PrecisionSettings{};
  p.hfd_half_band_m = 1000.0;
  big.settings.precision = p;
  const RunResult b = run(big);
  EXPECT_FALSE(b.site_boundary.hfd_cut);
  EXPECT_EQ(b.stop_reason, StopReason::kTargetsMet);
  ASSERT_NE(b.precision, nullptr);
  EXPECT_FALSE(b.precision->targets[0].unmeetable);
  EXPECT_TRUE(b.precision->targets[0].note.empty());
}

TEST(Precision, ProgressCarriesTheLastCheck) {
  Scenario sc = batched_scenario();
  PrecisionSettings p = targets();
  p.max_batches = 4;
  p.building_rel_error = 1e-4;
  sc.settings.precision = p;
  std::int64_t last_batches = 0;
  RunControl control;
  control.progress_interval_s = 0.0;
  control.on_progress = [&](const Progress& pr) {
    if (pr.precision) last_batches = std::max(last_batches, pr.precision->batches);
    EXPECT_EQ(pr.histories_total, 4 * (300 + 101));
  };
  sc.settings.threads = 1;
  run(sc, control);
  EXPECT_EQ(last_batches, 4);
}

// ---- the checks themselves ----

PrecisionSnapshot snapshot_with(Estimate impacts, Estimate penetrations) {
  PrecisionSnapshot s;
  s.batches = 4;
  s.histories = 4000;
  s.zero_count_bound = 0.03;
  s.buildings = {{"A", impacts, penetrations}, {"B", {2.0, 0.01}, {1.0, 0.01}}};
  return s;
}

TEST(PrecisionTargets, RelativeOrAbsoluteEitherHolds) {
  PrecisionSettings p;
  p.building_rel_error = 0.05;
  p.building_abs_error = 0.02;
  // se 0.04 on 1.0: 4 % relative -> met by the relative target.
  auto t = check_targets(p, snapshot_with({1.0, 0.04}, {0.1, 0.015}));
  ASSERT_EQ(t.size(), 4u);
  EXPECT_TRUE(t[0].met);
  EXPECT_DOUBLE_EQ(t[0].allowed, 0.05);
  // se 0.015 on 0.1: 15 % relative, but within the absolute 0.02 -> met.
  EXPECT_TRUE(t[1].met);
  EXPECT_DOUBLE_EQ(t[1].allowed, 0.02);
  // se 0.06 on 1.0: neither.
  t = check_targets(p, snapshot_with({1.0, 0.06}, {0.1, 0.015}));
  EXPECT_FALSE(t[0].met);
}

TEST(PrecisionTargets, AFigureNoHistoryTouchedNeedsTheAbsoluteTargetAndTheZeroCountBound) {
  PrecisionSettings p;
  p.building_rel_error = 0.5;
  auto t = check_targets(p, snapshot_with({0.0, 0.0}, {0.0, 0.0}));
  EXPECT_EQ(t[0].basis, "zero_count_bound");
  EXPECT_DOUBLE_EQ(t[0].value, 0.03);
  EXPECT_FALSE(t[0].met) << "se = 0 of nothing seen must not pass a relative target";
  p.building_abs_error = 0.05;
  t = check_targets(p, snapshot_with({0.0, 0.0}, {0.0, 0.0}));
  EXPECT_TRUE(t[0].met);
  p.building_abs_error = 0.02;
  t = check_targets(p, snapshot_with({0.0, 0.0}, {0.0, 0.0}));
  EXPECT_FALSE(t[0].met);
}

TEST(PrecisionTargets, BuildingListAndHfdBand) {
  PrecisionSettings p;
  p.building_abs_error = 1.0;
  p.buildings = {"B"};
  p.hfd_half_band_rel = 0.02;
  PrecisionSnapshot s = snapshot_with({1.0, 0.1}, {1.0, 0.1});
  s.hfd_m = 200.0;
  s.hfd_lower_m = 195.0;
  s.hfd_upper_m = 203.0;  // half band 4 m = 2 % of 200 m
  auto t = check_targets(p, s);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].figure, "hfd_half_band_m");
  EXPECT_DOUBLE_EQ(t[0].value, 4.0);
  EXPECT_TRUE(t[0].met);
  EXPECT_EQ(t[1].building, "B");
  EXPECT_EQ(t[2].building, "B");
  s.hfd_upper_m = 204.0;
  EXPECT_FALSE(check_targets(p, s)[0].met);
  p.hfd_half_band_m = 5.0;  // either
  EXPECT_TRUE(check_targets(p, s)[0].met);
}

// The site boundary and the HFD targets: cut at the band's lower end, unmeetable; cut only at the
// HFD or the band's upper end, not met (the band is not closed) but not unmeetable either.
TEST(PrecisionTargets, AnHfdCutByTheSiteBoundaryIsNotMetOrUnmeetable) {
  PrecisionSettings p;
  p.hfd_half_band_m = 10.0;
  p.ptn_rel_error_at_hfd = 0.5;
  PrecisionSnapshot s = snapshot_with({1.0, 0.1}, {1.0, 0.1});
  s.hfd_m = 200.0;
  s.hfd_lower_m = 198.0;
  s.hfd_upper_m = 201.0;
  s.ptn_rel_error_at_hfd = 0.1;
  auto t = check_targets(p, s);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_TRUE(t[0].met && t[1].met);

  s.hfd_upper_cut = true;
  t = check_targets(p, s);
  EXPECT_FALSE(t[0].met);
  EXPECT_FALSE(t[0].unmeetable);
  EXPECT_EQ(t[0].note, "the HFD band reaches the site boundary: not met while it does");
  EXPECT_TRUE(t[1].met) << "the density near the HFD: the HFD itself is not cut";

  s.hfd_cut = true;
  t = check_targets(p, s);
  EXPECT_FALSE(t[1].met);
  EXPECT_FALSE(t[1].unmeetable);

  s.hfd_lower_cut = true;
  s.hfd_lower_sectors_cut = 3;
  t = check_targets(p, s);
  for (const auto& x : t) {
    EXPECT_FALSE(x.met);
    EXPECT_TRUE(x.unmeetable);
    EXPECT_EQ(x.note,
              "the hazardous density reaches the site boundary in 3 sectors even at the band's "
              "lower end (mean - 1 se): the HFD is a lower bound; extend the terrain");
  }
  PrecisionTracker tracker;
  const PrecisionReport r = tracker.update(t, 2, 1000, 100.0);
  EXPECT_TRUE(r.any_unmeetable);
  EXPECT_TRUE(r.all_met_or_unmeetable());
  EXPECT_FALSE(r.all_met);
}

TEST(PrecisionTargets, PtnErrorNearTheHfdIsTheRmsOverTheOuterHazardousTriangles) {
  const std::vector<double> density = {1.0, 1.0, 1.0, 0.001, 1.0};
  const std::vector<double> se = {0.5, 0.1, 0.2, 0.001, 0.3};
  const std::vector<double> distance = {10.0, 96.0, 100.0, 150.0, 50.0};
  // Hazardous (>= 0.01) within [95, 100]: triangles 1 and 2.
  EXPECT_DOUBLE_EQ(ptn_rel_error_near_hfd(density, se, distance, 0.01, 100.0),
                   std::sqrt((0.01 + 0.04) / 2.0));
  EXPECT_EQ(ptn_rel_error_near_hfd(density, se, distance, 0.01, 0.0), 0.0);
}

// The importance learner's ring [0.85, 1.15] HFD: T triangles of equal density count T, a ring
// whose density one triangle holds counts about 1, an empty ring 1.
TEST(PrecisionTargets, RingParticipationCountsTheTrianglesThatShareTheRingsDensity) {
  const std::vector<double> distance = {50.0, 86.0, 100.0, 114.0, 120.0};
  EXPECT_DOUBLE_EQ(ring_participation({9.0, 1.0, 1.0, 1.0, 9.0}, distance, 100.0), 3.0);
  EXPECT_NEAR(ring_participation({0.0, 1.0, 1e-6, 0.0, 5.0}, distance, 100.0), 1.0, 1e-5);
  // Two equal and one of half their density: (2.5)^2 / 2.25.
  EXPECT_DOUBLE_EQ(ring_participation({0.0, 1.0, 1.0, 0.5, 0.0}, distance, 100.0),
                   2.5 * 2.5 / 2.25);
  EXPECT_EQ(ring_participation({1.0, 0.0, 0.0, 0.0, 1.0}, distance, 100.0), 1.0);
  EXPECT_EQ(ring_participation({1.0, 1.0, 1.0, 1.0, 1.0}, distance, 0.0), 1.0);
}

// Five checks at n = 1000 ... 5000 histories of a figure whose error is error(n), 1000 histories/s.
template <class Error>
PrecisionReport track(Error error, double allowed) {
  PrecisionTracker tracker;
  PrecisionReport r;
  for (int b = 1; b <= 5; ++b) {
    const double n = 1000.0 * b;
    TargetStatus t;
    t.figure = "x";
    t.value = error(n);
    t.allowed = allowed;
    r = tracker.update({t}, b, static_cast<std::int64_t>(n), 1000.0);
  }
  return r;
}

TEST(PrecisionTracker, ExtrapolatesTheObservedDecay) {
  // Error 1/sqrt(n) * 10: the target 0.01 is reached at n = 1e6.
  PrecisionReport r = track([](double n) { return 10.0 / std::sqrt(n); }, 0.01);
  EXPECT_FALSE(r.all_met);
  EXPECT_NEAR(r.decay_exponent, 0.5, 1e-9);
  EXPECT_NEAR(r.histories_needed, 1e6, 1.0);
  EXPECT_NEAR(r.eta_s, (1e6 - 5000.0) / 1000.0, 1e-3);
  // A figure decaying as 1/n is extrapolated with its own exponent.
  r = track([](double n) { return 10.0 / n; }, 1e-4);
  EXPECT_NEAR(r.decay_exponent, 1.0, 1e-9);
  EXPECT_NEAR(r.histories_needed, 1e5, 1e-3);
}

}  // namespace
}  // namespace fragsim::run
