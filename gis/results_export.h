#pragma once
// GIS outputs of a run (docs/gis.md, "Outputs"): `fragsim export RESULTS.h5 --out DIR` writes
//   ptn_density.tif     PTN density and its standard error (GeoTIFF, 2 float64 bands)
//   ptn_classes.tif     the density in classes relative to the threshold, with a colour table
//   hazard.gpkg         layers hazardous_area, buildings, hfd, hfd_sectors, and the site-plan
//                       boundary (gis/plan_boundary.h): hfd_envelope, hazard_boundary
//   hazardous_area.geojson, buildings.geojson, hazard_boundary.geojson   RFC 7946 (WGS 84)
//   hazard.kml          the six layers for Google Earth (WGS 84)
//   terrain.vtkhdf, buildings.vtkhdf, trajectories.vtkhdf   ParaView (gis/vtkhdf_export.h)
// With units kUs the vector layers carry US customary fields beside the SI ones (hfd_ft,
// threshold_per_600ft2, bearings, a description in ft; docs/units.md); the rasters stay SI.
// results.h5 holds everything needed (terrain, densities, buildings, the scenario and its CRS).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "api/units.h"

namespace fragsim::gis {

struct ExportOptions {
  std::filesystem::path results_h5;
  std::filesystem::path out_dir;  // created if missing; files replaced atomically
  std::optional<double> pixel_m;  // raster cell size; default: the terrain's cell size
  api::UnitSystem units = api::UnitSystem::kSi;  // kUs: US fields beside the SI ones
  // The site-plan boundary's closing radius (gis/plan_boundary.h); default: 2 raster cells.
  std::optional<double> smoothing_m = std::nullopt;
  // A paired comparison's compare.h5 of this run: also density_difference.tif (when it has one).
  std::optional<std::filesystem::path> compare_h5 = std::nullopt;
};

struct ExportReport {
  std::vector<std::string> files;  // written, in out_dir
  std::string crs;                 // "EPSG:32611", or "" when the site has none
  int raster_cols = 0, raster_rows = 0;
  double pixel_m = 0.0;
  std::size_t hazardous_triangles = 0;
  std::vector<std::string> notes;  // what was not written and why
};

ExportReport export_results(const ExportOptions& options);

// The map of a paired comparison (docs/comparison.md): compare.h5's density difference per
// terrain triangle (variant - base) and its paired standard error, rasterised over results_h5's
// terrain (either run's: both have the same triangles) as ptn_density.tif is, into a GeoTIFF of
// two float64 bands (NaN where no triangle covers a cell) in the site's CRS. Returns false, and
// writes nothing, when the comparison has no per-triangle difference (the terrains differ).
// Throws InputError naming the file when compare.h5 does not fit results_h5.
bool write_difference_map(const std::filesystem::path& results_h5,
                          const std::filesystem::path& compare_h5,
                          const std::filesystem::path& out_tif,
                          std::optional<double> pixel_m = std::nullopt);

inline constexpr const char* kDifferenceMapName = "density_difference.tif";

}  // namespace fragsim::gis
