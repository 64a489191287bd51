// Site queries: terrain height, segment intersection, inside-building test. These run in the
// simulation's hot loop: no heap allocation, no locks.
#include "core/scene/site.h"

#include <cmath>
#include <limits>

#include "core/scene/embree_scene.h"

namespace fragsim::scene {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double orient(const Vec3& a, const Vec3& b, double px, double py) {
  return (b.x() - a.x()) * (py - a.y()) - (b.y() - a.y()) * (px - a.x());
}

// Smallest |n . d| / |d| for which the hit t is refined in double against the triangle's plane;
// below it (a ray within 1e-6 rad of grazing) the plane solve is ill-conditioned and Embree's
// float t is kept.
constexpr double kRefineMinCosine = 1e-6;

// Depth below the terrain surface that counts as "below" for the slip guard (well above the
// float rounding of Embree hits in local coordinates, far below any physical length).
constexpr double kBelowTolerance_m = 1e-6;

// Nearest terrain hit in double precision over the candidates of the 2-D index: Moller &
// Trumbore (1997) with a 1e-9 barycentric allowance, so a ray through a shared edge or vertex
// hits every triangle that has it and cannot pass between them.
std::optional<std::pair<double, std::uint32_t>> exact_terrain_hit(const Site& site, const Vec3& org,
                                                                  const Vec3& dir, double t0,
                                                                  double t1) {
  constexpr double kTol = 1e-9;
  const auto& verts = site.terrain_vertices();
  const auto& tris = site.terrain_triangles();
  double best_t = std::numeric_limits<double>::infinity();
  std::uint32_t best_tri = 0;
  const Vec3 a = org + t0 * dir, b = org + t1 * dir;
  site.terrain_index().for_each_candidate(a.head<2>(), b.head<2>(), [&](std::uint32_t t) {
    const Vec3& v0 = verts[tris[t][0]];
    const Vec3 e1 = verts[tris[t][1]] - v0, e2 = verts[tris[t][2]] - v0;
    const Vec3 pv = dir.cross(e2);
    const double det = e1.dot(pv);
    if (!(std::abs(det) > 0)) return;
    const Vec3 tv = org - v0;
    const double u = tv.dot(pv) / det;
    const Vec3 qv = tv.cross(e1);
    const double w = dir.dot(qv) / det;
    if (u < -kTol || w < -kTol || u + w > 1 + kTol) return;
    const double s = e2.dot(qv) / det;
    if (s >= t0 && s <= t1 && s < best_t) {
      best_t = s;
      best_tri = t;
    }
  });
  if (!std::isfinite(best_t)) return std::nullopt;
  return std::make_pair(best_t, best_tri);
}

}  // namespace

bool Site::below_terrain(const Vec3& p) const {
  // Cheap rejections first: above all terrain, then above the highest terrain in p's bucket.
  if (p.z() >= terrain_bounds_.hi.z()) return false;
  const double fx = (p.x() - index_.origin.x()) / index_.cell.x();
  const double fy = (p.y() - index_.origin.y()) / index_.cell.y();
  if (!(fx >= 0 && fy >= 0 && fx <= index_.nx && fy <= index_.ny)) return false;
  const int i = std::min(static_cast<int>(fx), index_.nx - 1);
  const int j = std::min(static_cast<int>(fy), index_.ny - 1);
  if (p.z() >= static_cast<double>(index_.max_z[static_cast<std::size_t>(j) * index_.nx + i]))
    return false;
  return terrain_height(p.x(), p.y()) - p.z() > kBelowTolerance_m;  // false for NaN
}

Site::~Site() {
  embree::release(device_, scene_);
}

std::string Site::embree_error() const {
  return embree_log_ ? embree_log_->first_message() : std::string();
}

Vec3 Site::terrain_triangle_centroid(std::uint32_t t) const {
  const auto& tri = terrain_triangles_[t];
  return (terrain_vertices_[tri[0]] + terrain_vertices_[tri[1]] + terrain_vertices_[tri[2]]) / 3.0;
}

std::int64_t Site::terrain_triangle_at(double x, double y) const {
  if (terrain_is_lattice_) {
    // Plane or grid: the cell and the side of its (i,j)-(i+1,j+1) diagonal give the one triangle.
    const double fx = (x - index_.origin.x()) / index_.cell.x();
    const double fy = (y - index_.origin.y()) / index_.cell.y();
    if (!(fx >= 0 && fy >= 0 && fx <= index_.nx && fy <= index_.ny)) return -1;
    const int i = std::min(static_cast<int>(fx), index_.nx - 1);
    const int j = std::min(static_cast<int>(fy), index_.ny - 1);
    const std::size_t cell = static_cast<std::size_t>(j) * index_.nx + i;
    return static_cast<std::int64_t>(2 * cell + ((fy - j) > (fx - i) ? 1 : 0));
  }
  // Barycentric coordinates in the xy-projection (triangles are counter-clockwise from above).
  // The 1e-9 allowance makes points on shared edges and vertices belong to every triangle that
  // has them, so no point of the terrain falls between two triangles through rounding. With
  // overhangs, the triangle with the highest surface at (x, y) wins.
  constexpr double kTol = 1e-9;
  double best = -std::numeric_limits<double>::infinity();
  std::int64_t best_t = -1;
  index_.for_each_candidate_at(Vec2(x, y), [&](std::uint32_t t) {
    const auto& tri = terrain_triangles_[t];
    const Vec3& a = terrain_vertices_[tri[0]];
    const Vec3& b = terrain_vertices_[tri[1]];
    const Vec3& c = terrain_vertices_[tri[2]];
    const double area2 = orient(a, b, c.x(), c.y());
    const double la = orient(b, c, x, y) / area2;
    const double lb = orient(c, a, x, y) / area2;
    const double lc = 1.0 - la - lb;
    if (la >= -kTol && lb >= -kTol && lc >= -kTol) {
      const double z = la * a.z() + lb * b.z() + lc * c.z();
      if (z > best || (z == best && static_cast<std::int64_t>(t) < best_t)) {
        best = z;
        best_t = t;
      }
    }
  });
  return best_t;
}

double Site::terrain_height(double x, double y) const {
  if (terrain_is_plane_) return terrain_bounds_.contains_xy(x, y) ? plane_elevation_ : kNaN;
  const std::int64_t t = terrain_triangle_at(x, y);
  return t < 0 ? kNaN : terrain_plane_height(static_cast<std::uint32_t>(t), x, y);
}

std::optional<SceneHit> Site::intersect_embree(const Vec3& org, const Vec3& dir, double tnear,
                                               double tfar, unsigned mask) const {
  mask &= kQueryAll;
  if (!(tnear <= tfar) || !org.allFinite() || !dir.allFinite() || dir.squaredNorm() == 0.0)
    return std::nullopt;
  std::optional<SceneHit> best;
  double t_limit = tfar;

  if (terrain_is_plane_ && (mask & kQueryTerrain) && dir.z() != 0.0) {
    // Analytic plane z = plane_elevation_ (either side), inside the extent.
    const double t = (plane_elevation_ - org.z()) / dir.z();
    const double x = org.x() + t * dir.x(), y = org.y() + t * dir.y();
    if (t >= tnear && t <= tfar && terrain_bounds_.contains_xy(x, y)) {
      const double fx = (x - index_.origin.x()) / index_.cell.x();
      const double fy = (y - index_.origin.y()) / index_.cell.y();
      const int i = std::clamp(static_cast<int>(std::floor(fx)), 0, index_.nx - 1);
      const int j = std::clamp(static_cast<int>(std::floor(fy)), 0, index_.ny - 1);
      // Cell (i, j) holds triangles 2k (below the (i,j)-(i+1,j+1) diagonal) and 2k + 1.
      const auto cellk = static_cast<std::uint32_t>(j * index_.nx + i);
      SceneHit h;
      h.t = t;
      h.terrain = true;
      h.triangle = 2 * cellk + ((fy - j) > (fx - i) ? 1u : 0u);
      h.surface = SurfaceType::kTerrain;
      h.material = terrain_triangle_material(h.triangle);
      h.normal = Vec3::UnitZ();
      best = h;
      t_limit = t;
    }
  }
  if (terrain_is_plane_ || terrain_geom_ == ~0u) mask &= ~static_cast<unsigned>(kQueryTerrain);
  if (building_geom_ == ~0u) mask &= ~static_cast<unsigned>(kQueryBuildings);
  if (mask == 0) return best;

  // Float ray from the segment's start (better float resolution than from an arbitrary org,
  // and Embree wants tnear >= 0); the far end is rounded outward so the float interval covers
  // [tnear, t_limit].
  const Vec3 start = org + tnear * dir;
  const float span =
      std::nextafter(static_cast<float>(t_limit - tnear), std::numeric_limits<float>::infinity());
  embree::RayHit rh;
  if (!embree::intersect1(scene_, start, dir, 0.0f, span, mask, rh)) return best;

  SceneHit h;
  const Vec3* v0 = nullptr;
  if (rh.geom == terrain_geom_) {
    h.terrain = true;
    h.triangle = rh.prim;
    h.surface = SurfaceType::kTerrain;
    h.material = terrain_triangle_material(rh.prim);
    h.normal = terrain_facet_[rh.prim].normal;
    v0 = &terrain_vertices_[terrain_triangles_[rh.prim][0]];
  } else {
    const BuildingTriangle& bt = building_triangles_[rh.prim];
    h.terrain = false;
    h.triangle = rh.prim;
    h.building = bt.building;
    h.surface = bt.surface;
    h.material = bt.material;
    h.normal = building_normal_[rh.prim];
    v0 = &building_vertices_[bt.v[0]];
  }
  // Refine t in double on the triangle's plane: n . (start + s dir - v0) = 0.
  double s = static_cast<double>(rh.t);
  const double denom = h.normal.dot(dir);
  if (std::abs(denom) > kRefineMinCosine * dir.norm()) s = h.normal.dot(*v0 - start) / denom;
  h.t = std::clamp(tnear + s, tnear, tfar);
  if (!best || h.t <= best->t) best = h;  // ties go to the building (its wall meets the ground)
  return best;
}

std::optional<SceneHit> Site::intersect(const Vec3& org, const Vec3& dir, double tnear, double tfar,
                                        unsigned mask) const {
  std::optional<SceneHit> best = intersect_embree(org, dir, tnear, tfar, mask);
  if (!(mask & kQueryTerrain) || terrain_is_plane_ || terrain_geom_ == ~0u) return best;
  if (!(tnear <= tfar) || !org.allFinite() || !dir.allFinite() || dir.squaredNorm() == 0.0)
    return best;
  // Slip guard. Embree's robust mode can still let a ray through exactly at a shared vertex
  // (RenderKit/embree issues #174, #181). A slip shows as a physically inconsistent answer: the
  // free part of the segment ends below the terrain, or the first terrain hit is from below,
  // although the segment started above the terrain. Only then (rarely) is the terrain searched
  // exactly in double; the usual cost is one bucket lookup at the free end.
  // Only the part of the segment over the terrain's xy bounds can meet the terrain. Clipping to
  // it keeps the end checked over the terrain, so a ray which slipped through and then left the
  // terrain sideways is still caught.
  const auto clip_to_terrain = [&](double& ta, double& tb) {
    for (int k = 0; k < 2; ++k) {
      if (dir[k] == 0.0) continue;
      double u0 = (terrain_bounds_.lo[k] - org[k]) / dir[k];
      double u1 = (terrain_bounds_.hi[k] - org[k]) / dir[k];
      if (u0 > u1) std::swap(u0, u1);
      ta = std::max(ta, u0);
      tb = std::min(tb, u1);
    }
    return ta <= tb;
  };
  const auto over_terrain = [&](double t) {  // the point at t, kept inside the xy bounds
    Vec3 p = org + t * dir;
    p.x() = std::clamp(p.x(), terrain_bounds_.lo.x(), terrain_bounds_.hi.x());
    p.y() = std::clamp(p.y(), terrain_bounds_.lo.y(), terrain_bounds_.hi.y());
    return p;
  };
  double ta = tnear, tb = best ? best->t : tfar;
  if (best && best->terrain) {
    // A hit from above is the consistent first crossing; a hit from below needs a look at where
    // the segment started.
    if (!(best->normal.dot(dir) > 0) || !clip_to_terrain(ta, tb)) return best;
  } else {
    // Usual path: the free end over the terrain, usually rejected by the bucket's max_z.
    const Vec3 end = org + tb * dir;
    if (terrain_bounds_.contains_xy(end.x(), end.y())) {
      if (!below_terrain(end)) return best;
      clip_to_terrain(ta, tb);
    } else if (!clip_to_terrain(ta, tb) || !below_terrain(over_terrain(tb))) {
      return best;
    }
  }
  if (below_terrain(over_terrain(ta))) return best;  // started below: nothing was skipped
  const auto exact = exact_terrain_hit(*this, org, dir, ta, tb);
  if (!exact || (best && exact->first >= best->t)) return best;
  SceneHit h;
  h.t = exact->first;
  h.terrain = true;
  h.triangle = exact->second;
  h.surface = SurfaceType::kTerrain;
  h.material = terrain_triangle_material(exact->second);
  h.normal = terrain_facet_[exact->second].normal;
  return h;
}

bool Site::inside_building(const Vec3& p) const {
  if (buildings_.empty() || !p.allFinite()) return false;
  const auto in_box = [&](const Box3& b) {
    return (p.array() >= b.lo.array()).all() && (p.array() <= b.hi.array()).all();
  };
  if (!in_box(buildings_bounds_)) return false;
  // Fixed, deliberately skewed directions (no rational slopes) so that a ray through a mesh edge or
  // vertex, where the parity count would be ambiguous, is a coincidence; if it happens anyway the
  // next direction is tried.
  static const Vec3 kDirs[3] = {Vec3(0.2909944487, 0.4718045, 0.8323172).normalized(),
                                Vec3(-0.6180339887, 0.3090169944, 0.7236067977).normalized(),
                                Vec3(0.5257311121, -0.8506508084, 0.0195928).normalized()};
  for (const Building& b : buildings_) {
    if (!in_box(b.bounds)) continue;
    const double size = (b.bounds.hi - b.bounds.lo).norm();
    bool inside = false;
    for (const Vec3& d : kDirs) {
      // Moller & Trumbore (1997) ray-triangle test in double; barycentric margins of 1e-9 flag
      // edge and vertex crossings as ambiguous, as is a point (nearly) on the surface.
      constexpr double kEps = 1e-9;
      int crossings = 0;
      bool ambiguous = false;
      for (std::uint32_t t = b.first_triangle; t < b.first_triangle + b.triangle_count; ++t) {
        const auto& v = building_triangles_[t].v;
        const Vec3& a = building_vertices_[v[0]];
        const Vec3 e1 = building_vertices_[v[1]] - a, e2 = building_vertices_[v[2]] - a;
        const Vec3 pv = d.cross(e2);
        const double det = e1.dot(pv);
        if (std::abs(det) <= 1e-14 * e1.norm() * e2.norm()) continue;  // parallel to the face
        const Vec3 tv = p - a;
        const double u = tv.dot(pv) / det;
        const Vec3 qv = tv.cross(e1);
        const double w = d.dot(qv) / det;
        const double s = e2.dot(qv) / det;
        if (s < -kEps * size || u < -kEps || w < -kEps || u + w > 1 + kEps) continue;
        if (s <= kEps * size || u <= kEps || w <= kEps || u + w >= 1 - kEps) {
          ambiguous = true;
          break;
        }
        ++crossings;
      }
      inside = (crossings % 2) == 1;
      if (!ambiguous) break;
    }
    if (inside) return true;
  }
  return false;
}

}  // namespace fragsim::scene
