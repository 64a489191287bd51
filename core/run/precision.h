#pragma once
// Precision targets (settings.precision, docs/precision.md): at each batch boundary the run's
// estimates are checked against the requested targets; the run stops at the first boundary where
// all hold (after min_batches), or at a cap. The check is a pure function of the folded
// estimates, so where a run stops never depends on the thread count.
#include <cstdint>
#include <string>
#include <vector>

#include "core/run/result.h"
#include "core/run/scenario.h"

namespace fragsim::run {

// The estimates a target looks at, after `batches` batches (`histories` histories).
struct PrecisionSnapshot {
  std::int64_t batches = 0;
  std::int64_t histories = 0;
  double hfd_m = 0.0, hfd_lower_m = 0.0, hfd_upper_m = 0.0;
  // The terrain's boundary cuts the HFD of the field mean, mean - se (the band's lower end,
  // in `hfd_lower_sectors_cut` sectors), mean + se (core/run/hfd.h).
  bool hfd_cut = false, hfd_lower_cut = false, hfd_upper_cut = false;
  int hfd_lower_sectors_cut = 0;
  double ptn_rel_error_at_hfd = 0.0;  // see ptn_rel_error_near_hfd
  double ring_triangles = 1.0;        // see ring_participation
  struct Building {
    std::string id;
    Estimate impacts, penetrations;
  };
  std::vector<Building> buildings;  // all buildings of the site, in site order
  // 95 % upper bound on the expected real fragments of a figure that no history has touched
  // yet: sum over groups of 3 count_g / n_g (the "rule of three", -ln 0.05 = 3.0).
  double zero_count_bound = 0.0;
};

// One checked figure.
struct TargetStatus {
  std::string figure;    // hfd_half_band_m, ptn_rel_error_at_hfd, building_impacts, ...
  std::string building;  // building figures: the building's id
  // What `value` is: "std_error" (real fragments), "half_band_m", "rel_error", or
  // "zero_count_bound" for a building figure no history has touched (value: the bound).
  std::string basis;
  double value = 0.0;
  double allowed = 0.0;  // met when value <= allowed
  bool met = false;
  // Histories the run would need for this figure, extrapolated from its observed error decay
  // (PrecisionTracker); equal to the current histories when met; +inf when it cannot be met.
  double histories_needed = 0.0;
  // An HFD target on an HFD the terrain's boundary cuts even at the band's lower end: more
  // histories cannot make a lower bound a value (docs/precision.md).
  bool unmeetable = false;
  std::string note;  // why a target is unmeetable, or not met whatever its value
};

struct PrecisionReport {
  std::int64_t batches = 0;
  std::int64_t histories = 0;
  std::vector<TargetStatus> targets;
  bool all_met = false;
  bool any_unmeetable = false;
  double histories_needed = 0.0;  // the largest over the targets
  double eta_s = 0.0;             // to histories_needed at the observed rate (+inf: not reachable)
  double decay_exponent = 0.5;    // fitted error ~ n^-alpha (median over unmet targets)
  // Nothing more histories could change: every target met or unmeetable, some unmeetable.
  bool all_met_or_unmeetable() const {
    if (!any_unmeetable) return false;
    for (const auto& t : targets)
      if (!t.met && !t.unmeetable) return false;
    return true;
  }
};

// Checks every requested target against a snapshot (histories_needed left at 0).
std::vector<TargetStatus> check_targets(const PrecisionSettings& p, const PrecisionSnapshot& s);

// Root mean square of se/density over the hazardous triangles (density >= threshold) whose
// centroid lies within the outer 5 % of the HFD (distance >= 0.95 HFD): how well the density is
// known where it crosses the threshold. 0 when no triangle is hazardous.
double ptn_rel_error_near_hfd(const std::vector<double>& density, const std::vector<double>& se,
                              const std::vector<double>& distance_m, double threshold,
                              double hfd_m);

// The ring of triangles whose density decides the HFD, as the importance learner aims at it:
// centroid distance within [kRingInner, kRingOuter] x HFD.
inline constexpr double kRingInner = 0.85, kRingOuter = 1.15;

// How many terrain triangles share the density of the ring whose centroids lie within
// [kRingInner, kRingOuter] HFD (the importance learner's ring, core/run/importance.h): the
// participation ratio (sum density)^2 / sum density^2 over them, which is T for T triangles of
// equal density and less where a few hold most of it. 1 when the ring holds no density (or hfd_m is
// 0).
double ring_participation(const std::vector<double>& density, const std::vector<double>& distance_m,
                          double hfd_m);

// Turns successive checks into a report with an ETA: each figure's error is fitted as
// c * n^-alpha over its checks so far (least squares in log-log, alpha clamped to [0.25, 1];
// 0.5, the Monte Carlo rate, until three checks are available), and extrapolated to its target.
class PrecisionTracker {
 public:
  PrecisionReport update(std::vector<TargetStatus> targets, std::int64_t batches,
                         std::int64_t histories, double histories_per_s);

 private:
  std::vector<std::vector<std::pair<double, double>>> points_;  // per target: (log n, log value)
};

}  // namespace fragsim::run
