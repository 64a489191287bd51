#pragma once
// Impulse-based collision of a rigid body with a fixed surface (paper eqs. 6-36; Mirtich 1996,
// ch. 4): rigid bodies, Stronge's energetic restitution (eq. 6), Coulomb friction (eq. 8). A pure
// function: velocities and spin before -> impulse, velocities and spin after.
//
// The impact is followed along the normal impulse p_z (monotone through the whole impact, never
// singular, unlike u_z at a jam or W_z at the start of restitution): du/dp_z = K_hat zeta.
// Sliding is integrated by Taylor series in a rescaled impulse (dp_z = |u_t| dsigma); the ends
// of compression (u_z = 0) and restitution (W_z = (1 - e^2) W_c) are roots of the series;
// sticking, the last approach to it and sliding along an invariant ray have constant zeta and
// are exact straight segments. Contact velocity after: error ~2e-11 |u0| typical, ~1e-9 |u0|
// worst seen; u.n after >= 0 always (lifted past rounding). Details, sources: docs/physics.md
// C1-C10.
#include "core/common/types.h"

namespace fragsim::impact {

struct CollisionInput {
  double mass_kg = 0.0;
  Mat3 inv_inertia_world = Mat3::Zero();  // I_w^-1 in site axes (all zeros for a point mass)
  Vec3 r_m{0, 0, 0};                      // contact point minus centre of mass, site axes
  Vec3 normal{0, 0, 1};        // unit surface normal, site axes, from the surface toward the body
  Vec3 velocity_mps{0, 0, 0};  // centre-of-mass velocity before
  Vec3 omega_radps{0, 0, 0};   // angular velocity before, SITE axes
  double restitution = 0.0;    // e in [0, 1] (Stronge's energetic coefficient); clamped
  double friction = 0.0;       // mu >= 0 (Coulomb); negative is taken as 0
};

struct CollisionResult {
  bool impact = false;  // false when the contact point is not approaching (u.n >= 0) or the
                        // input is invalid (non-finite, mass <= 0, zero normal): nothing changes
  Vec3 impulse_ns{0, 0, 0};  // total impulse applied to the body at the contact point, site axes
  Vec3 velocity_mps{0, 0, 0}, omega_radps{0, 0, 0};                        // after (site axes)
  Vec3 contact_velocity_before{0, 0, 0}, contact_velocity_after{0, 0, 0};  // u = v + w x r
  bool ended_sticking = false;  // |u_t| <= 1e-9 |u_before| at the end
  bool jammed = false;          // (K_hat zeta)_z <= 0 occurred (u_z still falling while sliding)
  int steps = 0;                // Taylor steps used (0: straight segments only)

  // Phases met (for the bench and tests).
  bool stuck = false;             // the slip |u_t| reached 0 (or was 0 at the start)
  bool resumed_sliding = false;   // ... and sticking was unstable: sliding resumed along the ray
  bool recompressed = false;      // u_z turned negative again during restitution
  bool step_cap_reached = false;  // ran out of steps: finished with a normal-only impulse
  // Work of the contact impulse (J): W_c = normal work while u_z < 0 (<= 0); W_z = total normal
  // work = (1 - e^2) W_c at the end (Stronge, eq. 6); W_t = friction work (<= 0). The kinetic
  // energy changes by exactly W_z + W_t.
  double work_compression_j = 0.0;
  double work_normal_j = 0.0;
  double work_friction_j = 0.0;
};

CollisionResult resolve_collision(const CollisionInput& in);

// Building blocks, exposed for tests.

// Collision matrix K = (1/m) 1 - [r]x I_w^-1 [r]x (paper eq. 20): u(p) = u0 + K p (eq. 21).
Mat3 collision_matrix(double mass_kg, const Mat3& inv_inertia, const Vec3& r);
// Rotation R from site axes to the contact frame (eqs. 23-24): rows are tangent x, tangent y and
// the normal, so u_hat = R u and K_hat = R K R^T (eq. 26).
Mat3 contact_frame(const Vec3& normal);
// Sticking is stable when sqrt((K_hat^-1)_13^2 + (K_hat^-1)_23^2) <= mu (K_hat^-1)_33 (Mirtich
// 1996, sec. 4.4): the impulse that keeps u_t = 0 lies inside the friction cone.
bool sticking_is_stable(const Mat3& k_hat, double mu);
// Unit slip direction (cos phi, sin phi) in the contact frame along which sliding resumes after
// unstable sticking: the diverging invariant ray, (K_hat zeta)_t = lambda (cos phi, sin phi) with
// lambda > 0 and zeta = (-mu cos phi, -mu sin phi, 1). It is a root of Mirtich's quartic in
// tan(phi/2) and unique (docs/physics.md C1-C10). Precondition: !sticking_is_stable(k_hat, mu).
Vec2 diverging_slip_direction(const Mat3& k_hat, double mu);

}  // namespace fragsim::impact
