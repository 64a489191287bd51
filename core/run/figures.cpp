#include "core/run/figures.h"

#include <algorithm>

#include "core/run/attribution.h"
#include "core/run/hfd.h"

namespace fragsim::run {

namespace {

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

}  // namespace

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

}  // namespace fragsim::run
