#include "core/run/precision_control.h"

namespace fragsim::run {

PrecisionControl::PrecisionControl(const Scenario& sc, const scene::Site& site,
                                   const PartialRun& tallies)
    : sc_(sc), site_(site), tallies_(tallies), bins_(tally_bins(sc, site)) {
  if (!sc.settings.precision) return;
  p_ = &*sc.settings.precision;
  if (p_->hfd_half_band_m || p_->hfd_half_band_rel || p_->ptn_rel_error_at_hfd ||
      p_->direction_importance)
    geometry_.emplace(site, site.to_local(hfd_origin_input(sc, site)), true);
}

bool PrecisionControl::batch_done(std::int64_t batches, std::int64_t tallied,
                                  std::int64_t histories_run, double elapsed) {
  if (p_ == nullptr) return true;  // one batch
  if (tallied == 0) {  // the pilot: nothing to check yet; its density places the first ring
    if (wants_pilot_density()) pilot_ring();
    return false;
  }
  const std::int64_t histories = tallies_.histories_done;
  const PrecisionSnapshot snap = snapshot(tallied);
  hfd_m_ = snap.hfd_m;
  ring_triangles_ = snap.ring_triangles;
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

bool PrecisionControl::wants_pilot_density() const {
  return p_ != nullptr && p_->direction_importance && geometry_ &&
         (p_->hfd_half_band_m || p_->hfd_half_band_rel || p_->ptn_rel_error_at_hfd ||
          !p_->has_targets());
}

// The pilot's HFD and the triangles sharing its ring, from its own density (folded for this,
// Reducer::fold_pilot): without them the first learnt batch would have no ring to aim at and
// would be drawn, for the HFD, as without importance sampling.
void PrecisionControl::pilot_ring() {
  PrecisionSnapshot s;
  hfd_snapshot(1.0, s);
  hfd_m_ = s.hfd_m;
  ring_triangles_ = s.ring_triangles;
}

PrecisionSnapshot PrecisionControl::snapshot(std::int64_t batches) const {
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
void PrecisionControl::hfd_snapshot(double scale, PrecisionSnapshot& s) const {
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
  s.ring_triangles = ring_participation(density, g.distances(), s.hfd_m);
}

}  // namespace fragsim::run
