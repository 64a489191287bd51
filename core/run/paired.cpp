#include "core/run/paired.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/common/error.h"
#include "core/run/history.h"
#include "core/run/launch_strata.h"
#include "core/tally/stratified_tally.h"

namespace fragsim::run {

bool same_terrain(const scene::Site& a, const scene::Site& b) {
  return a.local_origin() == b.local_origin() && a.terrain_vertices() == b.terrain_vertices() &&
         a.terrain_triangles() == b.terrain_triangles();
}

void check_pairable(const Scenario& base, const Scenario& variant) {
  if (base.groups.size() != variant.groups.size())
    throw InputError("fragment_groups", "the variant must have the base's fragment groups");
  for (std::size_t g = 0; g < base.groups.size(); ++g)
    if (base.groups[g].samples != variant.groups[g].samples)
      throw InputError("fragment_groups[" + std::to_string(g) + "].samples",
                       "the variant must have the base's samples");
  if (base.settings.seed != variant.settings.seed)
    throw InputError("settings.seed", "the variant must have the base's seed");
  for (const Scenario* sc : {&base, &variant}) {
    if (sc->settings.precision)
      throw InputError("settings.precision",
                       "a comparison runs the groups' samples: its batches would stop on each "
                       "site's own figures (remove settings.precision)");
    if (sc->settings.ground_bracket)
      throw InputError("settings.ground_bracket",
                       "not run in a comparison (run the bracket on each site on its own)");
  }
}

namespace {

// What the paired fold needs of a base chunk, kept until the variant's same chunk arrives.
struct KeptChunk {
  std::uint32_t group = 0;
  std::int64_t first_history = 0, count = 0;
  std::vector<double> weights;
  std::vector<std::uint32_t> ptn_end;
  std::vector<PtnContribution> ptn;
  std::vector<std::int32_t> building_index;
  std::vector<BuildingContribution> buildings;
  std::vector<Outcome> outcomes;
  std::vector<std::int8_t> exit_sector;

  explicit KeptChunk(const ChunkOutput& c)
      : group(c.group),
        first_history(c.first_history),
        count(c.count),
        weights(c.weights),
        ptn_end(c.ptn_end),
        ptn(c.ptn),
        building_index(c.building_index),
        buildings(c.buildings),
        outcomes(c.outcomes),
        exit_sector(c.exit_sector) {}
  KeptChunk() = default;
};

// One history of either run, as the paired fold reads it.
struct HistoryView {
  const PtnContribution* ptn;
  std::uint32_t ptn_count;
  double weight;
  std::int32_t building;  // index into the buildings of the history's site, or -1
  bool penetrated;
  Outcome outcome;
  std::int8_t exit_sector;
};

// History h of a chunk (a ChunkOutput or a KeptChunk), whose PTN contributions start at `begin`.
template <class Chunk>
HistoryView view(const Chunk& c, std::size_t h, std::uint32_t begin) {
  const std::int32_t bi = c.building_index[h];
  const BuildingContribution* bc = bi >= 0 ? &c.buildings[static_cast<std::size_t>(bi)] : nullptr;
  return {c.ptn.data() + begin,
          c.ptn_end[h] - begin,
          c.weights[h],
          bc ? static_cast<std::int32_t>(bc->building) : -1,
          bc != nullptr && bc->penetrated,
          c.outcomes[h],
          c.exit_sector[h]};
}

// Per-triangle sums of one site's PTN contributions in kJackknifeGroups groups of histories
// (jackknife_group: history h is in group h mod kJackknifeGroups; with Sobol launch, whole
// blocks), for the HFD's jackknife. Kept only for
// the triangles a history touched (a slot index per triangle, 4 bytes): a dense table would be
// 128 bytes per triangle, 1 GB per site on an 8-million-triangle terrain.
class JackknifeFields {
 public:
  explicit JackknifeFields(std::size_t triangles) : slot_(triangles, kNone) {}
  void add(std::size_t group, std::uint32_t triangle, double value) {
    std::uint32_t& slot = slot_[triangle];
    if (slot == kNone) {
      slot = static_cast<std::uint32_t>(sums_.size());
      sums_.emplace_back();
      touched_.push_back(triangle);
    }
    sums_[slot][group] += value;
  }
  // The field without group j, scaled up to the whole run's histories.
  std::vector<double> without(int j) const {
    std::vector<double> f(slot_.size(), 0.0);
    const double scale = static_cast<double>(kJackknifeGroups) / (kJackknifeGroups - 1);
    for (std::size_t k = 0; k < touched_.size(); ++k) {
      double sum = 0.0;
      for (int g = 0; g < kJackknifeGroups; ++g)
        if (g != j) sum += sums_[k][static_cast<std::size_t>(g)];
      f[touched_[k]] = sum * scale;
    }
    return f;
  }

 private:
  static constexpr std::uint32_t kNone = 0xffffffffu;
  std::vector<std::uint32_t> slot_;  // per triangle: its row of sums_, or kNone
  std::vector<std::array<double, kJackknifeGroups>> sums_;
  std::vector<std::uint32_t> touched_;  // the triangle of each row
};

// The fold of the per-history differences (variant - base) into one stratified tally. Bins: the
// terrain triangles (when the terrains are the same), then impacts and penetrations per building
// of either site, then the outcomes, then the hazardous fragments that left the site.
class PairedFold {
 public:
  PairedFold(const Scenario& sc, const scene::Site& base, const scene::Site& variant)
      : strata_(sc),
        triangles_(same_terrain(base, variant) ? base.terrain_triangle_count() : 0),
        base_fields_(base.terrain_triangle_count()),
        variant_fields_(variant.terrain_triangle_count()) {
    map_buildings(base, variant);
    buildings_ = triangles_;
    outcomes_ = buildings_ + 2 * difference_.buildings.size();
    left_site_ = outcomes_ + kOutcomeCount;
    tally_ = tally::StratifiedTally(left_site_ + 1, strata_.partitions());
    difference_.same_terrain = triangles_ > 0;
  }

  // Both are called in chunk order under the run's fold lock (RunControl::on_chunk).
  void keep(const ChunkOutput& c) { kept_.emplace_back(c); }

  void pair(const ChunkOutput& v) {
    if (next_ >= kept_.size()) throw std::logic_error("paired fold: the variant ran ahead");
    const KeptChunk b = std::move(kept_[next_]);
    kept_[next_++] = KeptChunk{};  // its memory is freed as the variant goes
    if (b.group != v.group || b.first_history != v.first_history || b.count != v.count)
      throw std::logic_error("paired fold: the runs' chunks differ");
    fold(b, v);
  }

  PairedDifference finish(const Scenario& sc, const scene::Site& base, const scene::Site& variant,
                          const RunResult& rb, const RunResult& rv);

 private:
  void map_buildings(const scene::Site& base, const scene::Site& variant);
  void fold(const KeptChunk& b, const ChunkOutput& v);
  void start_strata(std::uint32_t g, std::int64_t i, bool chunk_start);
  std::size_t jackknife_group(std::uint32_t g, std::int64_t history) const;
  void add_history(const HistoryView& h, std::size_t jackknife, double sign,
                   const std::vector<std::int32_t>& building_bin, JackknifeFields& fields);
  void history_done();
  void fill_hfd(const Scenario& sc, const scene::Site& base, const scene::Site& variant,
                const RunResult& rb, const RunResult& rv);

  LaunchStrata strata_;
  std::size_t triangles_ = 0, buildings_ = 0, outcomes_ = 0, left_site_ = 0;
  std::vector<std::int32_t> base_bin_, variant_bin_;  // per site building: its difference index
  tally::StratifiedTally tally_;
  JackknifeFields base_fields_, variant_fields_;
  PairedDifference difference_;
  std::vector<KeptChunk> kept_;
  struct Pending {
    std::size_t bin;
    double value;
  };
  std::vector<Pending> pending_;  // the current history's contributions, both sites
  std::size_t next_ = 0;
};

void PairedFold::map_buildings(const scene::Site& base, const scene::Site& variant) {
  std::map<std::string, std::int32_t> index;
  auto& out = difference_.buildings;
  for (std::size_t i = 0; i < base.buildings().size(); ++i) {
    const std::string& id = base.buildings()[i].id;
    index[id] = static_cast<std::int32_t>(out.size());
    base_bin_.push_back(static_cast<std::int32_t>(out.size()));
    out.push_back({id, true, false, static_cast<std::int32_t>(i), -1, {}, {}});
  }
  for (std::size_t i = 0; i < variant.buildings().size(); ++i) {
    const std::string& id = variant.buildings()[i].id;
    auto it = index.find(id);
    if (it == index.end()) {
      it = index.emplace(id, static_cast<std::int32_t>(out.size())).first;
      out.push_back({id, false, false, -1, -1, {}, {}});
    }
    BuildingDifference& d = out[static_cast<std::size_t>(it->second)];
    d.in_variant = true;
    d.variant_index = static_cast<std::int32_t>(i);
    variant_bin_.push_back(it->second);
  }
}

void PairedFold::fold(const KeptChunk& b, const ChunkOutput& v) {
  std::uint32_t b_begin = 0, v_begin = 0;
  for (std::int64_t i = 0; i < b.count; ++i) {
    const auto h = static_cast<std::size_t>(i);
    const std::int64_t history = b.first_history + i;
    start_strata(b.group, history, i == 0);
    const std::size_t jk = jackknife_group(b.group, history);
    add_history(view(b, h, b_begin), jk, -1.0, base_bin_, base_fields_);
    add_history(view(v, h, v_begin), jk, +1.0, variant_bin_, variant_fields_);
    if (strata_.unit_ends(b.group, history)) history_done();
    b_begin = b.ptn_end[h];
    v_begin = v.ptn_end[h];
  }
  for (std::size_t k = 0; k < tally_.partitions(); ++k) tally_.flush(k);
}

// As the run's own fold (run.cpp, Reducer): batch 0, the run has no settings.precision.
void PairedFold::start_strata(std::uint32_t g, std::int64_t i, bool chunk_start) {
  for (std::size_t k = 0; k < tally_.partitions(); ++k) {
    const LaunchStrata::VarianceStratum s = strata_.variance_stratum(g, i, k);
    if (!chunk_start && s.first != i) continue;
    tally_.flush(k);
    tally_.start(k, tally::StratumKey{static_cast<std::uint32_t>(k), g, 0, s.index}, s.size);
  }
}

// Queues one site's contributions of a history: `sign` -1 for the base, +1 for the variant.
// The jackknife's groups must be independent: with Sobol launch a block's histories are not, so
// group j takes whole blocks (replicates >= kJackknifeGroups, api/compare_json.cpp).
std::size_t PairedFold::jackknife_group(std::uint32_t g, std::int64_t history) const {
  if (!strata_.sobol()) return static_cast<std::size_t>(history % kJackknifeGroups);
  return static_cast<std::size_t>(strata_.block_of(g, history) * kJackknifeGroups /
                                  strata_.replicates());
}

void PairedFold::add_history(const HistoryView& h, std::size_t jackknife, double sign,
                             const std::vector<std::int32_t>& building_bin,
                             JackknifeFields& fields) {
  for (std::uint32_t k = 0; k < h.ptn_count; ++k) {
    const PtnContribution& c = h.ptn[k];
    if (triangles_ > 0) pending_.push_back({c.triangle, sign * c.value});
    fields.add(jackknife, c.triangle, c.value);
  }
  if (h.building >= 0) {
    const std::size_t bin =
        buildings_ +
        2 * static_cast<std::size_t>(building_bin[static_cast<std::size_t>(h.building)]);
    pending_.push_back({bin, sign * h.weight});
    if (h.penetrated) pending_.push_back({bin + 1, sign * h.weight});
  }
  pending_.push_back({outcomes_ + static_cast<std::size_t>(h.outcome), sign * h.weight});
  if (h.exit_sector >= 0) pending_.push_back({left_site_, sign * h.weight});
}

// Tallies the unit's differences (a history's, or a Sobol block's): a bin both sites touched gets
// y - x once (the tally's sums of squares take one value per bin and unit).
void PairedFold::history_done() {
  std::sort(pending_.begin(), pending_.end(),
            [](const Pending& a, const Pending& b) { return a.bin < b.bin; });
  for (std::size_t k = 0; k < pending_.size();) {
    double d = 0.0;
    const std::size_t bin = pending_[k].bin;
    for (; k < pending_.size() && pending_[k].bin == bin; ++k) d += pending_[k].value;
    tally_.add(bin, d);
  }
  pending_.clear();
  tally_.history_done();
}

Estimate jackknife(const std::vector<double>& replicates, double estimate) {
  double mean = 0.0;
  for (double x : replicates) mean += x;
  mean /= static_cast<double>(replicates.size());
  double ss = 0.0;
  for (double x : replicates) ss += (x - mean) * (x - mean);
  const double k = static_cast<double>(replicates.size());
  return {estimate, std::sqrt((k - 1.0) / k * ss)};
}

void PairedFold::fill_hfd(const Scenario& sc, const scene::Site& base, const scene::Site& variant,
                          const RunResult& rb, const RunResult& rv) {
  const double threshold = sc.settings.hfd_threshold_per_m2;
  const HfdGeometry gb(base, base.to_local(rb.hfd_origin_m));
  const HfdGeometry gv(variant, variant.to_local(rv.hfd_origin_m));
  std::vector<double> overall;
  std::array<std::vector<double>, kHfdSectors> sectors;
  for (int j = 0; j < kJackknifeGroups; ++j) {
    SectorFigures sb{}, sv{};
    const double hb = gb.hfd(base_fields_.without(j), threshold, &sb);
    const double hv = gv.hfd(variant_fields_.without(j), threshold, &sv);
    overall.push_back(hv - hb);
    for (int s = 0; s < kHfdSectors; ++s) sectors[s].push_back(sv[s] - sb[s]);
  }
  HfdDifference& d = difference_.hfd;
  d.hfd_m = jackknife(overall, rv.hazardous_fragment_distance_m - rb.hazardous_fragment_distance_m);
  for (int s = 0; s < kHfdSectors; ++s)
    d.by_sector_m[s] = jackknife(sectors[s], rv.hfd_by_sector_m[s] - rb.hfd_by_sector_m[s]);
}

PairedDifference PairedFold::finish(const Scenario& sc, const scene::Site& base,
                                    const scene::Site& variant, const RunResult& rb,
                                    const RunResult& rv) {
  auto est = [&](std::size_t bin) { return Estimate{tally_.mean(bin), tally_.std_error(bin)}; };
  PairedDifference& d = difference_;
  if (triangles_ > 0) {
    d.density_per_m2 = tally_.means(0, triangles_);
    d.density_std_error_per_m2 = tally_.std_errors(0, triangles_);
    for (std::size_t t = 0; t < triangles_; ++t) {
      if (std::abs(d.density_per_m2[t]) <= d.max_abs_density_per_m2) continue;
      d.max_abs_density_per_m2 = std::abs(d.density_per_m2[t]);
      d.max_abs_triangle = static_cast<std::int64_t>(t);
    }
  }
  for (std::size_t b = 0; b < d.buildings.size(); ++b) {
    d.buildings[b].impacts = est(buildings_ + 2 * b);
    d.buildings[b].penetrations = est(buildings_ + 2 * b + 1);
  }
  for (std::size_t o = 0; o < kOutcomeCount; ++o) d.outcome_fragments[o] = est(outcomes_ + o);
  d.left_hazardous = est(left_site_);
  fill_hfd(sc, base, variant, rb, rv);
  return std::move(difference_);
}

}  // namespace

PairedRun run_paired(const Scenario& base, std::shared_ptr<const scene::Site> base_site,
                     const Scenario& variant, std::shared_ptr<const scene::Site> variant_site,
                     const RunControl& control) {
  check_pairable(base, variant);
  PairedFold fold(base, *base_site, *variant_site);
  std::int64_t total = 0;
  for (const auto& g : base.groups) total += g.samples;
  auto leg = [&](std::int64_t offset, std::function<void(const ChunkOutput&)> sink) {
    RunControl c;
    c.cancel = control.cancel;
    c.progress_interval_s = control.progress_interval_s;
    c.on_chunk = std::move(sink);
    if (control.on_progress)
      c.on_progress = [&control, offset, total](const Progress& p) {
        Progress q = p;
        q.histories_done += offset;
        q.histories_total = 2 * total;
        control.on_progress(q);
      };
    return c;
  };
  PairedRun out;
  const RunControl cb = leg(0, [&fold](const ChunkOutput& c) { fold.keep(c); });
  out.base = run(base, base_site, cb);
  out.cancelled = out.base.cancelled;
  if (out.cancelled) return out;
  const RunControl cv = leg(total, [&fold](const ChunkOutput& c) { fold.pair(c); });
  out.variant = run(variant, variant_site, cv);
  out.cancelled = out.variant.cancelled;
  if (!out.cancelled)
    out.difference = fold.finish(base, *base_site, *variant_site, out.base, out.variant);
  return out;
}

}  // namespace fragsim::run
