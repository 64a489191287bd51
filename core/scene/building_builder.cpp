// Buildings: footprint extrusion (walls, ear-clipped roof, floor; courtyards), explicit closed
// meshes, validation, and the default base elevation from the terrain.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <tuple>

#include "core/scene/polygon.h"
#include "core/scene/site_builder.h"
#include "core/scene/validation.h"

namespace fragsim::scene {

namespace {

using detail::fail;
using detail::indexed;

struct Tri {
  std::array<std::uint32_t, 3> v;  // into the building's own vertex list
  SurfaceType surface;
};

struct BuildingMesh {
  std::vector<Vec3> vertices;  // local
  std::vector<Tri> triangles;
  std::uint32_t floor_triangles = 0;  // the last ones
};

constexpr double kInf = std::numeric_limits<double>::infinity();

// A footprint ring in local coordinates, its input field's path, each coordinate checked finite.
// GIS rings often repeat the first vertex at the end; that copy is dropped.
std::vector<Vec2> local_ring(const Site& site, const std::vector<std::array<double, 2>>& ring,
                             const std::string& field) {
  std::vector<Vec2> poly;
  poly.reserve(ring.size());
  const Vec3& o = site.local_origin();
  for (std::size_t k = 0; k < ring.size(); ++k) {
    detail::require_finite(ring[k][0], indexed(indexed(field, k), 0));
    detail::require_finite(ring[k][1], indexed(indexed(field, k), 1));
    poly.emplace_back(ring[k][0] - o.x(), ring[k][1] - o.y());
  }
  if (poly.size() >= 4 && ring.front() == ring.back()) poly.pop_back();
  return poly;
}

// Lowest terrain height along a closed ring: at its vertices and where its edges enter or leave
// terrain triangles (the terrain is planar in between).
double lowest_terrain_along(const Site& site, const std::vector<Vec2>& poly) {
  double zmin = kInf;
  const auto& verts = site.terrain_vertices();
  const auto& tris = site.terrain_triangles();
  for (const Vec2& p : poly) {
    const double h = site.terrain_height(p.x(), p.y());
    if (std::isfinite(h)) zmin = std::min(zmin, h);
  }
  const std::size_t n = poly.size();
  for (std::size_t k = 0; k < n; ++k) {
    const Vec2& a = poly[k];
    const Vec2& b = poly[(k + 1) % n];
    site.terrain_index().for_each_candidate(a, b, [&](std::uint32_t t) {
      const Vec3& v0 = verts[tris[t][0]];
      const Vec3& v1 = verts[tris[t][1]];
      const Vec3& v2 = verts[tris[t][2]];
      const Vec2 p[3] = {v0.head<2>(), v1.head<2>(), v2.head<2>()};
      // Clip the edge's parameter range to the (counter-clockwise) triangle: inside is to the
      // left of each triangle edge, and the orientation is linear along a-b.
      double s0 = 0.0, s1 = 1.0;
      for (int e = 0; e < 3; ++e) {
        const double f0 = detail::orient2d(p[e], p[(e + 1) % 3], a);
        const double f1 = detail::orient2d(p[e], p[(e + 1) % 3], b);
        if (f0 < 0 && f1 < 0) return;
        if (f0 < 0) s0 = std::max(s0, f0 / (f0 - f1));
        if (f1 < 0) s1 = std::min(s1, f0 / (f0 - f1));
      }
      if (s0 > s1) return;
      const Vec3& nrm = site.terrain_triangle_normal(t);
      for (const double s : {s0, s1}) {
        const Vec2 x = a + s * (b - a);
        // Plane of the triangle: n . (X - v0) = 0 solved for z.
        const double z =
            v0.z() - (nrm.x() * (x.x() - v0.x()) + nrm.y() * (x.y() - v0.y())) / nrm.z();
        zmin = std::min(zmin, z);
      }
    });
  }
  return zmin;
}

// Lowest terrain vertex strictly under the building: inside the footprint rings[0] and outside
// its holes rings[1..] (a courtyard's ground is not under the building).
double lowest_terrain_vertex_inside(const Site& site, const std::vector<std::vector<Vec2>>& rings) {
  double zmin = kInf;
  const auto& verts = site.terrain_vertices();
  const auto& tris = site.terrain_triangles();
  const TerrainIndex2D& index = site.terrain_index();
  const std::vector<Vec2>& poly = rings[0];
  const auto under = [&](const Vec2& p) {
    if (!detail::point_in_polygon(poly, p)) return false;
    for (std::size_t h = 1; h < rings.size(); ++h)
      if (detail::point_in_polygon(rings[h], p)) return false;
    return true;
  };
  // Visit the buckets under the footprint's bounding box.
  Vec2 lo = poly[0], hi = poly[0];
  for (const Vec2& p : poly) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec2 glo = (lo - index.origin).cwiseQuotient(index.cell);
  const Vec2 ghi = (hi - index.origin).cwiseQuotient(index.cell);
  if (!(ghi.x() >= 0 && ghi.y() >= 0 && glo.x() <= index.nx && glo.y() <= index.ny)) return zmin;
  // Clamped in double before the conversion: a footprint far beyond a fine grid is more buckets
  // away than an int holds.
  const int i0 = clamped_bucket(glo.x(), index.nx), i1 = clamped_bucket(ghi.x(), index.nx);
  const int j0 = clamped_bucket(glo.y(), index.ny), j1 = clamped_bucket(ghi.y(), index.ny);
  for (int j = j0; j <= j1; ++j) {
    for (int i = i0; i <= i1; ++i) {
      const std::size_t bucket = static_cast<std::size_t>(j) * index.nx + i;
      for (std::uint32_t k = index.start[bucket]; k < index.start[bucket + 1]; ++k) {
        for (const std::uint32_t v : tris[index.triangles[k]]) {
          if (verts[v].z() < zmin && under(verts[v].head<2>())) zmin = verts[v].z();
        }
      }
    }
  }
  return zmin;
}

// Lowest terrain height under a footprint with holes (local coordinates; rings[0] the outline,
// rings[1..] the holes). The terrain is piecewise planar, so over the region its minimum is
// attained at a terrain vertex inside the region or on its boundary; along a boundary edge, at
// a ring vertex or where the edge enters or leaves a terrain triangle. All three sets are
// visited, so the walls, courtyard walls included, reach down to the ground everywhere (no gap
// under any wall). Returns +inf when the footprint misses the terrain entirely.
double lowest_terrain_under(const Site& site, const std::vector<std::vector<Vec2>>& rings) {
  double zmin = lowest_terrain_vertex_inside(site, rings);
  for (const auto& ring : rings) zmin = std::min(zmin, lowest_terrain_along(site, ring));
  return zmin;
}

// The rings in local coordinates, validated and oriented: rings[0] the footprint,
// counter-clockwise; rings[1..] the holes, clockwise (the solid on the left of every edge).
std::vector<std::vector<Vec2>> footprint_rings(const Site& site, const BuildingSpec& spec,
                                               const std::string& b) {
  const std::string ff = b + ".footprint_m";
  std::vector<std::vector<Vec2>> rings;
  rings.push_back(local_ring(site, spec.footprint_m, ff));
  detail::validate_simple_polygon(rings[0], ff);
  for (std::size_t h = 0; h < spec.holes_m.size(); ++h)
    rings.push_back(local_ring(site, spec.holes_m[h], indexed(b + ".holes_m", h)));
  // Validated as given, so that the edge numbers in messages are the input's.
  const std::vector<std::vector<Vec2>> holes(rings.begin() + 1, rings.end());
  detail::validate_holes(rings[0], holes, b + ".holes_m");
  if (detail::signed_area(rings[0]) < 0) std::reverse(rings[0].begin(), rings[0].end());
  for (std::size_t h = 1; h < rings.size(); ++h)
    if (detail::signed_area(rings[h]) > 0) std::reverse(rings[h].begin(), rings[h].end());
  return rings;
}

BuildingMesh extrude_footprint(const Site& site, const BuildingSpec& spec, const std::string& b) {
  const std::string ff = b + ".footprint_m";
  detail::require_positive(spec.height_m, b + ".height_m");
  if (spec.base_elevation_m)
    detail::require_finite(*spec.base_elevation_m, b + ".base_elevation_m");
  const std::vector<std::vector<Vec2>> rings = footprint_rings(site, spec, b);

  double base = 0.0;
  if (spec.base_elevation_m) {
    base = *spec.base_elevation_m - site.local_origin().z();
  } else {
    base = lowest_terrain_under(site, rings);
    if (!std::isfinite(base)) fail(ff, "footprint lies outside the terrain; give base_elevation_m");
  }
  const double top = base + spec.height_m;

  std::vector<std::array<std::uint32_t, 3>> roof;
  try {
    roof = detail::triangulate_polygon_with_holes(
        rings[0], std::vector<std::vector<Vec2>>(rings.begin() + 1, rings.end()));
  } catch (const std::runtime_error&) {
    fail(ff, "cannot triangulate the roof (nearly degenerate polygon)");
  }
  std::uint32_t n = 0;  // vertices of all rings, numbered in ring order
  for (const auto& ring : rings) n += static_cast<std::uint32_t>(ring.size());
  BuildingMesh mesh;
  mesh.vertices.reserve(2 * n);
  for (const double z : {base, top}) {  // base ring 0..n-1, top ring n..2n-1
    for (const auto& ring : rings)
      for (const Vec2& p : ring) mesh.vertices.emplace_back(p.x(), p.y(), z);
  }
  // Walls: one quad per ring edge k -> k+1. The solid is on the left of every edge (footprint
  // counter-clockwise, holes clockwise), so the outward side, into the open or into a
  // courtyard, is on its right, and (b0, b1, t1), (b0, t1, t0) wind counter-clockwise seen from
  // there: normal = (b1 - b0) x (t1 - b0) = h (dy, -dx, 0), which points right.
  std::uint32_t first = 0;
  for (const auto& ring : rings) {
    const auto m = static_cast<std::uint32_t>(ring.size());
    for (std::uint32_t k = first; k < first + m; ++k) {
      const std::uint32_t k1 = k + 1 < first + m ? k + 1 : first;
      mesh.triangles.push_back({{k, k1, n + k1}, SurfaceType::kWall});
      mesh.triangles.push_back({{k, n + k1, n + k}, SurfaceType::kWall});
    }
    first += m;
  }
  // Roof: the ear-clipped triangles are counter-clockwise from above, normal +z (outward).
  for (const auto& t : roof)
    mesh.triangles.push_back({{n + t[0], n + t[1], n + t[2]}, SurfaceType::kRoof});
  // Floor: the same triangulation reversed (normal -z), closing the mesh so that ray parity
  // (inside_building) is well defined. It rests on or in the ground, so no fragment reaches it
  // from outside; it is tagged as wall (wall material) and kept out of the exposed areas.
  for (const auto& t : roof) mesh.triangles.push_back({{t[0], t[2], t[1]}, SurfaceType::kWall});
  mesh.floor_triangles = static_cast<std::uint32_t>(roof.size());
  return mesh;
}

BuildingMesh explicit_mesh(const Site& site, const BuildingSpec& spec, const std::string& b) {
  const MeshSpec& in = *spec.mesh;
  const std::string f = b + ".mesh";
  detail::validate_mesh(in, f, f, "empty building mesh");
  if (in.surface.size() != in.triangles.size())
    fail(f + ".surface", "has " + std::to_string(in.surface.size()) +
                             " entries; triangles: " + std::to_string(in.triangles.size()));
  for (std::size_t t = 0; t < in.surface.size(); ++t) {
    const auto s = static_cast<int>(in.surface[t]);
    if (in.surface[t] == SurfaceType::kTerrain || s < 0 || s >= kSurfaceTypeCount)
      fail(indexed(f + ".surface", t), "not a building surface type (wall, roof or window)");
  }
  // Weld vertices with identical coordinates, so that an exporter's duplicated vertices do not
  // break the edge topology checked below (shared edges then share indices).
  std::vector<std::uint32_t> order(in.vertices_m.size());
  for (std::size_t v = 0; v < order.size(); ++v) order[v] = static_cast<std::uint32_t>(v);
  const auto key = [&](std::uint32_t v) {
    return std::tie(in.vertices_m[v].x(), in.vertices_m[v].y(), in.vertices_m[v].z());
  };
  std::sort(order.begin(), order.end(), [&](auto l, auto r) { return key(l) < key(r); });
  std::vector<std::uint32_t> remap(in.vertices_m.size());
  std::vector<std::uint32_t> original;  // welded index -> first input index (for messages)
  BuildingMesh mesh;
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k == 0 || key(order[k]) != key(order[k - 1])) {
      mesh.vertices.push_back(in.vertices_m[order[k]] - site.local_origin());
      original.push_back(order[k]);
    }
    remap[order[k]] = static_cast<std::uint32_t>(mesh.vertices.size() - 1);
  }
  for (std::size_t t = 0; t < in.triangles.size(); ++t) {
    Tri tri{};
    for (std::size_t k = 0; k < 3; ++k)
      tri.v[k] = remap[static_cast<std::size_t>(in.triangles[t][k])];
    tri.surface = in.surface[t];
    mesh.triangles.push_back(tri);
  }
  // Closed, consistently wound 2-manifold: every edge is used by exactly two triangles, in
  // opposite directions. Sort the directed edges by their undirected key.
  struct Edge {
    std::uint32_t lo, hi, tri;
    bool forward;  // traversed lo -> hi
  };
  std::vector<Edge> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = mesh.triangles[t].v[k], c = mesh.triangles[t].v[(k + 1) % 3];
      edges.push_back({std::min(a, c), std::max(a, c), static_cast<std::uint32_t>(t), a < c});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const Edge& l, const Edge& r) {
    return std::tie(l.lo, l.hi, l.tri) < std::tie(r.lo, r.hi, r.tri);
  });
  for (std::size_t k = 0; k < edges.size();) {
    std::size_t m = k;
    while (m < edges.size() && edges[m].lo == edges[k].lo && edges[m].hi == edges[k].hi) ++m;
    const std::string edge = "edge " + std::to_string(original[edges[k].lo]) + "-" +
                             std::to_string(original[edges[k].hi]);
    if (m - k == 1)
      fail(f, "not closed: " + edge + " belongs to triangle " + std::to_string(edges[k].tri) +
                  " only");
    if (m - k > 2)
      fail(f, "not a closed surface: " + edge + " is shared by " + std::to_string(m - k) +
                  " triangles");
    if (edges[k].forward == edges[k + 1].forward)
      fail(f, "inconsistent winding: triangles " + std::to_string(edges[k].tri) + " and " +
                  std::to_string(edges[k + 1].tri) + " run along " + edge +
                  " in the same direction");
    k = m;
  }
  // Orientation from the enclosed volume (divergence theorem: V = sum a.(b x c) / 6 over
  // triangles, about the vertex centroid for accuracy). Inward-wound meshes are flipped.
  Vec3 c = Vec3::Zero();
  for (const Vec3& v : mesh.vertices) c += v;
  c /= static_cast<double>(mesh.vertices.size());
  double volume6 = 0.0, scale = 0.0;
  for (const Tri& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t.v[0]] - c, bb = mesh.vertices[t.v[1]] - c,
               cc = mesh.vertices[t.v[2]] - c;
    volume6 += a.dot(bb.cross(cc));
    scale = std::max({scale, a.norm(), bb.norm(), cc.norm()});
  }
  if (!(std::abs(volume6) > 1e-12 * scale * scale * scale)) fail(f, "encloses no volume");
  if (volume6 < 0)
    for (Tri& t : mesh.triangles) std::swap(t.v[1], t.v[2]);
  return mesh;
}

}  // namespace

void SiteBuilder::build_buildings(Site& site, const SiteSpec& spec, const MaterialIds& ids) {
  constexpr auto kMaxIndex = static_cast<std::size_t>(std::numeric_limits<std::uint32_t>::max());
  std::map<std::string, std::size_t> seen;  // id -> first index
  site.buildings_.clear();
  site.building_vertices_.clear();
  site.building_triangles_.clear();
  site.building_normal_.clear();
  site.building_area_.clear();
  site.buildings_bounds_ = Box3{};
  for (std::size_t bi = 0; bi < spec.buildings.size(); ++bi) {
    const BuildingSpec& bs = spec.buildings[bi];
    const std::string b = indexed("site.buildings", bi);
    if (bs.id.empty()) fail(b + ".id", "missing id");
    if (const auto [it, fresh] = seen.emplace(bs.id, bi); !fresh)
      fail(b + ".id",
           "duplicate id \"" + bs.id + "\" (also " + indexed("site.buildings", it->second) + ")");
    if (bs.mesh && !bs.footprint_m.empty()) fail(b, "give either footprint_m or mesh, not both");
    if (bs.mesh && !bs.holes_m.empty())
      fail(b + ".holes_m", "only a footprint has holes; a mesh gives its courtyards as geometry");

    const BuildingMesh mesh = bs.mesh ? explicit_mesh(site, bs, b) : extrude_footprint(site, bs, b);
    // Materials per surface type: required where the building has such triangles, and checked
    // whenever named.
    bool used[kSurfaceTypeCount] = {};
    for (const Tri& t : mesh.triangles) used[static_cast<int>(t.surface)] = true;
    std::uint16_t material[kSurfaceTypeCount] = {};
    const std::pair<SurfaceType, const std::string*> names[] = {{SurfaceType::kWall, &bs.wall},
                                                                {SurfaceType::kRoof, &bs.roof},
                                                                {SurfaceType::kWindow, &bs.window}};
    for (const auto& [type, name] : names) {
      const int s = static_cast<int>(type);
      const std::string field = b + "." + surface_type_name(type);
      if (used[s] && name->empty())
        fail(field, std::string("missing material (the building has ") + surface_type_name(type) +
                        " triangles)");
      if (!name->empty()) material[s] = material_id(ids, *name, field);
    }

    if (site.building_vertices_.size() + mesh.vertices.size() >= kMaxIndex ||
        site.building_triangles_.size() + mesh.triangles.size() >= kMaxIndex)
      fail("site.buildings", "too many building vertices or triangles (limit 2^32 - 1)");
    Building out;
    out.id = bs.id;
    out.first_triangle = static_cast<std::uint32_t>(site.building_triangles_.size());
    out.triangle_count = static_cast<std::uint32_t>(mesh.triangles.size());
    out.floor_triangle_count = mesh.floor_triangles;
    const auto v0 = static_cast<std::uint32_t>(site.building_vertices_.size());
    for (const Vec3& v : mesh.vertices) {
      site.building_vertices_.push_back(v);
      out.bounds.extend(v);
    }
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      const Tri& tri = mesh.triangles[t];
      BuildingTriangle bt;
      bt.v = {v0 + tri.v[0], v0 + tri.v[1], v0 + tri.v[2]};
      bt.building = static_cast<std::uint32_t>(bi);
      bt.surface = tri.surface;
      bt.material = material[static_cast<int>(tri.surface)];
      const Vec3 n = (mesh.vertices[tri.v[1]] - mesh.vertices[tri.v[0]])
                         .cross(mesh.vertices[tri.v[2]] - mesh.vertices[tri.v[0]]);
      const double len = n.norm();
      site.building_triangles_.push_back(bt);
      site.building_normal_.push_back(n / len);
      site.building_area_.push_back(0.5 * len);
      const bool floor = t >= mesh.triangles.size() - mesh.floor_triangles;
      if (!floor) out.surface_area_m2[static_cast<int>(tri.surface)] += 0.5 * len;
    }
    site.buildings_bounds_.extend(out.bounds);
    site.buildings_.push_back(std::move(out));
  }
}

}  // namespace fragsim::scene
