#include "core/fragments/direction_cells.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>

namespace fragsim::fragments {

DirectionCells::DirectionCells(int n_elevation, int n_azimuth, int n_speed)
    : n_e_(std::max(1, n_elevation)), n_a_(std::max(1, n_azimuth)), n_s_(std::max(1, n_speed)) {}

DirectionCells::DirectionCells(int n_elevation, int n_azimuth, int n_speed, std::vector<double> q)
    : DirectionCells(n_elevation, n_azimuth, n_speed) {
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

double DirectionCells::probability(std::uint32_t cell) const {
  return q_.empty() ? 1.0 / cells() : q_[cell];
}

std::uint32_t DirectionCells::cell_of(double u_elevation, double u_azimuth, double u_speed) const {
  const int i = std::clamp(static_cast<int>(u_elevation * n_e_), 0, n_e_ - 1);
  const int j = std::clamp(static_cast<int>(u_azimuth * n_a_), 0, n_a_ - 1);
  const int k = std::clamp(static_cast<int>(u_speed * n_s_), 0, n_s_ - 1);
  return static_cast<std::uint32_t>((i * n_a_ + j) * n_s_ + k);
}

DirectionCells::Draw DirectionCells::draw(double u_elevation, double u_azimuth, double u_speed,
                                          double u_cell) const {
  Draw d;
  if (q_.empty()) {
    d.u_elevation = u_elevation;
    d.u_azimuth = u_azimuth;
    d.u_speed = u_speed;
    d.cell = cell_of(u_elevation, u_azimuth, u_speed);
    return d;
  }
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u_cell);
  const auto c = static_cast<std::uint32_t>(
      std::min<std::ptrdiff_t>(it - cdf_.begin(), static_cast<std::ptrdiff_t>(cdf_.size()) - 1));
  const int k = static_cast<int>(c) % n_s_, ij = static_cast<int>(c) / n_s_;
  const int i = ij / n_a_, j = ij % n_a_;
  d.u_elevation = (i + u_elevation) / n_e_;
  d.u_azimuth = (j + u_azimuth) / n_a_;
  d.u_speed = (k + u_speed) / n_s_;
  d.likelihood_ratio = (1.0 / cells()) / q_[c];
  d.cell = c;
  return d;
}

}  // namespace fragsim::fragments
