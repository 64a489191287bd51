#include "core/run/precision.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace fragsim::run {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

bool selected(const PrecisionSettings& p, const std::string& id) {
  return p.buildings.empty() ||
         std::find(p.buildings.begin(), p.buildings.end(), id) != p.buildings.end();
}

// An HFD target on an HFD that the terrain's boundary cuts. Cut at the band's lower end (the
// field mean - se reaches the boundary): the density there is over the threshold by a standard
// error, and no number of histories brings the HFD inside the model: unmeetable. Cut only at
// the HFD itself or at the band's upper end: not met, as the band is not closed, but more
// histories may narrow it back inside the terrain.
void check_boundary(const PrecisionSnapshot& s, bool cut, TargetStatus& t) {
  if (s.hfd_lower_cut) {
    t.met = false;
    t.unmeetable = true;
    t.note = "the hazardous density reaches the site boundary in " +
             std::to_string(s.hfd_lower_sectors_cut) +
             (s.hfd_lower_sectors_cut == 1 ? " sector" : " sectors") +
             " even at the band's lower end (mean - 1 se): the HFD is a lower bound; extend "
             "the terrain";
  } else if (cut) {
    t.met = false;
    t.note = "the HFD band reaches the site boundary: not met while it does";
  }
}

TargetStatus hfd_target(const PrecisionSettings& p, const PrecisionSnapshot& s) {
  TargetStatus t;
  t.figure = "hfd_half_band_m";
  t.basis = "half_band_m";
  t.value = 0.5 * (s.hfd_upper_m - s.hfd_lower_m);
  double allowed = -kInf;
  if (p.hfd_half_band_m) allowed = std::max(allowed, *p.hfd_half_band_m);
  if (p.hfd_half_band_rel) allowed = std::max(allowed, *p.hfd_half_band_rel * s.hfd_m);
  t.allowed = allowed;
  t.met = t.value <= allowed;
  check_boundary(s, s.hfd_upper_cut, t);  // the band's ends are the mean -+ se fields' HFDs
  return t;
}

TargetStatus building_target(const PrecisionSettings& p, const PrecisionSnapshot& s,
                             const std::string& id, const char* figure, const Estimate& e) {
  TargetStatus t;
  t.figure = figure;
  t.building = id;
  const double abs_allowed = p.building_abs_error ? *p.building_abs_error : -kInf;
  if (e.mean > 0.0) {
    t.basis = "std_error";
    t.value = e.std_error;
    t.allowed = abs_allowed;
    if (p.building_rel_error) t.allowed = std::max(t.allowed, *p.building_rel_error * e.mean);
  } else {
    // Nothing seen: a relative error is undefined, and se = 0 says nothing. Only an absolute
    // target can be met, by the bound on what the histories so far could have missed.
    t.basis = "zero_count_bound";
    t.value = s.zero_count_bound;
    t.allowed = abs_allowed;
  }
  t.met = t.value <= t.allowed;
  return t;
}

}  // namespace

std::vector<TargetStatus> check_targets(const PrecisionSettings& p, const PrecisionSnapshot& s) {
  std::vector<TargetStatus> out;
  if (p.hfd_half_band_m || p.hfd_half_band_rel) out.push_back(hfd_target(p, s));
  if (p.ptn_rel_error_at_hfd) {
    TargetStatus t;
    t.figure = "ptn_rel_error_at_hfd";
    t.basis = "rel_error";
    t.value = s.ptn_rel_error_at_hfd;
    t.allowed = *p.ptn_rel_error_at_hfd;
    t.met = t.value <= t.allowed;
    check_boundary(s, s.hfd_cut, t);
    out.push_back(t);
  }
  if (p.building_rel_error || p.building_abs_error) {
    for (const auto& b : s.buildings) {
      if (!selected(p, b.id)) continue;
      out.push_back(building_target(p, s, b.id, "building_impacts", b.impacts));
      out.push_back(building_target(p, s, b.id, "building_penetrations", b.penetrations));
    }
  }
  return out;
}

double ptn_rel_error_near_hfd(const std::vector<double>& density, const std::vector<double>& se,
                              const std::vector<double>& distance_m, double threshold,
                              double hfd_m) {
  if (!(hfd_m > 0.0)) return 0.0;
  double sum = 0.0;
  std::int64_t n = 0;
  for (std::size_t t = 0; t < density.size(); ++t) {
    if (!(density[t] >= threshold) || density[t] <= 0.0) continue;
    if (distance_m[t] < 0.95 * hfd_m) continue;
    const double rel = se[t] / density[t];
    sum += rel * rel;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

double ring_participation(const std::vector<double>& density, const std::vector<double>& distance_m,
                          double hfd_m) {
  double sum = 0.0, sum_sq = 0.0;
  for (std::size_t t = 0; t < density.size(); ++t) {
    if (!(distance_m[t] >= kRingInner * hfd_m && distance_m[t] <= kRingOuter * hfd_m)) continue;
    sum += density[t];
    sum_sq += density[t] * density[t];
  }
  return hfd_m > 0.0 && sum_sq > 0.0 ? std::max(1.0, sum * sum / sum_sq) : 1.0;
}

namespace {

// Least-squares slope of y on x; NaN with fewer than two distinct x.
double fitted_slope(const std::vector<std::pair<double, double>>& pts) {
  const double n = static_cast<double>(pts.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const auto& [x, y] : pts) {
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  const double den = n * sxx - sx * sx;
  if (!(den > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return (n * sxy - sx * sy) / den;
}

}  // namespace

PrecisionReport PrecisionTracker::update(std::vector<TargetStatus> targets, std::int64_t batches,
                                         std::int64_t histories, double histories_per_s) {
  PrecisionReport r;
  r.batches = batches;
  r.histories = histories;
  r.all_met = true;
  points_.resize(targets.size());
  const double n = static_cast<double>(histories);
  std::vector<double> exponents;
  for (std::size_t k = 0; k < targets.size(); ++k) {
    TargetStatus& t = targets[k];
    if (t.value > 0.0 && std::isfinite(t.value) && n > 0.0)
      points_[k].emplace_back(std::log(n), std::log(t.value));
    if (t.met) {
      t.histories_needed = n;
      continue;
    }
    r.all_met = false;
    r.any_unmeetable = r.any_unmeetable || t.unmeetable;
    if (!(t.allowed > 0.0) || t.unmeetable || !t.note.empty()) {
      t.histories_needed = kInf;
      continue;
    }
    double alpha = 0.5;
    if (points_[k].size() >= 3) {
      const double slope = fitted_slope(points_[k]);
      if (std::isfinite(slope)) alpha = std::clamp(-slope, 0.25, 1.0);
    }
    exponents.push_back(alpha);
    t.histories_needed = n * std::pow(t.value / t.allowed, 1.0 / alpha);
  }
  for (const auto& t : targets)
    r.histories_needed = std::max(r.histories_needed, t.histories_needed);
  if (!exponents.empty()) {
    std::nth_element(exponents.begin(), exponents.begin() + exponents.size() / 2, exponents.end());
    r.decay_exponent = exponents[exponents.size() / 2];
  }
  if (r.all_met) {
    r.eta_s = 0.0;
  } else if (std::isfinite(r.histories_needed) && histories_per_s > 0.0) {
    r.eta_s = std::max(0.0, r.histories_needed - n) / histories_per_s;
  } else {
    r.eta_s = kInf;
  }
  r.targets = std::move(targets);
  return r;
}

}  // namespace fragsim::run
