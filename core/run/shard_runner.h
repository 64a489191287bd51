#pragma once
// One shard's run: the domain fold of the run's ordered pipeline (core/run/pipeline.h).
// run_partial() (core/run/partial.h) is its entry point; nothing else uses this header.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "core/run/batch_plan.h"
#include "core/run/control.h"
#include "core/run/history.h"
#include "core/run/importance.h"
#include "core/run/launch_strata.h"
#include "core/run/partial.h"
#include "core/run/pipeline.h"
#include "core/run/precision_control.h"
#include "core/run/reducer.h"
#include "core/run/sampling_plans.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::run {

// Worker threads take the chunks of histories by index, batch after batch, simulate them and
// hand them to the pipeline, which folds them in chunk order. The batch loop, step by step
// (as OpenMC's initialize_batch -> transport -> finalize_batch):
//
//   batch_cells(b)      the batch's launch cells: fixed, or the importance plan published at
//                       the boundary before it (a worker waits for it)
//   simulate_chunk(k)   transport: the chunk's histories, on any worker, in any order
//   fold(chunk)         in chunk order: the pilot batch is only learnt from; the others are
//                       learnt from and tallied (Reducer)
//   end_batch()         after the batch's last chunk: exchange it with the other shards
//                       (a divided run), check the precision targets (PrecisionControl), then
//                       stop there or publish the next batch's plan
//
// With a synchronizer (a divided settings.precision run) part_ holds the current batch's tally
// and counts, exchanged at its boundary; the decisions read global_, every shard's batches.
class ShardRunner {
 public:
  ShardRunner(const Scenario& sc, std::shared_ptr<const scene::Site> site, const Shard& shard,
              const RunControl& control);
  PartialRun run();

 private:
  using Clock = std::chrono::steady_clock;
  struct WorkerScratch {
    HistoryScratch history;
    FoldScratch fold;
  };
  using Pipeline = OrderedPipeline<ChunkOutput, WorkerScratch>;

  Pipeline::Stages stages();
  bool batch_cells(std::int64_t batch, const SamplingPlans::Cells*& cells);
  bool simulate_chunk(std::int64_t k, const SamplingPlans::Cells* cells, HistoryScratch& scratch,
                      ChunkOutput& out);
  bool simulate_in_lanes(
      std::int64_t first, std::int64_t count,
      const std::function<bool(std::int64_t, HistoryScratch&, ChunkOutput&)>& history,
      ChunkOutput& out);
  void prefold(std::int64_t k, ChunkOutput& c, FoldScratch& s) const;
  void fold(ChunkOutput& c);
  void end_batch(bool pilot);
  bool exchange_batch(double& elapsed);
  void absorb(const BatchState& all);
  void idle_batches();
  void count_done(std::int64_t histories);
  bool cancelled() const {
    return control_.cancel != nullptr && control_.cancel->load(std::memory_order_relaxed);
  }
  void progress(std::int64_t done, double elapsed_s) const;
  PartialRun finish();

  const Scenario& sc_;
  const std::shared_ptr<const scene::Site> site_;
  const RunControl& control_;
  const Shard shard_;
  BatchSynchronizer* const sync_;  // null unless a divided settings.precision run
  const Clock::time_point t_start_ = Clock::now();
  const RunContext ctx_;
  const BatchPlan plan_;
  const std::int64_t per_batch_;            // chunks
  const std::int64_t total_;                // histories, all batches
  std::vector<std::int64_t> group_offset_;  // histories of the groups before, in global order
  const LaunchStrata strata_;
  PartialRun part_;
  PartialRun global_;    // with sync_: every shard's completed batches (tally and counts)
  LearnerInput learnt_;  // with sync_ and a learner: the current batch's input
  Reducer reducer_;
  PrecisionControl precision_;
  std::unique_ptr<DirectionLearner> learner_;
  SamplingPlans plans_;
  SamplingPlans::Cells strata_cells_;  // stratified without importance sampling: fixed cells
  const std::int64_t report_every_ns_;
  // Finished: the last batch is folded, later chunks are not needed. Stopped: cancelled, or a
  // worker failed.
  Pipeline pipeline_;

  // Under the fold's lock: batches folded; of them, the importance-sampling pilot (batch 0,
  // learnt from, not tallied: docs/precision.md); histories folded (the pilot's included).
  std::int64_t batches_ = 0, pilot_batches_ = 0, folded_ = 0;
  std::atomic<std::int64_t> histories_done_{0};
  std::atomic<std::int64_t> last_report_ns_{0};
};

}  // namespace fragsim::run
