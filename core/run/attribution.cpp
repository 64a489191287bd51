#include "core/run/attribution.h"

namespace fragsim::run {

const char* ptn_mechanism_name(PtnMechanism m) {
  switch (m) {
    case PtnMechanism::kDirectFlight: return "direct_flight";
    case PtnMechanism::kAfterRicochet: return "after_ricochet";
    case PtnMechanism::kGround: return "ground";
  }
  return "unknown";
}

GroupFieldsPlan plan_group_fields(std::size_t groups, std::size_t triangles) {
  GroupFieldsPlan plan;
  if (groups <= 1) return plan;  // the whole field is the group's
  if (groups > kMaxAttributedGroups) {
    plan.omitted_reason = std::to_string(groups) +
                          " fragment groups: per-group fields are kept for " + "at most " +
                          std::to_string(kMaxAttributedGroups) + " groups";
  } else if (groups * triangles > kMaxGroupFieldBins) {
    plan.omitted_reason = std::to_string(groups) + " fragment groups x " +
                          std::to_string(triangles) + " terrain triangles: per-group fields are " +
                          "kept up to " + std::to_string(kMaxGroupFieldBins) + " bins in all";
  } else {
    plan.fields = groups;
  }
  return plan;
}

namespace {

// The HFD figures of the field in bins [first, first + triangles).
HfdFigures field_figures(const HfdGeometry& geometry, const tally::StratifiedTally& tally,
                         std::size_t first, std::size_t triangles, double scale, double threshold) {
  std::vector<double> density = tally.means(first, triangles),
                      se = tally.std_errors(first, triangles);
  for (std::size_t t = 0; t < triangles; ++t) {
    density[t] *= scale;
    se[t] *= scale;
  }
  return geometry.figures(density, se, threshold);
}

}  // namespace

DensityShares density_shares(const tally::StratifiedTally& tally, const TallyBins& bins,
                             std::size_t groups, std::int64_t triangle) {
  DensityShares s;
  s.triangle = triangle;
  if (triangle < 0) return s;
  const auto t = static_cast<std::size_t>(triangle);
  const double whole = tally.mean(bins.terrain + t);
  if (!(whole > 0.0)) return s;
  for (int m = 0; m < kPtnMechanismCount; ++m)
    s.by_mechanism[static_cast<std::size_t>(m)] =
        tally.mean(bins.mechanism(static_cast<PtnMechanism>(m)) + t) / whole;
  if (groups == 1) s.by_group = {1.0};
  for (std::uint32_t g = 0; g < bins.group_fields; ++g)
    s.by_group.push_back(tally.mean(bins.group(g) + t) / whole);
  return s;
}

HfdAttribution attribute_hfd(const HfdGeometry& geometry, const tally::StratifiedTally& tally,
                             const TallyBins& bins, std::size_t groups, double scale,
                             double threshold, const std::vector<double>& density,
                             const HfdFigures& whole) {
  HfdAttribution a;
  for (int m = 0; m < kPtnMechanismCount; ++m)
    a.by_mechanism[static_cast<std::size_t>(m)] =
        field_figures(geometry, tally, bins.mechanism(static_cast<PtnMechanism>(m)), bins.triangles,
                      scale, threshold);
  if (groups == 1) a.by_group = {whole};
  for (std::uint32_t g = 0; g < bins.group_fields; ++g)
    a.by_group.push_back(
        field_figures(geometry, tally, bins.group(g), bins.triangles, scale, threshold));
  if (a.by_group.size() != groups)
    a.by_group_omitted_reason = plan_group_fields(groups, bins.triangles).omitted_reason;
  auto shares = [&](std::int64_t t, double distance_m) {
    DensityShares s = density_shares(tally, bins, groups, t);
    if (t >= 0) {
      s.distance_m = distance_m;
      s.density_per_m2 = density[static_cast<std::size_t>(t)];
    }
    return s;
  };
  a.at_hfd = shares(whole.set_by.overall, whole.hfd_m);
  for (std::size_t k = 0; k < kHfdSectors; ++k)
    a.at_sector_hfd[k] = shares(whole.set_by.by_sector[k], whole.by_sector_m[k]);
  return a;
}

}  // namespace fragsim::run
