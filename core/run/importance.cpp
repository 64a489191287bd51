#include "core/run/importance.h"

#include <algorithm>
#include <cmath>

#include "core/common/error.h"
#include "core/fragments/sampling.h"
#include "core/run/precision.h"

namespace fragsim::run {

DirectionLearner::DirectionLearner(const Scenario& sc, const scene::Site& site,
                                   std::vector<double> distance_m)
    : settings_(*sc.settings.precision->direction_importance),
      cells_(settings_.elevation_cells * settings_.azimuth_cells * settings_.speed_cells *
             settings_.mass_cells),
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
    g.neighbours = neighbour_lists(g.wraps);
    g.n.assign(static_cast<std::size_t>(cells_), 0);
    g.hits.assign(static_cast<std::size_t>(cells_) * buildings_, 0);
    g.building_mean.assign(buildings_, 0.0);
    if (ring_used_) {
      g.ring_sq.assign(static_cast<std::size_t>(cells_) * kDistanceBins, 0.0);
      g.bin_mean.assign(kDistanceBins, 0.0);
    }
    prior_.push_back(site_prior(sc.groups[k], site, g.wedge));
  }
}

namespace {

// Azimuths (rad, site axes) as an interval centre +- half.
struct AzimuthSpan {
  double centre = 0.0, half = kPi;  // the default: every azimuth
  bool overlaps(const AzimuthSpan& o) const {
    return std::abs(std::remainder(centre - o.centre, 2.0 * kPi)) <= half + o.half;
  }
};

// The span of the horizontal directions from `origin` to the points, about the direction to
// `toward`; every azimuth when a point is within 1 m of the origin horizontally.
template <class Points>
AzimuthSpan span_of(const Points& points, const Vec3& origin, const Vec3& toward) {
  const double c = std::atan2(toward.y() - origin.y(), toward.x() - origin.x());
  double lo = 0.0, hi = 0.0;
  for (const Vec3& p : points) {
    const double dx = p.x() - origin.x(), dy = p.y() - origin.y();
    if (std::hypot(dx, dy) < 1.0) return {};
    const double d = std::remainder(std::atan2(dy, dx) - c, 2.0 * kPi);
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  return {c + 0.5 * (lo + hi), 0.5 * (hi - lo)};
}

std::vector<Vec3> building_points(const scene::Site& site, const scene::Building& b) {
  std::vector<Vec3> out;
  for (std::uint32_t t = b.first_triangle; t < b.first_triangle + b.triangle_count; ++t)
    for (const std::uint32_t v : site.building_triangles()[t].v)
      out.push_back(site.building_vertices()[v]);
  return out;
}

// The site azimuths of the launch velocities from direction cell (i, j) of the group, at the
// group's median speed: the span of its corners and centre (every azimuth when one of them is
// vertical).
AzimuthSpan cell_span(const fragments::FragmentGroupSpec& g, int i, int j, int ne, int na) {
  const Mat3 rot = fragments::frame_rotation(g.frame);
  const double speed =
      g.speed_mps.sample(0.5, fragments::kSpeedRange.lo, fragments::kSpeedRange.hi);
  std::vector<Vec3> ends;
  for (const double fe : {0.0, 0.5, 1.0})
    for (const double fa : {0.0, 0.5, 1.0}) {
      const Vec3 v =
          speed * (rot * fragments::sample_direction(g.direction, (i + fe) / ne, (j + fa) / na)) +
          g.frame.velocity_mps;
      if (std::hypot(v.x(), v.y()) <= 1e-9 * (v.norm() + 1.0)) return {};
      ends.push_back(v);
    }
  return span_of(ends, Vec3::Zero(), ends[4]);  // ends[4]: the centre
}

}  // namespace

std::vector<double> DirectionLearner::site_prior(const fragments::FragmentGroupSpec& group,
                                                 const scene::Site& site,
                                                 std::vector<std::vector<char>>& wedges) const {
  const int ne = settings_.elevation_cells, na = settings_.azimuth_cells;
  const int inner = settings_.speed_cells * settings_.mass_cells;
  std::vector<AzimuthSpan> cells;
  for (int i = 0; i < ne; ++i)
    for (int j = 0; j < na; ++j) cells.push_back(cell_span(group, i, j, ne, na));
  const Vec3 origin = site.to_local(group.frame.origin_m);
  std::vector<double> w(cells.size(), ring_used_ ? 1.0 / static_cast<double>(cells.size()) : 0.0);
  wedges.assign(buildings_, {});
  for (std::size_t b = 0; b < buildings_; ++b) {
    if (!building_used_[b]) continue;
    wedges[b].assign(cells.size(), 0);
    const scene::Building& bd = site.buildings()[b];
    const AzimuthSpan span =
        span_of(building_points(site, bd), origin, 0.5 * (bd.bounds.lo + bd.bounds.hi));
    std::vector<std::size_t> hit;
    for (std::size_t c = 0; c < cells.size(); ++c)
      if (cells[c].overlaps(span)) hit.push_back(c);
    for (const std::size_t c : hit) {
      w[c] += 1.0 / static_cast<double>(hit.size());
      wedges[b][c] = 1;
    }
  }
  std::vector<double> out;
  out.reserve(cells.size() * static_cast<std::size_t>(inner));
  for (const double v : w) out.insert(out.end(), static_cast<std::size_t>(inner), v);
  return out;
}

int DirectionLearner::distance_bin(double d_m) {
  static const double kLogStep = std::log(1.05);
  const double b = std::log(std::max(d_m, 1.0)) / kLogStep;
  return std::clamp(static_cast<int>(b), 0, kDistanceBins - 1);
}

void LearnerInput::clear() {
  group.clear();
  cell.clear();
  likelihood_ratio.clear();
  building.clear();
  contributed.clear();
  entries_end.clear();
  bin.clear();
  x.clear();
}

void DirectionLearner::add(std::uint32_t group, std::uint32_t cell, double likelihood_ratio,
                           std::int32_t building, const PtnContribution* begin,
                           const PtnContribution* end) {
  reduce(likelihood_ratio, begin, end, entries_);
  apply(group, cell, likelihood_ratio, building, begin != end, entries_.data(),
        entries_.data() + entries_.size());
}

void DirectionLearner::observe(std::uint32_t group, std::uint32_t cell, double likelihood_ratio,
                               std::int32_t building, const PtnContribution* begin,
                               const PtnContribution* end, LearnerInput& out) {
  reduce(likelihood_ratio, begin, end, entries_);
  out.group.push_back(group);
  out.cell.push_back(cell);
  out.likelihood_ratio.push_back(likelihood_ratio);
  out.building.push_back(building);
  out.contributed.push_back(begin != end ? 1 : 0);
  for (const auto& [bin, x] : entries_) {
    out.bin.push_back(bin);
    out.x.push_back(x);
  }
  out.entries_end.push_back(static_cast<std::uint32_t>(out.bin.size()));
}

void DirectionLearner::replay(const LearnerInput& in) {
  const std::size_t n = in.size();
  if (in.cell.size() != n || in.likelihood_ratio.size() != n || in.building.size() != n ||
      in.contributed.size() != n || in.entries_end.size() != n || in.x.size() != in.bin.size())
    throw InputError("learner input", "arrays of different lengths");
  std::uint32_t first = 0;
  for (std::size_t h = 0; h < n; ++h) {
    const std::uint32_t last = in.entries_end[h];
    if (in.group[h] >= groups_.size() || in.cell[h] >= static_cast<std::uint32_t>(cells_) ||
        in.building[h] >= static_cast<std::int32_t>(buildings_) || in.building[h] < -1 ||
        last < first || last > in.bin.size() || (last > first && !ring_used_))
      throw InputError("learner input", "a history out of range");
    entries_.clear();
    for (std::uint32_t k = first; k < last; ++k) {
      if (in.bin[k] >= kDistanceBins) throw InputError("learner input", "a bin out of range");
      entries_.emplace_back(in.bin[k], in.x[k]);
    }
    apply(in.group[h], in.cell[h], in.likelihood_ratio[h], in.building[h], in.contributed[h] != 0,
          entries_.data(), entries_.data() + entries_.size());
    first = last;
  }
}

// Each PTN contribution's x without the likelihood ratio (the density under the group's own p),
// with its distance bin, in the history's order: one entry per triangle (the fold keeps a
// triangle's first crossing only), so the squares the learner sums are per triangle, as the
// target's figure (the relative error of each triangle's density) needs.
void DirectionLearner::reduce(double likelihood_ratio, const PtnContribution* begin,
                              const PtnContribution* end,
                              std::vector<std::pair<std::uint16_t, double>>& entries) {
  entries.clear();
  if (!ring_used_) return;
  for (const PtnContribution* c = begin; c != end; ++c)
    entries.emplace_back(static_cast<std::uint16_t>(distance_bin(distance_m_[c->triangle])),
                         c->value / likelihood_ratio);
}

void DirectionLearner::apply(std::uint32_t group, std::uint32_t cell, double likelihood_ratio,
                             std::int32_t building, bool contributed,
                             const std::pair<std::uint16_t, double>* begin,
                             const std::pair<std::uint16_t, double>* end) {
  GroupStats& g = groups_[group];
  ++g.histories;
  ++g.n[cell];
  if ((building >= 0 && building_used_[static_cast<std::size_t>(building)]) ||
      (ring_used_ && contributed))
    ++g.touching;
  if (building >= 0) {
    const auto b = static_cast<std::size_t>(building);
    ++g.hits[cell * buildings_ + b];
    g.building_mean[b] += likelihood_ratio;
  }
  for (const auto* e = begin; e != end; ++e) {
    const double x = e->second;
    g.ring_sq[cell * static_cast<std::size_t>(kDistanceBins) + e->first] += x * x;
    g.bin_mean[e->first] += likelihood_ratio * x;
  }
}

// Each cell's neighbourhood: itself and the cells within one step in each of the four
// dimensions (azimuth wraps round when the range is the full circle).
std::vector<std::vector<std::uint32_t>> DirectionLearner::neighbour_lists(bool wraps) const {
  const int ne = settings_.elevation_cells, na = settings_.azimuth_cells,
            ns = settings_.speed_cells, nm = settings_.mass_cells;
  auto index = [&](int i, int j, int k, int l) {
    return static_cast<std::uint32_t>(((i * na + j) * ns + k) * nm + l);
  };
  std::vector<std::vector<std::uint32_t>> out(static_cast<std::size_t>(cells_));
  for (int i = 0; i < ne; ++i)
    for (int j = 0; j < na; ++j)
      for (int k = 0; k < ns; ++k)
        for (int l = 0; l < nm; ++l) {
          std::vector<std::uint32_t>& list = out[index(i, j, k, l)];
          for (int ii = std::max(0, i - 1); ii <= std::min(ne - 1, i + 1); ++ii)
            for (int dj = -1; dj <= 1; ++dj) {
              int jj = j + dj;
              if (jj < 0 || jj >= na) {
                if (!wraps) continue;
                jj = (jj + na) % na;
              }
              for (int kk = std::max(0, k - 1); kk <= std::min(ns - 1, k + 1); ++kk)
                for (int ll = std::max(0, l - 1); ll <= std::min(nm - 1, l + 1); ++ll)
                  list.push_back(index(ii, jj, kk, ll));
            }
          std::sort(list.begin(), list.end());
          list.erase(std::unique(list.begin(), list.end()), list.end());
        }
  return out;
}

std::vector<double> DirectionLearner::spread_to_neighbours(const std::vector<double>& s,
                                                           const GroupStats& g) const {
  // Up to half of each cell's weight reaches its neighbours: a figure seen in one cell is often
  // also in the next, and a cell holding part of it that few histories have visited would
  // otherwise get only the defensive share. The floor fades as the cell's own histories show
  // what it holds.
  std::vector<double> out(s);
  for (std::size_t c = 0; c < out.size(); ++c) {
    double m = 0.0;
    for (const std::uint32_t nb : g.neighbours[c]) m = std::max(m, s[nb]);
    const double own = static_cast<double>(g.n[c]) / kNeighbourTrust;
    out[c] = std::max(out[c], 0.5 * m / (1.0 + own));
  }
  return out;
}

// Per cell, a sum over its histories turned into a per-history value shrunk toward its
// neighbourhood's (empirical Bayes):
//   (own_c + A bar_c) / (n_c + A),  bar_c = sum of own / sum of histories over the neighbourhood,
// A = kPriorHistories. A cell at the edge of a figure's region, where the figure is rarer and may
// not have been seen yet, keeps a value in proportion to what its neighbours show (instead of
// only the defensive share, whose histories would carry likelihood ratios of 1/delta); a cell no
// history has visited takes its neighbourhood's value.
std::vector<double> DirectionLearner::shrunk_to_neighbourhood(
    const GroupStats& g, const std::vector<double>& own) const {
  std::vector<double> out(own.size(), 0.0);
  for (std::size_t c = 0; c < own.size(); ++c) {
    double sum = 0.0, n = 0.0;
    for (const std::uint32_t nb : g.neighbours[c]) {
      sum += own[nb];
      n += static_cast<double>(g.n[nb]);
    }
    const double bar = n > 0.0 ? sum / n : 0.0;
    out[c] = (own[c] + kPriorHistories * bar) / (static_cast<double>(g.n[c]) + kPriorHistories);
  }
  return out;
}

// E[sum_t x_t^2 | c] over the ring's bins [lo, hi], shrunk as the buildings' hit rates are: a few
// per cent of the histories reach the ring, so a cell's own sum rests on a handful of them.
std::vector<double> DirectionLearner::ring_second_moments(const GroupStats& g, int lo,
                                                          int hi) const {
  std::vector<double> own(static_cast<std::size_t>(cells_), 0.0);
  for (std::size_t c = 0; c < own.size(); ++c)
    for (int k = lo; k <= hi; ++k)
      own[c] += g.ring_sq[c * kDistanceBins + static_cast<std::size_t>(k)];
  return shrunk_to_neighbourhood(g, own);
}

// A building's hit rate per cell, shrunk toward its neighbourhood's rate.
std::vector<double> DirectionLearner::smoothed_hit_rates(const GroupStats& g,
                                                         std::size_t building) const {
  std::vector<double> hits(static_cast<std::size_t>(cells_), 0.0);
  for (std::size_t c = 0; c < hits.size(); ++c)
    hits[c] = static_cast<double>(g.hits[c * buildings_ + building]);
  return shrunk_to_neighbourhood(g, hits);
}

// A building's hit rates for the plan: the learnt rates (smoothed_hit_rates) blended with the
// rate spread evenly over the cells facing the building (its wedge, from the site as for the
// pilot) in proportion to the evidence,
//   r_c = lambda r_learnt,c + (1 - lambda) r_wedge [c faces b],   r_wedge = E_p[hit] N / N_wedge,
//   lambda = H / (H + kBuildingEvidence),  H = the group's hits of the building so far.
// Both parts hold the same expected hits (sum_c r_c / N = E_p[hit]). A pilot with a handful of
// hits of a rare building (one, for the demo's B08) then does not concentrate the next batch on
// their neighbourhoods, where a hit from a facing cell outside them carried a likelihood ratio
// of 1/delta, hundreds of times the others' (docs/precision.md, "Learning q").
std::vector<double> DirectionLearner::building_rates(const GroupStats& g, std::size_t building,
                                                     double mean) const {
  std::vector<double> r = smoothed_hit_rates(g, building);
  const std::vector<char>& wedge = g.wedge[building];
  const auto inner = static_cast<std::size_t>(settings_.speed_cells * settings_.mass_cells);
  double facing = 0.0;
  for (const char f : wedge) facing += f ? static_cast<double>(inner) : 0.0;
  if (!(facing > 0.0)) return r;
  double hits = 0.0;
  for (std::size_t c = 0; c < r.size(); ++c)
    hits += static_cast<double>(g.hits[c * buildings_ + building]);
  const double lambda = hits / (hits + kBuildingEvidence);
  const double r_wedge = mean * static_cast<double>(cells_) / facing;
  for (std::size_t c = 0; c < r.size(); ++c)
    r[c] = lambda * r[c] + (wedge[c / inner] ? (1.0 - lambda) * r_wedge : 0.0);
  return r;
}

std::vector<fragments::DirectionCells> DirectionLearner::uniform() const {
  return std::vector<fragments::DirectionCells>(
      groups_.size(), fragments::DirectionCells(settings_.elevation_cells, settings_.azimuth_cells,
                                                settings_.speed_cells, settings_.mass_cells));
}

std::vector<fragments::DirectionCells> DirectionLearner::pilot() const {
  std::vector<fragments::DirectionCells> out;
  for (const std::vector<double>& prior : prior_)
    out.push_back(mixture(prior, settings_.defensive_fraction));
  return out;
}

fragments::DirectionCells DirectionLearner::mixture(const std::vector<double>& s,
                                                    double delta) const {
  const auto cells = static_cast<std::size_t>(cells_);
  double total = 0.0;
  for (const double v : s) total += v;
  if (!(total > 0.0) || !std::isfinite(total))  // nothing to follow: the group's own density
    return {settings_.elevation_cells, settings_.azimuth_cells, settings_.speed_cells,
            settings_.mass_cells};
  std::vector<double> q(cells);
  for (std::size_t c = 0; c < cells; ++c)
    q[c] = delta / static_cast<double>(cells) + (1.0 - delta) * s[c] / total;
  return {settings_.elevation_cells, settings_.azimuth_cells, settings_.speed_cells,
          settings_.mass_cells, std::move(q)};
}

std::vector<fragments::DirectionCells> DirectionLearner::plan(double hfd_m,
                                                              double ring_triangles) const {
  std::vector<fragments::DirectionCells> out;
  int ring_lo = 1, ring_hi = 0;  // empty
  if (ring_used_ && hfd_m > 0.0) {
    ring_lo = distance_bin(kRingInner * hfd_m);
    ring_hi = distance_bin(kRingOuter * hfd_m);
  }
  const auto cells = static_cast<std::size_t>(cells_);
  for (const GroupStats& g : groups_) {
    std::vector<double> a(cells, 0.0);
    const double n = static_cast<double>(g.histories);
    for (std::size_t b = 0; b < buildings_ && n > 0; ++b) {
      const double mean = g.building_mean[b] / n;  // E_p[hit]
      if (!building_used_[b] || !(mean > 0.0)) continue;
      const std::vector<double> rate = building_rates(g, b, mean);
      for (std::size_t c = 0; c < cells; ++c) a[c] += rate[c] / (mean * mean);
    }
    double ring_mean = 0.0;
    for (int k = ring_lo; k <= ring_hi; ++k) ring_mean += g.bin_mean[static_cast<std::size_t>(k)];
    if (n > 0) ring_mean /= n;
    if (ring_mean > 0.0) {
      // The mean over the ring's triangles of E[x_t^2 | c] / E[x_t]^2: with the ring's density
      // spread over T triangles, E[x_t] = E[x_ring] / T, so it is T sum_t E[x_t^2 | c] /
      // E[x_ring]^2 (docs/precision.md, "Learning q").
      const double per_triangle = std::max(1.0, ring_triangles) / (ring_mean * ring_mean);
      const std::vector<double> sq = ring_second_moments(g, ring_lo, ring_hi);
      for (std::size_t c = 0; c < cells; ++c) a[c] += sq[c] * per_triangle;
    }
    for (double& v : a) v = std::sqrt(v);
    a = spread_to_neighbours(a, g);
    // Trust the learnt shape as far as the evidence goes: with H histories that touched a
    // figure, (1 - delta) H / (H + kEvidence) of the mass follows it.
    const double h = static_cast<double>(g.touching);
    out.push_back(mixture(
        a, 1.0 - (1.0 - settings_.defensive_fraction) * h / (h + static_cast<double>(kEvidence))));
  }
  return out;
}

}  // namespace fragsim::run
