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
    : out_(out), bins_(tally_bins(sc, site)), strata_(strata), partitions_(strata.partitions()) {
  out_.tally = tally::StratifiedTally(bins_.total, partitions_);
  for (const auto& g : sc.groups) samples_.push_back(g.samples);
}

// prefold()'s steps over one chunk: its histories in order, each contribution into the current
// piece of every partition's stratum (with Sobol launch first into its block's sums).
class Reducer::Prefold {
 public:
  Prefold(const Reducer& r, ChunkOutput& c, FoldScratch& s)
      : bins_(r.bins_), strata_(r.strata_), c_(c), pieces_(s.pieces), unit_(s.unit) {}

  // The chunk's histories; `density_only`: the terrain's PTN density alone.
  void run(std::int64_t samples, bool density_only) {
    const std::int64_t batch = c_.first_history / samples;
    const std::int64_t first = c_.first_history - batch * samples;  // within the batch
    std::uint32_t begin = 0;
    for (std::int64_t i = 0; i < c_.count; ++i) {
      start_strata(batch, first + i, i == 0);
      const std::uint32_t end = c_.ptn_end[static_cast<std::size_t>(i)];
      for (std::uint32_t k = begin; k < end; ++k) {
        if (density_only)
          add(bins_.terrain + c_.ptn[k].triangle, c_.ptn[k].value);
        else
          add_ptn(c_.ptn[k]);
      }
      begin = end;
      if (!density_only) add_outcomes(static_cast<std::size_t>(i));
      if (strata_.unit_ends(c_.group, first + i)) unit_done();
    }
    if (!unit_.empty()) throw std::logic_error("Reducer: a chunk ends inside a Sobol block");
    for (std::size_t k = 0; k < pieces_.partitions(); ++k) pieces_.flush(k, c_.pieces);
  }

 private:
  // Names each partition's stratum at history i (within its batch) when one starts there (or
  // at a chunk's first history), ending the piece of the previous one.
  void start_strata(std::int64_t batch, std::int64_t i, bool chunk_start) {
    for (std::size_t k = 0; k < pieces_.partitions(); ++k) {
      const LaunchStrata::VarianceStratum v = strata_.variance_stratum(c_.group, i, k);
      if (!chunk_start && v.first != i) continue;
      pieces_.flush(k, c_.pieces);
      pieces_.start(k, tally::StratumKey{static_cast<std::uint32_t>(k), c_.group, batch, v.index},
                    v.size);
    }
  }

  // A contribution of the current unit of the variance estimate: the history, or with Sobol
  // launch the block, whose exact sum per bin enters the tally as one value at its end.
  void add(std::size_t bin, double x) {
    if (!strata_.sobol()) {
      pieces_.add(bin, x);
      return;
    }
    unit_.add(static_cast<std::uint32_t>(bin), x);
  }

  // A block's sums, and its discreteness floor: where a net puts nearly its exact share of
  // points in a region, its count still moves by one history, and 16 nets can by chance all
  // agree (docs/precision.md, "Scrambled Sobol launch"); a two-point spread of one history's
  // largest contribution m has variance at most m^2/4, added to the block's square.
  void unit_done() {
    for (std::size_t k = 0; k < unit_.size(); ++k) {
      const double sum = unit_.sum(k), m = unit_.max(k);
      pieces_.add(unit_.bin(k), sum);
      if (sum != 0.0) pieces_.add_square(unit_.bin(k), 0.25 * m * m);
    }
    unit_.clear();
    pieces_.history_done();
  }

  // History h's building hit, outcome and exit from the site.
  void add_outcomes(std::size_t h) {
    const double w = c_.weights[h];  // with the likelihood ratio
    if (c_.building_index[h] >= 0)
      add_building(c_.buildings[static_cast<std::size_t>(c_.building_index[h])], w);
    add(bins_.outcomes + static_cast<std::size_t>(c_.outcomes[h]), w);
    if (c_.exit_sector[h] >= 0) add_left_hazardous(c_.exit_sector[h], w);
  }

  // A contribution to the whole field, to its mechanism's and to its group's (when kept).
  void add_ptn(const PtnContribution& p) {
    add(bins_.terrain + p.triangle, p.value);
    add(bins_.mechanism(p.mechanism) + p.triangle, p.value);
    if (bins_.group_fields > 0) add(bins_.group(c_.group) + p.triangle, p.value);
  }

  void add_building(const BuildingContribution& b, double w) {
    const std::size_t base =
        bins_.buildings + static_cast<std::size_t>(b.building) * kBuildingFigures;
    add(base + kImpacts, w);
    add(base + kImpactsBySurface + b.surface, w);
    if (!b.penetrated) return;
    add(base + kPenetrations, w);
    add(base + kPenetrationsBySurface + b.surface, w);
    add(base + kResidualKe, w * b.residual_ke_j);
  }

  void add_left_hazardous(std::int8_t sector, double w) {
    add(bins_.left_site, w);
    add(bins_.left_site + 1 + static_cast<std::size_t>(sector), w);
  }

  const TallyBins& bins_;
  const LaunchStrata& strata_;
  ChunkOutput& c_;
  tally::PieceBuilder& pieces_;
  UnitSums& unit_;
};

void Reducer::prefold(ChunkOutput& c, FoldScratch& s, bool density_only) const {
  if (s.pieces.partitions() != static_cast<std::size_t>(partitions_))
    s.pieces = tally::PieceBuilder(partitions_);
  c.pieces.clear();
  Prefold(*this, c, s).run(samples_[c.group], density_only);
}

void Reducer::fold(ChunkOutput& c) {
  add_pieces(c);
  for (std::size_t h = 0; h < c.outcomes.size(); ++h) {
    ++out_.outcome_histories[static_cast<std::size_t>(c.outcomes[h])];
    if (c.exit_sector[h] >= 0) ++out_.left_hazardous_histories;
  }
  out_.histories_done += c.count;
  add_records_and_stats(c);
}

void Reducer::fold_pilot(ChunkOutput& c) {
  add_pieces(c);
}

void Reducer::add_pieces(ChunkOutput& c) {
  for (tally::StratumPiece& p : c.pieces) out_.tally.add_piece(std::move(p));
  c.pieces.clear();
}

void Reducer::add_records_and_stats(ChunkOutput& c) {
  out_.records.insert(out_.records.end(), c.records.begin(), c.records.end());
  for (auto& tr : c.trajectories) out_.trajectories.push_back(std::move(tr));
  out_.stats += c.stats;
  out_.integration_s += c.integration_s;
  out_.geometry_s += c.geometry_s;
  out_.tally_s += c.tally_s;
}

}  // namespace fragsim::run
