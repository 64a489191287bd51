#include "core/run/reducer.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/run/attribution.h"

namespace fragsim::run {

TallyBins tally_bins(const Scenario& sc, const scene::Site& site) {
  TallyBins b;
  b.terrain = 0;
  b.triangles = site.terrain_triangle_count();
  b.buildings = b.triangles;
  b.outcomes = b.buildings + site.buildings().size() * kBuildingFigures;
  b.left_site = b.outcomes + kOutcomeCount;
  b.mechanisms = b.left_site + kLeftSiteBins;
  b.groups = b.mechanisms + kPtnMechanismCount * b.triangles;
  b.group_fields = plan_group_fields(sc.groups.size(), b.triangles).fields;
  b.total = b.groups + b.group_fields * b.triangles;
  return b;
}

Reducer::Reducer(const Scenario& sc, const scene::Site& site, const LaunchStrata& strata,
                 PartialRun& out)
    : out_(out), bins_(tally_bins(sc, site)), strata_(strata) {
  out_.tally = tally::StratifiedTally(bins_.total, strata.partitions());
  if (strata.sobol()) {
    unit_ = tally::ExactBins(bins_.total);
    unit_max_.assign(bins_.total, 0.0);
  }
  for (const auto& g : sc.groups) samples_.push_back(g.samples);
}

void Reducer::fold(ChunkOutput& c) {
  fold_histories(c, false);
  out_.histories_done += c.count;
  add_records_and_stats(c);
}

void Reducer::fold_pilot(const ChunkOutput& c) {
  fold_histories(c, true);
}

// The chunk's histories into the tally; `density_only`: the terrain's PTN density alone (the
// pilot's, fold_pilot()).
void Reducer::fold_histories(const ChunkOutput& c, bool density_only) {
  tally::StratifiedTally& t = out_.tally;
  const std::int64_t samples = samples_[c.group];
  const std::int64_t batch = c.first_history / samples;
  const std::int64_t first = c.first_history - batch * samples;  // within the batch
  std::uint32_t begin = 0;
  for (std::int64_t i = 0; i < c.count; ++i) {
    start_strata(c.group, batch, first + i, i == 0);
    const std::uint32_t end = c.ptn_end[static_cast<std::size_t>(i)];
    for (std::uint32_t k = begin; k < end; ++k) {
      if (density_only)
        add(bins_.terrain + c.ptn[k].triangle, c.ptn[k].value);
      else
        add_ptn(c.ptn[k], c.group);
    }
    begin = end;
    if (!density_only) add_outcomes(c, static_cast<std::size_t>(i));
    if (strata_.unit_ends(c.group, first + i)) unit_done();
  }
  if (!unit_.bins().empty()) throw std::logic_error("Reducer: a chunk ends inside a Sobol block");
  for (std::size_t k = 0; k < t.partitions(); ++k) t.flush(k);
}

// History h's building hit, outcome and exit from the site.
void Reducer::add_outcomes(const ChunkOutput& c, std::size_t h) {
  const double w = c.weights[h];  // with the likelihood ratio
  if (c.building_index[h] >= 0)
    add_building(c.buildings[static_cast<std::size_t>(c.building_index[h])], w);
  const auto o = static_cast<std::size_t>(c.outcomes[h]);
  add(bins_.outcomes + o, w);
  ++out_.outcome_histories[o];
  if (c.exit_sector[h] >= 0) add_left_hazardous(c.exit_sector[h], w);
}

// Names each partition's stratum at history i (within its batch) when one starts there (or
// at a chunk's first history), ending the piece of the previous one.
void Reducer::start_strata(std::uint32_t g, std::int64_t batch, std::int64_t i, bool chunk_start) {
  tally::StratifiedTally& t = out_.tally;
  for (std::size_t k = 0; k < t.partitions(); ++k) {
    const LaunchStrata::VarianceStratum v = strata_.variance_stratum(g, i, k);
    if (!chunk_start && v.first != i) continue;
    t.flush(k);
    t.start(k, tally::StratumKey{static_cast<std::uint32_t>(k), g, batch, v.index}, v.size);
  }
}

// A contribution of the current unit of the variance estimate: the history, or with Sobol
// launch the block, whose exact sum per bin enters the tally as one value at its end.
void Reducer::add(std::size_t bin, double x) {
  if (!strata_.sobol()) {
    out_.tally.add(bin, x);
    return;
  }
  unit_.add(bin, x);
  unit_max_[bin] = std::max(unit_max_[bin], std::abs(x));
}

// A block's sums, and its discreteness floor: where a net puts nearly its exact share of
// points in a region, its count still moves by one history, and 16 nets can by chance all
// agree (docs/precision.md, "Scrambled Sobol launch"); a two-point spread of one history's
// largest contribution m has variance at most m^2/4, added to the block's square.
void Reducer::unit_done() {
  for (std::size_t k = 0; k < unit_.bins().size(); ++k) {
    const std::size_t bin = unit_.bins()[k];
    const double sum = unit_.sums()[k].value();
    out_.tally.add(bin, sum);
    if (sum != 0.0) out_.tally.add_square(bin, 0.25 * unit_max_[bin] * unit_max_[bin]);
    unit_max_[bin] = 0.0;
  }
  unit_.clear();
  out_.tally.history_done();
}

// A contribution to the whole field, to its mechanism's and to its group's (when kept).
void Reducer::add_ptn(const PtnContribution& c, std::uint32_t group) {
  add(bins_.terrain + c.triangle, c.value);
  add(bins_.mechanism(c.mechanism) + c.triangle, c.value);
  if (bins_.group_fields > 0) add(bins_.group(group) + c.triangle, c.value);
}

void Reducer::add_building(const BuildingContribution& b, double w) {
  const std::size_t base =
      bins_.buildings + static_cast<std::size_t>(b.building) * kBuildingFigures;
  add(base + kImpacts, w);
  add(base + kImpactsBySurface + b.surface, w);
  if (!b.penetrated) return;
  add(base + kPenetrations, w);
  add(base + kPenetrationsBySurface + b.surface, w);
  add(base + kResidualKe, w * b.residual_ke_j);
}

void Reducer::add_left_hazardous(std::int8_t sector, double w) {
  add(bins_.left_site, w);
  add(bins_.left_site + 1 + static_cast<std::size_t>(sector), w);
  ++out_.left_hazardous_histories;
}

void Reducer::add_records_and_stats(ChunkOutput& c) {
  for (auto& r : c.records) out_.records.push_back(r);
  for (auto& tr : c.trajectories) out_.trajectories.push_back(std::move(tr));
  out_.stats += c.stats;
  out_.integration_s += c.integration_s;
  out_.geometry_s += c.geometry_s;
  out_.tally_s += c.tally_s;
}

}  // namespace fragsim::run
