// Import files and site assembly (site_import.h).
#include "gis/site_import.h"

#include "api/json_fields.h"
#include "gis/gdal_support.h"

namespace fragsim::gis {

namespace {

using api::ObjectReader;
using Json = nlohmann::json;

const std::vector<std::string> kTopKeys = {"schema",    "description", "terrain",
                                           "buildings", "materials",   "origin_elevation_m"};
const std::vector<std::string> kTerrainKeys = {"path",     "band",       "nodata",
                                               "window_m", "spacing_m",  "resampling",
                                               "crs",      "source_crs", "material"};
const std::vector<std::string> kBuildingKeys = {"path",
                                                "layer",
                                                "source_crs",
                                                "id_attribute",
                                                "height_attribute",
                                                "default_height_m",
                                                "base_elevation_attribute",
                                                "wall",
                                                "roof",
                                                "window",
                                                "wall_attribute",
                                                "roof_attribute",
                                                "window_attribute"};

std::string resolve(const std::filesystem::path& base, const std::string& p) {
  const std::filesystem::path path(p);
  return (path.is_absolute() ? path : base / path).lexically_normal().string();
}

std::optional<std::array<double, 4>> read_window(const ObjectReader& o) {
  const Json* w = o.find("window_m");
  if (w == nullptr) return std::nullopt;
  const std::string p = o.at("window_m");
  if (w->is_object()) {  // {"center_m": [x, y], "radius_m": r}: the square around the circle
    const ObjectReader c(*w, p, std::vector<std::string>{"center_m", "radius_m"});
    const std::vector<double> centre = api::read_numbers(c.require("center_m"), c.at("center_m"));
    if (centre.size() != 2) api::fail(c.at("center_m"), "expected [x, y]");
    const double r = c.number("radius_m");
    api::check_gt(r, 0.0, c.at("radius_m"));
    return std::array<double, 4>{centre[0] - r, centre[1] - r, centre[0] + r, centre[1] + r};
  }
  const std::vector<double> box = api::read_numbers(*w, p);
  if (box.size() != 4)
    api::fail(p, "expected [xmin, ymin, xmax, ymax] or {\"center_m\": [x, y], \"radius_m\": r}");
  if (!(box[2] > box[0] && box[3] > box[1])) api::fail(p, "needs xmax > xmin and ymax > ymin");
  return std::array<double, 4>{box[0], box[1], box[2], box[3]};
}

TerrainImport parse_terrain(const Json& j, const std::filesystem::path& base) {
  const ObjectReader o(j, "terrain", kTerrainKeys);
  TerrainImport t;
  t.path = resolve(base, o.string("path"));
  t.band = static_cast<int>(o.integer_or("band", 1, 1, 1 << 16));
  const std::string nodata = o.string_or("nodata", "refuse");
  if (nodata == "fill") {
    t.nodata = TerrainImport::Nodata::kFill;
  } else if (nodata != "refuse") {
    api::fail(o.at("nodata"), "must be \"refuse\" or \"fill\" (got \"" + nodata + "\")");
  }
  t.window_m = read_window(o);
  t.spacing_m = o.optional_number("spacing_m");
  if (t.spacing_m) api::check_gt(*t.spacing_m, 0.0, o.at("spacing_m"));
  t.resampling = o.string_or("resampling", t.resampling);
  t.crs = o.string_or("crs", "");
  t.source_crs = o.string_or("source_crs", "");
  t.material = o.string("material");
  return t;
}

BuildingsImport parse_buildings(const Json& j, const std::filesystem::path& base) {
  const ObjectReader o(j, "buildings", kBuildingKeys);
  BuildingsImport b;
  b.path = resolve(base, o.string("path"));
  b.layer = o.string_or("layer", "");
  b.source_crs = o.string_or("source_crs", "");
  b.id_attribute = o.string_or("id_attribute", "");
  b.height_attribute = o.string_or("height_attribute", "");
  b.default_height_m = o.optional_number("default_height_m");
  if (b.default_height_m) api::check_gt(*b.default_height_m, 0.0, o.at("default_height_m"));
  b.base_elevation_attribute = o.string_or("base_elevation_attribute", "");
  b.wall = o.string_or("wall", b.wall);
  b.roof = o.string_or("roof", b.roof);
  b.window = o.string_or("window", b.window);
  b.wall_attribute = o.string_or("wall_attribute", "");
  b.roof_attribute = o.string_or("roof_attribute", "");
  b.window_attribute = o.string_or("window_attribute", "");
  return b;
}

}  // namespace

SiteImport parse_site_import(const Json& j, const std::filesystem::path& base_dir) {
  const ObjectReader o(j, "", kTopKeys);
  const std::string schema = o.string("schema");
  if (schema != "fragsim.site_import/1")
    api::fail("schema", "must be \"fragsim.site_import/1\" (got \"" + schema + "\")");
  SiteImport s;
  s.terrain = parse_terrain(o.require("terrain"), base_dir);
  if (const Json* b = o.find("buildings")) s.buildings = parse_buildings(*b, base_dir);
  if (const Json* m = o.find("materials")) {
    if (!m->is_object()) api::fail("materials", "expected object, got " + api::json_type_name(*m));
    s.materials = *m;
  }
  s.origin_elevation_m = o.number_or("origin_elevation_m", 0.0);
  return s;
}

ImportedSite import_site(const SiteImport& spec) {
  ImportedSite out;
  out.terrain = import_terrain(spec.terrain);
  out.site = nlohmann::ordered_json::object();
  out.site["origin"] = {{"crs", crs_name(out.terrain.srs)},
                        {"easting_m", 0.0},
                        {"northing_m", 0.0},
                        {"elevation_m", spec.origin_elevation_m}};
  out.site["terrain"] = std::move(out.terrain.terrain);
  out.terrain.terrain = nullptr;
  out.site["materials"] = spec.materials;
  if (spec.buildings) {
    auto buildings = import_buildings(*spec.buildings, out.terrain.srs, out.terrain.outline_m);
    out.buildings = buildings.size();
    out.site["buildings"] = std::move(buildings);
  }
  return out;
}

}  // namespace fragsim::gis
