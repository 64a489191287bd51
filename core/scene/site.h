#pragma once
// A built, validated, immutable site: terrain and building triangle meshes in site-local
// coordinates, materials, the Embree scene, and a 2-D index of terrain triangles.
//
// Coordinates: input coordinates (as in the scenario, possibly UTM-sized) minus `local_origin()`,
// a double-precision point near the terrain centre. Embree stores floats; everything else is
// double. Altitude above sea level (for the atmosphere) = local z + `altitude_offset_m()`.
//
// Thread safety: a Site is immutable once `build` returns; any number of threads may query it.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/common/types.h"
#include "core/scene/site_spec.h"

struct RTCDeviceTy;
struct RTCSceneTy;

namespace fragsim::scene {

struct Material {
  std::string name;
  double friction = 0.5;
  double rolling_resistance = 0.1;
  RestitutionSpec restitution;
  double penetration_ke_per_area_j_per_m2 = std::numeric_limits<double>::infinity();
  std::optional<EmbedmentSpec> embedment;
  std::optional<FastContactSpec> fast_contact;
  // The speed from which a contact follows fast_contact (F1); infinite without it.
  double fast_contact_speed_mps() const {
    return fast_contact ? fast_contact->switch_speed_mps : std::numeric_limits<double>::infinity();
  }
  // e at a given normal impact speed (constant or table, clamped).
  double restitution_at(double normal_speed_mps) const;
  // Does a fragment of density `density_kg_m3` arriving with `velocity` on a surface of unit
  // normal n stop in it (EmbedmentSpec)? Never without an embedment model.
  bool embeds(const Vec3& velocity, const Vec3& n, double density_kg_m3) const;
};

struct Building {
  std::string id;
  Box3 bounds;                       // local coordinates
  std::uint32_t first_triangle = 0;  // range in Site::building_triangles()
  std::uint32_t triangle_count = 0;
  std::array<double, kSurfaceTypeCount> surface_area_m2{};  // by SurfaceType, exposed surface only
  // Footprint buildings end their triangle range with a floor (tagged kWall, wall material) that
  // closes the mesh; it sits on or below the ground, so it is left out of surface_area_m2.
  std::uint32_t floor_triangle_count = 0;
};

// Per building triangle.
struct BuildingTriangle {
  std::array<std::uint32_t, 3> v;  // into building_vertices()
  std::uint32_t building = 0;
  SurfaceType surface = SurfaceType::kWall;
  std::uint16_t material = 0;
};

// Result of a segment query against the scene.
struct SceneHit {
  double t = 0.0;              // hit at org + t * dir
  bool terrain = false;        // terrain or a building
  std::uint32_t triangle = 0;  // terrain triangle index, or building triangle index
  std::uint32_t building = 0;  // valid when !terrain
  SurfaceType surface = SurfaceType::kTerrain;
  std::uint16_t material = 0;
  Vec3 normal = Vec3::UnitZ();  // unit geometric normal; terrain: upward; building: outward
};

enum QueryMask : unsigned { kQueryTerrain = 1u, kQueryBuildings = 2u, kQueryAll = 3u };

// Uniform 2-D bucket grid over the xy-projections of the terrain triangles (CSR layout).
// For plane and grid terrains a bucket is exactly one grid cell (two triangles), so buckets may be
// rectangular (a plane's cells fit its extent exactly and are only about square).
class TerrainIndex2D {
 public:
  // Calls f(triangle) for every terrain triangle whose bucket the xy-segment a->b passes through.
  // A triangle may be reported more than once; callers do the exact clipping.
  template <class F>
  void for_each_candidate(const Vec2& a, const Vec2& b, F&& f) const;
  // As for_each_candidate for the segment's xy-projection, but skips the buckets where the
  // segment stays higher than `above_m` over the bucket's highest terrain (max_z) all the way
  // across: no point of those buckets' triangles, nor of anything within `above_m` above them,
  // is on that part of the segment. (The PTN walk, with above_m = person height.)
  template <class F>
  void for_each_candidate_below(const Vec3& a, const Vec3& b, double above_m, F&& f) const;
  // The least height of the segment a->b over the highest terrain (max_z) of the buckets its
  // xy-projection passes through: min over them of (the segment's lowest z in the bucket -
  // max_z). +inf when it passes over none. A segment with clearance > 0 meets no terrain. The
  // walk stops at the first bucket where the height is `enough` or less, and returns it.
  double clearance(const Vec3& a, const Vec3& b,
                   double enough = -std::numeric_limits<double>::infinity()) const;
  // Calls f(triangle) for the candidates of the bucket containing p.
  template <class F>
  void for_each_candidate_at(const Vec2& p, F&& f) const;

  // Public for the builder (core/scene) and tests; treat as read-only.
  Vec2 origin{0, 0};
  Vec2 cell{1.0, 1.0};  // bucket size in x and y
  int nx = 0, ny = 0;
  std::vector<std::uint32_t> start;      // nx*ny + 1
  std::vector<std::uint32_t> triangles;  // bucket contents
  std::vector<float> max_z;              // per bucket: highest terrain z (local)

 private:
  template <class F>
  void visit_bucket(std::size_t bucket, F& f) const;
  // The buckets the xy-segment pa->pb (bucket units) passes through, in order: visit(bucket,
  // s_in, s_out) with the parameters where it enters and leaves the bucket, reported as
  // s_base + s_scale * s for the segment's own s in [0, 1]. The walk stops when visit returns
  // false; then walk returns true.
  template <class V>
  bool walk(const Vec2& pa, const Vec2& pb, double s_base, double s_scale, V& visit) const;
  // The segment's lowest z over [s_in, s_out] minus max_z of the bucket.
  double clearance_in(std::size_t bucket, double za, double zb, double s_in, double s_out) const {
    return std::min(za + s_in * (zb - za), za + s_out * (zb - za)) -
           static_cast<double>(max_z[bucket]);
  }
};

// floor(f) as a bucket index clamped to [0, n - 1], with the clamp done in double: a cast of a
// value beyond int's range (a point far outside the grid) would be undefined. NaN gives 0.
inline int clamped_bucket(double f, int n) {
  const double c = std::floor(f);
  if (!(c > 0.0)) return 0;
  return c >= static_cast<double>(n - 1) ? n - 1 : static_cast<int>(c);
}

struct EmbreeErrorLog;  // embree_scene.h

class Site {
 public:
  // Validates and builds. Throws InputError naming the offending element
  // ("site.terrain.triangles[12]: zero-area triangle", "site.buildings[2].footprint_m: ...").
  static std::shared_ptr<const Site> build(const SiteSpec& spec);
  ~Site();
  Site(const Site&) = delete;
  Site& operator=(const Site&) = delete;

  // Frames
  const Vec3& local_origin() const { return local_origin_; }
  double altitude_offset_m() const { return altitude_offset_m_; }
  Vec3 to_local(const Vec3& input) const { return input - local_origin_; }
  Vec3 to_input(const Vec3& local) const { return local + local_origin_; }
  const std::optional<SiteOrigin>& origin() const { return origin_; }

  // Terrain (local coordinates)
  const std::vector<Vec3>& terrain_vertices() const { return terrain_vertices_; }
  const std::vector<std::array<std::uint32_t, 3>>& terrain_triangles() const {
    return terrain_triangles_;
  }
  std::size_t terrain_triangle_count() const { return terrain_triangles_.size(); }
  double terrain_triangle_area(std::uint32_t t) const { return terrain_area_[t]; }
  const Vec3& terrain_triangle_normal(std::uint32_t t) const {
    return terrain_facet_[t].normal;
  }  // up
  Vec3 terrain_triangle_centroid(std::uint32_t t) const;
  bool terrain_is_plane() const { return terrain_is_plane_; }
  double plane_elevation() const { return plane_elevation_; }  // local z, when terrain_is_plane()
  const Box3& terrain_bounds() const { return terrain_bounds_; }
  // Height of the terrain surface at (x, y) (local); NaN outside the terrain's projection.
  // For a mesh with overhangs: the highest surface at (x, y).
  double terrain_height(double x, double y) const;
  // The terrain triangle whose surface is highest at (x, y) (the one terrain_height uses);
  // -1 outside the terrain's projection.
  std::int64_t terrain_triangle_at(double x, double y) const;
  // Height at (x, y) of the plane through terrain triangle t (also outside the triangle).
  double terrain_plane_height(std::uint32_t t, double x, double y) const {
    const auto& g = terrain_facet_[t].plane;
    return g[0] * x + g[1] * y + g[2];
  }
  // Starts loading triangle t's normal and plane (one cache line): for walks that know the next
  // triangle ahead.
  void prefetch_terrain_triangle(std::uint32_t t) const { __builtin_prefetch(&terrain_facet_[t]); }
  const TerrainIndex2D& terrain_index() const { return index_; }
  // The terrain triangles that touch its boundary, ascending: those with a vertex on an edge
  // that no other triangle shares (the outer ring of cells of a plane or grid; the rim of a mesh,
  // and of its holes). Nothing is modelled beyond them, so a hazardous density on one of them
  // makes the HFD of its sector a lower bound (core/run/hfd.h). Vertices are matched by position,
  // so a mesh whose triangles repeat their shared vertices has the same boundary as a welded one.
  const std::vector<std::uint32_t>& terrain_boundary_triangles() const { return terrain_boundary_; }
  // Plane or grid terrain: terrain_index() bucket (i, j) = grid cell (i, j), holding triangle
  // 2k below its (i,j)-(i+1,j+1) diagonal and 2k + 1 above it (k = j nx + i).
  bool terrain_is_lattice() const { return terrain_is_lattice_; }
  // The site's base terrain material (site.terrain.material): every triangle's unless zones or
  // per-triangle materials say otherwise.
  std::uint16_t terrain_material() const { return terrain_material_; }
  // The material of terrain triangle t (docs/scenario.md, "Materials by zone").
  std::uint16_t terrain_triangle_material(std::uint32_t t) const {
    return terrain_triangle_material_.empty() ? terrain_material_ : terrain_triangle_material_[t];
  }
  // Does any terrain triangle have a material other than terrain_material()?
  bool terrain_has_zones() const { return !terrain_triangle_material_.empty(); }

  // Buildings
  bool has_buildings() const { return !buildings_.empty(); }
  const std::vector<Building>& buildings() const { return buildings_; }
  const std::vector<Vec3>& building_vertices() const { return building_vertices_; }
  const std::vector<BuildingTriangle>& building_triangles() const { return building_triangles_; }
  const Box3& buildings_bounds() const { return buildings_bounds_; }
  // Cheap pre-test for a building query: does the bounding box of the segment a-b overlap the
  // bounds of some building? Building by building for up to kBuildingBoxScan buildings (the
  // bounds of all buildings together can cover most of a site), the overall bounds beyond.
  bool segment_near_buildings(const Vec3& a, const Vec3& b) const {
    const auto overlaps = [&](const Box3& box) {
      return std::max(a.x(), b.x()) >= box.lo.x() && std::min(a.x(), b.x()) <= box.hi.x() &&
             std::max(a.y(), b.y()) >= box.lo.y() && std::min(a.y(), b.y()) <= box.hi.y() &&
             std::max(a.z(), b.z()) >= box.lo.z() && std::min(a.z(), b.z()) <= box.hi.z();
    };
    if (buildings_.empty() || !overlaps(buildings_bounds_)) return false;
    if (buildings_.size() > kBuildingBoxScan) return true;
    for (const Building& bd : buildings_)
      if (overlaps(bd.bounds)) return true;
    return false;
  }
  static constexpr std::size_t kBuildingBoxScan = 64;
  // Horizontal distance from (x, y) to the nearest building's bounding box (0 inside one,
  // +inf with no buildings). Building by building up to kBuildingBoxScan buildings, the overall
  // bounds beyond (a lower bound then).
  double building_distance_xy(double x, double y) const {
    const auto dist2 = [&](const Box3& box) {
      const double dx = std::max({box.lo.x() - x, 0.0, x - box.hi.x()});
      const double dy = std::max({box.lo.y() - y, 0.0, y - box.hi.y()});
      return dx * dx + dy * dy;
    };
    if (buildings_.empty()) return std::numeric_limits<double>::infinity();
    if (buildings_.size() > kBuildingBoxScan) return std::sqrt(dist2(buildings_bounds_));
    double d2 = std::numeric_limits<double>::infinity();
    for (const Building& bd : buildings_) d2 = std::min(d2, dist2(bd.bounds));
    return std::sqrt(d2);
  }
  // Does some building's bounding box come within horizontal distance r of (x, y)?
  bool building_within_xy(double x, double y, double r) const {
    return building_distance_xy(x, y) <= r;
  }
  // True when p lies inside a building's closed mesh (ray parity).
  bool inside_building(const Vec3& p) const;

  // Everything: terrain and buildings.
  const Box3& bounds() const { return bounds_; }

  // Per building triangle (local coordinates): outward unit normal and area.
  const Vec3& building_triangle_normal(std::uint32_t t) const { return building_normal_[t]; }
  double building_triangle_area(std::uint32_t t) const { return building_area_[t]; }

  // Materials, indexed by the uint16 ids above.
  const std::vector<Material>& materials() const { return materials_; }

  // Nearest hit of the segment org + t*dir, t in [tnear, tfar], against the geometry selected by
  // `mask`. For a plane terrain the terrain part is analytic (no BVH walk); with no buildings the
  // building part costs nothing.
  // The hit t is refined in double against the hit triangle's plane (Embree's float t is only
  // used for grazing hits) and clamped to [tnear, tfar]. Terrain meshes get a double-precision
  // guard against rays slipping through shared vertices (see site.cpp).
  std::optional<SceneHit> intersect(const Vec3& org, const Vec3& dir, double tnear, double tfar,
                                    unsigned mask = kQueryAll) const;

  // First error message Embree reported for this site's device (empty if none). Errors during the
  // build already throw; this is for diagnostics after queries.
  std::string embree_error() const;

 private:
  Site() = default;
  friend class SiteBuilder;
  // intersect() without the vertex slip guard: analytic plane + Embree.
  std::optional<SceneHit> intersect_embree(const Vec3& org, const Vec3& dir, double tnear,
                                           double tfar, unsigned mask) const;
  // Strictly below the terrain surface at p's xy (false outside the terrain).
  bool below_terrain(const Vec3& p) const;

  Vec3 local_origin_{0, 0, 0};
  double altitude_offset_m_ = 0.0;
  std::optional<SiteOrigin> origin_;

  std::vector<Vec3> terrain_vertices_;
  std::vector<std::array<std::uint32_t, 3>> terrain_triangles_;
  std::vector<double> terrain_area_;
  // Per triangle, together (the ground walk reads both at every triangle it enters).
  struct alignas(64) TerrainFacet {
    Vec3 normal{0, 0, 1};           // unit, upward
    std::array<double, 3> plane{};  // z = [0] x + [1] y + [2]
  };
  std::vector<TerrainFacet> terrain_facet_;
  bool terrain_is_plane_ = false;
  bool terrain_is_lattice_ = false;  // plane or grid: bucket (i, j) holds triangles 2k, 2k + 1
  double plane_elevation_ = 0.0;
  Box3 terrain_bounds_;
  TerrainIndex2D index_;
  std::vector<std::uint32_t> terrain_boundary_;
  std::uint16_t terrain_material_ = 0;
  std::vector<std::uint16_t> terrain_triangle_material_;  // empty: all terrain_material_

  std::vector<Building> buildings_;
  std::vector<Vec3> building_vertices_;
  std::vector<BuildingTriangle> building_triangles_;
  std::vector<Vec3> building_normal_;
  std::vector<double> building_area_;
  Box3 buildings_bounds_;
  Box3 bounds_;
  std::vector<Material> materials_;

  RTCDeviceTy* device_ = nullptr;
  RTCSceneTy* scene_ = nullptr;  // terrain (geometry 0, absent for a plane) + buildings (1)
  unsigned terrain_geom_ = ~0u;
  unsigned building_geom_ = ~0u;
  std::unique_ptr<EmbreeErrorLog> embree_log_;  // the device error callback writes here
};

// ---- inline template members ----
template <class F>
void TerrainIndex2D::visit_bucket(std::size_t b, F& f) const {
  for (std::uint32_t k = start[b]; k < start[b + 1]; ++k) f(triangles[k]);
}

template <class F>
void TerrainIndex2D::for_each_candidate_at(const Vec2& p, F&& f) const {
  const double fx = (p.x() - origin.x()) / cell.x(), fy = (p.y() - origin.y()) / cell.y();
  if (!(fx >= 0 && fy >= 0 && fx <= nx && fy <= ny)) return;  // also rejects NaN
  const int i = std::min(static_cast<int>(fx), nx - 1), j = std::min(static_cast<int>(fy), ny - 1);
  visit_bucket(static_cast<std::size_t>(j) * nx + i, f);
}

template <class F>
void TerrainIndex2D::for_each_candidate(const Vec2& a, const Vec2& b, F&& f) const {
  if (nx <= 0 || ny <= 0) return;
  const Vec2 pa = (a - origin).cwiseQuotient(cell), pb = (b - origin).cwiseQuotient(cell);
  if (!pa.allFinite() || !pb.allFinite()) return;  // NaN would reach an int cast below (UB)
  auto visit = [&](std::size_t bucket, double, double) {
    visit_bucket(bucket, f);
    return true;
  };
  walk(pa, pb, 0.0, 1.0, visit);
}

// The skip is conservative by kClearanceSlack_m: the bucket parameters s_in, s_out are rounded
// (to ~1e-16 of the segment), so a bucket is skipped only when the segment is clearly higher.
inline constexpr double kClearanceSlack_m = 1e-6;

template <class F>
void TerrainIndex2D::for_each_candidate_below(const Vec3& a, const Vec3& b, double above_m,
                                              F&& f) const {
  if (nx <= 0 || ny <= 0) return;
  const Vec2 pa = (a.head<2>() - origin).cwiseQuotient(cell);
  const Vec2 pb = (b.head<2>() - origin).cwiseQuotient(cell);
  if (!pa.allFinite() || !pb.allFinite()) return;
  const double za = a.z(), zb = b.z(), limit = above_m + kClearanceSlack_m;
  auto visit = [&](std::size_t bucket, double s_in, double s_out) {
    // `!(x > limit)`: a NaN height is not skipped (the exact tests then decide).
    if (!(clearance_in(bucket, za, zb, s_in, s_out) > limit)) visit_bucket(bucket, f);
    return true;
  };
  walk(pa, pb, 0.0, 1.0, visit);
}

inline double TerrainIndex2D::clearance(const Vec3& a, const Vec3& b, double enough) const {
  double least = std::numeric_limits<double>::infinity();
  if (nx <= 0 || ny <= 0) return least;
  const Vec2 pa = (a.head<2>() - origin).cwiseQuotient(cell);
  const Vec2 pb = (b.head<2>() - origin).cwiseQuotient(cell);
  if (!pa.allFinite() || !pb.allFinite()) return -least;  // cannot tell: not clear
  const double za = a.z(), zb = b.z();
  auto visit = [&](std::size_t bucket, double s_in, double s_out) {
    const double c = clearance_in(bucket, za, zb, s_in, s_out) - kClearanceSlack_m;
    if (!(c >= least)) least = std::isnan(c) ? -std::numeric_limits<double>::infinity() : c;
    return least > enough && least > -std::numeric_limits<double>::infinity();
  };
  walk(pa, pb, 0.0, 1.0, visit);
  return least;
}

// Amanatides & Woo (1987) grid traversal of the xy-segment a->b, clipped to the grid.
// Buckets the segment only touches (at a corner or along a bucket edge) may or may not be visited;
// the builder pads bucket contents so that every triangle the segment crosses is reported.
template <class V>
bool TerrainIndex2D::walk(const Vec2& pa, const Vec2& pb, double s_base, double s_scale,
                          V& visit) const {
  if (std::max(pa.x(), pb.x()) < 0 || std::min(pa.x(), pb.x()) > nx ||
      std::max(pa.y(), pb.y()) < 0 || std::min(pa.y(), pb.y()) > ny)
    return false;  // beside the grid
  const Vec2 d = pb - pa;
  // The clipping below resolves a segment to ~1e-16 of its length (and a difference of ends
  // near the largest doubles overflows, and 0 * inf is NaN): a segment longer than 2^32 buckets
  // is halved first, and halves beside the grid are dropped. Only a far-away point (a footprint
  // far from a fine terrain, a core caller's extreme input) makes one; chords are short. The
  // halves report parameters of the whole segment (s_base, s_scale).
  constexpr double kLongest = 4294967296.0;
  if (!(std::abs(d.x()) <= kLongest && std::abs(d.y()) <= kLongest)) {
    const Vec2 pm = 0.5 * pa + 0.5 * pb;
    const double half = 0.5 * s_scale;
    if (walk(pa, pm, s_base, half, visit)) return true;
    return walk(pm, pb, s_base + half, half, visit);
  }
  // Clip the parametric segment to [0,nx]x[0,ny].
  double s0 = 0.0, s1 = 1.0;
  for (int k = 0; k < 2; ++k) {
    const double lo = 0.0, hi = (k == 0) ? nx : ny;
    if (d[k] == 0.0) {
      if (pa[k] < lo || pa[k] > hi) return false;
    } else {
      double u0 = (lo - pa[k]) / d[k], u1 = (hi - pa[k]) / d[k];
      if (u0 > u1) std::swap(u0, u1);
      s0 = std::max(s0, u0);
      s1 = std::min(s1, u1);
    }
  }
  if (s0 > s1) return false;
  const Vec2 p0 = pa + s0 * d;
  int i = clamped_bucket(p0.x(), nx);
  int j = clamped_bucket(p0.y(), ny);
  const Vec2 p1 = pa + s1 * d;
  const int iend = clamped_bucket(p1.x(), nx);
  const int jend = clamped_bucket(p1.y(), ny);
  const int si = d.x() > 0 ? 1 : (d.x() < 0 ? -1 : 0);
  const int sj = d.y() > 0 ? 1 : (d.y() < 0 ? -1 : 0);
  const double inf = std::numeric_limits<double>::infinity();
  // Parameter of the next x (y) bucket boundary, recomputed from the integer boundary at every step
  // rather than accumulated (t += dt drifts by one rounding per step on long segments).
  const auto next_x = [&](int ii) {
    return si != 0 ? ((ii + (si > 0 ? 1 : 0)) - pa.x()) / d.x() : inf;
  };
  const auto next_y = [&](int jj) {
    return sj != 0 ? ((jj + (sj > 0 ? 1 : 0)) - pa.y()) / d.y() : inf;
  };
  double tmx = next_x(i), tmy = next_y(j);
  double s_in = s0;
  // Bounded loop: at most nx + ny + 2 buckets for any segment.
  for (int guard = nx + ny + 2; guard > 0; --guard) {
    const double s_out = std::clamp(std::min(tmx, tmy), s_in, s1);
    if (!visit(static_cast<std::size_t>(j) * nx + i, s_base + s_scale * s_in,
               s_base + s_scale * s_out))
      return true;
    if (i == iend && j == jend) break;
    if (tmx < tmy) {
      if (tmx > s1) break;
      i += si;
      tmx = next_x(i);
    } else {
      if (tmy > s1) break;
      j += sj;
      tmy = next_y(j);
    }
    s_in = s_out;
    if (i < 0 || j < 0 || i >= nx || j >= ny) break;
  }
  return false;
}

}  // namespace fragsim::scene
