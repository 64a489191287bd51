#include "core/run/run.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>

#include "core/common/error.h"
#include "core/run/attribution.h"
#include "core/run/bracket.h"
#include "core/run/hfd.h"
#include "core/run/history.h"
#include "core/run/importance.h"
#include "core/run/launch_strata.h"
#include "core/run/ordered_sequencer.h"
#include "core/run/partial.h"
#include "core/run/precision.h"
#include "core/tally/stratified_tally.h"

namespace fragsim::run {

const char* outcome_name(Outcome o) {
  switch (o) {
    case Outcome::kGround: return "ground";
    case Outcome::kBuilding: return "building";
    case Outcome::kMaxFlightTime: return "max_flight_time";
    case Outcome::kLeftSite: return "left_site";
    case Outcome::kStartedInside: return "started_inside";
    case Outcome::kHarmless: return "harmless";
    case Outcome::kIntegrationFailed: return "integration_failed";
    case Outcome::kEmbedded: return "embedded";
    case Outcome::kWorkLimit: return "work_limit";
    case Outcome::kGroundStepCap: return "ground_step_cap";
  }
  return "unknown";
}

const char* trajectory_event_name(TrajectoryEvent e) {
  switch (e) {
    case TrajectoryEvent::kLaunch: return "launch";
    case TrajectoryEvent::kFlight: return "flight";
    case TrajectoryEvent::kTerrainImpact: return "terrain_impact";
    case TrajectoryEvent::kTakeOff: return "take_off";
    case TrajectoryEvent::kGround: return "ground";
    case TrajectoryEvent::kBuildingHit: return "building_hit";
    case TrajectoryEvent::kEnd: return "end";
  }
  return "unknown";
}

namespace {

using Clock = std::chrono::steady_clock;

struct ChunkSpec {
  std::uint32_t group;
  std::int64_t first;  // within the batch
  std::int64_t count;
  bool last_of_batch;  // the plan's last chunk of a batch
};

// The fold of chunks into the run's exact tally (tally/stratified_tally.h). The sums are exact,
// so the order of chunks, threads and shards cannot change a bit of the result.
class Reducer {
 public:
  Reducer(const Scenario& sc, const scene::Site& site, const LaunchStrata& strata, PartialRun& out)
      : out_(out), bins_(tally_bins(sc, site)), strata_(strata) {
    out_.tally = tally::StratifiedTally(bins_.total, strata.partitions());
    if (strata.sobol()) {
      unit_ = tally::ExactBins(bins_.total);
      unit_max_.assign(bins_.total, 0.0);
    }
    for (const auto& g : sc.groups) samples_.push_back(g.samples);
  }

  void fold(ChunkOutput& c) {
    tally::StratifiedTally& t = out_.tally;
    const std::int64_t samples = samples_[c.group];
    const std::int64_t batch = c.first_history / samples;
    const std::int64_t first = c.first_history - batch * samples;  // within the batch
    std::uint32_t begin = 0;
    for (std::int64_t i = 0; i < c.count; ++i) {
      start_strata(c.group, batch, first + i, i == 0);
      const std::uint32_t end = c.ptn_end[static_cast<std::size_t>(i)];
      for (std::uint32_t k = begin; k < end; ++k) add_ptn(c.ptn[k], c.group);
      begin = end;
      const auto h = static_cast<std::size_t>(i);
      const double w = c.weights[h];  // with the likelihood ratio
      if (c.building_index[h] >= 0)
        add_building(c.buildings[static_cast<std::size_t>(c.building_index[h])], w);
      const auto o = static_cast<std::size_t>(c.outcomes[h]);
      add(bins_.outcomes + o, w);
      ++out_.outcome_histories[o];
      if (c.exit_sector[h] >= 0) add_left_hazardous(c.exit_sector[h], w);
      if (strata_.unit_ends(c.group, first + i)) unit_done();
    }
    if (!unit_.bins().empty()) throw std::logic_error("Reducer: a chunk ends inside a Sobol block");
    for (std::size_t k = 0; k < t.partitions(); ++k) t.flush(k);
    out_.histories_done += c.count;
    add_records_and_stats(c);
  }

 private:
  // Names each partition's stratum at history i (within its batch) when one starts there (or
  // at a chunk's first history), ending the piece of the previous one.
  void start_strata(std::uint32_t g, std::int64_t batch, std::int64_t i, bool chunk_start) {
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
  void add(std::size_t bin, double x) {
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
  void unit_done() {
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
  void add_ptn(const PtnContribution& c, std::uint32_t group) {
    add(bins_.terrain + c.triangle, c.value);
    add(bins_.mechanism(c.mechanism) + c.triangle, c.value);
    if (bins_.group_fields > 0) add(bins_.group(group) + c.triangle, c.value);
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
    ++out_.left_hazardous_histories;
  }

  void add_records_and_stats(ChunkOutput& c) {
    for (auto& r : c.records) out_.records.push_back(r);
    for (auto& tr : c.trajectories) out_.trajectories.push_back(std::move(tr));
    out_.stats += c.stats;
    out_.integration_s += c.integration_s;
    out_.geometry_s += c.geometry_s;
    out_.tally_s += c.tally_s;
  }

  PartialRun& out_;
  const TallyBins bins_;
  const LaunchStrata& strata_;
  std::vector<std::int64_t> samples_;
  tally::ExactBins unit_;         // Sobol launch: the current block's sums
  std::vector<double> unit_max_;  // and per bin its largest single contribution
};

}  // namespace

namespace {

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

// Checks the precision targets at each batch boundary (under the sequencer's lock) and decides
// whether the run stops there.
class PrecisionControl {
 public:
  PrecisionControl(const Scenario& sc, const scene::Site& site, const PartialRun& tallies)
      : sc_(sc), site_(site), tallies_(tallies), bins_(tally_bins(sc, site)) {
    if (!sc.settings.precision) return;
    p_ = &*sc.settings.precision;
    if (p_->hfd_half_band_m || p_->hfd_half_band_rel || p_->ptn_rel_error_at_hfd ||
        p_->direction_importance)
      geometry_.emplace(site, site.to_local(hfd_origin_input(sc, site)), true);
  }

  // After batch `batches` (1-based) has been folded, `tallied` of them into the estimates (all
  // but an importance-sampling pilot): true when the run stops here.
  // `elapsed`: seconds since the run's start (of divided shards: the longest's).
  bool batch_done(std::int64_t batches, std::int64_t tallied, std::int64_t histories_run,
                  double elapsed) {
    if (p_ == nullptr) return true;  // one batch
    if (tallied == 0) return false;  // the pilot: nothing to check yet
    const std::int64_t histories = tallies_.histories_done;
    const PrecisionSnapshot snap = snapshot(tallied);
    hfd_m_ = snap.hfd_m;
    auto report = std::make_shared<PrecisionReport>(
        tracker_.update(check_targets(*p_, snap), batches, histories,
                        elapsed > 0.0 ? static_cast<double>(histories_run) / elapsed : 0.0));
    const bool settled = p_->has_targets() && tallied >= p_->min_batches;
    if (settled && report->all_met) {
      reason_ = StopReason::kTargetsMet;
    } else if (settled && report->all_met_or_unmeetable()) {
      reason_ = StopReason::kTargetsUnmeetable;
    } else if (batches >= p_->max_batches) {
      reason_ = StopReason::kMaxBatches;
    } else if (p_->max_wall_s > 0.0 && elapsed >= p_->max_wall_s) {
      reason_ = StopReason::kMaxWallTime;
    }
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      report_ = std::move(report);
    }
    return reason_ != StopReason::kSamples;
  }

  std::shared_ptr<const PrecisionReport> report() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return report_;
  }
  StopReason reason() const { return reason_; }
  double hfd_m() const { return hfd_m_; }  // at the last boundary (0 unless computed)
  const std::vector<double>& distances() const {
    static const std::vector<double> none;
    return geometry_ ? geometry_->distances() : none;
  }

 private:
  PrecisionSnapshot snapshot(std::int64_t batches) const {
    PrecisionSnapshot s;
    s.batches = batches;
    s.histories = tallies_.histories_done;
    const double scale = 1.0 / static_cast<double>(batches);
    if (geometry_) hfd_snapshot(scale, s);
    const auto& bs = site_.buildings();
    for (std::size_t b = 0; b < bs.size(); ++b) {
      const std::size_t base = bins_.buildings + b * kBuildingFigures;
      auto est = [&](std::size_t bin) {
        return Estimate{tallies_.tally.mean(bin) * scale, tallies_.tally.std_error(bin) * scale};
      };
      s.buildings.push_back({bs[b].id, est(base + kImpacts), est(base + kPenetrations)});
    }
    // Under importance sampling every cell keeps at least the defensive share of its probability
    // (q_c >= delta p_c), so n histories without a hit bound the probability per history under
    // p by 3 / (n delta) only (docs/precision.md, "Targets and the stop").
    const double share =
        p_->direction_importance ? p_->direction_importance->defensive_fraction : 1.0;
    for (const auto& g : sc_.groups)
      s.zero_count_bound +=
          3.0 * g.count / (static_cast<double>(g.samples) * static_cast<double>(batches) * share);
    return s;
  }

  // The HFD, its band and where the terrain's boundary cuts them, from the estimates of
  // `1 / scale` batches.
  void hfd_snapshot(double scale, PrecisionSnapshot& s) const {
    const std::size_t n = site_.terrain_triangle_count();
    const double threshold = sc_.settings.hfd_threshold_per_m2;
    std::vector<double> density = tallies_.tally.means(bins_.terrain, n),
                        se = tallies_.tally.std_errors(bins_.terrain, n);
    for (std::size_t t = 0; t < n; ++t) {
      density[t] *= scale;
      se[t] *= scale;
    }
    const HfdGeometry& g = *geometry_;
    const HfdFigures f = g.figures(density, se, threshold);
    s.hfd_m = f.hfd_m;
    s.hfd_lower_m = f.lower_m;
    s.hfd_upper_m = f.upper_m;
    s.hfd_cut = f.cut.any();
    s.hfd_lower_cut = f.lower_cut.any();
    s.hfd_lower_sectors_cut = f.lower_cut.sector_count;
    s.hfd_upper_cut = f.upper_cut.any();
    s.ptn_rel_error_at_hfd = ptn_rel_error_near_hfd(density, se, g.distances(), threshold, s.hfd_m);
  }

  const Scenario& sc_;
  const scene::Site& site_;
  const PartialRun& tallies_;
  const TallyBins bins_;
  const PrecisionSettings* p_ = nullptr;
  std::optional<HfdGeometry> geometry_;
  PrecisionTracker tracker_;
  StopReason reason_ = StopReason::kSamples;
  double hfd_m_ = 0.0;
  mutable std::mutex mutex_;
  std::shared_ptr<const PrecisionReport> report_;
};

// The launch-direction cells of each batch (importance sampling), published at the boundary
// before it; a worker with a chunk of a batch whose cells are not known yet waits for them.
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
SamplingPlans::Cells drawable(SamplingPlans::Cells cells, const LaunchStrata& strata) {
  if (!strata.on() || strata.sobol()) return cells;  // a Sobol point draws from uniform cells too
  for (auto& c : cells)
    if (c.uniform())
      c = fragments::DirectionCells::equal(c.n_elevation(), c.n_azimuth(), c.n_speed(), c.n_mass());
  return cells;
}

// Feeds a folded chunk's histories to the importance learner, or with `out` (a shard of a
// divided run) keeps them for the batch boundary's exchange.
void learn(DirectionLearner& learner, const ChunkOutput& c, LearnerInput* out) {
  std::uint32_t begin = 0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(c.count); ++i) {
    const std::uint32_t end = c.ptn_end[i];
    const std::int32_t bi = c.building_index[i];
    const std::int32_t building =
        bi >= 0 ? static_cast<std::int32_t>(c.buildings[static_cast<std::size_t>(bi)].building)
                : -1;
    if (out != nullptr)
      learner.observe(c.group, c.cells[i], c.weights[i] / c.weight, building, c.ptn.data() + begin,
                      c.ptn.data() + end, *out);
    else
      learner.add(c.group, c.cells[i], c.weights[i] / c.weight, building, c.ptn.data() + begin,
                  c.ptn.data() + end);
    begin = end;
  }
}

// The HFD, its band, its sectors and which of them the terrain's boundary cuts, from the
// result's density field; what sets them (core/run/attribution.h) from the tally's fields.
void fill_hfd(const Scenario& sc, const scene::Site& site, const PartialRun& p,
              const TallyBins& bins, double scale, RunResult& r) {
  r.hfd_origin_m = hfd_origin_input(sc, site);
  const double threshold = sc.settings.hfd_threshold_per_m2;
  const HfdGeometry geometry(site, site.to_local(r.hfd_origin_m));
  const HfdFigures f = geometry.figures(r.ptn_density_per_m2, r.ptn_std_error_per_m2, threshold);
  r.hazardous_fragment_distance_m = f.hfd_m;
  r.hfd_lower_m = f.lower_m;
  r.hfd_upper_m = f.upper_m;
  r.hfd_by_sector_m = f.by_sector_m;
  SiteBoundary& sb = r.site_boundary;
  sb.hfd_sector_cut = f.cut.sectors;
  sb.hfd_sectors_cut = f.cut.sector_count;
  sb.hfd_cut = f.cut.any();
  sb.band_lower_cut = f.lower_cut.any();
  sb.band_upper_cut = f.upper_cut.any();
  sb.max_boundary_density_per_m2 = f.max_boundary_density_per_m2;
  r.hfd_attribution = attribute_hfd(geometry, p.tally, bins, sc.groups.size(), scale, threshold,
                                    r.ptn_density_per_m2, f);
}

// Turns the folded tallies of `batches` batches into the result's figures.
void fill_figures(const Scenario& sc, const scene::Site& site, const PartialRun& p,
                  std::int64_t batches, RunResult& r) {
  const double scale = 1.0 / static_cast<double>(std::max<std::int64_t>(1, batches));
  const TallyBins bins = tally_bins(sc, site);
  r.ptn_density_per_m2 = p.tally.means(bins.terrain, site.terrain_triangle_count());
  r.ptn_std_error_per_m2 = p.tally.std_errors(bins.terrain, site.terrain_triangle_count());
  for (std::size_t t = 0; t < r.ptn_density_per_m2.size(); ++t) {
    r.ptn_density_per_m2[t] *= scale;
    r.ptn_std_error_per_m2[t] *= scale;
    if (r.ptn_density_per_m2[t] > r.max_ptn_density_per_m2) {
      r.max_ptn_density_per_m2 = r.ptn_density_per_m2[t];
      r.max_ptn_triangle = static_cast<std::int64_t>(t);
    }
  }
  if (r.max_ptn_triangle >= 0) {
    r.max_ptn_location_m = site.to_input(
        site.terrain_triangle_centroid(static_cast<std::uint32_t>(r.max_ptn_triangle)));
  }

  fill_hfd(sc, site, p, bins, scale, r);
  auto est = [&](std::size_t bin) {
    return Estimate{p.tally.mean(bin) * scale, p.tally.std_error(bin) * scale};
  };
  const auto& bs = site.buildings();
  r.buildings.resize(bs.size());
  for (std::size_t b = 0; b < bs.size(); ++b) {
    const std::size_t base = bins.buildings + b * kBuildingFigures;
    BuildingResult& br = r.buildings[b];
    br.id = bs[b].id;
    br.impacts = est(base + kImpacts);
    br.penetrations = est(base + kPenetrations);
    for (std::size_t s = 0; s < scene::kSurfaceTypeCount; ++s) {
      br.impacts_by_surface[s] = est(base + kImpactsBySurface + s);
      br.penetrations_by_surface[s] = est(base + kPenetrationsBySurface + s);
    }
    br.residual_ke_j = est(base + kResidualKe);
  }
  for (std::size_t o = 0; o < kOutcomeCount; ++o) {
    r.outcome_fragments[o] = est(bins.outcomes + o);
    r.outcome_histories[o] = p.outcome_histories[o];
  }
  SiteBoundary& sb = r.site_boundary;
  sb.left_hazardous = est(bins.left_site);
  for (std::size_t k = 0; k < sb.left_hazardous_by_sector.size(); ++k)
    sb.left_hazardous_by_sector[k] = est(bins.left_site + 1 + k);
  sb.left_hazardous_histories = p.left_hazardous_histories;
}

}  // namespace

const char* stop_reason_name(StopReason s) {
  switch (s) {
    case StopReason::kSamples: return "samples";
    case StopReason::kTargetsMet: return "targets_met";
    case StopReason::kMaxBatches: return "max_batches";
    case StopReason::kMaxWallTime: return "max_wall_time";
    case StopReason::kCancelled: return "cancelled";
    case StopReason::kTargetsUnmeetable: return "targets_unmeetable";
  }
  return "unknown";
}

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

namespace {

// "shard 1 of 3 missing", "shards 0, 2, 5, ... (7 of 9) missing".
std::string missing_shards(const PartialRun& p) {
  std::vector<std::int64_t> missing;
  for (std::int64_t k = 0, i = 0; k < p.shard_count && missing.size() < 8; ++k) {
    while (i < static_cast<std::int64_t>(p.shards.size()) &&
           p.shards[static_cast<std::size_t>(i)] < k)
      ++i;
    if (i == static_cast<std::int64_t>(p.shards.size()) ||
        p.shards[static_cast<std::size_t>(i)] != k)
      missing.push_back(k);
  }
  const std::int64_t count = p.shard_count - static_cast<std::int64_t>(p.shards.size());
  const std::string total = std::to_string(p.shard_count);
  if (count == 1) return "shard " + std::to_string(missing[0]) + " of " + total + " missing";
  std::string list;
  for (const std::int64_t k : missing) list += (list.empty() ? "" : ", ") + std::to_string(k);
  if (count > static_cast<std::int64_t>(missing.size())) list += ", ...";
  return "shards " + list + " (" + std::to_string(count) + " of " + total + ") missing";
}

void check_shard(const Scenario& sc, const Shard& shard, const RunControl& control) {
  if (shard.count < 1 || shard.index < 0 || shard.index >= shard.count)
    throw InputError("shard", "must be I/N with 0 <= I < N (got " + std::to_string(shard.index) +
                                  "/" + std::to_string(shard.count) + ")");
  if (shard.count > 1 && sc.settings.precision && control.synchronizer == nullptr)
    throw InputError("settings.precision",
                     "cannot be split into independent shards: its checks at batch boundaries "
                     "need every history of a batch (divide it with fragsim-mpi, whose ranks "
                     "exchange each batch)");
}

// A chunk's output, its fields set and its per-history arrays reserved.
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

// One shard's run (docs/architecture.md, "Data flow"). Worker threads take the chunks of
// histories by index, batch after batch, simulate them and submit them to an ordered
// sequencer. Its fold, under its lock and in chunk order, tallies each chunk (or, in the
// importance-sampling pilot, only learns from it) and at each batch boundary checks the
// precision targets: the run ends there, or the next batch's sampling plan is published.
// With a synchronizer (a divided settings.precision run) part_ holds the current batch's tally
// and counts, exchanged at its boundary; the decisions read global_, every shard's batches.
class ShardRunner {
 public:
  ShardRunner(const Scenario& sc, std::shared_ptr<const scene::Site> site, const Shard& shard,
              const RunControl& control);
  PartialRun run();

 private:
  struct Fold {
    ShardRunner* runner;
    void operator()(ChunkOutput& c) const { runner->fold(c); }
  };

  void work();
  void work_guarded();
  bool cells_for(std::int64_t batch, const SamplingPlans::Cells*& cells);
  bool simulate_chunk(std::int64_t k, const SamplingPlans::Cells* cells, HistoryScratch& scratch,
                      ChunkOutput& out);
  void fold(ChunkOutput& c);
  void end_batch(bool pilot);
  bool exchange_batch(double& elapsed);
  void absorb(const BatchState& all);
  void idle_batches();
  void count_done(std::int64_t histories);
  bool cancelled() const {
    return control_.cancel != nullptr && control_.cancel->load(std::memory_order_relaxed);
  }
  void progress(std::int64_t done, double elapsed_s) const;
  PartialRun finish();

  const Scenario& sc_;
  const std::shared_ptr<const scene::Site> site_;
  const RunControl& control_;
  const Shard shard_;
  BatchSynchronizer* const sync_;  // null unless a divided settings.precision run
  const Clock::time_point t_start_ = Clock::now();
  const RunContext ctx_;
  const BatchPlan plan_;
  const std::int64_t per_batch_;            // chunks
  const std::int64_t total_;                // histories, all batches
  std::vector<std::int64_t> group_offset_;  // histories of the groups before, in global order
  const int threads_;
  const LaunchStrata strata_;
  PartialRun part_;
  PartialRun global_;    // with sync_: every shard's completed batches (tally and counts)
  LearnerInput learnt_;  // with sync_ and a learner: the current batch's input
  Reducer reducer_;
  PrecisionControl precision_;
  std::unique_ptr<DirectionLearner> learner_;
  SamplingPlans plans_;
  SamplingPlans::Cells strata_cells_;  // stratified without importance sampling: fixed cells
  const std::int64_t report_every_ns_;

  // Under the sequencer's lock: batches folded; of them, the importance-sampling pilot (batch 0,
  // learnt from, not tallied: docs/precision.md); histories folded (the pilot's included).
  std::int64_t batches_ = 0, pilot_batches_ = 0, folded_ = 0;
  OrderedSequencer<ChunkOutput, Fold> sequencer_{Fold{this}};
  std::atomic<bool> finished_{false};  // the last batch is folded: later chunks are not needed
  std::atomic<bool> stop_{false};      // cancelled, or a worker failed
  std::atomic<std::int64_t> next_chunk_{0};
  std::atomic<std::int64_t> histories_done_{0};
  std::atomic<std::int64_t> last_report_ns_{0};
  std::mutex error_mutex_;
  std::exception_ptr error_;  // a worker's first exception, rethrown by run()
};

ShardRunner::ShardRunner(const Scenario& sc, std::shared_ptr<const scene::Site> site,
                         const Shard& shard, const RunControl& control)
    : sc_(sc),
      site_(std::move(site)),
      control_(control),
      shard_(shard),
      sync_(sc.settings.precision ? control.synchronizer : nullptr),
      ctx_(sc, *site_),
      plan_(plan_batches(sc, shard)),
      per_batch_(static_cast<std::int64_t>(plan_.chunks.size())),
      total_(plan_.histories * plan_.max_batches),
      group_offset_(sc.groups.size(), 0),
      threads_(thread_count(sc.settings, plan_.total_chunks())),
      strata_(sc),
      reducer_(sc, *site_, strata_, part_),
      precision_(sc, *site_, sync_ != nullptr ? global_ : part_),
      report_every_ns_(
          static_cast<std::int64_t>(std::max(0.0, control.progress_interval_s) * 1e9)) {
  // Trajectories are recorded for the first max_recorded_trajectories histories in global order.
  for (std::size_t g = 1; g < sc.groups.size(); ++g)
    group_offset_[g] = group_offset_[g - 1] + sc.groups[g - 1].samples;
  part_.shard_count = shard.count;
  part_.shards = {shard.index};
  if (sync_) {
    global_.shard_count = shard.count;
    global_.tally =
        tally::StratifiedTally(part_.tally.size(), static_cast<int>(part_.tally.partitions()));
  }
  const Settings& st = sc.settings;
  if (st.precision && st.precision->direction_importance) {
    learner_ = std::make_unique<DirectionLearner>(sc, *site_, precision_.distances());
    plans_.publish(0, drawable(learner_->pilot(), strata_));
  }
  if (strata_.on() && !strata_.sobol() && !learner_)  // about one equal cell per stratum
    for (std::uint32_t g = 0; g < sc.groups.size(); ++g)
      strata_cells_.push_back(fragments::DirectionCells::for_strata(
          strata_.strata(g), sc.groups[g].direction, st.stratified_launch->speed));
}

PartialRun ShardRunner::run() {
  if (sync_ && plan_.chunks.empty()) {
    idle_batches();
    return finish();
  }
  std::vector<std::thread> pool;
  for (int i = 1; i < threads_; ++i) pool.emplace_back([this] { work_guarded(); });
  work_guarded();
  for (auto& th : pool) th.join();
  if (error_) std::rethrow_exception(error_);
  return finish();
}

// A worker's exception (an exact sum out of range, memory) stops the others and is rethrown.
void ShardRunner::work_guarded() {
  try {
    work();
  } catch (...) {
    const std::lock_guard<std::mutex> lock(error_mutex_);
    if (!error_) error_ = std::current_exception();
    stop_.store(true);
    plans_.abort();
  }
}

void ShardRunner::work() {
  HistoryScratch scratch;
  while (!stop_.load(std::memory_order_relaxed) && !finished_.load(std::memory_order_relaxed)) {
    const std::int64_t k = next_chunk_.fetch_add(1);
    if (k >= plan_.total_chunks()) break;
    const SamplingPlans::Cells* cells = nullptr;
    if (!cells_for(k / per_batch_, cells)) return;
    ChunkOutput out;
    if (!simulate_chunk(k, cells, scratch, out)) return;
    const std::int64_t histories = out.count;
    sequencer_.submit(k, std::move(out));
    count_done(histories);
  }
}

// The launch cells of a batch's draws: the fixed strata cells, or the importance-sampling plan
// published for the batch (waited for). False when the run ends or is cancelled meanwhile.
bool ShardRunner::cells_for(std::int64_t batch, const SamplingPlans::Cells*& cells) {
  cells = strata_cells_.empty() ? nullptr : &strata_cells_;
  if (!learner_) return true;
  cells = plans_.get(batch, [this] { return cancelled(); });
  if (cells != nullptr) return true;
  if (cancelled()) stop_.store(true);
  return false;
}

// Simulates chunk k of the run (chunk k % per_batch of batch k / per_batch) into `out`. False
// when cancelled midway: the unfinished chunk is dropped, so the folded chunks form a clean
// prefix.
bool ShardRunner::simulate_chunk(std::int64_t k, const SamplingPlans::Cells* cells,
                                 HistoryScratch& scratch, ChunkOutput& out) {
  const std::int64_t batch = k / per_batch_;
  const ChunkSpec& cs = plan_.chunks[static_cast<std::size_t>(k % per_batch_)];
  const fragments::FragmentGroupSpec& group = sc_.groups[cs.group];
  const std::int64_t batch_first = batch * group.samples;
  const std::int64_t first = batch_first + cs.first;
  const Settings& st = sc_.settings;
  out = chunk_output(cs, first, group);
  for (std::int64_t h = first; h < first + cs.count; ++h) {
    if (cancelled()) {
      stop_.store(true);
      return false;
    }
    const bool record = st.record_trajectories && batch == (learner_ ? 1 : 0) &&
                        group_offset_[cs.group] + h < st.max_recorded_trajectories;
    const fragments::LaunchStratum ls =
        strata_.on() ? strata_.of(cs.group, h - batch_first, batch) : fragments::LaunchStratum{};
    simulate_history(ctx_, cs.group, h, record, scratch, out, cells ? &(*cells)[cs.group] : nullptr,
                     strata_.on() ? &ls : nullptr);
  }
  return true;
}

// Under the sequencer's lock, in chunk order.
void ShardRunner::fold(ChunkOutput& c) {
  if (finished_.load(std::memory_order_relaxed)) return;
  const bool pilot = learner_ && batches_ == 0;
  if (learner_) learn(*learner_, c, sync_ != nullptr ? &learnt_ : nullptr);
  folded_ += c.count;
  if (pilot) {
    part_.pilot_histories += c.count;
  } else {
    if (control_.on_chunk) control_.on_chunk(c);
    reducer_.fold(c);
  }
  if (c.last_of_batch) end_batch(pilot);
}

// At a batch boundary: the precision targets decide whether the run ends here; if not, the
// importance learner's plan for the next batch is published.
void ShardRunner::end_batch(bool pilot) {
  double elapsed = std::chrono::duration<double>(Clock::now() - t_start_).count();
  if (sync_ && !exchange_batch(elapsed)) return;
  ++batches_;
  pilot_batches_ += pilot ? 1 : 0;
  const PartialRun& all = sync_ != nullptr ? global_ : part_;
  if (precision_.batch_done(batches_, batches_ - pilot_batches_,
                            all.histories_done + all.pilot_histories, elapsed)) {
    finished_.store(true);
    plans_.abort();
  } else if (learner_) {
    plans_.publish(batches_, drawable(learner_->plan(precision_.hfd_m()), strata_));
  }
}

// A divided run's batch boundary: hands this shard's batch (tally, counts, learner input) to the
// synchronizer and absorbs every shard's, merged, into global_ and the learner; `elapsed` becomes
// the longest shard's. False when the run stops instead (the batch stays in part_).
bool ShardRunner::exchange_batch(double& elapsed) {
  BatchState mine;
  mine.batch = batches_;
  mine.elapsed_s = elapsed;
  PartialRun& b = mine.part;
  b.shard_count = part_.shard_count;
  b.shards = part_.shards;
  b.outcome_histories = part_.outcome_histories;
  b.left_hazardous_histories = part_.left_hazardous_histories;
  b.histories_done = part_.histories_done;
  b.pilot_histories = part_.pilot_histories;
  b.tally = std::move(part_.tally);
  mine.learnt.push_back({shard_.index, std::move(learnt_)});
  std::optional<BatchState> all;
  try {
    all = sync_->exchange(mine);
  } catch (...) {
    part_.tally = std::move(b.tally);
    throw;
  }
  part_.tally = std::move(b.tally);
  learnt_ = std::move(mine.learnt.front().input);
  if (!all) {
    stop_.store(true);
    plans_.abort();
    return false;
  }
  part_.tally.clear();
  learnt_.clear();
  part_.outcome_histories = {};
  part_.left_hazardous_histories = part_.histories_done = part_.pilot_histories = 0;
  absorb(*all);
  elapsed = all->elapsed_s;
  return true;
}

// Adds the tallies and history counts of `from` into `into` (exact sums: any order).
void add_tallies(PartialRun& into, const PartialRun& from) {
  into.tally.merge(from.tally);
  for (std::size_t o = 0; o < kOutcomeCount; ++o)
    into.outcome_histories[o] += from.outcome_histories[o];
  into.left_hazardous_histories += from.left_hazardous_histories;
  into.histories_done += from.histories_done;
  into.pilot_histories += from.pilot_histories;
}

// Adds every shard's batch to global_ and, in shard order (for each group: the order of its
// histories in one process), to the learner.
void ShardRunner::absorb(const BatchState& all) {
  const PartialRun& b = all.part;
  if (all.batch != batches_ || b.shard_count != shard_.count ||
      static_cast<std::int64_t>(b.shards.size()) != shard_.count)
    throw std::runtime_error("a batch boundary without every shard's batch (batch " +
                             std::to_string(all.batch) + ", " + std::to_string(b.shards.size()) +
                             " of " + std::to_string(shard_.count) + " shards)");
  add_tallies(global_, b);
  if (learner_)
    for (const BatchState::Learnt& l : all.learnt) learner_->replay(l.input);
}

// A shard of a divided run that holds no history still takes part in every batch boundary.
void ShardRunner::idle_batches() {
  while (!finished_.load() && !stop_.load()) {
    if (cancelled()) {
      stop_.store(true);
      break;
    }
    end_batch(learner_ && batches_ == 0);
  }
}

// Counts a simulated chunk's histories and reports progress at most every progress_interval_s.
void ShardRunner::count_done(std::int64_t histories) {
  const std::int64_t done = histories_done_.fetch_add(histories) + histories;
  if (!control_.on_progress) return;
  const std::int64_t now =
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t_start_).count();
  std::int64_t last = last_report_ns_.load();
  if (now - last >= report_every_ns_ && last_report_ns_.compare_exchange_strong(last, now))
    progress(done, static_cast<double>(now) * 1e-9);
}

void ShardRunner::progress(std::int64_t done, double elapsed_s) const {
  Progress p;
  p.histories_done = done;
  p.histories_total = total_;
  p.elapsed_s = elapsed_s;
  p.precision = precision_.report();
  control_.on_progress(p);
}

// The shard's partial result, once the workers have stopped.
PartialRun ShardRunner::finish() {
  PartialRun& part = part_;
  part.cancelled = !finished_.load() && (cancelled() || stop_.load());
  part.tallied_batches = batches_ - pilot_batches_;
  // A shard without histories has no batch to fold (unless the shards run each batch together).
  const bool idle = plan_.chunks.empty() && sync_ == nullptr;
  part.batches = idle && !part.cancelled ? 1 : batches_;
  if (idle) part.tallied_batches = part.batches;
  if (sync_ != nullptr && shard_.index == 0) {  // every shard's completed batches
    add_tallies(part, global_);
  }
  part.stop_reason = part.cancelled ? StopReason::kCancelled : precision_.reason();
  part.precision = precision_.report();
  part.wall_s = std::chrono::duration<double>(Clock::now() - t_start_).count();
  part.threads = threads_;
  if (control_.on_progress) progress(folded_, part.wall_s);
  return std::move(part);
}

}  // namespace

PartialRun run_partial(const Scenario& sc, std::shared_ptr<const scene::Site> site,
                       const Shard& shard, const RunControl& control) {
  check_shard(sc, shard, control);
  ShardRunner runner(sc, std::move(site), shard, control);
  return runner.run();
}

namespace {

// a += b for counts from partial files: a sum out of range is a damaged or forged partial.
void add_count(std::int64_t& a, std::int64_t b) {
  if (__builtin_add_overflow(a, b, &a))
    throw InputError("shards", "counts out of range (a damaged or forged partial)");
}

}  // namespace

void merge(PartialRun& into, PartialRun&& other) {
  if (into.shard_count != other.shard_count)
    throw InputError("shards", "partials of different splits (" + std::to_string(into.shard_count) +
                                   " and " + std::to_string(other.shard_count) + " shards)");
  if (into.tally.size() != other.tally.size() ||
      into.tally.partitions() != other.tally.partitions())
    throw InputError("shards", "partials of different sites or settings");
  for (const std::int64_t k : other.shards)
    if (std::find(into.shards.begin(), into.shards.end(), k) != into.shards.end())
      throw InputError("shards", "shard " + std::to_string(k) + " is there twice");
  PartialRun sum = std::move(into);  // `into` is left as it was when this throws
  try {
    sum.tally.merge(other.tally);
  } catch (const std::overflow_error& e) {
    into = std::move(sum);
    throw InputError("shards", std::string(e.what()) + " (a damaged or forged partial)");
  }
  sum.shards.insert(sum.shards.end(), other.shards.begin(), other.shards.end());
  std::sort(sum.shards.begin(), sum.shards.end());
  for (std::size_t o = 0; o < kOutcomeCount; ++o)
    add_count(sum.outcome_histories[o], other.outcome_histories[o]);
  add_count(sum.left_hazardous_histories, other.left_hazardous_histories);
  add_count(sum.histories_done, other.histories_done);
  add_count(sum.pilot_histories, other.pilot_histories);
  for (const auto m : RunStats::counters()) add_count(sum.stats.*m, other.stats.*m);
  sum.batches = std::max(sum.batches, other.batches);
  sum.tallied_batches = std::max(sum.tallied_batches, other.tallied_batches);
  sum.cancelled = sum.cancelled || other.cancelled;
  if (sum.cancelled) sum.stop_reason = StopReason::kCancelled;
  std::move(other.records.begin(), other.records.end(), std::back_inserter(sum.records));
  std::move(other.trajectories.begin(), other.trajectories.end(),
            std::back_inserter(sum.trajectories));
  sum.integration_s += other.integration_s;
  sum.geometry_s += other.geometry_s;
  sum.tally_s += other.tally_s;
  sum.wall_s = std::max(sum.wall_s, other.wall_s);
  if (__builtin_add_overflow(sum.threads, other.threads, &sum.threads))
    throw InputError("shards", "thread counts out of range (a damaged or forged partial)");
  into = std::move(sum);
}

void merge(BatchState& into, BatchState&& other) {
  if (into.batch != other.batch)
    throw InputError("shards", "states of different batches (" + std::to_string(into.batch) +
                                   " and " + std::to_string(other.batch) + ")");
  merge(into.part, std::move(other.part));
  into.elapsed_s = std::max(into.elapsed_s, other.elapsed_s);
  for (auto& l : other.learnt) into.learnt.push_back(std::move(l));
  std::stable_sort(into.learnt.begin(), into.learnt.end(),
                   [](const auto& a, const auto& b) { return a.shard < b.shard; });
}

RunResult finish(const Scenario& sc, const scene::Site& site, PartialRun p,
                 const RunControl& control) {
  RunResult r = finish_tally(sc, site, std::move(p));
  // settings.ground_bracket: the whole study is done; its variants are runs of their own.
  if (sc.settings.ground_bracket && !r.cancelled)
    r.ground_bracket = run_ground_bracket(sc, control);
  return r;
}

RunResult finish_tally(const Scenario& sc, const scene::Site& site, PartialRun p) {
  if (!p.cancelled && static_cast<std::int64_t>(p.shards.size()) != p.shard_count)
    throw InputError("shards", missing_shards(p));
  try {
    if (p.cancelled) p.tally.close_open_strata();  // the strata a cancellation cut short
  } catch (const std::overflow_error& e) {
    throw InputError("shards", std::string(e.what()) + " (a damaged or forged partial)");
  }
  if (!p.tally.open_strata().empty())
    throw InputError("shards", "partials do not cover the run's histories");
  RunResult r;
  r.cancelled = p.cancelled;
  std::int64_t histories = 0;
  for (const auto& g : sc.groups) {
    histories += g.samples;
    r.real_fragments += g.count;
  }
  const std::int64_t max_batches =
      sc.settings.precision ? std::max<std::int64_t>(1, sc.settings.precision->max_batches) : 1;
  r.samples = r.cancelled ? histories * max_batches : histories * p.tallied_batches;
  r.histories_done = p.histories_done + p.pilot_histories;
  r.pilot_histories = p.pilot_histories;
  r.seed = sc.settings.seed;
  r.batches = r.cancelled ? p.batches + 1 : p.batches;  // the partial batch counts (one's estimate)
  r.stop_reason = p.stop_reason;
  r.precision = p.precision;
  r.stats = p.stats;
  r.timing.wall_s = p.wall_s;
  r.timing.threads = p.threads;
  r.timing.integration_s = p.integration_s;
  r.timing.geometry_s = p.geometry_s;
  r.timing.tally_s = p.tally_s;
  if (r.timing.wall_s > 0.0) {
    r.timing.fragments_per_s = static_cast<double>(r.histories_done) / r.timing.wall_s;
    r.timing.fragments_per_s_per_thread = r.timing.fragments_per_s / r.timing.threads;
  }
  // A cancelled run's figures are never shown (callers write nothing for it, and `fragsim
  // merge` and fragsimd refuse a cancelled shard's partial): its counts are enough, and a cancel
  // returns without the figures' work or sorting millions of records (seconds under TSan: a cancel
  // must end within a second, docs/http-api.md).
  if (r.cancelled) return r;
  fill_figures(sc, site, p, p.tallied_batches, r);
  auto by_history = [](const auto& a, const auto& b) {
    return std::tie(a.group, a.history) < std::tie(b.group, b.history);
  };
  std::sort(p.records.begin(), p.records.end(), by_history);
  std::sort(p.trajectories.begin(), p.trajectories.end(), by_history);
  r.fragments = std::move(p.records);
  r.trajectories = std::move(p.trajectories);
  return r;
}

RunResult run(const Scenario& sc, std::shared_ptr<const scene::Site> site,
              const RunControl& control) {
  PartialRun p = run_partial(sc, site, Shard{}, control);
  return finish(sc, *site, std::move(p), control);
}

RunResult run(const Scenario& sc, const RunControl& control) {
  const auto t0 = Clock::now();
  auto site = scene::Site::build(sc.site);
  const double build_s = std::chrono::duration<double>(Clock::now() - t0).count();
  RunResult r = run(sc, std::move(site), control);
  r.timing.build_s = build_s;
  return r;
}

}  // namespace fragsim::run
