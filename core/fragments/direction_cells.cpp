#include "core/fragments/direction_cells.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace fragsim::fragments {

DirectionCells::DirectionCells(int n_elevation, int n_azimuth, int n_speed, int n_mass)
    : n_e_(std::max(1, n_elevation)),
      n_a_(std::max(1, n_azimuth)),
      n_s_(std::max(1, n_speed)),
      n_m_(std::max(1, n_mass)) {}

DirectionCells::DirectionCells(int n_elevation, int n_azimuth, int n_speed, int n_mass,
                               std::vector<double> q)
    : DirectionCells(n_elevation, n_azimuth, n_speed, n_mass) {
  if (q.size() != static_cast<std::size_t>(cells()))
    throw std::invalid_argument("DirectionCells: q has the wrong size");
  const double total = std::accumulate(q.begin(), q.end(), 0.0);
  if (!(total > 0.0) || std::any_of(q.begin(), q.end(), [](double v) { return !(v > 0.0); }))
    throw std::invalid_argument("DirectionCells: every q must be > 0");
  q_ = std::move(q);
  for (double& v : q_) v /= total;
  cdf_.resize(q_.size());
  std::partial_sum(q_.begin(), q_.end(), cdf_.begin());
  cdf_.back() = 1.0;
}

DirectionCells DirectionCells::equal(int n_elevation, int n_azimuth, int n_speed, int n_mass) {
  const DirectionCells shape(n_elevation, n_azimuth, n_speed, n_mass);
  return DirectionCells(shape.n_e_, shape.n_a_, shape.n_s_, shape.n_m_,
                        std::vector<double>(static_cast<std::size_t>(shape.cells()), 1.0));
}

// More strata than this share cells (each cell still gets its share of u_cell): 4 MB of q and
// cumulative q per group at most.
constexpr std::int64_t kMaxCells = 1 << 18;

DirectionCells DirectionCells::for_strata(std::int64_t strata, const DirectionSpec& d,
                                          bool with_speed) {
  const double j = static_cast<double>(std::clamp<std::int64_t>(strata, 1, kMaxCells));
  // Extents on the unit sphere: elevation E (rad), and azimuth (rad) times the band's mean
  // cos(elevation), (sin hi - sin lo) / E (the zone's area over E; 1 for a flat fan). A range
  // of zero width gets one cell; speed, when stratified, as many cells as elevation (azimuth
  // for a flat fan).
  const double e = std::abs(d.elevation_max_deg - d.elevation_min_deg) * kDegToRad;
  const double s_span = std::abs(std::sin(d.elevation_max_deg * kDegToRad) -
                                 std::sin(d.elevation_min_deg * kDegToRad));
  const double a =
      std::abs(d.azimuth_max_deg - d.azimuth_min_deg) * kDegToRad * (e > 1e-9 ? s_span / e : 1.0);
  const double ext_e = e > 1e-9 ? e : 0.0, ext_a = a > 1e-9 ? a : 0.0;
  const double ext_s = !with_speed ? 0.0 : ext_e > 0.0 ? ext_e : ext_a > 0.0 ? ext_a : 1.0;
  double product = 1.0;
  int free = 0;
  for (const double x : {ext_e, ext_a, ext_s})
    if (x > 0.0) {
      product *= x;
      ++free;
    }
  if (free == 0) return equal(1, 1, 1);
  // n = k * extent for every free dimension, their product j; rounded down, the last free
  // dimension then takes what is left.
  const double k = std::pow(j / product, 1.0 / free);
  auto cells_for = [k](double x) { return x > 0.0 ? std::max(1, static_cast<int>(k * x)) : 1; };
  int n_e = cells_for(ext_e), n_a = cells_for(ext_a), n_s = cells_for(ext_s);
  if (ext_s > 0.0)
    n_s = std::max(1, static_cast<int>(j / (static_cast<double>(n_e) * n_a)));
  else if (ext_a > 0.0)
    n_a = std::max(1, static_cast<int>(j / static_cast<double>(n_e)));
  return equal(n_e, n_a, n_s);
}

double DirectionCells::probability(std::uint32_t cell) const {
  return q_.empty() ? 1.0 / cells() : q_[cell];
}

std::uint32_t DirectionCells::cell_of(double u_elevation, double u_azimuth, double u_speed,
                                      double u_mass) const {
  const int i = std::clamp(static_cast<int>(u_elevation * n_e_), 0, n_e_ - 1);
  const int j = std::clamp(static_cast<int>(u_azimuth * n_a_), 0, n_a_ - 1);
  const int k = std::clamp(static_cast<int>(u_speed * n_s_), 0, n_s_ - 1);
  const int l = std::clamp(static_cast<int>(u_mass * n_m_), 0, n_m_ - 1);
  return static_cast<std::uint32_t>(((i * n_a_ + j) * n_s_ + k) * n_m_ + l);
}

DirectionCells::Draw DirectionCells::draw(double u_elevation, double u_azimuth, double u_speed,
                                          double u_cell, double u_mass) const {
  Draw d;
  if (q_.empty()) {
    d.u_elevation = u_elevation;
    d.u_azimuth = u_azimuth;
    d.u_speed = u_speed;
    d.u_mass = u_mass;
    d.cell = cell_of(u_elevation, u_azimuth, u_speed, u_mass);
    return d;
  }
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u_cell);
  const auto c = static_cast<std::uint32_t>(
      std::min<std::ptrdiff_t>(it - cdf_.begin(), static_cast<std::ptrdiff_t>(cdf_.size()) - 1));
  const int ci = static_cast<int>(c);
  const int l = ci % n_m_, k = ci / n_m_ % n_s_, ij = ci / n_m_ / n_s_;
  const int i = ij / n_a_, j = ij % n_a_;
  d.u_elevation = (i + u_elevation) / n_e_;
  d.u_azimuth = (j + u_azimuth) / n_a_;
  d.u_speed = (k + u_speed) / n_s_;
  d.u_mass = (l + u_mass) / n_m_;
  d.likelihood_ratio = (1.0 / cells()) / q_[c];
  d.cell = c;
  return d;
}

DirectionCells::Draw DirectionCells::draw_filling(double u_elevation, double u_speed, double u_cell,
                                                  double u_mass) const {
  if (q_.empty()) throw std::logic_error("DirectionCells::draw_filling needs cell probabilities");
  Draw d = draw(u_elevation, 0.5, u_speed, u_cell, u_mass);
  const double lo = d.cell == 0 ? 0.0 : cdf_[d.cell - 1];
  const double f = (u_cell - lo) / (cdf_[d.cell] - lo);
  const int j = static_cast<int>(d.cell) / n_m_ / n_s_ % n_a_;
  d.u_azimuth = (j + std::clamp(f, 0.0, std::nextafter(1.0, 0.0))) / n_a_;
  return d;
}

}  // namespace fragsim::fragments
