// Import files and site assembly (site_import.h).
#include "gis/site_import.h"

#include <algorithm>

#include "api/json_fields.h"
#include "gis/gdal_support.h"

namespace fragsim::gis {

namespace {

using api::ObjectReader;
using Json = nlohmann::json;

const std::vector<std::string> kTopKeys = {
    "schema", "description", "terrain", "buildings", "materials", "origin_elevation_m", "zones"};
const std::vector<std::string> kMeshTerrainKeys = {"meshes", "axes", "weld_m", "grid_spacing_m",
                                                   "crs"};
const std::vector<std::string> kMeshKeys = {"path", "material", "material_by_group"};
const std::vector<std::string> kZoneKeys = {"path", "layer", "material_attribute", "source_crs"};
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

// The material names an import may use: the keys of its materials and the built-ins.
std::vector<std::string> material_names(const Json& materials) {
  std::vector<std::string> names = {"hard", "soft"};
  for (const auto& [k, v] : materials.items()) names.push_back(k);
  return names;
}

std::string known_material(const std::string& path, const Json& v,
                           const std::vector<std::string>& names) {
  const std::string m = api::read_string(v, path);
  if (std::find(names.begin(), names.end(), m) == names.end())
    api::fail(path, "\"" + m + "\" is not a key of materials (nor \"hard\" or \"soft\")");
  return m;
}

MeshTerrainImport parse_mesh_terrain(const ObjectReader& o, const std::filesystem::path& base,
                                     const std::vector<std::string>& names) {
  MeshTerrainImport t;
  const Json& meshes = api::read_array(o.require("meshes"), o.at("meshes"));
  if (meshes.empty()) api::fail(o.at("meshes"), "needs at least one mesh file");
  for (std::size_t k = 0; k < meshes.size(); ++k) {
    const ObjectReader m(meshes[k], api::index_path(o.at("meshes"), k), kMeshKeys);
    MeshSource src;
    src.path = resolve(base, m.string("path"));
    src.material = known_material(m.at("material"), m.require("material"), names);
    if (const Json* g = m.find("material_by_group")) {
      if (!g->is_object())
        api::fail(m.at("material_by_group"), "expected object, got " + api::json_type_name(*g));
      for (const auto& [name, v] : g->items())
        src.material_by_group[name] =
            known_material(api::child_path(m.at("material_by_group"), name), v, names);
    }
    t.meshes.push_back(std::move(src));
  }
  if (const Json* a = o.find("axes")) t.axes = parse_axes(*a, o.at("axes"));
  t.weld_m = o.number_or("weld_m", t.weld_m);
  api::check_ge(t.weld_m, 0.0, o.at("weld_m"));
  t.grid_spacing_m = o.optional_number("grid_spacing_m");
  if (t.grid_spacing_m) api::check_gt(*t.grid_spacing_m, 0.0, o.at("grid_spacing_m"));
  return t;
}

ZonesImport parse_zones(const Json& j, const std::filesystem::path& base) {
  const ObjectReader o(j, "zones", kZoneKeys);
  ZonesImport z;
  z.path = resolve(base, o.string("path"));
  z.layer = o.string_or("layer", "");
  z.material_attribute = o.string("material_attribute");
  z.source_crs = o.string_or("source_crs", "");
  return z;
}

}  // namespace

SiteImport parse_site_import(const Json& j, const std::filesystem::path& base_dir) {
  const ObjectReader o(j, "", kTopKeys);
  const std::string schema = o.string("schema");
  if (schema != "fragsim.site_import/1")
    api::fail("schema", "must be \"fragsim.site_import/1\" (got \"" + schema + "\")");
  SiteImport s;
  if (const Json* m = o.find("materials")) {
    if (!m->is_object()) api::fail("materials", "expected object, got " + api::json_type_name(*m));
    s.materials = *m;
  }
  const Json& terrain = o.require("terrain");
  if (terrain.is_object() && terrain.contains("meshes")) {
    if (terrain.contains("path"))
      api::fail("terrain", "give either \"path\" (a raster) or \"meshes\" (mesh files), not both");
    const ObjectReader t(terrain, "terrain", kMeshTerrainKeys);
    s.mesh_terrain = parse_mesh_terrain(t, base_dir, material_names(s.materials));
    s.mesh_crs = t.string_or("crs", "");
  } else {
    s.terrain = parse_terrain(terrain, base_dir);
  }
  if (const Json* b = o.find("buildings")) s.buildings = parse_buildings(*b, base_dir);
  if (const Json* z = o.find("zones")) s.zones = parse_zones(*z, base_dir);
  s.origin_elevation_m = o.number_or("origin_elevation_m", 0.0);
  return s;
}

namespace {

// The meshes form: terrain from mesh files, in terrain.crs (or none: local metres).
void import_mesh_site(const SiteImport& spec, ImportedSite& out) {
  if (!spec.mesh_crs.empty()) {
    out.terrain.srs = crs_from_text(spec.mesh_crs, "terrain.crs");
    require_projected_metres(out.terrain.srs, "terrain.crs", "terrain.crs",
                             "give a projected CRS in metres, e.g. the site's UTM zone");
  }
  out.mesh = import_mesh_terrain(*spec.mesh_terrain);
  out.terrain.outline_m = out.mesh->outline_m;
  out.terrain.terrain = std::move(out.mesh->terrain);
  out.mesh->terrain = nullptr;
  if (spec.buildings && spec.mesh_crs.empty())
    api::fail("terrain.crs",
              "buildings from a GIS layer need the meshes' CRS (e.g. \"EPSG:2154\")");
}

}  // namespace

ImportedSite import_site(const SiteImport& spec) {
  ImportedSite out;
  if (spec.mesh_terrain) {
    import_mesh_site(spec, out);
  } else {
    out.terrain = import_terrain(spec.terrain);
  }
  out.site = nlohmann::ordered_json::object();
  out.site["origin"] = {{"crs", out.terrain.srs.IsEmpty() ? "" : crs_name(out.terrain.srs)},
                        {"easting_m", 0.0},
                        {"northing_m", 0.0},
                        {"elevation_m", spec.origin_elevation_m}};
  out.site["terrain"] = std::move(out.terrain.terrain);
  out.terrain.terrain = nullptr;
  out.site["materials"] = spec.materials;
  if (spec.zones) {
    auto zones = import_zones(*spec.zones, out.terrain.srs, material_names(spec.materials));
    out.zones = zones.size();
    out.site["terrain"]["zones"] = std::move(zones);
  }
  if (spec.buildings) {
    auto buildings = import_buildings(*spec.buildings, out.terrain.srs, out.terrain.outline_m);
    out.buildings = buildings.size();
    out.site["buildings"] = std::move(buildings);
  }
  return out;
}

}  // namespace fragsim::gis
