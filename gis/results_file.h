#pragma once
// What the exports, the site-plan boundary and the study report read from results.h5
// (formats/results_h5.h), in the site's CRS: input coordinates plus the site origin's easting and
// northing. Shared by gis/results_export, gis/plan_boundary and report/.
#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/common/types.h"
#include "gis/plan_raster.h"

class OGRGeometry;

namespace fragsim::gis {

struct ResultsBuilding {
  std::string id;
  double impacts = 0, impacts_se = 0, penetrations = 0, penetrations_se = 0;
  std::vector<std::array<Vec2, 3>> plan;  // its triangles seen from above
};

// What the exports need from results.h5, in the site's CRS (input + origin offset).
struct ResultsFile {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::size_t, 3>> triangles;
  std::vector<double> density, std_error;
  double threshold = 0, hfd_m = 0, band_lo = 0, band_hi = 0;
  std::vector<double> by_sector;
  // Where the terrain's boundary cuts the HFD (results.h5 /hfd/*bound*, format 2): "lower" or
  // "none" each; "unknown" from a results.h5 of format 1, which does not say.
  std::string hfd_bound = "unknown", band_lower_bound = "unknown", band_upper_bound = "unknown";
  std::vector<std::string> sector_bound = std::vector<std::string>(36, "unknown");
  std::string hfd_note;
  double left_hazardous = 0, left_hazardous_se = 0;  // real fragments (format 2)
  std::vector<double> left_hazardous_by_sector = std::vector<double>(36, 0.0);
  Vec3 hfd_origin{0, 0, 0};
  std::vector<ResultsBuilding> buildings;
  std::string crs;            // "" when the site has none
  Vec2 offset{0, 0};          // site.origin easting, northing
  double terrain_cell_m = 0;  // grid spacing / plane cell; 0 for a mesh
  // A grid terrain: its vertices are the DEM's samples (docs/gis.md): the raster's cells are
  // centred on them, as the DEM's own cells were.
  std::optional<std::array<double, 2>> grid_origin;
  int grid_nx = 0, grid_ny = 0;
};

// Reads `f`; throws InputError("RESULTS.h5", "<file>: <what>") when it is not a fragsim
// results file or an object is missing.
ResultsFile read_results_file(const std::filesystem::path& f);

// The raster cell the exports default to: the terrain's grid spacing or plane cell, else (a mesh)
// about the size of a triangle pair.
double default_cell(const ResultsFile& r);

// The density (value set 0) and its standard error (1) on a plan raster of `cell_m`; on the
// DEM's own samples when `on_grid_samples` (a grid terrain only).
PlanRaster rasterise(const ResultsFile& r, double cell_m, bool on_grid_samples);

// The union of triangles seen from above (vertical ones skipped), merged by GEOS.
std::unique_ptr<OGRGeometry> union_of(const std::vector<std::array<Vec2, 3>>& triangles);

// Terrain triangles where density + s * std_error >= threshold, merged; `count` gets how many.
std::unique_ptr<OGRGeometry> hazard_area(const ResultsFile& r, double s, std::size_t* count);

}  // namespace fragsim::gis
