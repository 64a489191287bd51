#pragma once
// Material zones from an OGR polygon layer (docs/gis.md, "Zones"): site.terrain.zones[] objects
// of the scenario contract, {"material", "polygon_m"}, in the layer's order (a later zone wins
// where zones overlap).
#include <ogr_spatialref.h>

#include <nlohmann/json.hpp>
#include <string>

namespace fragsim::gis {

struct ZonesImport {
  std::string path;                // the vector dataset (resolved)
  std::string layer;               // "" = the first layer
  std::string material_attribute;  // the attribute naming each zone's material
  std::string source_crs;          // the layer's CRS when the file has none
};

// Each polygon feature becomes a zone, each part of a multipolygon one zone, reprojected into
// `site_srs` (when the site has none, the layer's coordinates are taken as they are). Refused,
// with InputError("zones...", ...) naming the file, layer and feature: a feature without
// geometry, not a polygon, with a hole (interior ring), with fewer than 3 distinct vertices, or
// whose material is empty or not one of `materials` (site.materials' keys and the built-ins).
nlohmann::ordered_json import_zones(const ZonesImport& spec, const OGRSpatialReference& site_srs,
                                    const std::vector<std::string>& materials);

}  // namespace fragsim::gis
