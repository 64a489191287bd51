// The `site` object: origin, terrain (plane | grid | mesh), materials, buildings.
// Type, range and reference checks happen here; geometry (mesh indices, zero-area triangles,
// footprint polygons, closed building meshes) is checked by scene::Site::build.
#include "api/site_json.h"

#include <limits>
#include <set>

#include "api/limits.h"
#include "core/scene/site_limits.h"

namespace fragsim::api::detail {

namespace {

constexpr std::int64_t kInt64Min = std::numeric_limits<std::int64_t>::min();
constexpr std::int64_t kInt64Max = std::numeric_limits<std::int64_t>::max();
constexpr std::int64_t kIntMax = std::numeric_limits<int>::max();

// ---- Materials ----

scene::RestitutionSpec parse_restitution(const Json& j, const std::string& path) {
  scene::RestitutionSpec r;
  if (j.is_number()) {
    r.constant = read_number(j, path);
    check_in(r.constant, 0.0, 1.0, path);
    return r;
  }
  if (!j.is_object()) fail(path, "expected number or object, got " + json_type_name(j));
  const ObjectReader o(j, path, "restitution_table");
  r.normal_speed_mps = read_numbers(o.require("normal_speed_mps"), o.at("normal_speed_mps"));
  r.e = read_numbers(o.require("e"), o.at("e"));
  if (r.normal_speed_mps.empty()) fail(o.at("normal_speed_mps"), "must not be empty");
  if (r.e.size() != r.normal_speed_mps.size())
    fail(o.at("e"), "expected " + std::to_string(r.normal_speed_mps.size()) +
                        " values (one per normal speed), got " + std::to_string(r.e.size()));
  for (std::size_t k = 0; k < r.normal_speed_mps.size(); ++k) {
    const std::string sp = index_path(o.at("normal_speed_mps"), k);
    check_ge_le(r.normal_speed_mps[k], 0.0, limits::kMaxImpactSpeed_mps, sp);
    if (k > 0 && !(r.normal_speed_mps[k] > r.normal_speed_mps[k - 1]))
      fail(sp, "must be strictly increasing (got " + format_number(r.normal_speed_mps[k]) +
                   " after " + format_number(r.normal_speed_mps[k - 1]) + ")");
    check_in(r.e[k], 0.0, 1.0, index_path(o.at("e"), k));
  }
  r.constant = r.e.front();  // unused with a table; keeps the spec self-consistent
  return r;
}

// Embedment of fast fragments (scene::EmbedmentSpec; docs/physics.md, "Fast impacts on soil").
// The model is named so that others can be added; the bulk density has no default (no value is
// right for every ground).
scene::EmbedmentSpec parse_embedment(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "embedment");
  const std::string model = o.string("model");
  if (model != "johnson_reid_1975")
    fail(o.at("model"), "unknown model \"" + model + "\" (known: \"johnson_reid_1975\")");
  scene::EmbedmentSpec e;
  e.bulk_density_kg_m3 = o.number("bulk_density_kg_m3");
  check_gt(e.bulk_density_kg_m3, 0.0, o.at("bulk_density_kg_m3"));
  check_ge_le(e.bulk_density_kg_m3, limits::kMinDensity_kg_m3, limits::kMaxDensity_kg_m3,
              o.at("bulk_density_kg_m3"));
  e.coefficient_deg = o.number_or("coefficient_deg", e.coefficient_deg);
  check_gt_le(e.coefficient_deg, 0.0, 90.0, o.at("coefficient_deg"));  // an angle
  e.min_speed_mps = o.number_or("min_speed_mps", e.min_speed_mps);
  check_ge_le(e.min_speed_mps, 0.0, limits::kMaxImpactSpeed_mps, o.at("min_speed_mps"));
  return e;
}

// Fast contact on deformable ground (scene::FastContactSpec; docs/physics.md, F1-F6). Only the
// bulk density is required; the other constants default to the nominal values of docs/physics.md.
scene::FastContactSpec parse_fast_contact(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "fast_contact");
  scene::FastContactSpec f;
  f.bulk_density_kg_m3 = o.number("bulk_density_kg_m3");
  check_ge_le(f.bulk_density_kg_m3, limits::kMinDensity_kg_m3, limits::kMaxDensity_kg_m3,
              o.at("bulk_density_kg_m3"));
  f.switch_speed_mps = o.number_or("switch_speed_mps", f.switch_speed_mps);
  check_gt(f.switch_speed_mps, 0.0, o.at("switch_speed_mps"));
  check_ge_le(f.switch_speed_mps, 0.0, limits::kMaxImpactSpeed_mps, o.at("switch_speed_mps"));
  f.critical_angle_coefficient_deg =
      o.number_or("critical_angle_coefficient_deg", f.critical_angle_coefficient_deg);
  check_gt_le(f.critical_angle_coefficient_deg, 0.0, 90.0, o.at("critical_angle_coefficient_deg"));
  f.drag_to_lift_ratio = o.number_or("drag_to_lift_ratio", f.drag_to_lift_ratio);
  check_gt_le(f.drag_to_lift_ratio, 0.0, 100.0, o.at("drag_to_lift_ratio"));
  f.roughness_deg = o.number_or("roughness_deg", f.roughness_deg);
  check_ge_le(f.roughness_deg, 0.0, 45.0, o.at("roughness_deg"));
  f.exit_angle_ratio = o.number_or("exit_angle_ratio", f.exit_angle_ratio);
  check_ge_le(f.exit_angle_ratio, 0.0, 10.0, o.at("exit_angle_ratio"));
  return f;
}

// Ranges of uncertain constants (settings.ground_bracket): {"name": [low, high]}. Which names a
// material accepts, and the values at both ends, scene::SiteBuilder checks (material.cpp).
std::map<std::string, std::array<double, 2>> parse_ranges(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "material_ranges");
  std::map<std::string, std::array<double, 2>> out;
  for (const std::string& name : scene::material_constant_names()) {
    if (!o.has(name)) continue;
    const std::array<double, 2> r = read_vec2(o.require(name), o.at(name));
    if (!(r[0] <= r[1])) fail(o.at(name), "low end above the high end");
    out.emplace(name, r);
  }
  return out;
}

scene::MaterialSpec parse_material(const Json& j, const std::string& path, MaterialNotes& notes) {
  const ObjectReader o(j, path, "material");
  scene::MaterialSpec m;
  m.friction = o.number_or("friction", m.friction);
  check_ge_le(m.friction, 0.0, limits::kMaxFriction, o.at("friction"));
  m.rolling_resistance = o.number_or("rolling_resistance", m.rolling_resistance);
  check_ge_le(m.rolling_resistance, 0.0, limits::kMaxFriction, o.at("rolling_resistance"));
  if (const Json* r = o.find("restitution"))
    m.restitution = parse_restitution(*r, o.at("restitution"));
  if (const Json* p = o.find("penetration")) {
    const ObjectReader pen(*p, o.at("penetration"), "penetration");
    const double ke = pen.number("ke_per_area_j_per_m2");
    check_gt(ke, 0.0, pen.at("ke_per_area_j_per_m2"));
    m.penetration_ke_per_area_j_per_m2 = ke;
  }
  if (const Json* e = o.find("embedment")) m.embedment = parse_embedment(*e, o.at("embedment"));
  if (const Json* f = o.find("fast_contact")) {
    if (m.embedment)
      fail(o.at("fast_contact"),
           "give embedment or fast_contact, not both (fast_contact has its own critical angle)");
    m.fast_contact = parse_fast_contact(*f, o.at("fast_contact"));
  }
  if (const Json* r = o.find("ranges")) m.ranges = parse_ranges(*r, o.at("ranges"));
  notes.illustrative = o.bool_or("illustrative", false);
  notes.source = o.string_or("source", "");
  return m;
}

// ---- Terrain ----

std::vector<Vec3> parse_vertices(const Json& j, const std::string& path) {
  read_array(j, path);
  std::vector<Vec3> out;
  out.reserve(j.size());
  for (std::size_t k = 0; k < j.size(); ++k) out.push_back(read_vec3(j[k], index_path(path, k)));
  return out;
}

// Indices are range-checked against the vertices by Site::build (same paths).
std::vector<std::array<std::int64_t, 3>> parse_triangles(const Json& j, const std::string& path) {
  read_array(j, path);
  std::vector<std::array<std::int64_t, 3>> out;
  out.reserve(j.size());
  for (std::size_t t = 0; t < j.size(); ++t) {
    const std::string tp = index_path(path, t);
    const Json& tri = j[t];
    if (!tri.is_array()) fail(tp, "expected array of 3 vertex indices, got " + json_type_name(tri));
    if (tri.size() != 3) fail(tp, "expected 3 vertex indices, got " + std::to_string(tri.size()));
    std::array<std::int64_t, 3> v{};
    for (std::size_t k = 0; k < 3; ++k)
      v[k] = read_integer(tri[k], index_path(tp, k), kInt64Min, kInt64Max);
    out.push_back(v);
  }
  return out;
}

std::vector<std::array<double, 2>> parse_ring(const Json& j, const std::string& path);

void require_material(const std::map<std::string, scene::MaterialSpec>& materials,
                      const std::string& name, const std::string& path) {
  if (!materials.count(name)) fail(path, "unknown material \"" + name + "\"");
}

// site.terrain.triangle_materials {names, index} and site.terrain.zones (docs/scenario.md,
// "Materials by zone"); counts and ranges against the terrain are checked by the site builder.
void parse_terrain_materials(const ObjectReader& o, scene::TerrainSpec& t,
                             const std::map<std::string, scene::MaterialSpec>& materials) {
  if (const Json* tm = o.find("triangle_materials")) {
    const ObjectReader r(*tm, o.at("triangle_materials"), "terrain_triangle_materials");
    const Json& names = read_array(r.require("names"), r.at("names"));
    for (std::size_t k = 0; k < names.size(); ++k) {
      const std::string np = index_path(r.at("names"), k);
      t.triangle_material_names.push_back(read_string(names[k], np));
      require_material(materials, t.triangle_material_names.back(), np);
    }
    const Json& index = read_array(r.require("index"), r.at("index"));
    t.triangle_material.reserve(index.size());
    for (std::size_t k = 0; k < index.size(); ++k)
      t.triangle_material.push_back(
          read_integer(index[k], index_path(r.at("index"), k), 0, kInt64Max));
  }
  if (const Json* zones = o.find("zones")) {
    read_array(*zones, o.at("zones"));
    for (std::size_t k = 0; k < zones->size(); ++k) {
      const ObjectReader r((*zones)[k], index_path(o.at("zones"), k), "terrain_zone");
      scene::MaterialZoneSpec z;
      z.material = r.string("material");
      require_material(materials, z.material, r.at("material"));
      z.polygon_m = parse_ring(r.require("polygon_m"), r.at("polygon_m"));
      t.zones.push_back(std::move(z));
    }
  }
}

scene::TerrainSpec parse_terrain(const Json& j, const std::string& path,
                                 const std::map<std::string, scene::MaterialSpec>& materials) {
  const ObjectReader o(j, path, "terrain");
  std::vector<std::string> forms;
  for (const char* f : {"plane", "grid", "mesh"})
    if (o.has(f)) forms.emplace_back(f);
  if (forms.empty()) fail(path, "needs one of plane, grid or mesh");
  if (forms.size() > 1)
    fail(path,
         "give exactly one of plane, grid or mesh (got " + forms[0] + " and " + forms[1] + ")");

  scene::TerrainSpec t;
  if (const Json* p = o.find("plane")) {
    const ObjectReader r(*p, o.at("plane"), "terrain_plane");
    scene::PlaneTerrainSpec plane;
    plane.elevation_m = r.number_or("elevation_m", 0.0);
    const Json& e = read_array(r.require("extent_m"), r.at("extent_m"), 4);
    for (std::size_t k = 0; k < 4; ++k)
      plane.extent_m[k] = read_number(e[k], index_path(r.at("extent_m"), k));
    plane.cell_m = r.number_or("cell_m", plane.cell_m);
    check_gt(plane.cell_m, 0.0, r.at("cell_m"));
    t.geometry = plane;
  } else if (const Json* g = o.find("grid")) {
    const ObjectReader r(*g, o.at("grid"), "terrain_grid");
    scene::GridTerrainSpec grid;
    grid.origin_m = read_vec2(r.require("origin_m"), r.at("origin_m"));
    grid.spacing_m = r.number("spacing_m");
    check_gt(grid.spacing_m, 0.0, r.at("spacing_m"));
    grid.nx = static_cast<int>(r.integer("nx", 2, kIntMax));
    grid.ny = static_cast<int>(r.integer("ny", 2, kIntMax));
    grid.elevation_m = read_numbers(r.require("elevation_m"), r.at("elevation_m"));
    t.geometry = std::move(grid);
  } else {
    const ObjectReader r(o.require("mesh"), o.at("mesh"), "terrain_mesh");
    scene::MeshSpec mesh;
    mesh.vertices_m = parse_vertices(r.require("vertices_m"), r.at("vertices_m"));
    mesh.triangles = parse_triangles(r.require("triangles"), r.at("triangles"));
    t.geometry = std::move(mesh);
  }
  t.material = o.string("material");
  require_material(materials, t.material, o.at("material"));
  parse_terrain_materials(o, t, materials);
  return t;
}

// ---- Buildings ----

scene::SurfaceType parse_surface(const Json& j, const std::string& path) {
  const std::string s = read_string(j, path);
  if (s == "wall") return scene::SurfaceType::kWall;
  if (s == "roof") return scene::SurfaceType::kRoof;
  if (s == "window") return scene::SurfaceType::kWindow;
  fail(path, "must be \"wall\", \"roof\" or \"window\" (got \"" + s + "\")");
}

// A ring of [x, y] vertices (a footprint or a hole); its shape is checked by Site::build.
std::vector<std::array<double, 2>> parse_ring(const Json& j, const std::string& path) {
  read_array(j, path);
  std::vector<std::array<double, 2>> ring;
  ring.reserve(j.size());
  for (std::size_t k = 0; k < j.size(); ++k) ring.push_back(read_vec2(j[k], index_path(path, k)));
  return ring;
}

scene::BuildingSpec parse_building(const Json& j, const std::string& path,
                                   const std::map<std::string, scene::MaterialSpec>& materials) {
  if (j.is_object() && j.contains("mesh") && j.contains("footprint_m"))
    fail(path, "give either footprint_m or mesh, not both");
  const bool mesh_form = j.is_object() && j.contains("mesh");
  // Said plainly rather than as an unknown key of the mesh form.
  if (mesh_form && j.contains("holes_m"))
    fail(child_path(path, "holes_m"),
         "only the footprint form has holes; a mesh gives its courtyards as geometry");
  const ObjectReader o(j, path, mesh_form ? "building_mesh" : "building_footprint");
  scene::BuildingSpec b;
  b.id = o.string("id");
  if (b.id.empty()) fail(o.at("id"), "must not be empty");
  if (mesh_form) {
    const ObjectReader m(o.require("mesh"), o.at("mesh"), "building_mesh_geometry");
    scene::MeshSpec mesh;
    mesh.vertices_m = parse_vertices(m.require("vertices_m"), m.at("vertices_m"));
    mesh.triangles = parse_triangles(m.require("triangles"), m.at("triangles"));
    const Json& surface = read_array(m.require("surface"), m.at("surface"));
    for (std::size_t k = 0; k < surface.size(); ++k)
      mesh.surface.push_back(parse_surface(surface[k], index_path(m.at("surface"), k)));
    b.mesh = std::move(mesh);
  } else {
    b.footprint_m = parse_ring(o.require("footprint_m"), o.at("footprint_m"));
    if (const Json* holes = o.find("holes_m")) {
      const std::string hp = o.at("holes_m");
      read_array(*holes, hp);
      for (std::size_t k = 0; k < holes->size(); ++k)
        b.holes_m.push_back(parse_ring((*holes)[k], index_path(hp, k)));
    }
    b.height_m = o.number("height_m");
    check_gt(b.height_m, 0.0, o.at("height_m"));
    b.base_elevation_m = o.optional_number("base_elevation_m");
  }
  // The footprint form always has walls and a roof; a mesh names what its triangles use (checked
  // against the surface types by Site::build).
  const auto material = [&](const char* key, bool required) {
    if (!required && !o.has(key)) return std::string();
    const std::string name = o.string(key);
    if (!materials.count(name)) fail(o.at(key), "unknown material \"" + name + "\"");
    return name;
  };
  b.wall = material("wall", !mesh_form);
  b.roof = material("roof", !mesh_form);
  b.window = material("window", false);
  return b;
}

// ---- Limits ----

// The site limits (core/scene/site_limits.h), checked before anything is sized from the site.
// Core names fields from "site"; a site document is the site itself (path "").
void check_limits(const scene::SiteSpec& site, const std::string& path) {
  try {
    scene::check_site_limits(site);
  } catch (const InputError& e) {
    std::string field = e.field();
    if (field.compare(0, 4, "site") == 0) {
      field.erase(0, 4);
      if (path.empty() && !field.empty() && field[0] == '.') field.erase(0, 1);
      field = path + field;
    }
    throw InputError(field, e.message());
  }
}

// ---- Output ----

Json vec2_json(const std::array<double, 2>& v) {
  return Json::array({v[0], v[1]});
}
Json vec3_json(const Vec3& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

Json mesh_json(const scene::MeshSpec& m, bool with_surface) {
  Json vertices = Json::array();
  for (const Vec3& v : m.vertices_m) vertices.push_back(vec3_json(v));
  Json triangles = Json::array();
  for (const auto& t : m.triangles) triangles.push_back(Json::array({t[0], t[1], t[2]}));
  Json out = {{"vertices_m", std::move(vertices)}, {"triangles", std::move(triangles)}};
  if (with_surface) {
    Json surface = Json::array();
    for (const auto s : m.surface) surface.push_back(scene::surface_type_name(s));
    out["surface"] = std::move(surface);
  }
  return out;
}

Json restitution_json(const scene::RestitutionSpec& r) {
  if (r.normal_speed_mps.empty()) return r.constant;
  return {{"normal_speed_mps", r.normal_speed_mps}, {"e", r.e}};
}

}  // namespace

scene::SiteSpec parse_site(const Json& j, const std::string& path,
                           std::map<std::string, MaterialNotes>& notes) {
  const ObjectReader o(j, path, "site");
  scene::SiteSpec site;
  if (const Json* origin = o.find("origin")) {
    const ObjectReader r(*origin, o.at("origin"), "site_origin");
    scene::SiteOrigin so;
    so.crs = r.string_or("crs", "");
    so.easting_m = r.number_or("easting_m", 0.0);
    so.northing_m = r.number_or("northing_m", 0.0);
    so.elevation_m = r.number_or("elevation_m", 0.0);
    site.origin = so;
  }

  const std::string mp = o.at("materials");
  const Json& materials = o.require("materials");
  if (!materials.is_object()) fail(mp, "expected object, got " + json_type_name(materials));
  for (const auto& item : materials.items()) {
    if (item.key().empty()) fail(mp, "empty material name");
    site.materials[item.key()] =
        parse_material(item.value(), child_path(mp, item.key()), notes[item.key()]);
  }

  // The built-in ground materials ("hard", "soft"; scene::builtin_ground_material) join the
  // site's materials when a surface names one the site does not define. They are then written
  // into the normalised scenario like any other, so a result records the values it used.
  const auto adopt_builtin = [&](const Json* holder, const char* key) {
    if (holder == nullptr || !holder->is_object()) return;
    const auto it = holder->find(key);
    if (it == holder->end() || !it->is_string()) return;
    const std::string name = it->get<std::string>();
    if (site.materials.count(name)) return;
    if (auto m = scene::builtin_ground_material(name)) {
      site.materials[name] = *m;
      notes[name] = {true,
                     "fragsim built-in ground material: friction from Gan & Chrostowski "
                     "(DDESB 2010); restitution table illustrative (docs/physics.md)"};
    }
  };
  adopt_builtin(o.find("terrain"), "material");
  if (const Json* t = o.find("terrain"); t != nullptr && t->is_object()) {
    if (const auto tm = t->find("triangle_materials"); tm != t->end() && tm->is_object()) {
      if (const auto names = tm->find("names"); names != tm->end() && names->is_array()) {
        for (const Json& name : *names) {
          const Json holder = {{"material", name}};
          adopt_builtin(&holder, "material");
        }
      }
    }
    if (const auto zones = t->find("zones"); zones != t->end() && zones->is_array()) {
      for (const Json& z : *zones) adopt_builtin(&z, "material");
    }
  }
  if (const Json* bs = o.find("buildings"); bs != nullptr && bs->is_array()) {
    for (const Json& b : *bs) {
      for (const char* key : {"wall", "roof", "window"}) adopt_builtin(&b, key);
    }
  }

  site.terrain = parse_terrain(o.require("terrain"), o.at("terrain"), site.materials);

  if (const Json* buildings = o.find("buildings")) {
    const std::string bp = o.at("buildings");
    read_array(*buildings, bp);
    std::map<std::string, std::size_t> seen;
    for (std::size_t k = 0; k < buildings->size(); ++k) {
      const std::string path_k = index_path(bp, k);
      scene::BuildingSpec b = parse_building((*buildings)[k], path_k, site.materials);
      if (const auto [it, fresh] = seen.emplace(b.id, k); !fresh)
        fail(child_path(path_k, "id"),
             "duplicate id \"" + b.id + "\" (also " + index_path(bp, it->second) + ")");
      site.buildings.push_back(std::move(b));
    }
  }
  check_limits(site, path);
  return site;
}

namespace {

Json ring_json(const std::vector<std::array<double, 2>>& ring) {
  Json out = Json::array();
  for (const auto& p : ring) out.push_back(vec2_json(p));
  return out;
}

Json terrain_json(const scene::TerrainSpec& t) {
  Json terrain = Json::object();
  if (const auto* plane = std::get_if<scene::PlaneTerrainSpec>(&t.geometry)) {
    terrain["plane"] = {{"elevation_m", plane->elevation_m},
                        {"extent_m", plane->extent_m},
                        {"cell_m", plane->cell_m}};
  } else if (const auto* grid = std::get_if<scene::GridTerrainSpec>(&t.geometry)) {
    terrain["grid"] = {{"origin_m", vec2_json(grid->origin_m)},
                       {"spacing_m", grid->spacing_m},
                       {"nx", grid->nx},
                       {"ny", grid->ny},
                       {"elevation_m", grid->elevation_m}};
  } else {
    terrain["mesh"] = mesh_json(std::get<scene::MeshSpec>(t.geometry), false);
  }
  terrain["material"] = t.material;
  if (!t.triangle_material_names.empty() || !t.triangle_material.empty())
    terrain["triangle_materials"] = {{"names", t.triangle_material_names},
                                     {"index", t.triangle_material}};
  if (!t.zones.empty()) {
    Json zones = Json::array();
    for (const auto& z : t.zones)
      zones.push_back({{"material", z.material}, {"polygon_m", ring_json(z.polygon_m)}});
    terrain["zones"] = std::move(zones);
  }
  return terrain;
}

// One material; `note` (may be null) says whether its values are illustrative and their source.
Json material_json(const scene::MaterialSpec& m, const MaterialNotes* note) {
  Json mj = {{"friction", m.friction},
             {"rolling_resistance", m.rolling_resistance},
             {"restitution", restitution_json(m.restitution)}};
  if (m.penetration_ke_per_area_j_per_m2)
    mj["penetration"] = {{"ke_per_area_j_per_m2", *m.penetration_ke_per_area_j_per_m2}};
  if (m.fast_contact) {
    const scene::FastContactSpec& f = *m.fast_contact;
    mj["fast_contact"] = {{"bulk_density_kg_m3", f.bulk_density_kg_m3},
                          {"switch_speed_mps", f.switch_speed_mps},
                          {"critical_angle_coefficient_deg", f.critical_angle_coefficient_deg},
                          {"drag_to_lift_ratio", f.drag_to_lift_ratio},
                          {"roughness_deg", f.roughness_deg},
                          {"exit_angle_ratio", f.exit_angle_ratio}};
  }
  if (!m.ranges.empty()) {
    Json r = Json::object();
    for (const auto& [constant, range] : m.ranges) r[constant] = {range[0], range[1]};
    mj["ranges"] = std::move(r);
  }
  if (m.embedment)
    mj["embedment"] = {{"model", "johnson_reid_1975"},
                       {"bulk_density_kg_m3", m.embedment->bulk_density_kg_m3},
                       {"coefficient_deg", m.embedment->coefficient_deg},
                       {"min_speed_mps", m.embedment->min_speed_mps}};
  if (note) {
    mj["illustrative"] = note->illustrative;
    if (!note->source.empty()) mj["source"] = note->source;
  }
  return mj;
}

Json building_json(const scene::BuildingSpec& b) {
  Json bj = {{"id", b.id}};
  if (b.mesh) {
    bj["mesh"] = mesh_json(*b.mesh, true);
  } else {
    bj["footprint_m"] = ring_json(b.footprint_m);
    // Only when there are holes: a site without them keeps its normalised form (and its id).
    if (!b.holes_m.empty()) {
      Json holes = Json::array();
      for (const auto& ring : b.holes_m) holes.push_back(ring_json(ring));
      bj["holes_m"] = std::move(holes);
    }
    bj["height_m"] = b.height_m;
    if (b.base_elevation_m) bj["base_elevation_m"] = *b.base_elevation_m;
  }
  if (!b.wall.empty()) bj["wall"] = b.wall;
  if (!b.roof.empty()) bj["roof"] = b.roof;
  if (!b.window.empty()) bj["window"] = b.window;
  return bj;
}

}  // namespace

Json site_to_json(const scene::SiteSpec& site, const std::map<std::string, MaterialNotes>* notes) {
  Json out = Json::object();
  if (site.origin) {
    out["origin"] = {{"crs", site.origin->crs},
                     {"easting_m", site.origin->easting_m},
                     {"northing_m", site.origin->northing_m},
                     {"elevation_m", site.origin->elevation_m}};
  }
  out["terrain"] = terrain_json(site.terrain);
  Json materials = Json::object();
  for (const auto& [name, m] : site.materials) {
    const MaterialNotes* note = nullptr;
    if (notes) {
      if (const auto it = notes->find(name); it != notes->end()) note = &it->second;
    }
    materials[name] = material_json(m, note);
  }
  out["materials"] = std::move(materials);
  Json buildings = Json::array();
  for (const auto& b : site.buildings) buildings.push_back(building_json(b));
  out["buildings"] = std::move(buildings);
  return out;
}

}  // namespace fragsim::api::detail
