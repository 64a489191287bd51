#include "core/run/batch_plan.h"

#include <algorithm>
#include <thread>

#include "core/run/launch_strata.h"

namespace fragsim::run {

BatchPlan plan_batches(const Scenario& sc, const Shard& shard) {
  BatchPlan plan;
  const std::int64_t chunk = std::max<std::int64_t>(1, sc.settings.chunk_histories);
  const LaunchStrata strata(sc);
  for (std::uint32_t g = 0; g < sc.groups.size(); ++g) {
    const std::int64_t n = sc.groups[g].samples;
    if (strata.sobol()) {
      const std::int64_t r0 = shard_begin(strata.replicates(), shard),
                         r1 = shard_begin(strata.replicates(), {shard.index + 1, shard.count});
      for (std::int64_t r = r0; r < r1; ++r) {
        const std::int64_t first = strata.block_first(g, r);
        plan.chunks.push_back({g, first, strata.block_first(g, r + 1) - first, false});
        plan.histories += plan.chunks.back().count;
      }
      continue;
    }
    const std::int64_t begin = shard_begin(n, shard),
                       end = shard_begin(n, {shard.index + 1, shard.count});
    plan.histories += end - begin;
    for (std::int64_t first = begin; first < end; first += chunk)
      plan.chunks.push_back({g, first, std::min(chunk, end - first), false});
  }
  if (!plan.chunks.empty()) plan.chunks.back().last_of_batch = true;
  if (sc.settings.precision)
    plan.max_batches = std::max<std::int64_t>(1, sc.settings.precision->max_batches);
  return plan;
}

int thread_count(const Settings& st, std::int64_t chunks) {
  int threads = st.threads > 0 ? st.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, 1024);
  threads = static_cast<int>(std::min<std::int64_t>(threads, chunks));
  return std::max(threads, 1);
}

ChunkOutput chunk_output(const ChunkSpec& cs, std::int64_t first,
                         const fragments::FragmentGroupSpec& group) {
  ChunkOutput out;
  out.group = cs.group;
  out.first_history = first;
  out.count = cs.count;
  out.last_of_batch = cs.last_of_batch;
  out.weight = group.count / static_cast<double>(group.samples);
  const auto n = static_cast<std::size_t>(cs.count);
  out.ptn_end.reserve(n);
  out.outcomes.reserve(n);
  out.exit_sector.reserve(n);
  out.building_index.reserve(n);
  out.weights.reserve(n);
  out.cells.reserve(n);
  return out;
}

}  // namespace fragsim::run
