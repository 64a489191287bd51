// Any split of a run's histories into shards, each run with any thread count and chunk size,
// merged in any order, gives the bits of the whole run in one process (core/run/partial.h).
#include "core/run/partial.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "core/common/error.h"
#include "core/run/run_fixtures.h"

namespace fragsim::run {
namespace {

// The mixed case with a third of its histories (1,201 and 517: shard boundaries fall anywhere),
// the second group of other weight, and trajectories recorded too.
Scenario shard_scenario() {
  Scenario sc = testing::mixed_scenario(1201, 517);
  sc.groups[1].count = 333.0;
  sc.settings.record_trajectories = true;
  sc.settings.max_recorded_trajectories = 50;
  return sc;
}

using testing::same_bits;

using testing::expect_same_figures;

// Runs the scenario as `n` shards, each with its own thread count and chunk size (drawn from
// `gen`), and merges them in a shuffled order.
RunResult sharded(Scenario sc, std::int64_t n, std::mt19937& gen) {
  const auto site = scene::Site::build(sc.site);
  std::vector<PartialRun> parts;
  for (std::int64_t i = 0; i < n; ++i) {
    sc.settings.threads = 1 + static_cast<int>(gen() % 2);
    sc.settings.chunk_histories = std::array<std::int64_t, 4>{1, 7, 64, 1000}[gen() % 4];
    parts.push_back(run_partial(sc, site, Shard{i, n}));
  }
  std::shuffle(parts.begin(), parts.end(), gen);
  PartialRun all = std::move(parts[0]);
  for (std::size_t k = 1; k < parts.size(); ++k) merge(all, std::move(parts[k]));
  return finish(sc, *site, std::move(all));
}

TEST(Shards, AnySplitMergedInAnyOrderGivesTheBitsOfOneRun) {
  Scenario sc = shard_scenario();
  sc.settings.threads = 2;
  const RunResult whole = run(sc);
  ASSERT_GT(whole.buildings[0].impacts.mean + whole.buildings[1].impacts.mean, 0.0);
  ASSERT_GT(whole.max_ptn_density_per_m2, 0.0);
  std::mt19937 gen(11);
  for (const std::int64_t n : {1, 2, 3, 7, 600}) {  // 600 > 517: some shards hold no history
    SCOPED_TRACE(n);
    expect_same_figures(whole, sharded(sc, n, gen));
  }
}

TEST(Shards, StratifiedLaunchStrataCutByShardsAreClosedWhole) {
  Scenario sc = shard_scenario();
  sc.settings.record_trajectories = false;
  StratifiedLaunchSettings strat;
  strat.histories_per_stratum = 5;
  sc.settings.stratified_launch = strat;
  const RunResult whole = run(sc);
  std::mt19937 gen(5);
  for (const std::int64_t n : {2, 3, 13}) {  // boundaries that cut collapsed strata of both
    SCOPED_TRACE(n);                         // partitions
    expect_same_figures(whole, sharded(sc, n, gen));
  }
}

// Sobol launch: a shard takes whole nets (blocks), 16 per group; 2, 3 and 13 shards cut the
// groups' nets unevenly, and 20 shards leave some shards without a net of a group.
TEST(Shards, SobolNetsSplitByShardsGiveTheBitsOfOneRun) {
  Scenario sc = shard_scenario();
  sc.settings.record_trajectories = false;
  StratifiedLaunchSettings sobol;
  sobol.method = LaunchStratification::kSobol;
  sc.settings.stratified_launch = sobol;
  const RunResult whole = run(sc);
  ASSERT_GT(whole.buildings[0].impacts.std_error, 0.0);
  std::mt19937 gen(7);
  for (const std::int64_t n : {2, 3, 13, 20}) {
    SCOPED_TRACE(n);
    expect_same_figures(whole, sharded(sc, n, gen));
  }
}

TEST(Shards, APartialLeavesTheStrataItCutsOpen) {
  Scenario sc = shard_scenario();
  const auto site = scene::Site::build(sc.site);
  const PartialRun p = run_partial(sc, site, Shard{1, 3});
  // Shard 1 of 3 holds the middle of both groups: one open stratum per group (no stratified
  // launch: a group's batch is one stratum).
  ASSERT_EQ(p.tally.open_strata().size(), 2u);
  for (const auto& [key, st] : p.tally.open_strata()) EXPECT_LT(st.n, st.size);
  EXPECT_EQ(p.histories_done, (800 - 400) + (344 - 172));
}

TEST(Shards, MissingDuplicateAndForeignShardsAreErrors) {
  Scenario sc = shard_scenario();
  sc.settings.record_trajectories = false;
  sc.settings.record_fragments = false;
  const auto site = scene::Site::build(sc.site);
  PartialRun a = run_partial(sc, site, Shard{0, 3});
  PartialRun b = run_partial(sc, site, Shard{2, 3});
  PartialRun b2 = run_partial(sc, site, Shard{2, 3});
  PartialRun other = run_partial(sc, site, Shard{0, 2});
  merge(a, std::move(b));
  EXPECT_THROW(merge(a, std::move(b2)), InputError);     // shard 2 twice
  EXPECT_THROW(merge(a, std::move(other)), InputError);  // a split of 2
  try {
    finish(sc, *site, std::move(a));
    ADD_FAILURE() << "a run with a shard missing finished";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("shard 1 of 3 missing"), std::string::npos) << e.what();
  }
}

TEST(Shards, BadShardsAndPrecisionSplitsAreRefused) {
  Scenario sc = shard_scenario();
  const auto site = scene::Site::build(sc.site);
  EXPECT_THROW(run_partial(sc, site, Shard{3, 3}), InputError);
  EXPECT_THROW(run_partial(sc, site, Shard{-1, 3}), InputError);
  EXPECT_THROW(run_partial(sc, site, Shard{0, 0}), InputError);
  sc.settings.precision = PrecisionSettings{};
  EXPECT_THROW(run_partial(sc, site, Shard{0, 2}), InputError);
}

TEST(Shards, ShardBoundariesCoverEveryHistoryOnce) {
  for (const std::int64_t samples : {1, 2, 517, 1'000'000'007}) {
    for (const std::int64_t n : {1, 2, 3, 600, 1'000'000}) {
      std::int64_t covered = 0, prev = 0;
      for (std::int64_t i = 0; i < n; ++i) {
        const std::int64_t b = shard_begin(samples, {i, n}), e = shard_begin(samples, {i + 1, n});
        ASSERT_EQ(b, prev);
        ASSERT_LE(b, e);
        covered += e - b;
        prev = e;
      }
      EXPECT_EQ(covered, samples) << samples << " " << n;
    }
  }
}

}  // namespace
}  // namespace fragsim::run
