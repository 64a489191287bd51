#pragma once
// Torque-free rotation of an asymmetric rigid body (three distinct principal moments): the exact
// solution in Jacobi elliptic functions (Landau & Lifshitz, Mechanics, 3rd ed., sect. 37), whose
// cost does not depend on the number of revolutions, and the numerical DOPRI5 reference it
// replaces (kept for the near-separatrix case, where the polhode period diverges, and for
// comparison).
//
// propagate_torque_free() in trajectory.h dispatches: zero spin and axisymmetric inertia in closed
// form there, asymmetric inertia here (analytic, DOPRI5 fallback).
#include <optional>

#include "core/common/elliptic.h"
#include "core/common/types.h"
#include "core/flight/trajectory.h"

namespace fragsim::flight {

// ---------------------------------------------------------------------------------------------
// Elliptic functions and integrals (real arguments). The parameter is m = k^2; its complement
// mc = 1 - m is passed separately so that both are known to full relative precision near m = 1.

// Carlson's symmetric integrals R_F and R_J: core/common/elliptic.h.

struct JacobiSnCnDn {
  double sn = 0.0, cn = 1.0, dn = 1.0;
};

// Jacobi sn, cn, dn of parameter m in [0, 1) for any real argument: reduction to [-K, K] by
// sn(u + 2K) = -sn(u), cn(u + 2K) = -cn(u), dn(u + 2K) = dn(u), then the arithmetic-geometric
// mean with descending Landen transformation (Abramowitz & Stegun 16.4); dn from
// dn^2 = mc + m cn^2 (no cancellation). The AGM sequence depends on m only and is set up once.
class JacobiElliptic {
 public:
  JacobiElliptic(double m_param, double mc_param);
  double m() const { return m_; }
  double mc() const { return mc_; }
  double K() const { return k_complete_; }  // quarter period K(m) = R_F(0, mc, 1)
  JacobiSnCnDn operator()(double u) const;
  // u = 2 K j + r with r in [-K, K]; returns sn, cn, dn of r (cn(r) >= 0) and sets j.
  JacobiSnCnDn reduced(double u, double& j) const;
  // Incomplete integral of the first kind of the amplitude: F(am, m) for any real am
  // (F(am + j pi) = F(am) + 2 j K), i.e. the inverse of am(u) = atan2(sn u, cn u) unwrapped.
  double F(double am) const;
  // Pi(n; am(u), m) = int_0^u du' / (1 - n sn^2 u') for any real u, with n < 1 (Carlson R_J form,
  // DLMF 19.25.14, and Pi(n; am + pi) = Pi(n; am) + 2 Pi(n)).
  double Pi_of_u(double n, double u) const;

 private:
  static constexpr int kMaxAgm = 16;
  double m_, mc_, k_complete_;
  int n_agm_ = 0;
  double a_n_ = 1.0;                // a_N
  double ratio_[kMaxAgm + 1] = {};  // c_n / a_n
};

// ---------------------------------------------------------------------------------------------
// Torque-free motion.

// Polhodes with 1 - k^2 below this (within ~1e-6 of the separatrix through the intermediate axis)
// go to the numerical path: K(k) ~ ln(4 / k') grows without bound there and the Jacobi functions
// lose the digits the analytic solution needs.
inline constexpr double kTorqueFreeSeparatrixMc = 1e-6;

// The exact motion from one initial state, set up once (~1 us) and evaluated at any time offset
// (~1 us each, independent of the number of revolutions). Body principal axes in any order, the
// three moments distinct (relative gap > 1e-14). valid() is false when the analytic form is not
// used: moments not distinct, or the polhode within kTorqueFreeSeparatrixMc of the separatrix
// (pure spin about the intermediate axis itself is exact: constant omega).
//
// Method (L&L sect. 37): sort I_e, I_m, I_c with I_m the intermediate moment and I_c the extreme
// moment whose axis the polhode circles (the largest when L^2 > 2 E I_m, else the smallest).
// omega_e = a_e cn(tau), omega_m = s_m a_m sn(tau), omega_c = s_c a_c dn(tau), tau = tau0 +
// lambda t. The attitude: with the space Z axis along the constant L and z-x-z Euler angles
// (phi, theta, psi) of the body frame relabelled cyclically so that axis c is its third axis,
// cos theta = I_c omega_c / L, tan psi = I_1 omega_1 / (I_2 omega_2) and
// phi' = L / I_c + L (I_c - I_e) / (I_e I_c (1 - n sn^2 tau)), n = I_c (I_e - I_m) / (I_e (I_c -
// I_m)) < 0, whose integral is the elliptic integral of the third kind Pi(n; am tau, k).
class AsymmetricTorqueFree {
 public:
  AsymmetricTorqueFree(const Vec3& inertia_principal_kg_m2, const RotationState& s0);
  bool valid() const { return valid_; }
  // State at t0 + dt (dt of either sign). Requires valid().
  RotationState at(double dt_s) const;
  // Diagnostics (elliptic case only): k^2 and 1 - k^2 of the polhode, and the period of
  // omega_body(t), 4 K / lambda in seconds (the limit for a vanishing polhode when k = 0).
  double m() const { return jac_.m(); }
  double mc() const { return jac_.mc(); }
  double omega_period_s() const { return 4.0 * jac_.K() / (lambda_ * spin_); }

 private:
  enum class Kind { kNone, kIntermediateAxis, kElliptic };
  Kind kind_ = Kind::kNone;
  bool valid_ = false;
  RotationState s0_;
  double spin_ = 0.0;             // |omega0|; the solution is set up for omega0 / |omega0|
  int ie_ = 0, im_ = 1, ic_ = 2;  // body axis indices (other extreme, intermediate, circled)
  Vec3 j_{1, 1, 1};               // inertia / max inertia
  double a_e_ = 0, a_m_ = 0, a_c_ = 0, s_m_ = 1, s_c_ = 1;
  double psi_e_ = 0, psi_m_ = 0;  // sqrt(J_e / |J_c - J_e|), sqrt(J_m / |J_c - J_m|)
  double lambda_ = 0, tau0_ = 0, l_ = 0, n_ = 0, phi_rate_c_ = 0, phi_coef_ = 0;
  double pi_j0_ = 0, pi_r0_ = 0;  // Pi_of_u(tau0) split as 2 j0 Pi(n) + Pi(n; am r0)
  double pi_complete_ = 0;        // Pi(n, m)
  JacobiElliptic jac_{0.0, 1.0};
  Quat q_perm_ = Quat::Identity();  // canonical (cyclically relabelled, axis c third) -> body
  Quat q_left_ = Quat::Identity();  // q0 * q_perm * M(0)^-1: the fixed q_L of the composition

  // Canonical-frame rotation Rx(theta) Rz(psi) from (sn, cn, dn) at one tau.
  Quat nutation_spin(double sn, double cn, double dn, Vec3& omega_unit) const;
};

// Exact solution for asymmetric inertia; std::nullopt where AsymmetricTorqueFree is not valid().
// Throws std::invalid_argument on non-finite input or moments <= 0.
std::optional<RotationState> propagate_torque_free_analytic(const Vec3& inertia_principal_kg_m2,
                                                            const RotationState& s, double dt_s);

// The numerical path: DOPRI5 at `rtol` on Euler's equations and q' = 1/2 q (x) (0, omega) in
// scaled time |omega0| t, quaternion renormalised at the end. Any inertia. Cost grows linearly
// with the rotation angle. Throws std::invalid_argument on bad input, std::runtime_error on step
// size underflow.
RotationState propagate_torque_free_numeric(const Vec3& inertia_principal_kg_m2,
                                            const RotationState& s, double dt_s,
                                            double rtol = 1e-12);

}  // namespace fragsim::flight
