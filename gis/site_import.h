#pragma once
// A site document from GIS files (docs/gis.md): `fragsim site import IMPORT.json --out SITE.json`.
// The import file names a DEM raster and, optionally, a layer of building footprints, with the
// choices that go with them; the result is an ordinary site object of the scenario contract, in
// the site's projected CRS (metres), that `fragsim run` (as a scenario's "site") and
// `POST /v1/sites` accept.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "gis/mesh_terrain.h"
#include "gis/raster_terrain.h"
#include "gis/vector_buildings.h"
#include "gis/vector_zones.h"

namespace fragsim::gis {

struct SiteImport {
  TerrainImport terrain;                          // a raster (when mesh_terrain is not set)
  std::optional<MeshTerrainImport> mesh_terrain;  // terrain.meshes: mesh files
  std::string mesh_crs;  // terrain.crs of the meshes form: the CRS of their mapped coordinates
  std::optional<BuildingsImport> buildings;
  std::optional<ZonesImport> zones;
  nlohmann::json materials = nlohmann::json::object();  // copied into site.materials
  double origin_elevation_m = 0.0;  // site.origin.elevation_m: altitude of z = 0
};

// Parses an import file (schema "fragsim.site_import/1"); relative paths are taken from
// `base_dir`, the import file's folder. InputError with the field's path on a bad value.
SiteImport parse_site_import(const nlohmann::json& j, const std::filesystem::path& base_dir);

struct ImportedSite {
  nlohmann::ordered_json site;  // the site object
  ImportedTerrain terrain;      // (its terrain JSON moved into `site`); srs also for meshes
  std::optional<ImportedMeshTerrain> mesh;  // the meshes form (its JSON moved into `site`)
  std::size_t buildings = 0, zones = 0;
};

// Reads the files and assembles the site; coordinates are the CRS's own (site.origin's easting
// and northing are 0). Does not build the site: the caller checks it as any site is checked.
ImportedSite import_site(const SiteImport& spec);

}  // namespace fragsim::gis
