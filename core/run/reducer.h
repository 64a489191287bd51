#pragma once
// The domain fold of a run's chunks into its exact tally (tally/stratified_tally.h), and the
// layout of the tally's bins (tally_bins(), core/run/partial.h). The sums are exact, so the order
// of chunks, threads and shards cannot change a bit of the result.
#include <cstdint>
#include <vector>

#include "core/run/history.h"
#include "core/run/launch_strata.h"
#include "core/run/partial.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"
#include "core/tally/stratified_tally.h"

namespace fragsim::run {

class Reducer {
 public:
  // Sizes `out.tally` for the scenario's bins and folds into `out`.
  Reducer(const Scenario& sc, const scene::Site& site, const LaunchStrata& strata, PartialRun& out);

  // Tallies a chunk's histories (their PTN contributions, building hits, outcomes, exits) and
  // appends its records, trajectories, statistics and timings.
  void fold(ChunkOutput& c);
  // A pilot's chunk under direction importance sampling: its terrain PTN density alone, for the
  // pilot's HFD (PrecisionControl::batch_done at the pilot's boundary); the caller clears it.
  void fold_pilot(const ChunkOutput& c);

 private:
  void fold_histories(const ChunkOutput& c, bool density_only);
  void add_outcomes(const ChunkOutput& c, std::size_t h);
  void start_strata(std::uint32_t g, std::int64_t batch, std::int64_t i, bool chunk_start);
  void add(std::size_t bin, double x);
  void unit_done();
  void add_ptn(const PtnContribution& c, std::uint32_t group);
  void add_building(const BuildingContribution& b, double w);
  void add_left_hazardous(std::int8_t sector, double w);
  void add_records_and_stats(ChunkOutput& c);

  PartialRun& out_;
  const TallyBins bins_;
  const LaunchStrata& strata_;
  std::vector<std::int64_t> samples_;
  tally::ExactBins unit_;         // Sobol launch: the current block's sums
  std::vector<double> unit_max_;  // and per bin its largest single contribution
};

}  // namespace fragsim::run
