#pragma once
// What sets the HFD (docs/precision.md, "What sets the HFD"). Every PTN contribution carries the
// mechanism that made it (history_impl.h: direct flight, flight after a ricochet, the ground
// phase); the run's tally keeps, beside the whole density field, the field of each mechanism and
// of each fragment group (TallyBins in core/run/partial.h), summed as exactly as the whole field,
// so the split is as independent of threads, chunks, shards and ranks as the field itself.
// From them: the HFD figures of each mechanism's and each group's field alone (HfdGeometry, the
// same machinery as the HFD's), and the shares of the density at the triangles that set the HFD
// and each sector's HFD.
#include <cstddef>
#include <string>
#include <vector>

#include "core/run/hfd.h"
#include "core/run/partial.h"
#include "core/run/result.h"
#include "core/tally/stratified_tally.h"

namespace fragsim::run {

// Per-group fields cost groups x triangles tally bins, each 16 bytes of dense tally index (28
// with stratified launch sampling) before any is touched. They are kept for 2 to
// kMaxAttributedGroups groups holding at most kMaxGroupFieldBins bins together (64 MiB of
// index); one group's field is the whole field. Beyond either limit the per-group figures are
// omitted, and the result says why (HfdAttribution::by_group_omitted_reason).
inline constexpr std::size_t kMaxAttributedGroups = 64;
inline constexpr std::size_t kMaxGroupFieldBins = std::size_t{1} << 22;

struct GroupFieldsPlan {
  std::size_t fields = 0;      // per-group fields in the tally
  std::string omitted_reason;  // "" unless the per-group figures are omitted
};
GroupFieldsPlan plan_group_fields(std::size_t groups, std::size_t triangles);

// The attribution of a folded tally (means times `scale`, 1 / batches, as the whole field),
// whose whole field `density` has the HFD figures `whole` on `geometry`.
HfdAttribution attribute_hfd(const HfdGeometry& geometry, const tally::StratifiedTally& tally,
                             const TallyBins& bins, std::size_t groups, double scale,
                             double threshold, const std::vector<double>& density,
                             const HfdFigures& whole);

// The shares of the density at `triangle` (-1: none, all shares 0) from each mechanism's field
// and each group's (when kept): field / whole field, from the exact sums.
DensityShares density_shares(const tally::StratifiedTally& tally, const TallyBins& bins,
                             std::size_t groups, std::int64_t triangle);

}  // namespace fragsim::run
