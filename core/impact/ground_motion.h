#pragma once
// Slide, roll and rest: what a fragment does on the terrain once its bounces have died out
// (docs/physics.md, "Slide, roll and rest"). The paper gives no model for this phase; this one is
// the textbook motion of a body on an inclined plane, triangle by triangle:
//
//   sliding (cuboid, ellipsoid, cylinder):  a = g_t - mu g_n v_hat             (Coulomb)
//   rolling (sphere, point as a sphere):    a = 5/7 (g_t - mu_r g_n v_hat)    (solid sphere,
//                                            rolling without slipping; mu_r rolling resistance)
//
// with g_t the gravity component along the triangle's plane and g_n = g n_z the normal load per
// mass. A body at rest stays at rest where |g_t| <= c g_n (c = mu or mu_r: the friction angle);
// on a steeper slope it starts again down the slope. The centre of mass is kept `clearance_m`
// above the surface (measured along the normal). Crossing onto a neighbouring triangle, the
// velocity is projected onto the new plane: speed is never gained at an edge. A convex edge that
// would launch the body (a crest taken fast) is followed, not flown over: a simplification.
//
// Steps go from triangle edge to triangle edge. Within a step the acceleration is held constant
// (the friction direction is v_hat at the step's start), so the motion is the closed form
//   p(t) = p0 + v0 t + a t^2 / 2,   v(t) = v0 + a t,
// and the step ends at the first of: the exit through an edge of the triangle (the smallest
// positive root of N_k . p_xy(t) = c_k over its three edges, a quadratic), the stop (speed along
// v0 reaching 0 at t = |v0| / -(a . v_hat0)), the time limit, or, where g_t has a component
// across v, kGroundMaxDt_s. This is exact on a level triangle and whenever v is parallel to g_t
// (up or down the fall line); otherwise the friction direction turns by about
// k |g_t x v_hat| dt / |v| within a step, which kGroundMaxDt_s bounds (as the fixed steps did).
// Along every step the energy per unit mass v^2 / (2k) + g z_surface falls at c g n_z |v . v_hat0|
// (>= 0 up to the stop), and it does not jump at an edge (z_surface is continuous, speed is not
// gained): the bound that ground_reach_m_per_j() and the history's stopping rule rest on.
//
// Every call terminates: by rest, by leaving the terrain, by the time limit, by the caller's
// segment callback, or at `max_steps` (reported as such).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/common/types.h"
#include "core/scene/site.h"

namespace fragsim::impact {

struct GroundMotionInput {
  double t_s = 0.0;
  Vec3 position_m{0, 0, 0};  // centre of mass, local
  Vec3 velocity_mps{0, 0, 0};
  double clearance_m = 0.0;  // centre-of-mass height above the surface, along its normal
  bool rolling = false;      // rolls (sphere) or slides
  double gravity_mps2 = kStandardGravity_mps2;
  double t_max_s = 120.0;
  long max_steps = 100000;
};

enum class GroundEnd { kRest, kLeftSite, kMaxTime, kStoppedByCaller, kStepCap };

struct GroundMotionResult {
  GroundEnd end = GroundEnd::kRest;
  double t_s = 0.0;
  Vec3 position_m{0, 0, 0};
  Vec3 velocity_mps{0, 0, 0};
  double path_m = 0.0;  // distance travelled on the ground
  long steps = 0;
};

// One straight piece of the ground path: the centre goes from a (time ta, velocity va) to b (tb,
// vb) over terrain triangle `triangle` (its xy-projection stays inside that triangle's, up to
// rounding; b may lie on its edge). b is already put onto the next triangle's plane when the step
// crosses an edge.
struct GroundSegment {
  Vec3 a{0, 0, 0}, b{0, 0, 0};
  double ta = 0.0, tb = 0.0;
  Vec3 va{0, 0, 0}, vb{0, 0, 0};
  std::uint32_t triangle = 0;
  double ha = 0.0, hb = 0.0;  // heights of a and b above the plane of `triangle`, vertically
};

// Speeds below this are rest: the phase ends (or restarts from rest on a steep slope).
inline constexpr double kRestSpeed_mps = 1e-6;
// Longest step: bounds how far the friction direction is held fixed on a sloping triangle.
inline constexpr double kGroundMaxDt_s = 0.25;

// 1 for sliding, 5/7 for a rolling solid sphere (1 / (1 + I / (m R^2))).
inline double ground_k(bool rolling) { return rolling ? 5.0 / 7.0 : 1.0; }

// First time t > 0 at which f(t) = A t^2 + B t + C reaches 0 from below (C <= 0: inside), or
// +inf. A point marginally outside through rounding (C > 0) counts as on the line: it exits at
// once if moving out (B > 0, or B = 0 and A > 0), otherwise from C = 0. Stable root forms.
inline double first_exit_time(double A, double B, double C) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (C >= 0.0) {
    if (B > 0.0 || (B == 0.0 && A > 0.0)) return 0.0;
    C = 0.0;
  }
  const double D = B * B - 4.0 * A * C;
  if (B >= 0.0) {
    if (B == 0.0 && A <= 0.0) return kInf;
    if (D < 0.0) return kInf;
    const double den = B + std::sqrt(D);
    return den > 0.0 ? -2.0 * C / den : kInf;
  }
  if (A > 0.0) return (-B + std::sqrt(D)) / (2.0 * A);  // D >= B^2 > 0 here
  return kInf;  // moving away and not turned back within a concave or straight path
}

// The time of the first exit of p_xy(t) = p + v t + a t^2 / 2 from the xy-projection of terrain
// triangle `tri` (+inf if it never leaves).
inline double triangle_exit_time(const scene::Site& site, std::uint32_t tri, const Vec3& p,
                                 const Vec3& v, const Vec3& a) {
  const auto& ids = site.terrain_triangles()[tri];
  const auto& vs = site.terrain_vertices();
  const Vec3* q[3] = {&vs[ids[0]], &vs[ids[1]], &vs[ids[2]]};
  const double orient = (q[1]->x() - q[0]->x()) * (q[2]->y() - q[0]->y()) -
                        (q[1]->y() - q[0]->y()) * (q[2]->x() - q[0]->x());
  if (orient < 0.0) std::swap(q[1], q[2]);  // counter-clockwise: (dy, -dx) points outward
  double t_exit = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const Vec3& u = *q[k];
    const Vec3& w = *q[(k + 1) % 3];
    const double nx = w.y() - u.y(), ny = -(w.x() - u.x());
    const double A = 0.5 * (nx * a.x() + ny * a.y());
    const double B = nx * v.x() + ny * v.y();
    const double C = nx * (p.x() - u.x()) + ny * (p.y() - u.y());
    t_exit = std::min(t_exit, first_exit_time(A, B, C));
  }
  return t_exit;
}

// The same for a lattice terrain (Site::terrain_is_lattice()), from the cell arithmetic alone (no
// vertex loads), and the triangle across the edge it leaves by (-1: off the terrain). In cell
// units u = (x - x0) / cx - i, w = (y - y0) / cy - j, triangle 2k is {w >= 0, u <= 1, w <= u}
// and 2k + 1 is {u >= 0, w <= 1, w >= u}.
inline double lattice_exit_time(const scene::TerrainIndex2D& grid, std::uint32_t tri, const Vec3& p,
                                const Vec3& v, const Vec3& a, std::int64_t& next) {
  const std::int64_t cell = tri / 2, nx = grid.nx, ny = grid.ny;
  const std::int64_t i = cell % nx, j = cell / nx;
  const double u = (p.x() - grid.origin.x()) / grid.cell.x() - static_cast<double>(i);
  const double w = (p.y() - grid.origin.y()) / grid.cell.y() - static_cast<double>(j);
  const double du = v.x() / grid.cell.x(), dw = v.y() / grid.cell.y();
  const double au = 0.5 * a.x() / grid.cell.x(), aw = 0.5 * a.y() / grid.cell.y();
  double t[3];
  std::int64_t to[3];
  if (tri % 2 == 0) {
    t[0] = first_exit_time(-aw, -dw, -w);  // w = 0: cell (i, j - 1), its upper triangle
    to[0] = j > 0 ? 2 * (cell - nx) + 1 : -1;
    t[1] = first_exit_time(au, du, u - 1.0);  // u = 1: cell (i + 1, j), upper
    to[1] = i + 1 < nx ? 2 * (cell + 1) + 1 : -1;
    t[2] = first_exit_time(aw - au, dw - du, w - u);  // diagonal: this cell's upper
    to[2] = 2 * cell + 1;
  } else {
    t[0] = first_exit_time(-au, -du, -u);  // u = 0: cell (i - 1, j), lower
    to[0] = i > 0 ? 2 * (cell - 1) : -1;
    t[1] = first_exit_time(aw, dw, w - 1.0);  // w = 1: cell (i, j + 1), lower
    to[1] = j + 1 < ny ? 2 * (cell + nx) : -1;
    t[2] = first_exit_time(au - aw, du - dw, u - w);  // diagonal: this cell's lower
    to[2] = 2 * cell;
  }
  int kmin = 0;
  for (int k = 1; k < 3; ++k)
    if (t[k] < t[kmin]) kmin = k;
  next = to[kmin];
  return t[kmin];
}

// on_segment(const GroundSegment&) is called for every straight piece of the path; it returns
// true to stop the motion there (a building hit, or nothing left to tally). prefetch(triangle)
// is told the triangle a step will cross into, ahead of time (a hint: the caller may start
// loading its own data for it).
template <class SegmentFn, class PrefetchFn>
GroundMotionResult move_on_ground(const scene::Site& site, const GroundMotionInput& in,
                                  SegmentFn&& on_segment, PrefetchFn&& prefetch) {
  GroundMotionResult r;
  r.t_s = in.t_s;
  r.position_m = in.position_m;
  Vec3 v = in.velocity_mps;
  const double g = in.gravity_mps2;
  const scene::Material& mat = site.materials()[site.terrain_material()];
  const double c = in.rolling ? mat.rolling_resistance : mat.friction;
  const double k = ground_k(in.rolling);
  // Smallest step past an edge (rounding can leave an edge point a hair inside its triangle):
  // every step makes progress, and the next triangle is looked up this far beyond the exit.
  const auto& cell = site.terrain_index().cell;
  const double nudge_m = 1e-7 * std::max(1e-3, std::min(cell.x(), cell.y()));

  const bool lattice = site.terrain_is_lattice();
  Vec3 p = r.position_m;
  std::int64_t tri = site.terrain_triangle_at(p.x(), p.y());
  for (r.steps = 0; r.steps < in.max_steps; ++r.steps) {
    if (tri < 0) {
      r.end = GroundEnd::kLeftSite;
      break;
    }
    const auto t1 = static_cast<std::uint32_t>(tri);
    const Vec3& n = site.terrain_triangle_normal(t1);
    const double gn = g * n.z();                          // normal load per mass
    const Vec3 gt = Vec3(0, 0, -g) + g * n.z() * n;      // gravity along the plane
    v -= v.dot(n) * n;                                   // on the plane: never gains speed
    double speed = v.norm();
    Vec3 a;
    if (speed < kRestSpeed_mps) {
      const double gt_norm = gt.norm();
      if (gt_norm <= c * gn) {  // within the friction angle: rest
        v.setZero();
        r.end = GroundEnd::kRest;
        break;
      }
      v.setZero();
      speed = 0.0;
      a = k * (gt_norm - c * gn) / gt_norm * gt;  // starts down the slope
    } else {
      a = k * (gt - c * gn * v / speed);
    }
    // Step: to the triangle's edge, the stop, kGroundMaxDt_s or the time limit, whichever first.
    // The cap only matters where the friction direction can turn (g_t not along v): on a level
    // triangle, from rest, or along the fall line the constant acceleration is exact.
    const bool turns =
        speed > 0.0 && (gt - gt.dot(v) / (speed * speed) * v).squaredNorm() > 1e-24 * g * g;
    double dt = turns ? kGroundMaxDt_s : std::numeric_limits<double>::infinity();
    bool stops = false, exits = false;
    if (speed > 0.0) {
      const double a_along = a.dot(v) / speed;
      if (a_along < 0.0 && speed / -a_along <= dt) {  // never beyond the stop
        dt = speed / -a_along;
        stops = true;
      }
    }
    std::int64_t across = -1;  // lattice: the triangle beyond the exit edge
    const double t_edge = lattice ? lattice_exit_time(site.terrain_index(), t1, p, v, a, across)
                                  : triangle_exit_time(site, t1, p, v, a);
    // The next triangle's plane and normal are read at the end of this step and its data by the
    // caller at the next one: start loading them now (random access over a large terrain).
    if (across >= 0) {
      const auto t_next = static_cast<std::uint32_t>(across);
      site.prefetch_terrain_triangle(t_next);
      prefetch(t_next);
    }
    if (t_edge <= dt) {
      // At least nudge_m of travel (|v| dt + |a| dt^2 / 2 = nudge_m), unless it stops first.
      const double amag = a.norm();
      const double dt_min = amag > 0.0 ? (std::sqrt(speed * speed + 2.0 * amag * nudge_m) - speed) / amag
                                       : nudge_m / speed;
      const double te = std::max(t_edge, dt_min);
      if (te < dt || !stops) {
        dt = te;
        stops = false;
        exits = true;
      }
    }
    if (in.t_max_s - r.t_s <= dt) {
      dt = std::max(0.0, in.t_max_s - r.t_s);
      stops = exits = false;
    }
    Vec3 p_new = p + v * dt + 0.5 * a * dt * dt;
    Vec3 v_new = v + a * dt;
    if (stops) v_new -= (v_new.dot(v) / (speed * speed)) * v;  // no component left along v
    // Across an edge: the triangle just beyond the exit point along the motion.
    std::int64_t tri_new = tri;
    if (exits && lattice) {
      tri_new = across;
    } else if (exits) {
      Vec3 dir = v_new;
      dir.z() = 0.0;
      const double dn = dir.norm();
      tri_new = dn > 0.0 ? site.terrain_triangle_at(p_new.x() + nudge_m * dir.x() / dn,
                                                    p_new.y() + nudge_m * dir.y() / dn)
                         : site.terrain_triangle_at(p_new.x(), p_new.y());
    }
    // Onto the surface, clearance along the (new) triangle's normal.
    const bool left = tri_new < 0;
    if (!left) {
      const auto t2 = static_cast<std::uint32_t>(tri_new);
      const Vec3& n2 = site.terrain_triangle_normal(t2);
      p_new.z() = site.terrain_plane_height(t2, p_new.x(), p_new.y()) + in.clearance_m / n2.z();
      if (t2 != t1) {
        const double s_before = v_new.norm();
        v_new -= v_new.dot(n2) * n2;
        const double s_after = v_new.norm();
        if (s_after > s_before && s_after > 0.0) v_new *= s_before / s_after;  // rounding guard
      }
    }
    const double t_new = r.t_s + dt;
    r.path_m += (p_new - p).norm();
    const double ha = p.z() - site.terrain_plane_height(t1, p.x(), p.y());
    const double hb = p_new.z() - site.terrain_plane_height(t1, p_new.x(), p_new.y());
    const bool stop = on_segment(GroundSegment{p, p_new, r.t_s, t_new, v, v_new, t1, ha, hb});
    p = p_new;
    v = v_new;
    r.t_s = t_new;
    tri = tri_new;
    if (stop) {
      r.end = GroundEnd::kStoppedByCaller;
      break;
    }
    if (left) {
      r.end = GroundEnd::kLeftSite;
      break;
    }
    if (r.t_s >= in.t_max_s) {
      r.end = GroundEnd::kMaxTime;
      break;
    }
    if (v.norm() < kRestSpeed_mps) v.setZero();
  }
  if (r.steps >= in.max_steps) r.end = GroundEnd::kStepCap;
  r.position_m = p;
  r.velocity_mps = v;
  return r;
}

template <class SegmentFn>
GroundMotionResult move_on_ground(const scene::Site& site, const GroundMotionInput& in,
                                  SegmentFn&& on_segment) {
  return move_on_ground(site, in, on_segment, [](std::uint32_t) {});
}

struct GroundBoundInput {
  double mass_kg = 0.0;
  double gravity_mps2 = kStandardGravity_mps2;
  double k = 1.0;               // ground_k(rolling)
  double friction = 0.0;        // c: mu sliding, mu_r rolling
  double terrain_min_z = 0.0;   // lowest terrain point (local)
  double terrain_min_nz = 1.0;  // smallest normal z of a terrain triangle
  double hazardous_ke_j = 0.0;
};

// Slack for rounding in the bound below: height 1 mm (a step ends at most 1e-7 cell past an edge
// on its old plane, which can lift the surface height under it by that times the slope change),
// and 1e-6 relative on the path length.
inline constexpr double kGroundBoundSlack_m = 1e-3;

// True when a body on the ground at centre p (surface height z_surface under it) with velocity v
// can provably never again be hazardous nor come into a building's bounding box. Along the slide
// (see the top) E = v^2 / (2k) + g z_s falls by at least c g n_min per metre of path (n_min the
// smallest normal z of the terrain) and never jumps up at an edge; E >= g z_min, so
//   remaining path <= (v^2 / (2k) + g (z_s - z_min)) / (c g n_min)
// and the kinetic energy never exceeds m k (E - g z_min) = m v^2 / 2 + k m g (z_s - z_min).
// A building is reached only if the centre's xy comes into its bounding box. Never true without
// friction.
inline bool ground_never_matters(const scene::Site& site, const GroundBoundInput& b, const Vec3& p,
                                 double z_surface, const Vec3& v) {
  const double ke = 0.5 * b.mass_kg * v.squaredNorm();
  if (!(ke < b.hazardous_ke_j)) return false;
  if (!(b.friction > 0.0) || !(b.terrain_min_nz > 0.0)) return false;
  const double g = b.gravity_mps2;
  const double drop = std::max(0.0, z_surface - b.terrain_min_z) + kGroundBoundSlack_m;
  if (!(ke + b.k * b.mass_kg * g * drop < b.hazardous_ke_j)) return false;
  const double reach =
      (1.0 + 1e-6) * (0.5 * v.squaredNorm() / b.k + g * drop) / (b.friction * g * b.terrain_min_nz) +
      kGroundBoundSlack_m;
  return !site.building_within_xy(p.x(), p.y(), reach);
}

}  // namespace fragsim::impact
