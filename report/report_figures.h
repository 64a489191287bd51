#pragma once
// The data behind the report's figures (docs/report.md, "Figures"), in the report's units and
// relative to the HFD origin (x east, y north): the map (density classes on a raster, the
// site-plan boundary, the HFD circle, the buildings), the sector rose and density against
// distance. report/assets/report.js draws them with Observable Plot.
#include <nlohmann/json.hpp>

#include "api/units.h"
#include "report/report_inputs.h"

namespace fragsim::report {

// The largest raster the map carries (cells per side); larger sites get coarser cells.
inline constexpr int kMapMaxCells = 240;

nlohmann::json figure_data(const ReportInputs& in, api::UnitSystem units);

// Density against distance from the HFD origin: per distance bin, the largest triangle density
// and the area-weighted mean (per m^2), over triangles whose centroid falls in the bin.
struct DensityProfile {
  double bin_m = 0.0;
  std::vector<double> max_per_m2, mean_per_m2;  // bin k: [k bin_m, (k + 1) bin_m)
};
DensityProfile density_profile(const gis::ResultsFile& r, double range_m, int bins);

}  // namespace fragsim::report
