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
// Every call terminates: by rest, by leaving the terrain, by the time limit, by the caller's
// segment callback, or at `max_steps` (reported as such).
#include <algorithm>
#include <cmath>

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

// Speeds below this are rest: the phase ends (or restarts from rest on a steep slope).
inline constexpr double kRestSpeed_mps = 1e-6;

// on_segment(a, b, ta, tb, va, vb) is called for every straight piece of the path (local
// coordinates, times, velocities at the ends); it returns true to stop the motion there (a
// building hit, or nothing left to tally).
template <class SegmentFn>
GroundMotionResult move_on_ground(const scene::Site& site, const GroundMotionInput& in,
                                  SegmentFn&& on_segment) {
  GroundMotionResult r;
  r.t_s = in.t_s;
  r.position_m = in.position_m;
  Vec3 v = in.velocity_mps;
  const double g = in.gravity_mps2;
  const scene::Material& mat = site.materials()[site.terrain_material()];
  const double c = in.rolling ? mat.rolling_resistance : mat.friction;
  const double k = in.rolling ? 5.0 / 7.0 : 1.0;  // solid sphere: 1 / (1 + I / (m R^2))
  // A step moves at most one terrain bucket (a grid cell: two triangles), so a triangle's plane
  // is never followed far past its edge (the position is put back on the surface after every
  // step).
  const auto& cell = site.terrain_index().cell;
  const double max_step_m = std::max(1e-3, std::min(cell.x(), cell.y()));
  constexpr double kMaxDt_s = 0.25;

  Vec3 p = r.position_m;
  for (r.steps = 0; r.steps < in.max_steps; ++r.steps) {
    const std::int64_t tri = site.terrain_triangle_at(p.x(), p.y());
    if (tri < 0) {
      r.end = GroundEnd::kLeftSite;
      break;
    }
    const Vec3& n = site.terrain_triangle_normal(static_cast<std::uint32_t>(tri));
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
    // Step length: at most max_step_m of travel and kMaxDt_s; ends exactly where the speed along
    // the direction of motion would reach zero (friction decelerates, it never reverses motion).
    const double amag = a.norm();
    double dt = kMaxDt_s;
    if (speed > 0.0 || amag > 0.0) {
      // |v| dt + |a| dt^2 / 2 = max_step_m
      dt = std::min(dt, amag > 0.0 ? (std::sqrt(speed * speed + 2.0 * amag * max_step_m) - speed) / amag
                                   : max_step_m / speed);
    }
    bool stops = false;
    if (speed > 0.0) {
      const double a_along = a.dot(v) / speed;
      if (a_along < 0.0 && speed / -a_along <= dt) {
        dt = speed / -a_along;
        stops = true;
      }
    }
    dt = std::min(dt, in.t_max_s - r.t_s);
    Vec3 p_new = p + v * dt + 0.5 * a * dt * dt;
    Vec3 v_new = v + a * dt;
    if (stops) v_new -= (v_new.dot(v) / (speed * speed)) * v;  // no component left along v
    // Back onto the surface, clearance along the new triangle's normal.
    const std::int64_t tri_new = site.terrain_triangle_at(p_new.x(), p_new.y());
    bool left = tri_new < 0;
    if (!left) {
      const auto t2 = static_cast<std::uint32_t>(tri_new);
      const Vec3& n2 = site.terrain_triangle_normal(t2);
      p_new.z() = site.terrain_plane_height(t2, p_new.x(), p_new.y()) + in.clearance_m / n2.z();
      const double s_before = v_new.norm();
      v_new -= v_new.dot(n2) * n2;
      const double s_after = v_new.norm();
      if (s_after > s_before && s_after > 0.0) v_new *= s_before / s_after;  // rounding guard
    }
    const double t_new = r.t_s + dt;
    r.path_m += (p_new - p).norm();
    const bool stop = on_segment(p, p_new, r.t_s, t_new, v, v_new);
    p = p_new;
    v = v_new;
    r.t_s = t_new;
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

}  // namespace fragsim::impact
