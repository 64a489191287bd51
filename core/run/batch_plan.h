#pragma once
// The division of a shard's histories into batches and chunks: what each worker takes by index.
#include <cstdint>
#include <vector>

#include "core/run/history.h"
#include "core/run/partial.h"
#include "core/run/scenario.h"

namespace fragsim::run {

struct ChunkSpec {
  std::uint32_t group;
  std::int64_t first;  // within the batch
  std::int64_t count;
  bool last_of_batch;  // the plan's last chunk of a batch
};

// The work of one batch: every group's `samples` histories, in chunks that never straddle groups.
// Batch b runs histories [b * samples_g, (b + 1) * samples_g) of group g; batch 0 is the run
// without settings.precision.
struct BatchPlan {
  std::vector<ChunkSpec> chunks;
  std::int64_t histories = 0;
  std::int64_t max_batches = 1;
  std::int64_t total_chunks() const {
    return static_cast<std::int64_t>(chunks.size()) * max_batches;
  }
};

// With Sobol launch a chunk is one block and a shard takes whole blocks (a block is one unit of
// the variance estimate: its sums must be complete before they are squared).
BatchPlan plan_batches(const Scenario& sc, const Shard& shard);

// settings.threads (0: the hardware's), at most one per chunk.
int thread_count(const Settings& st, std::int64_t chunks);

// A chunk's output, its fields set and its per-history arrays reserved.
ChunkOutput chunk_output(const ChunkSpec& cs, std::int64_t first,
                         const fragments::FragmentGroupSpec& group);

}  // namespace fragsim::run
