#pragma once
// Terrain from any GDAL raster (a DEM: GeoTIFF, DTED, ASCII grid, ...) as a site.terrain object
// of the scenario contract (docs/gis.md, "Terrain").
#include <ogr_spatialref.h>

#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/common/types.h"

namespace fragsim::gis {

struct TerrainImport {
  std::string path;  // the raster (already resolved against the import file's folder)
  int band = 1;
  // Cells without data: refused (the default, with their count and where the first is), or
  // filled by inverse-distance interpolation from the cells around (GDALFillNodata).
  enum class Nodata { kRefuse, kFill } nodata = Nodata::kRefuse;
  // A window [xmin, ymin, xmax, ymax] in the site's CRS: the cells whose centres fall inside.
  std::optional<std::array<double, 4>> window_m;
  // Resampling to square cells of this size (GDAL warp; `resampling` names the kernel).
  std::optional<double> spacing_m;
  std::string resampling = "bilinear";
  // The site's CRS when it differs from the raster's (the raster is then reprojected), and the
  // raster's CRS when the file has none.
  std::string crs;
  std::string source_crs;
  std::string material;  // the terrain's material (a key of site.materials)
};

struct ImportedTerrain {
  nlohmann::ordered_json terrain;  // {"grid": {...}} or {"mesh": {...}}, and "material"
  OGRSpatialReference srs;         // the site's CRS
  std::vector<Vec2> outline_m;     // the terrain's outline, counter-clockwise (4 corners)
  int nx = 0, ny = 0;              // vertices along the raster's columns and rows
  std::int64_t filled_cells = 0;   // nodata cells filled
  bool as_grid = false;            // north-up with square cells: a grid; otherwise a mesh
};

// Field names in errors are those of the import file ("terrain.path", "terrain.window_m", ...).
ImportedTerrain import_terrain(const TerrainImport& spec);

}  // namespace fragsim::gis
