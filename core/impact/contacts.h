#pragma once
// Contact detection along a flight arc. Each accepted integrator step is cut into straight chords
// whose sagitta stays under a tolerance; each chord is a segment query against the site; a hit is
// then refined on the dense-output interpolant (not the chord), so the sagitta tolerance only
// decides which hits can be found (paths skimming a surface closer than the tolerance), not where
// they are.
#include <algorithm>
#include <cmath>

#include "core/common/roots.h"
#include "core/common/types.h"
#include "core/scene/site.h"

namespace fragsim::impact {

// Curvature of a path with velocity v and acceleration a: kappa = |v x a| / |v|^3 (infinite at
// v = 0).
inline double path_curvature(const Vec3& v, const Vec3& a) {
  const double s = v.norm();
  return s > 0.0 ? v.cross(a).norm() / (s * s * s) : std::numeric_limits<double>::infinity();
}

// Number of chords so that the sagitta of each stays <= sagitta_m (docs/physics.md, "Reference
// formulas"):
//   n = ceil(L sqrt(kappa / (8 delta)))
// with kappa the largest curvature on the step (the caller samples both ends and the middle: the
// curvature peaks at an apex, which may lie inside a step).
inline int chord_count(double length_m, double kappa_max, double sagitta_m, int max_chords = 256) {
  if (!(kappa_max > 0.0)) return 1;
  const double n = std::ceil(length_m * std::sqrt(kappa_max / (8.0 * sagitta_m)));
  if (!(n < max_chords)) return max_chords;  // also catches inf/NaN (v = 0)
  return std::max(1, static_cast<int>(n));
}

// How far an arc of chord length L whose curvature is at most kappa strays from its chord: the
// sagitta kappa L^2 / 8 (docs/physics.md, "Reference formulas"), here kappa L^2: a factor 4 for a
// curvature that peaks between the step's three samples (the flight's examine_step) and 2 more
// for the sagitta's growth beyond its first-order form. Only while kappa L <= 1/4 (then an arc of
// 4 kappa has sagitta at most 0.134 L, within the bound 0.25 L); +inf beyond, or for an unknown
// curvature.
inline double chord_deviation_bound(double length_m, double kappa) {
  if (!(kappa * length_m <= 0.25)) return std::numeric_limits<double>::infinity();
  return kappa * length_m * length_m;
}

// Time in [t_lo, t_hi] at which the arc P(t) crosses the plane through q with normal n, found by
// the Illinois regula falsi (common/roots.h) on g(t) = n.(P(t) - q). Requires g(t_lo) and g(t_hi)
// of opposite signs (or one of them 0); returns NaN otherwise.
template <class PositionFn>
double refine_plane_crossing(const PositionFn& position, const Vec3& n, const Vec3& q, double t_lo,
                             double t_hi) {
  const double glo = n.dot(position(t_lo) - q);
  const double ghi = n.dot(position(t_hi) - q);
  if (glo == 0.0) return t_lo;
  if (ghi == 0.0) return t_hi;
  if ((glo > 0.0) == (ghi > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  const auto g = [&](double t) { return n.dot(position(t) - q); };
  return illinois(g, t_lo, t_hi, glo, ghi, 1e-14).last;
}

// Impact angle between the velocity and the surface, degrees: 0 grazing, 90 head-on.
inline double impact_angle_deg(const Vec3& velocity, const Vec3& normal) {
  const double s = velocity.norm();
  if (!(s > 0.0)) return 0.0;
  return std::asin(std::min(1.0, std::abs(velocity.dot(normal)) / s)) / kDegToRad;
}

}  // namespace fragsim::impact
