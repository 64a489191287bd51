// Terrain: validation, meshing of the plane and grid forms, the local frame, normals, areas and
// the 2-D index.
#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "core/scene/polygon.h"
#include "core/scene/site_builder.h"
#include "core/scene/terrain_index.h"
#include "core/scene/validation.h"

namespace fragsim::scene {

namespace {

using detail::fail;
using detail::indexed;

// Guards against a typo (cell_m = 0.001 over kilometres) asking for terabytes: 2^25 cells is
// 67 M triangles, about 3 GB of mesh, index and per-triangle data.
constexpr double kMaxTerrainCells = 33554432.0;

// Whole metres: the local origin only has to be near the terrain, and a round number keeps
// local <-> input conversions exact for inputs given to the millimetre or coarser.
Vec3 round_origin(const Vec3& p) {
  return Vec3(std::round(p.x()), std::round(p.y()), std::round(p.z()));
}

// A rectilinear vertex lattice xs x ys with heights z(i, j), two triangles per cell split along
// the (i, j)-(i+1, j+1) diagonal, both counter-clockwise seen from above (normals up):
// cell (i, j) -> triangles 2*(j*ncx + i) = (v00, v10, v11) and 2*(j*ncx + i) + 1 = (v00, v11, v01).
template <class Z>
void mesh_lattice(const std::vector<double>& xs, const std::vector<double>& ys, Z&& z,
                  std::vector<Vec3>& vertices, std::vector<std::array<std::uint32_t, 3>>& tris) {
  const std::size_t nvx = xs.size(), nvy = ys.size();
  vertices.resize(nvx * nvy);
  for (std::size_t j = 0; j < nvy; ++j)
    for (std::size_t i = 0; i < nvx; ++i) vertices[j * nvx + i] = Vec3(xs[i], ys[j], z(i, j));
  tris.clear();
  tris.reserve(2 * (nvx - 1) * (nvy - 1));
  for (std::size_t j = 0; j + 1 < nvy; ++j) {
    for (std::size_t i = 0; i + 1 < nvx; ++i) {
      const auto v00 = static_cast<std::uint32_t>(j * nvx + i);
      const auto v10 = v00 + 1, v01 = static_cast<std::uint32_t>(v00 + nvx), v11 = v01 + 1;
      tris.push_back({v00, v10, v11});
      tris.push_back({v00, v11, v01});
    }
  }
}

// Cells fitting an extent exactly: n = ceil(extent / cell), with a 1e-9 relative allowance so
// that 400 / 10 does not become 41 cells through rounding.
int cells_for(double extent, double cell) {
  return std::max(1, static_cast<int>(std::ceil(extent / cell * (1.0 - 1e-9))));
}

}  // namespace

void SiteBuilder::build_terrain(Site& site, const SiteSpec& spec, const MaterialIds& ids) {
  const TerrainSpec& terrain = spec.terrain;
  const std::string f = detail::terrain_form_field(terrain);
  site.terrain_material_ = material_id(ids, terrain.material, "site.terrain.material");
  site.terrain_is_plane_ = false;
  Lattice lattice;  // stays empty for a mesh
  if (const auto* plane = std::get_if<PlaneTerrainSpec>(&terrain.geometry))
    lattice = build_plane_terrain(site, *plane, f);
  else if (const auto* grid = std::get_if<GridTerrainSpec>(&terrain.geometry))
    lattice = build_grid_terrain(site, *grid, f);
  else
    build_mesh_terrain(site, std::get<MeshSpec>(terrain.geometry), f);
  build_terrain_facets(site);
  build_terrain_boundary(site, lattice);
  site.terrain_is_lattice_ = lattice.ncx > 0;
  site.index_ =
      site.terrain_is_lattice_
          ? detail::make_cell_index(lattice.origin, lattice.cell, lattice.ncx, lattice.ncy,
                                    site.terrain_vertices_, site.terrain_triangles_)
          : detail::make_mesh_index(site.terrain_vertices_, site.terrain_triangles_);
  build_terrain_materials(site, terrain, ids);
}

namespace {

// Calls f(t) for every terrain triangle whose centroid lies inside `poly` (local, counter-
// clockwise or not): the candidates are those of the index buckets under the polygon's bounds.
template <class F>
void for_each_triangle_in(const Site& site, const std::vector<Vec2>& poly, F&& f) {
  Vec2 lo = poly[0], hi = poly[0];
  for (const Vec2& p : poly) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const TerrainIndex2D& ix = site.terrain_index();
  const int i0 = clamped_bucket((lo.x() - ix.origin.x()) / ix.cell.x(), ix.nx);
  const int i1 = clamped_bucket((hi.x() - ix.origin.x()) / ix.cell.x(), ix.nx);
  const int j0 = clamped_bucket((lo.y() - ix.origin.y()) / ix.cell.y(), ix.ny);
  const int j1 = clamped_bucket((hi.y() - ix.origin.y()) / ix.cell.y(), ix.ny);
  for (int j = j0; j <= j1; ++j) {
    for (int i = i0; i <= i1; ++i) {
      const std::size_t b = static_cast<std::size_t>(j) * ix.nx + i;
      for (std::uint32_t k = ix.start[b]; k < ix.start[b + 1]; ++k) {
        const std::uint32_t t = ix.triangles[k];
        const Vec2 c = site.terrain_triangle_centroid(t).head<2>();
        if (c.x() >= lo.x() && c.x() <= hi.x() && c.y() >= lo.y() && c.y() <= hi.y() &&
            detail::point_in_polygon(poly, c))
          f(t);
      }
    }
  }
}

}  // namespace

void SiteBuilder::build_terrain_materials(Site& site, const TerrainSpec& terrain,
                                          const MaterialIds& ids) {
  site.terrain_triangle_material_.clear();
  if (terrain.triangle_material_names.empty() && terrain.triangle_material.empty() &&
      terrain.zones.empty())
    return;
  const std::size_t nt = site.terrain_triangles_.size();
  std::vector<std::uint16_t> m(nt, site.terrain_material_);
  const std::string tf = "site.terrain.triangle_materials";
  if (!terrain.triangle_material.empty() || !terrain.triangle_material_names.empty()) {
    std::vector<std::uint16_t> named;
    for (std::size_t k = 0; k < terrain.triangle_material_names.size(); ++k)
      named.push_back(
          material_id(ids, terrain.triangle_material_names[k], indexed(tf + ".names", k)));
    if (named.empty()) fail(tf + ".names", "is empty (name the materials the index refers to)");
    if (terrain.triangle_material.size() != nt)
      fail(tf + ".index", "has " + std::to_string(terrain.triangle_material.size()) +
                              " entries; the terrain has " + std::to_string(nt) + " triangles");
    for (std::size_t t = 0; t < nt; ++t) {
      const std::int64_t k = terrain.triangle_material[t];
      if (k < 0 || static_cast<std::size_t>(k) >= named.size())
        fail(indexed(tf + ".index", t), "must be in [0, " + std::to_string(named.size() - 1) +
                                            "] (got " + std::to_string(k) + ")");
      m[t] = named[static_cast<std::size_t>(k)];
    }
  }
  const Vec3& o = site.local_origin_;
  for (std::size_t z = 0; z < terrain.zones.size(); ++z) {
    const std::string zf = indexed("site.terrain.zones", z);
    const std::uint16_t id = material_id(ids, terrain.zones[z].material, zf + ".material");
    const auto& ring = terrain.zones[z].polygon_m;
    std::vector<Vec2> poly;
    for (std::size_t k = 0; k < ring.size(); ++k) {
      detail::require_finite(ring[k][0], indexed(indexed(zf + ".polygon_m", k), 0));
      detail::require_finite(ring[k][1], indexed(indexed(zf + ".polygon_m", k), 1));
      poly.emplace_back(ring[k][0] - o.x(), ring[k][1] - o.y());
    }
    if (poly.size() >= 4 && ring.front() == ring.back()) poly.pop_back();  // GIS closing vertex
    detail::validate_simple_polygon(poly, zf + ".polygon_m", "zone");
    for_each_triangle_in(site, poly, [&](std::uint32_t t) { m[t] = id; });
  }
  if (std::all_of(m.begin(), m.end(), [&](std::uint16_t k) { return k == site.terrain_material_; }))
    return;  // nothing differs from the base material: the single-material fast path
  site.terrain_triangle_material_ = std::move(m);
}

SiteBuilder::Lattice SiteBuilder::build_plane_terrain(Site& site, const PlaneTerrainSpec& plane,
                                                      const std::string& f) {
  detail::require_finite(plane.elevation_m, f + ".elevation_m");
  for (std::size_t k = 0; k < 4; ++k)
    detail::require_finite(plane.extent_m[k], indexed(f + ".extent_m", k));
  const auto& e = plane.extent_m;
  if (!(e[2] > e[0]))
    fail(f + ".extent_m", "xmax must be greater than xmin (got xmin " +
                              detail::format_number(e[0]) + ", xmax " +
                              detail::format_number(e[2]) + ")");
  if (!(e[3] > e[1]))
    fail(f + ".extent_m", "ymax must be greater than ymin (got ymin " +
                              detail::format_number(e[1]) + ", ymax " +
                              detail::format_number(e[3]) + ")");
  detail::require_positive(plane.cell_m, f + ".cell_m");
  const double ex = e[2] - e[0], ey = e[3] - e[1];
  if (std::ceil(ex / plane.cell_m) * std::ceil(ey / plane.cell_m) > kMaxTerrainCells)
    fail(f + ".cell_m", "too small for the extent (more than 2^25 cells)");
  Lattice l;
  l.ncx = cells_for(ex, plane.cell_m);
  l.ncy = cells_for(ey, plane.cell_m);
  site.local_origin_ =
      round_origin(Vec3(0.5 * (e[0] + e[2]), 0.5 * (e[1] + e[3]), plane.elevation_m));
  const Vec3& o = site.local_origin_;
  std::vector<double> xs(static_cast<std::size_t>(l.ncx) + 1),
      ys(static_cast<std::size_t>(l.ncy) + 1);
  // Subtract the origin first, then subdivide: local coordinates carry no UTM-sized rounding.
  const double x0 = e[0] - o.x(), x1 = e[2] - o.x(), y0 = e[1] - o.y(), y1 = e[3] - o.y();
  for (int i = 0; i <= l.ncx; ++i) xs[i] = i == l.ncx ? x1 : x0 + (x1 - x0) * i / l.ncx;
  for (int j = 0; j <= l.ncy; ++j) ys[j] = j == l.ncy ? y1 : y0 + (y1 - y0) * j / l.ncy;
  site.terrain_is_plane_ = true;
  site.plane_elevation_ = plane.elevation_m - o.z();
  const double zl = site.plane_elevation_;
  mesh_lattice(
      xs, ys, [zl](std::size_t, std::size_t) { return zl; }, site.terrain_vertices_,
      site.terrain_triangles_);
  l.origin = Vec2(x0, y0);
  l.cell = Vec2((x1 - x0) / l.ncx, (y1 - y0) / l.ncy);
  return l;
}

SiteBuilder::Lattice SiteBuilder::build_grid_terrain(Site& site, const GridTerrainSpec& grid,
                                                     const std::string& f) {
  detail::require_finite(grid.origin_m[0], f + ".origin_m[0]");
  detail::require_finite(grid.origin_m[1], f + ".origin_m[1]");
  detail::require_positive(grid.spacing_m, f + ".spacing_m");
  if (grid.nx < 2) fail(f + ".nx", "must be at least 2 (got " + std::to_string(grid.nx) + ")");
  if (grid.ny < 2) fail(f + ".ny", "must be at least 2 (got " + std::to_string(grid.ny) + ")");
  if (static_cast<double>(grid.nx - 1) * static_cast<double>(grid.ny - 1) > kMaxTerrainCells)
    fail(f, "too many cells (more than 2^25)");
  const auto nvx = static_cast<std::size_t>(grid.nx), nvy = static_cast<std::size_t>(grid.ny);
  if (grid.elevation_m.size() != nvx * nvy)
    fail(f + ".elevation_m", "has " + std::to_string(grid.elevation_m.size()) +
                                 " values; nx * ny = " + std::to_string(nvx * nvy));
  double zmin = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < grid.elevation_m.size(); ++k) {
    detail::require_finite(grid.elevation_m[k], indexed(f + ".elevation_m", k));
    zmin = std::min(zmin, grid.elevation_m[k]);
  }
  const double s = grid.spacing_m;
  site.local_origin_ =
      round_origin(Vec3(grid.origin_m[0] + 0.5 * s * static_cast<double>(nvx - 1),
                        grid.origin_m[1] + 0.5 * s * static_cast<double>(nvy - 1), zmin));
  const Vec3& o = site.local_origin_;
  const double x0 = grid.origin_m[0] - o.x(), y0 = grid.origin_m[1] - o.y();
  std::vector<double> xs(nvx), ys(nvy);
  for (std::size_t i = 0; i < nvx; ++i) xs[i] = x0 + s * static_cast<double>(i);
  for (std::size_t j = 0; j < nvy; ++j) ys[j] = y0 + s * static_cast<double>(j);
  mesh_lattice(
      xs, ys, [&](std::size_t i, std::size_t j) { return grid.elevation_m[j * nvx + i] - o.z(); },
      site.terrain_vertices_, site.terrain_triangles_);
  Lattice l;
  l.ncx = grid.nx - 1;
  l.ncy = grid.ny - 1;
  l.origin = Vec2(x0, y0);
  l.cell = Vec2(s, s);
  return l;
}

void SiteBuilder::build_mesh_terrain(Site& site, const MeshSpec& mesh, const std::string& f) {
  if (!mesh.surface.empty())
    fail(f + ".surface", "per-triangle surface types are for building meshes only");
  detail::validate_mesh(mesh, f, "site.terrain", "empty terrain");
  Box3 box;
  for (const auto& t : mesh.triangles)
    for (const auto v : t) box.extend(mesh.vertices_m[v]);
  site.local_origin_ = round_origin(
      Vec3(0.5 * (box.lo.x() + box.hi.x()), 0.5 * (box.lo.y() + box.hi.y()), box.lo.z()));
  site.terrain_vertices_.resize(mesh.vertices_m.size());
  for (std::size_t v = 0; v < mesh.vertices_m.size(); ++v)
    site.terrain_vertices_[v] = mesh.vertices_m[v] - site.local_origin_;
  site.terrain_triangles_.resize(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    std::array<std::uint32_t, 3> tri{};
    for (std::size_t k = 0; k < 3; ++k) tri[k] = static_cast<std::uint32_t>(mesh.triangles[t][k]);
    const Vec3& a = site.terrain_vertices_[tri[0]];
    const Vec3& b = site.terrain_vertices_[tri[1]];
    const Vec3& c = site.terrain_vertices_[tri[2]];
    // A terrain is a height surface: every triangle must have a proper xy-projection (same
    // relative test as for zero area, applied to the projection).
    if (detail::is_zero_area_2d(a.head<2>(), b.head<2>(), c.head<2>()))
      fail(indexed(f + ".triangles", t), "vertical triangle (terrain must be a height surface)");
    if ((b - a).cross(c - a).z() < 0) std::swap(tri[1], tri[2]);  // make the normal point up
    site.terrain_triangles_[t] = tri;
  }
}

void SiteBuilder::build_terrain_facets(Site& site) {
  const std::size_t nt = site.terrain_triangles_.size();
  site.terrain_area_.resize(nt);
  site.terrain_facet_.resize(nt);
  site.terrain_bounds_ = Box3{};
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& tri = site.terrain_triangles_[t];
    const Vec3& a = site.terrain_vertices_[tri[0]];
    const Vec3& b = site.terrain_vertices_[tri[1]];
    const Vec3& c = site.terrain_vertices_[tri[2]];
    const Vec3 n = (b - a).cross(c - a);
    const double len = n.norm();
    site.terrain_area_[t] = 0.5 * len;
    site.terrain_facet_[t].normal = n / len;
    // Plane z = gx x + gy y + gz through the triangle (n_z > 0: not vertical).
    site.terrain_facet_[t].plane = {-n.x() / n.z(), -n.y() / n.z(),
                                    a.z() + (n.x() * a.x() + n.y() * a.y()) / n.z()};
    site.terrain_bounds_.extend(a);
    site.terrain_bounds_.extend(b);
    site.terrain_bounds_.extend(c);
  }
}

namespace {

// Triangles of a lattice of ncx x ncy cells that lie in its outer ring of cells, ascending.
std::vector<std::uint32_t> lattice_boundary(int ncx, int ncy) {
  std::vector<std::uint32_t> out;
  const auto add = [&](int i, int j) {
    const auto k = static_cast<std::uint32_t>(j * ncx + i);
    out.push_back(2 * k);
    out.push_back(2 * k + 1);
  };
  for (int j = 0; j < ncy; ++j) {
    if (j == 0 || j == ncy - 1) {
      for (int i = 0; i < ncx; ++i) add(i, j);
    } else {
      add(0, j);
      if (ncx > 1) add(ncx - 1, j);
    }
  }
  return out;
}

// Per vertex: the smallest index of a vertex at the same position.
std::vector<std::uint32_t> welded_ids(const std::vector<Vec3>& vertices) {
  std::vector<std::uint32_t> order(vertices.size());
  for (std::uint32_t v = 0; v < order.size(); ++v) order[v] = v;
  const auto key = [&](std::uint32_t v) {
    return std::make_tuple(vertices[v].x(), vertices[v].y(), vertices[v].z(), v);
  };
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  std::vector<std::uint32_t> id(vertices.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const bool same = k > 0 && vertices[order[k]] == vertices[order[k - 1]];
    id[order[k]] = same ? id[order[k - 1]] : order[k];
  }
  return id;
}

// Triangles of a mesh with a vertex on an edge used by one triangle only.
std::vector<std::uint32_t> mesh_boundary(const std::vector<Vec3>& vertices,
                                         const std::vector<std::array<std::uint32_t, 3>>& tris) {
  const std::vector<std::uint32_t> id = welded_ids(vertices);
  std::vector<std::uint64_t> edges;
  edges.reserve(3 * tris.size());
  for (const auto& t : tris) {
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t a = id[t[k]], b = id[t[(k + 1) % 3]];
      edges.push_back(std::min(a, b) << 32 | std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<bool> on_rim(vertices.size(), false);
  for (std::size_t k = 0; k < edges.size();) {
    std::size_t n = 1;
    while (k + n < edges.size() && edges[k + n] == edges[k]) ++n;
    if (n == 1) {
      on_rim[edges[k] >> 32] = true;
      on_rim[edges[k] & 0xffffffffu] = true;
    }
    k += n;
  }
  std::vector<std::uint32_t> out;
  for (std::uint32_t t = 0; t < tris.size(); ++t) {
    const auto& v = tris[t];
    if (on_rim[id[v[0]]] || on_rim[id[v[1]]] || on_rim[id[v[2]]]) out.push_back(t);
  }
  return out;
}

}  // namespace

void SiteBuilder::build_terrain_boundary(Site& site, const Lattice& lattice) {
  site.terrain_boundary_ = lattice.ncx > 0
                               ? lattice_boundary(lattice.ncx, lattice.ncy)
                               : mesh_boundary(site.terrain_vertices_, site.terrain_triangles_);
}

}  // namespace fragsim::scene
