// A settings.precision run divided into shards that exchange each batch (core/run/partial.h,
// BatchState and BatchSynchronizer): whatever the split, threads and chunk sizes, it stops at the
// batch of the run in one process, for the same reason, with the same bits and the same
// precision report, with and without importance sampling (whose pilot and learning see every
// shard's histories).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <thread>

#include "core/common/error.h"
#include "core/run/partial.h"
#include "core/run/precision.h"
#include "core/run/run_fixtures.h"

namespace fragsim::run {
namespace {

// The shards of one run on threads of this process: a batch boundary waits until every shard
// has brought its state, then each gets the merge (made once, in reverse shard order: the order
// cannot matter). A cancellation seen before the last shard arrives aborts that boundary for
// all of them, so that every shard stops at the same one (as fragsim-mpi's ranks do).
class ThreadSynchronizer : public BatchSynchronizer {
 public:
  ThreadSynchronizer(std::int64_t shards, const std::atomic<bool>* cancel)
      : shards_(shards), cancel_(cancel) {}

  std::optional<BatchState> exchange(const BatchState& mine) override {
    std::unique_lock<std::mutex> lock(mutex_);
    ++exchanges_;
    if (aborted_ || stopping()) return abort();
    const std::int64_t generation = generation_;
    states_.push_back(mine);
    if (static_cast<std::int64_t>(states_.size()) == shards_) {
      std::sort(states_.begin(), states_.end(), [](const BatchState& a, const BatchState& b) {
        return a.part.shards[0] > b.part.shards[0];
      });
      merged_ = std::move(states_[0]);
      for (std::size_t k = 1; k < states_.size(); ++k) merge(merged_, std::move(states_[k]));
      states_.clear();
      ++generation_;
      cv_.notify_all();
      return merged_;
    }
    for (;;) {
      cv_.wait_for(lock, std::chrono::milliseconds(5));
      if (generation_ != generation) return merged_;
      if (aborted_ || stopping()) return abort();
    }
  }
  std::int64_t exchanges() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return exchanges_;
  }

 private:
  bool stopping() const { return cancel_ != nullptr && cancel_->load(); }
  std::optional<BatchState> abort() {
    aborted_ = true;
    cv_.notify_all();
    return std::nullopt;
  }
  const std::int64_t shards_;
  const std::atomic<bool>* cancel_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<BatchState> states_;
  BatchState merged_;
  std::int64_t generation_ = 0, exchanges_ = 0;
  bool aborted_ = false;
};

struct Divided {
  RunResult result;
  std::vector<PartialRun> parts;  // as the shards returned them (before the merge)
};

// Runs the scenario as `n` shards on threads (shard i with 1 + i % 2 threads and its own chunk
// size), synchronized at each batch boundary, then merges and finishes the partials.
Divided divided(const Scenario& sc, std::int64_t n, const std::atomic<bool>* cancel = nullptr,
                const std::function<void(const Progress&)>& on_progress = {}) {
  const auto site = scene::Site::build(sc.site);
  ThreadSynchronizer sync(n, cancel);
  std::vector<PartialRun> parts(static_cast<std::size_t>(n));
  std::vector<std::exception_ptr> errors(parts.size());
  std::vector<std::thread> shards;
  for (std::int64_t i = 0; i < n; ++i)
    shards.emplace_back([&, i] {
      Scenario mine = sc;
      mine.settings.threads = 1 + static_cast<int>(i % 2);
      mine.settings.chunk_histories = std::array<std::int64_t, 3>{64, 7, 1000}[i % 3];
      RunControl control;
      control.synchronizer = &sync;
      control.cancel = cancel;
      control.on_progress = on_progress;
      control.progress_interval_s = 0.0;
      try {
        parts[static_cast<std::size_t>(i)] = run_partial(mine, site, Shard{i, n}, control);
      } catch (...) {
        errors[static_cast<std::size_t>(i)] = std::current_exception();
      }
    });
  for (auto& t : shards) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  Divided d;
  d.parts = parts;
  PartialRun all = std::move(parts[0]);
  for (std::size_t k = 1; k < parts.size(); ++k) merge(all, std::move(parts[k]));
  d.result = finish(sc, *site, std::move(all));
  return d;
}

using testing::same_bits;

// Every figure to the bit; the precision report but its ETA (a wall-clock rate).
void expect_same_run(const RunResult& a, const RunResult& b) {
  EXPECT_EQ(a.batches, b.batches);
  EXPECT_EQ(a.stop_reason, b.stop_reason);
  EXPECT_EQ(a.pilot_histories, b.pilot_histories);
  testing::expect_same_figures(a, b);
  ASSERT_EQ(a.fragments.size(), b.fragments.size());
  for (std::size_t i = 0; i < a.fragments.size(); ++i) {
    EXPECT_EQ(a.fragments[i].history, b.fragments[i].history);
    EXPECT_TRUE(same_bits(a.fragments[i].launch_velocity_mps, b.fragments[i].launch_velocity_mps));
    EXPECT_TRUE(same_bits(a.fragments[i].weight, b.fragments[i].weight));
  }
  ASSERT_NE(a.precision, nullptr);
  ASSERT_NE(b.precision, nullptr);
  const PrecisionReport &p = *a.precision, &q = *b.precision;
  EXPECT_EQ(p.batches, q.batches);
  EXPECT_EQ(p.histories, q.histories);
  EXPECT_EQ(p.all_met, q.all_met);
  EXPECT_EQ(p.any_unmeetable, q.any_unmeetable);
  EXPECT_TRUE(same_bits(p.histories_needed, q.histories_needed));
  EXPECT_TRUE(same_bits(p.decay_exponent, q.decay_exponent));
  ASSERT_EQ(p.targets.size(), q.targets.size());
  for (std::size_t k = 0; k < p.targets.size(); ++k) {
    EXPECT_EQ(p.targets[k].figure, q.targets[k].figure);
    EXPECT_EQ(p.targets[k].building, q.targets[k].building);
    EXPECT_TRUE(same_bits(p.targets[k].value, q.targets[k].value)) << p.targets[k].figure;
    EXPECT_EQ(p.targets[k].met, q.targets[k].met);
    EXPECT_TRUE(same_bits(p.targets[k].histories_needed, q.targets[k].histories_needed));
  }
}

// The mixed case (two groups, two buildings; run_fixtures.h) at 301 + 117 histories a batch
// (shard boundaries fall anywhere), fragments recorded.
Scenario precision_scenario(bool importance, bool targets) {
  Scenario sc = testing::mixed_scenario(301, 117);
  sc.settings.threads = 1;
  PrecisionSettings p;
  p.max_batches = 7;
  if (targets) {
    // A plane of +-800 m (cells of 16 m): the HFD band within it.
    auto& plane = std::get<scene::PlaneTerrainSpec>(sc.site.terrain.geometry);
    plane.extent_m = {-800.0, -800.0, 800.0, 800.0};
    plane.cell_m = 16.0;
    p.hfd_half_band_m = 250.0;    // loose; makes the learner follow the HFD ring too
    p.building_rel_error = 0.12;  // met after 17 batches (plain); 23 with importance (the HFD)
    p.max_batches = 40;
  }
  if (importance) p.direction_importance = DirectionImportanceSettings{6, 24, 1, 0.3, 2};
  sc.settings.precision = p;
  return sc;
}

void check_divisions(const Scenario& sc, StopReason expected_reason) {
  const RunResult whole = run(sc);
  ASSERT_EQ(whole.stop_reason, expected_reason);
  ASSERT_GT(whole.batches, 2);  // a stop after some boundaries that did not stop
  ASSERT_GT(whole.buildings[0].impacts.mean, 0.0);
  for (const std::int64_t n : {2, 3}) {
    SCOPED_TRACE(n);
    expect_same_run(whole, divided(sc, n).result);
  }
}

TEST(DividedPrecision, StopByTargetsAtTheBatchAndWithTheBitsOfOneProcess) {
  check_divisions(precision_scenario(false, true), StopReason::kTargetsMet);
}

TEST(DividedPrecision, StopByMaxBatchesWithTheBitsOfOneProcess) {
  check_divisions(precision_scenario(false, false), StopReason::kMaxBatches);
}

TEST(DividedPrecision, ImportanceSamplingLearnsFromEveryShardAsOneProcessDoes) {
  check_divisions(precision_scenario(true, true), StopReason::kTargetsMet);
  check_divisions(precision_scenario(true, false), StopReason::kMaxBatches);
}

// Stratified launch: the strata a shard boundary cuts are closed whole at the batch boundary.
TEST(DividedPrecision, StratifiedStrataCutByShardsAreClosedAtEachBoundary) {
  Scenario sc = precision_scenario(true, false);
  StratifiedLaunchSettings strat;
  strat.histories_per_stratum = 5;
  sc.settings.stratified_launch = strat;
  check_divisions(sc, StopReason::kMaxBatches);
}

// More shards than a group has histories: the idle shards still take part in every boundary.
TEST(DividedPrecision, ShardsWithoutHistoriesTakePartInEveryBoundary) {
  Scenario sc = testing::mixed_scenario(5, 2);
  sc.settings.threads = 1;
  PrecisionSettings p;
  p.max_batches = 4;
  p.direction_importance = DirectionImportanceSettings{2, 6, 1, 0.3, 1};
  sc.settings.precision = p;
  const RunResult whole = run(sc);
  const Divided d = divided(sc, 7);
  expect_same_run(whole, d.result);
  for (const PartialRun& part : d.parts) EXPECT_EQ(part.batches, 4);
}

// A cancellation stops every shard at the same boundary; the merged result says cancelled.
TEST(DividedPrecision, ACancellationStopsEveryShardAtTheSameBoundary) {
  Scenario sc = precision_scenario(true, false);
  sc.settings.precision->max_batches = 1000;
  std::atomic<bool> cancel{false};
  const Divided d = divided(sc, 3, &cancel, [&](const Progress& pr) {
    if (pr.precision && pr.precision->batches >= 3) cancel.store(true);
  });
  EXPECT_TRUE(d.result.cancelled);
  EXPECT_EQ(d.result.stop_reason, StopReason::kCancelled);
  const std::int64_t batches = d.parts[0].batches;
  EXPECT_GE(batches, 3);
  EXPECT_LT(batches, 1000);
  for (const PartialRun& part : d.parts) {
    EXPECT_TRUE(part.cancelled);
    EXPECT_EQ(part.batches, batches);
  }
}

// Without settings.precision a synchronizer changes nothing: one batch, no exchange.
TEST(DividedPrecision, ARunWithoutPrecisionIgnoresTheSynchronizer) {
  Scenario sc = testing::mixed_scenario(301, 117);
  const auto site = scene::Site::build(sc.site);
  ThreadSynchronizer sync(2, nullptr);
  RunControl control;
  control.synchronizer = &sync;
  PartialRun a = run_partial(sc, site, Shard{0, 2}, control);
  PartialRun b = run_partial(sc, site, Shard{1, 2}, control);
  EXPECT_EQ(sync.exchanges(), 0);
  merge(a, std::move(b));
  const RunResult whole = run(sc);
  const RunResult r = finish(sc, *site, std::move(a));
  EXPECT_TRUE(same_bits(r.ptn_density_per_m2, whole.ptn_density_per_m2));
  EXPECT_TRUE(same_bits(r.ptn_std_error_per_m2, whole.ptn_std_error_per_m2));
}

TEST(DividedPrecision, BatchStatesOfDifferentBatchesDoNotMerge) {
  BatchState a, b;
  a.batch = 1;
  b.batch = 2;
  EXPECT_THROW(merge(a, std::move(b)), InputError);
}

}  // namespace
}  // namespace fragsim::run
