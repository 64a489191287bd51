// Site limits (site_limits.h): coordinate magnitudes, the terrain's extent, element counts.
#include "core/scene/site_limits.h"

#include <array>
#include <cmath>
#include <string>

#include "core/scene/validation.h"

namespace fragsim::scene {

namespace {

using detail::fail;
using detail::format_number;
using detail::indexed;

void check_xy(double v, const std::string& field) {
  detail::require_in(v, -kMaxAbsCoordinate_m, kMaxAbsCoordinate_m, field);
}

void check_z(double v, const std::string& field) {
  detail::require_in(v, -kMaxAbsElevation_m, kMaxAbsElevation_m, field);
}

void check_point(const Vec3& p, const std::string& field) {
  check_xy(p.x(), indexed(field, 0));
  check_xy(p.y(), indexed(field, 1));
  check_z(p.z(), indexed(field, 2));
}

void check_count(std::size_t n, std::size_t max, const std::string& field, const char* what) {
  if (n > max)
    fail(field, "has " + std::to_string(n) + " " + what + "; at most " + std::to_string(max) +
                    " are allowed");
}

std::string too_wide(double span, int axis) {
  return "spans " + format_number(span) + " m in " + (axis == 0 ? "x" : "y") +
         "; a terrain may span at most " + format_number(kMaxTerrainExtent_m) + " m";
}

void check_mesh_points(const MeshSpec& m, const std::string& field) {
  for (std::size_t v = 0; v < m.vertices_m.size(); ++v)
    check_point(m.vertices_m[v], indexed(field + ".vertices_m", v));
}

// The horizontal span of the vertices the triangles use; indices out of range are left to
// validate_mesh. The message names the two extreme vertices.
void check_mesh_span(const MeshSpec& m, const std::string& field) {
  const auto nv = static_cast<std::int64_t>(m.vertices_m.size());
  std::array<std::int64_t, 2> lo{-1, -1}, hi{-1, -1};
  for (const auto& tri : m.triangles) {
    for (const std::int64_t v : tri) {
      if (v < 0 || v >= nv) continue;
      for (int k = 0; k < 2; ++k) {
        const auto at = [&](std::int64_t i) {
          return m.vertices_m[static_cast<std::size_t>(i)][k];
        };
        if (lo[k] < 0 || at(v) < at(lo[k])) lo[k] = v;
        if (hi[k] < 0 || at(v) > at(hi[k])) hi[k] = v;
      }
    }
  }
  for (int k = 0; k < 2; ++k) {
    if (lo[k] < 0) return;
    const double span = m.vertices_m[static_cast<std::size_t>(hi[k])][k] -
                        m.vertices_m[static_cast<std::size_t>(lo[k])][k];
    if (span > kMaxTerrainExtent_m)
      fail(indexed(field + ".vertices_m", static_cast<std::size_t>(hi[k])),
           too_wide(span, k) + " (from vertices_m[" + std::to_string(lo[k]) + "])");
  }
}

void check_terrain(const TerrainSpec& terrain) {
  const std::string f = detail::terrain_form_field(terrain);
  if (const auto* plane = std::get_if<PlaneTerrainSpec>(&terrain.geometry)) {
    check_z(plane->elevation_m, f + ".elevation_m");
    for (std::size_t k = 0; k < 4; ++k) check_xy(plane->extent_m[k], indexed(f + ".extent_m", k));
    for (int k = 0; k < 2; ++k) {
      const double span = plane->extent_m[k + 2] - plane->extent_m[k];
      if (span > kMaxTerrainExtent_m) fail(f + ".extent_m", too_wide(span, k));
    }
  } else if (const auto* grid = std::get_if<GridTerrainSpec>(&terrain.geometry)) {
    check_xy(grid->origin_m[0], f + ".origin_m[0]");
    check_xy(grid->origin_m[1], f + ".origin_m[1]");
    for (std::size_t k = 0; k < grid->elevation_m.size(); ++k)
      check_z(grid->elevation_m[k], indexed(f + ".elevation_m", k));
    const int n[2] = {grid->nx, grid->ny};
    for (int k = 0; k < 2; ++k) {
      // (n - 1) spacing; a bad spacing or count is reported by the terrain builder.
      const double span = grid->spacing_m * static_cast<double>(n[k] - 1);
      if (std::isfinite(grid->spacing_m) && n[k] >= 2 && span > kMaxTerrainExtent_m)
        fail(f + ".spacing_m",
             too_wide(span, k) + " ((n" + (k == 0 ? "x" : "y") + " - 1) * spacing_m)");
    }
  } else {
    const auto& mesh = std::get<MeshSpec>(terrain.geometry);
    check_count(mesh.vertices_m.size(), kMaxTerrainVertices, f + ".vertices_m", "vertices");
    check_count(mesh.triangles.size(), kMaxTerrainTriangles, f + ".triangles", "triangles");
    check_mesh_points(mesh, f);
    check_mesh_span(mesh, f);
  }
  check_count(terrain.triangle_material.size(), kMaxTerrainTriangles,
              "site.terrain.triangle_materials.index", "entries");
  check_count(terrain.zones.size(), kMaxMaterialZones, "site.terrain.zones", "zones");
  for (std::size_t z = 0; z < terrain.zones.size(); ++z) {
    const std::string zf = indexed("site.terrain.zones", z) + ".polygon_m";
    check_count(terrain.zones[z].polygon_m.size(), kMaxZoneVertices, zf, "vertices");
    for (std::size_t k = 0; k < terrain.zones[z].polygon_m.size(); ++k) {
      check_xy(terrain.zones[z].polygon_m[k][0], indexed(indexed(zf, k), 0));
      check_xy(terrain.zones[z].polygon_m[k][1], indexed(indexed(zf, k), 1));
    }
  }
}

// The building's triangles as built: a footprint of n vertices (all rings together) with h holes
// gives 2n walls, and n + 2h - 2 roof and as many floor triangles (a triangulation of a polygon
// with h holes, vertices only at its own; Euler's formula). A GIS ring's closing copy of its
// first vertex counts too (the builder drops it): an upper bound then. Rings of fewer than 3
// vertices are the builder's to refuse.
std::size_t building_triangles(const BuildingSpec& b) {
  if (b.mesh) return b.mesh->triangles.size();
  if (b.footprint_m.size() < 3) return 0;
  std::size_t n = b.footprint_m.size();
  for (const auto& hole : b.holes_m) n += hole.size();
  return 4 * n + 4 * b.holes_m.size() - 4;
}

// Hole vertices are footprint vertices: the same coordinate range, and one count for all rings.
void check_holes(const BuildingSpec& b, const std::string& field) {
  std::size_t n = b.footprint_m.size();
  for (std::size_t h = 0; h < b.holes_m.size(); ++h) {
    const std::string hf = indexed(field + ".holes_m", h);
    n += b.holes_m[h].size();
    if (n > kMaxFootprintVertices)
      fail(hf, "brings the footprint's vertices to " + std::to_string(n) +
                   " (footprint_m and holes_m together); at most " +
                   std::to_string(kMaxFootprintVertices) + " are allowed");
    for (std::size_t k = 0; k < b.holes_m[h].size(); ++k) {
      check_xy(b.holes_m[h][k][0], indexed(indexed(hf, k), 0));
      check_xy(b.holes_m[h][k][1], indexed(indexed(hf, k), 1));
    }
  }
}

void check_building(const BuildingSpec& b, const std::string& field) {
  if (b.mesh) {
    check_count(b.mesh->vertices_m.size(), kMaxBuildingTriangles, field + ".mesh.vertices_m",
                "vertices");
    check_mesh_points(*b.mesh, field + ".mesh");
    return;
  }
  const std::string ff = field + ".footprint_m";
  check_count(b.footprint_m.size(), kMaxFootprintVertices, ff, "vertices");
  for (std::size_t k = 0; k < b.footprint_m.size(); ++k) {
    check_xy(b.footprint_m[k][0], indexed(indexed(ff, k), 0));
    check_xy(b.footprint_m[k][1], indexed(indexed(ff, k), 1));
  }
  check_holes(b, field);
  if (b.height_m > kMaxBuildingHeight_m)  // NaN and <= 0 are the builder's
    fail(field + ".height_m", "must be <= " + format_number(kMaxBuildingHeight_m) + " (got " +
                                  format_number(b.height_m) + ")");
  if (b.base_elevation_m) check_z(*b.base_elevation_m, field + ".base_elevation_m");
}

void check_buildings(const std::vector<BuildingSpec>& buildings) {
  check_count(buildings.size(), kMaxBuildings, "site.buildings", "buildings");
  std::size_t triangles = 0;
  for (std::size_t k = 0; k < buildings.size(); ++k) {
    const std::string field = indexed("site.buildings", k);
    check_building(buildings[k], field);
    triangles += building_triangles(buildings[k]);
    if (triangles > kMaxBuildingTriangles)
      fail(field, "brings the building triangles to " + std::to_string(triangles) + "; at most " +
                      std::to_string(kMaxBuildingTriangles) + " in all");
  }
}

}  // namespace

double terrain_triangles_of(const TerrainSpec& terrain) {
  if (const auto* plane = std::get_if<PlaneTerrainSpec>(&terrain.geometry)) {
    const auto& e = plane->extent_m;
    const double nx = std::ceil((e[2] - e[0]) / plane->cell_m);
    const double ny = std::ceil((e[3] - e[1]) / plane->cell_m);
    if (!(nx > 0.0) || !(ny > 0.0)) return 0.0;  // NaN or empty: refused by the builder
    return 2.0 * nx * ny;
  }
  if (const auto* grid = std::get_if<GridTerrainSpec>(&terrain.geometry)) {
    if (grid->nx < 2 || grid->ny < 2) return 0.0;
    return 2.0 * static_cast<double>(grid->nx - 1) * static_cast<double>(grid->ny - 1);
  }
  return static_cast<double>(std::get<MeshSpec>(terrain.geometry).triangles.size());
}

void check_site_limits(const SiteSpec& spec) {
  if (spec.origin) {
    check_xy(spec.origin->easting_m, "site.origin.easting_m");
    check_xy(spec.origin->northing_m, "site.origin.northing_m");
    check_z(spec.origin->elevation_m, "site.origin.elevation_m");
  }
  check_terrain(spec.terrain);
  check_buildings(spec.buildings);
}

}  // namespace fragsim::scene
