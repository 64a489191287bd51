#pragma once
// The domain fold of a run's chunks into its exact tally (tally/stratified_tally.h), and the
// layout of the tally's bins (tally_bins(), core/run/partial.h). The sums are exact, so the order
// of chunks, threads and shards cannot change a bit of the result.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/run/history.h"
#include "core/run/launch_strata.h"
#include "core/run/partial.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"
#include "core/tally/stratified_tally.h"
#include "core/tally/stratum_pieces.h"

namespace fragsim::run {

// The block sums of Sobol launch (settings.stratified_launch.sobol): a block of histories enters
// the tally as one unit, per bin its exact sum and its largest single contribution.
class UnitSums {
 public:
  void add(std::uint32_t bin, double x) {
    const std::uint32_t k = index_.find_or_add(bin);
    if (k == sums_.size()) {
      sums_.emplace_back();
      max_.push_back(0.0);
    }
    sums_[k].add(x);
    max_[k] = std::max(max_[k], std::abs(x));
  }
  bool empty() const { return index_.size() == 0; }
  std::size_t size() const { return index_.size(); }
  std::uint32_t bin(std::size_t k) const { return index_.bins()[k]; }
  double sum(std::size_t k) const { return sums_[k].value(); }
  double max(std::size_t k) const { return max_[k]; }
  void clear() {
    index_.clear();
    sums_.clear();
    max_.clear();
  }

 private:
  tally::BinIndex index_;  // bins in the order first touched
  std::vector<tally::ExactSum> sums_;
  std::vector<double> max_;
};

// A worker's scratch for Reducer::prefold, reused between chunks.
struct FoldScratch {
  tally::PieceBuilder pieces;
  UnitSums unit;  // Sobol launch: the current block's
};

// The fold in two stages. prefold(), on the worker that computed a chunk, in parallel with the
// other chunks: its histories' contributions into exact stratum pieces (ChunkOutput::pieces).
// fold(), under the run's fold lock in chunk order: the pieces into the tally, one merge per
// touched bin. The sums are exact, so which thread built a piece cannot change a bit.
class Reducer {
 public:
  // Sizes `out.tally` for the scenario's bins and folds into `out`.
  Reducer(const Scenario& sc, const scene::Site& site, const LaunchStrata& strata, PartialRun& out);

  // The chunk's PTN contributions, building hits, outcomes and exits into c.pieces;
  // `density_only`: the terrain's PTN density alone (a pilot's chunk, fold_pilot()).
  void prefold(ChunkOutput& c, FoldScratch& s, bool density_only) const;
  // c's pieces into the tally (prefold()'s, density_only false), its outcome counts, records,
  // statistics and timings.
  void fold(ChunkOutput& c);
  // A pilot's chunk under direction importance sampling: its pieces (prefold()'s, density_only
  // true), the terrain PTN density for the pilot's HFD (PrecisionControl::batch_done at the
  // pilot's boundary); the caller clears it.
  void fold_pilot(ChunkOutput& c);

 private:
  class Prefold;  // prefold()'s steps over one chunk
  void add_pieces(ChunkOutput& c);
  void add_records_and_stats(ChunkOutput& c);

  PartialRun& out_;
  const TallyBins bins_;
  const LaunchStrata& strata_;
  const int partitions_;  // the tally's (read by prefold(), off the fold's lock)
  std::vector<std::int64_t> samples_;
};

}  // namespace fragsim::run
