#pragma once
// The inverse of `site import` (docs/gis.md, "A site as GIS files"): a site document with a grid
// terrain and a CRS written as a GeoTIFF DEM, a GeoPackage of footprints and the import file that
// reads them back. `fragsim site export-gis SITE.json --out DIR`; the demo's GIS files are made
// with it (examples/demo/gis/make.sh).
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace fragsim::gis {

struct SiteGisReport {
  std::vector<std::string> files;  // in the output directory
  std::vector<std::string> notes;  // what could not be written as GIS and why
};

// `site` is a site object as a scenario's "site" holds it (parsed and checked by the caller).
// InputError when the site has no CRS or a terrain other than a grid.
SiteGisReport write_site_gis(const nlohmann::json& site, const std::filesystem::path& out_dir);

}  // namespace fragsim::gis
