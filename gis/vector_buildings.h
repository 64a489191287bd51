#pragma once
// Buildings from any OGR vector layer (GeoPackage, shapefile, GeoJSON, ...) as site.buildings[]
// objects of the scenario contract (docs/gis.md, "Buildings").
#include <ogr_spatialref.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/common/types.h"

namespace fragsim::gis {

struct BuildingsImport {
  std::string path;                        // the vector dataset (resolved)
  std::string layer;                       // "" = the dataset's only (or first) layer
  std::string source_crs;                  // the layer's CRS when the file has none
  std::string id_attribute;                // "" = the feature id (FID)
  std::string height_attribute;            // height above the base, m
  std::optional<double> default_height_m;  // when the attribute is null or absent
  std::string base_elevation_attribute;    // optional; null = lowest terrain under it
  // Materials by surface: the attribute's value when the attribute is named and set, else the
  // default name.
  std::string wall = "concrete_wall", roof = "metal_roof", window;
  std::string wall_attribute, roof_attribute, window_attribute;
};

// Every feature becomes a footprint building (a multipolygon one per part, ids "<id>-1", ...;
// interior rings become holes_m), reprojected into `site_srs`. Features that cannot be imported
// (not polygons, invalid, degenerate, outside `terrain_outline_m`, no height) are all reported
// together in one InputError("buildings", ...) naming the file, the layer and each feature.
nlohmann::ordered_json import_buildings(const BuildingsImport& spec,
                                        const OGRSpatialReference& site_srs,
                                        const std::vector<Vec2>& terrain_outline_m);

}  // namespace fragsim::gis
