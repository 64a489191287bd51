#pragma once
// A run split into shards, and the exact merge of their results (docs/cluster.md).
//
// Shard i of N runs, of every fragment group g, the histories [floor(i n_g / N),
// floor((i + 1) n_g / N)) of its n_g samples. Its tallies are kept exactly (tally/exact_sum.h),
// with the strata it cuts left open, so that merging the partials of all N shards, in any order,
// and finishing gives the same bits as the whole run in one process, whatever the thread counts,
// chunk sizes and N.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "core/run/control.h"
#include "core/run/importance.h"
#include "core/run/result.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"
#include "core/tally/stratified_tally.h"

namespace fragsim::run {

struct Shard {
  std::int64_t index = 0;
  std::int64_t count = 1;
};

// The histories [first, end) of a group of `samples` histories that shard `s` runs.
// (Written so that no product overflows for count <= kMaxShards.)
inline constexpr std::int64_t kMaxShards = 1'000'000;
inline std::int64_t shard_begin(std::int64_t samples, const Shard& s) {
  return samples / s.count * s.index + samples % s.count * s.index / s.count;
}

// The exact, mergeable state of a run or of some of its shards.
struct PartialRun {
  std::int64_t shard_count = 1;
  std::vector<std::int64_t> shards;  // the shards merged in, ascending
  // Bins: terrain triangles, then building figures (kBuildingFigures per building), then
  // outcomes, then the hazardous fragments that left the site, then the terrain triangles per
  // mechanism and per group (see tally_bins()).
  tally::StratifiedTally tally;
  std::array<std::int64_t, kOutcomeCount> outcome_histories{};
  std::int64_t left_hazardous_histories = 0;  // left the site while hazardous (SiteBoundary)
  std::int64_t histories_done = 0;            // tallied histories (not the pilot's)
  std::int64_t pilot_histories = 0;
  std::int64_t batches = 0;          // batches completed, the pilot's included
  std::int64_t tallied_batches = 0;  // of them, tallied
  bool cancelled = false;
  StopReason stop_reason = StopReason::kSamples;
  std::shared_ptr<const PrecisionReport> precision;
  std::vector<FragmentRecord> records;         // any order until finish()
  std::vector<TrajectoryRecord> trajectories;  // any order until finish()
  RunStats stats;
  double integration_s = 0.0, geometry_s = 0.0, tally_s = 0.0;  // summed over threads
  double wall_s = 0.0;                                          // the longest shard's
  int threads = 1;                                              // summed over shards
};

// Building figures per building, each a bin of the tally.
enum BuildingFigure : int {
  kImpacts = 0,
  kPenetrations = 1,
  kImpactsBySurface = 2,                                                  // + surface type
  kPenetrationsBySurface = kImpactsBySurface + scene::kSurfaceTypeCount,  // + surface type
  kResidualKe = kPenetrationsBySurface + scene::kSurfaceTypeCount,
  kBuildingFigures = kResidualKe + 1,
};
// Real fragments that left the site while hazardous: in all, then per HFD sector.
inline constexpr std::size_t kLeftSiteBins = 1 + 36;
struct TallyBins {
  std::size_t terrain = 0;       // first bin of the terrain triangles
  std::size_t buildings = 0;     // first bin of the building figures
  std::size_t outcomes = 0;      // first bin of the outcomes
  std::size_t left_site = 0;     // first of the kLeftSiteBins bins
  std::size_t triangles = 0;     // terrain triangles (the length of one density field)
  std::size_t mechanisms = 0;    // first bin of the fields per mechanism (kPtnMechanismCount)
  std::size_t groups = 0;        // first bin of the fields per group
  std::size_t group_fields = 0;  // of them (core/run/attribution.h: 0 when not kept)
  std::size_t total = 0;
  // The first bin of mechanism m's field and of group g's.
  std::size_t mechanism(PtnMechanism m) const {
    return mechanisms + static_cast<std::size_t>(m) * triangles;
  }
  std::size_t group(std::uint32_t g) const { return groups + g * triangles; }
};
TallyBins tally_bins(const Scenario& scenario, const scene::Site& site);

// A settings.precision run divided into shards (docs/precision.md, "Divided runs"): the shards
// run each batch together. At every batch boundary each hands the synchronizer its batch's exact
// state and gets back every shard's merged; from that, the same bits on every shard, it decides
// whether to stop and learns the next batch's launch densities. So a run divided in any way
// stops at the batch, and gives the bits, of the run in one process.
//
// The partial of a synchronized shard: shard 0's carries the tallies and counts of every batch
// (all shards'), each shard's its own records, trajectories, statistics and timings (and the
// histories of a batch a cancellation cut short); merged, they are the whole run's.
struct BatchState {
  std::int64_t batch = 0;  // 0-based (batch 0 is the importance-sampling pilot, when there is one)
  double elapsed_s = 0.0;  // since the run's start at the boundary: the longest of the shards'
  PartialRun part;         // the batch's tally and counts (no records, trajectories or stats)
  struct Learnt {
    std::int64_t shard = 0;
    LearnerInput input;  // what the importance learner takes from the shard's batch
  };
  std::vector<Learnt> learnt;  // ascending shard
};

// Adds `other` into `into`: exact, any order gives the same bits. Throws InputError when they
// are of different batches or splits, or share a shard.
void merge(BatchState& into, BatchState&& other);

class BatchSynchronizer {
 public:
  virtual ~BatchSynchronizer() = default;
  // Called by every shard once per batch boundary (from one of its threads, under its fold's
  // lock: the shard's other threads wait): returns every shard's state of the batch merged, or
  // nullopt when the run stops without it (cancelled, or another shard failed): the shard ends
  // cancelled.
  virtual std::optional<BatchState> exchange(const BatchState& mine) = 0;
};

// Runs shard `shard` of the scenario on a built site. Throws InputError for a shard that is not
// one of 0..count-1, or a split scenario with settings.precision without
// control.synchronizer (its batch-boundary checks need every history of a batch).
PartialRun run_partial(const Scenario& scenario, std::shared_ptr<const scene::Site> site,
                       const Shard& shard, const RunControl& control = {});

// Adds `other` into `into`: exact, so any order of merging gives the same bits. Throws
// InputError when they are shards of different splits or share a shard.
void merge(PartialRun& into, PartialRun&& other);

// The result of the merged shards (taken by value: their memory is freed on return). Throws
// InputError when a shard is missing (unless cancelled). A cancelled partial gives the counts,
// stop reason and timing only: no figures (its callers write nothing).
// With settings.ground_bracket it then runs the bracket (core/run/bracket.h; `control.cancel`
// stops it).
RunResult finish(const Scenario& scenario, const scene::Site& site, PartialRun partial,
                 const RunControl& control = {});
// The figures of the partial alone (no bracket runs).
RunResult finish_tally(const Scenario& scenario, const scene::Site& site, PartialRun partial);

}  // namespace fragsim::run
