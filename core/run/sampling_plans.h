#pragma once
// The launch-direction cells of each batch under importance sampling (docs/precision.md,
// "Direction importance"): the learner's plan for a batch is published at the boundary before
// it; a worker holding a chunk of a batch whose cells are not known yet waits for them.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "core/fragments/direction_cells.h"
#include "core/run/history.h"
#include "core/run/importance.h"
#include "core/run/launch_strata.h"

namespace fragsim::run {

class SamplingPlans {
 public:
  using Cells = std::vector<fragments::DirectionCells>;  // per group

  void publish(std::int64_t batch, Cells cells) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      plans_.emplace(batch, std::make_unique<Cells>(std::move(cells)));
    }
    cv_.notify_all();
  }
  void abort() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      aborted_ = true;
    }
    cv_.notify_all();
  }
  // The batch's cells; null when the run ended (abort) or `stop()` says so while waiting.
  template <class Stop>
  const Cells* get(std::int64_t batch, Stop stop) {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      if (const auto it = plans_.find(batch); it != plans_.end()) return it->second.get();
      if (aborted_ || stop()) return nullptr;
      cv_.wait_for(lock, std::chrono::milliseconds(20));  // also polls stop()
    }
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::map<std::int64_t, std::unique_ptr<Cells>> plans_;
  bool aborted_ = false;
};

// Cells a stratified draw can use: uniform ones (the importance-sampling pilot, groups with
// nothing learnt) become equal cells of the same grid, drawn through their cumulative q.
SamplingPlans::Cells drawable(SamplingPlans::Cells cells, const LaunchStrata& strata);

// Feeds a folded chunk's histories to the importance learner, or with `out` (a shard of a
// divided run) keeps them for the batch boundary's exchange.
void learn(DirectionLearner& learner, const ChunkOutput& c, LearnerInput* out);

}  // namespace fragsim::run
