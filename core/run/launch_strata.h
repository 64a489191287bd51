#pragma once
// settings.stratified_launch: which launch stratum a history draws from, and the strata its
// variance is estimated on (docs/precision.md). Shared by the run's fold (run.cpp) and the
// paired fold of a comparison (paired.cpp), which must cut the histories the same way.
#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/fragments/sampling.h"
#include "core/run/scenario.h"

namespace fragsim::run {

// settings.stratified_launch: group g's histories of a batch, i = 0 ... samples_g - 1, fall in
// J_g = max(1, samples_g / m) strata of m consecutive histories, the last taking the remainder.
// A stratum has probability 1/J_g and n_j histories, so a history's weight is count_g / (J_g n_j),
// i.e. count_g / samples_g times samples_g / (J_g n_j) (exactly 1 but in a remainder stratum).
class LaunchStrata {
 public:
  explicit LaunchStrata(const Scenario& sc) {
    for (const auto& g : sc.groups) group_samples_.push_back(g.samples);
    if (!sc.settings.stratified_launch) return;
    if (sc.settings.stratified_launch->method == LaunchStratification::kSobol) {
      replicates_ = std::max<std::int64_t>(2, sc.settings.stratified_launch->replicates);
      return;
    }
    m_ = std::max<std::int64_t>(2, sc.settings.stratified_launch->histories_per_stratum);
    for (const auto& g : sc.groups) {
      samples_.push_back(g.samples);
      count_.push_back(std::max<std::int64_t>(1, g.samples / m_));
    }
  }
  bool on() const { return m_ > 0 || sobol(); }
  bool sobol() const { return replicates_ > 0; }
  // Partitions of the variance strata: two offset ones for strata of u_cell, else one.
  int partitions() const { return m_ > 0 ? 2 : 1; }
  std::int64_t strata(std::uint32_t g) const { return count_[g]; }

  // Sobol: group g's batch of n histories is cut into R blocks, block r holding the histories
  // [block_first(g, r), block_first(g, r + 1)) (sizes differ by at most one), each the first
  // points of its own scrambled net. A block is one unit of the variance estimate: the run cuts
  // its chunks and shards at block boundaries (run.cpp, plan_batches).
  std::int64_t replicates() const { return replicates_; }
  std::int64_t block_first(std::uint32_t g, std::int64_t r) const {
    return r * group_samples_[g] / replicates_;
  }
  std::int64_t block_of(std::uint32_t g, std::int64_t i) const {
    std::int64_t r = std::min(replicates_ - 1, i * replicates_ / group_samples_[g]);
    while (r + 1 < replicates_ && block_first(g, r + 1) <= i) ++r;
    while (r > 0 && block_first(g, r) > i) --r;
    return r;
  }
  // History i ends a unit of the variance estimate: every history, or a Sobol block's last.
  bool unit_ends(std::uint32_t g, std::int64_t i) const {
    return !sobol() || i + 1 == block_first(g, block_of(g, i) + 1);
  }

  // History i of group g in batch `batch`.
  fragments::LaunchStratum of(std::uint32_t g, std::int64_t i, std::int64_t batch = 0) const {
    if (sobol()) return sobol_point(g, i, batch);
    const std::int64_t j_count = count_[g];
    fragments::LaunchStratum s;
    s.index = std::min(i / m_, j_count - 1);
    s.count = j_count;
    const std::int64_t n = s.index == j_count - 1 ? samples_[g] - m_ * (j_count - 1) : m_;
    s.weight_factor = static_cast<double>(samples_[g]) / static_cast<double>(j_count * n);
    return s;
  }
  // The variance is estimated on collapsed strata of kCollapsed sampling strata, in two
  // partitions offset by half of one (docs/precision.md). Without stratified sampling a group's
  // batch is one stratum. History i (within its batch) of group g lies in stratum `index` of
  // `partition`, which holds `size` histories starting at `first`.
  static constexpr std::int64_t kCollapsed = 4;
  struct VarianceStratum {
    std::int64_t index = 0, first = 0, size = 0;
  };
  // Sobol: the group's batch is one stratum of R units, the blocks.
  VarianceStratum variance_stratum(std::uint32_t g, std::int64_t i, std::size_t partition) const {
    const std::int64_t n = group_samples_[g];
    if (sobol()) return {0, 0, replicates_};
    if (!on()) return {0, 0, n};
    const std::int64_t size = m_ * kCollapsed, offset = partition == 0 ? 0 : size / 2;
    const std::int64_t j = (i + offset) / size;
    const std::int64_t lo = std::max<std::int64_t>(0, j * size - offset);
    const std::int64_t hi = std::min(n, (j + 1) * size - offset);
    return {j, lo, hi - lo};
  }

 private:
  // Each block is an unbiased estimate of 1/R of the group's total (weight factor n / (R n_r)), so
  // the R blocks are identically distributed units whatever the remainder.
  fragments::LaunchStratum sobol_point(std::uint32_t g, std::int64_t i, std::int64_t batch) const {
    const std::int64_t r = block_of(g, i), first = block_first(g, r);
    const std::int64_t n_r = block_first(g, r + 1) - first;
    fragments::LaunchStratum s;
    s.sobol_net = batch * replicates_ + r;
    s.sobol_point = static_cast<std::uint32_t>(i - first);
    s.weight_factor = static_cast<double>(group_samples_[g]) /
                      (static_cast<double>(replicates_) * static_cast<double>(n_r));
    return s;
  }

  std::int64_t m_ = 0, replicates_ = 0;
  std::vector<std::int64_t> samples_, count_;
  std::vector<std::int64_t> group_samples_;
};

}  // namespace fragsim::run
