#include "core/run/importance.h"

#include <algorithm>
#include <cmath>

namespace fragsim::run {

DirectionLearner::DirectionLearner(const Scenario& sc, const scene::Site& site,
                                   std::vector<double> distance_m)
    : settings_(*sc.settings.precision->direction_importance),
      cells_(settings_.elevation_cells * settings_.azimuth_cells * settings_.speed_cells),
      buildings_(site.buildings().size()),
      distance_m_(std::move(distance_m)) {
  const PrecisionSettings& p = *sc.settings.precision;
  const bool building_targets = p.building_rel_error || p.building_abs_error;
  const bool hfd_targets = p.hfd_half_band_m || p.hfd_half_band_rel || p.ptn_rel_error_at_hfd;
  const bool none = !p.has_targets();
  building_used_.assign(buildings_, 0);
  for (std::size_t b = 0; b < buildings_; ++b) {
    const std::string& id = site.buildings()[b].id;
    building_used_[b] =
        (none || (building_targets &&
                  (p.buildings.empty() ||
                   std::find(p.buildings.begin(), p.buildings.end(), id) != p.buildings.end())))
            ? 1
            : 0;
  }
  ring_used_ = none || hfd_targets;
  groups_.resize(sc.groups.size());
  for (std::size_t k = 0; k < groups_.size(); ++k) {
    GroupStats& g = groups_[k];
    const auto& d = sc.groups[k].direction;
    g.wraps = d.azimuth_max_deg - d.azimuth_min_deg >= 360.0 - 1e-9;
    g.n.assign(static_cast<std::size_t>(cells_), 0);
    g.hits.assign(static_cast<std::size_t>(cells_) * buildings_, 0);
    g.building_mean.assign(buildings_, 0.0);
    if (ring_used_) {
      g.ring_sq.assign(static_cast<std::size_t>(cells_) * kDistanceBins, 0.0);
      g.bin_mean.assign(kDistanceBins, 0.0);
      g.scratch.assign(kDistanceBins, 0.0);
    }
  }
}

int DirectionLearner::distance_bin(double d_m) {
  static const double kLogStep = std::log(1.05);
  const double b = std::log(std::max(d_m, 1.0)) / kLogStep;
  return std::clamp(static_cast<int>(b), 0, kDistanceBins - 1);
}

void DirectionLearner::add(std::uint32_t group, std::uint32_t cell, double likelihood_ratio,
                           std::int32_t building, const PtnContribution* begin,
                           const PtnContribution* end) {
  GroupStats& g = groups_[group];
  ++g.histories;
  ++g.n[cell];
  if ((building >= 0 && building_used_[static_cast<std::size_t>(building)]) ||
      (ring_used_ && begin != end))
    ++g.touching;
  if (building >= 0) {
    const auto b = static_cast<std::size_t>(building);
    ++g.hits[cell * buildings_ + b];
    g.building_mean[b] += likelihood_ratio;
  }
  if (!ring_used_ || begin == end) return;
  // x per distance bin without the likelihood ratio (the density under the group's own p).
  std::vector<int>& touched = g.touched;
  touched.clear();
  for (const PtnContribution* c = begin; c != end; ++c) {
    const int bin = distance_bin(distance_m_[c->triangle]);
    if (g.scratch[static_cast<std::size_t>(bin)] == 0.0) touched.push_back(bin);
    g.scratch[static_cast<std::size_t>(bin)] += c->value / likelihood_ratio;
  }
  for (const int bin : touched) {
    const auto k = static_cast<std::size_t>(bin);
    const double x = g.scratch[k];
    g.ring_sq[cell * static_cast<std::size_t>(kDistanceBins) + k] += x * x;
    g.bin_mean[k] += likelihood_ratio * x;
    g.scratch[k] = 0.0;
  }
}

std::vector<double> DirectionLearner::spread_to_neighbours(const std::vector<double>& s,
                                                           const std::vector<std::int64_t>& n,
                                                           bool wraps) const {
  // Up to half of each cell's weight reaches its neighbours (azimuth wraps round when the range
  // is the full circle): a figure seen in one cell is often also in the next, and a cell holding
  // part of it that few histories have visited would otherwise get only the defensive share.
  // The floor fades as the cell's own histories show what it holds.
  const int ne = settings_.elevation_cells, na = settings_.azimuth_cells,
            ns = settings_.speed_cells;
  auto index = [&](int i, int j, int k) { return static_cast<std::size_t>((i * na + j) * ns + k); };
  std::vector<double> out(s);
  for (int i = 0; i < ne; ++i)
    for (int j = 0; j < na; ++j)
      for (int k = 0; k < ns; ++k) {
        double m = 0.0;
        for (int di = -1; di <= 1; ++di)
          for (int dj = -1; dj <= 1; ++dj)
            for (int dk = -1; dk <= 1; ++dk) {
              const int ii = i + di, kk = k + dk;
              int jj = j + dj;
              if (ii < 0 || ii >= ne || kk < 0 || kk >= ns) continue;
              if (jj < 0 || jj >= na) {
                if (!wraps) continue;
                jj = (jj + na) % na;
              }
              m = std::max(m, s[index(ii, jj, kk)]);
            }
        const std::size_t c = index(i, j, k);
        const double own = static_cast<double>(n[c]) / kNeighbourTrust;
        out[c] = std::max(out[c], 0.5 * m / (1.0 + own));
      }
  return out;
}

std::vector<fragments::DirectionCells> DirectionLearner::uniform() const {
  return std::vector<fragments::DirectionCells>(
      groups_.size(), fragments::DirectionCells(settings_.elevation_cells, settings_.azimuth_cells,
                                                settings_.speed_cells));
}

std::vector<fragments::DirectionCells> DirectionLearner::plan(double hfd_m) const {
  std::vector<fragments::DirectionCells> out;
  int ring_lo = 1, ring_hi = 0;  // empty
  if (ring_used_ && hfd_m > 0.0) {
    ring_lo = distance_bin(0.85 * hfd_m);
    ring_hi = distance_bin(1.15 * hfd_m);
  }
  const auto cells = static_cast<std::size_t>(cells_);
  for (const GroupStats& g : groups_) {
    std::vector<double> a(cells, 0.0);
    const double n = static_cast<double>(g.histories);
    for (std::size_t b = 0; b < buildings_ && n > 0; ++b) {
      const double mean = g.building_mean[b] / n;  // E_p[hit]
      if (!building_used_[b] || !(mean > 0.0)) continue;
      for (std::size_t c = 0; c < cells; ++c)
        if (g.n[c] > 0)
          a[c] += static_cast<double>(g.hits[c * buildings_ + b]) / static_cast<double>(g.n[c]) /
                  (mean * mean);
    }
    double ring_mean = 0.0;
    for (int k = ring_lo; k <= ring_hi; ++k) ring_mean += g.bin_mean[static_cast<std::size_t>(k)];
    if (n > 0) ring_mean /= n;
    if (ring_mean > 0.0) {
      for (std::size_t c = 0; c < cells; ++c) {
        if (g.n[c] == 0) continue;
        double sq = 0.0;
        for (int k = ring_lo; k <= ring_hi; ++k)
          sq += g.ring_sq[c * kDistanceBins + static_cast<std::size_t>(k)];
        a[c] += sq / static_cast<double>(g.n[c]) / (ring_mean * ring_mean);
      }
    }
    for (double& v : a) v = std::sqrt(v);
    a = spread_to_neighbours(a, g.n, g.wraps);
    double total = 0.0;
    for (const double v : a) total += v;
    if (!(total > 0.0) || !std::isfinite(total)) {
      out.emplace_back(settings_.elevation_cells, settings_.azimuth_cells, settings_.speed_cells);
      continue;
    }
    // Trust the learnt shape as far as the evidence goes: with H histories that touched a
    // figure, (1 - delta) H / (H + kEvidence) of the mass follows it.
    const double h = static_cast<double>(g.touching);
    const double delta =
        1.0 - (1.0 - settings_.defensive_fraction) * h / (h + static_cast<double>(kEvidence));
    std::vector<double> q(cells);
    for (std::size_t c = 0; c < cells; ++c)
      q[c] = delta / static_cast<double>(cells) + (1.0 - delta) * a[c] / total;
    out.emplace_back(settings_.elevation_cells, settings_.azimuth_cells, settings_.speed_cells,
                     std::move(q));
  }
  return out;
}

}  // namespace fragsim::run
