#pragma once
// What a caller gives a run besides the scenario: progress, cancel, the chunk observer, and the
// batch synchronizer of a divided settings.precision run (core/run/run.h, core/run/partial.h).
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>

#include "core/run/result.h"

namespace fragsim::run {

struct ChunkOutput;       // core/run/history.h
class BatchSynchronizer;  // core/run/partial.h

struct Progress {
  std::int64_t histories_done = 0;
  std::int64_t histories_total = 0;
  double elapsed_s = 0.0;
  // settings.precision: the last batch boundary's check of the targets (null before the first).
  std::shared_ptr<const PrecisionReport> precision;
};

struct RunControl {
  // Called from a worker thread at most every `progress_interval_s` and at the end.
  std::function<void(const Progress&)> on_progress;
  double progress_interval_s = 0.5;
  // Set to true from any thread to stop; the result comes back with cancelled = true.
  const std::atomic<bool>* cancel = nullptr;
  // Sees every tallied chunk of histories before it is tallied: in chunk order, under the fold's
  // lock, so a slow observer slows the run (the paired fold of a comparison: core/run/paired.h).
  std::function<void(const ChunkOutput&)> on_chunk;
  // A settings.precision run divided into shards that run each batch together: at every batch
  // boundary the shard's batch is merged exactly with the other shards' here, and the stop and
  // the next batch's launch densities are decided from the merge (core/run/partial.h). Null: the
  // shard decides alone (one shard: the whole run).
  BatchSynchronizer* synchronizer = nullptr;
  // One history at a time per worker instead of flight::kLanes in lanes (core/run/lane_runner.h).
  // The results are the same bits either way; tests compare the two, benchmarks time them.
  bool serial_histories = false;
};

}  // namespace fragsim::run
