// Exact torque-free motion of an asymmetric rigid body (Landau & Lifshitz, Mechanics, sect. 37)
// in Jacobi elliptic functions and the elliptic integral of the third kind, and the DOPRI5
// reference path.
#include "core/flight/torque_free.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/flight/dopri5.h"

namespace fragsim::flight {

// ---------------------------------------------------------------------------------------------
// Jacobi elliptic functions

JacobiElliptic::JacobiElliptic(double m_param, double mc_param) : m_(m_param), mc_(mc_param) {
  if (!(m_ >= 0.0 && mc_ > 0.0 && m_ < 1.0))
    throw std::invalid_argument("JacobiElliptic: need 0 <= m < 1 and mc > 0");
  k_complete_ = carlson_rf(0.0, mc_, 1.0);
  // AGM (A&S 16.4.2): a0 = 1, b0 = sqrt(mc), c0 = sqrt(m); a_{n+1} = (a_n + b_n)/2,
  // b_{n+1} = sqrt(a_n b_n), ic_{n+1} = (a_n - b_n)/2 = c_n^2 / (4 a_{n+1}) (no cancellation).
  double a = 1.0, b = std::sqrt(mc_), c = std::sqrt(m_);
  n_agm_ = 0;
  while (c > 0x1p-54 * a && n_agm_ < kMaxAgm) {
    const double a1 = 0.5 * (a + b);
    const double b1 = std::sqrt(a * b);
    c = c * c / (4.0 * a1);
    a = a1;
    b = b1;
    ++n_agm_;
    ratio_[n_agm_] = c / a;
  }
  a_n_ = a;
}

JacobiSnCnDn JacobiElliptic::reduced(double u, double& j) const {
  j = std::nearbyint(u / (2.0 * k_complete_));
  const double r = u - 2.0 * k_complete_ * j;
  // Descending Landen (A&S 16.4.3): phi_N = 2^N a_N r, phi_{n-1} = (phi_n + asin((c_n / a_n)
  // sin phi_n)) / 2; sn = sin phi_0, cn = cos phi_0.
  double phi = std::ldexp(a_n_ * r, n_agm_);
  for (int n = n_agm_; n >= 1; --n) phi = 0.5 * (phi + std::asin(ratio_[n] * std::sin(phi)));
  JacobiSnCnDn out;
  out.sn = std::sin(phi);
  out.cn = std::cos(phi);
  out.dn = std::sqrt(mc_ + m_ * out.cn * out.cn);
  return out;
}

JacobiSnCnDn JacobiElliptic::operator()(double u) const {
  double j = 0.0;
  JacobiSnCnDn out = reduced(u, j);
  if (std::fmod(j, 2.0) != 0.0) {
    out.sn = -out.sn;
    out.cn = -out.cn;
  }
  return out;
}

double JacobiElliptic::F(double am) const {
  const double j = std::nearbyint(am / kPi);
  const double phi = am - kPi * j;  // [-pi/2, pi/2]
  const double s = std::sin(phi), c = std::cos(phi);
  // DLMF 19.25.5: F(phi, k) = sin phi R_F(cos^2 phi, 1 - k^2 sin^2 phi, 1).
  return 2.0 * j * k_complete_ + s * carlson_rf(c * c, mc_ + m_ * c * c, 1.0);
}

namespace {

// Pi(n; am r, m) for |am r| <= pi/2 from sn, cn (>= 0), dn of r (DLMF 19.25.14).
double pi_reduced(double n, const JacobiSnCnDn& r) {
  const double s2 = r.sn * r.sn;
  return r.sn * carlson_rf(r.cn * r.cn, r.dn * r.dn, 1.0) +
         n / 3.0 * r.sn * s2 * carlson_rj(r.cn * r.cn, r.dn * r.dn, 1.0, 1.0 - n * s2);
}

// Complete Pi(n, m) (DLMF 19.25.2).
double pi_complete(double n, double mc) {
  return carlson_rf(0.0, mc, 1.0) + n / 3.0 * carlson_rj(0.0, mc, 1.0, 1.0 - n);
}

}  // namespace

double JacobiElliptic::Pi_of_u(double n, double u) const {
  double j = 0.0;
  const JacobiSnCnDn r = reduced(u, j);
  return 2.0 * j * pi_complete(n, mc_) + pi_reduced(n, r);
}

// ---------------------------------------------------------------------------------------------
// Asymmetric torque-free motion

namespace {

void check_input(const Vec3& inertia, const RotationState& s, double dt) {
  if (!(inertia.minCoeff() > 0.0) || !inertia.allFinite())
    throw std::invalid_argument("propagate_torque_free: principal moments must be finite and > 0");
  if (!std::isfinite(dt) || !s.omega_body.allFinite() || !s.q.coeffs().allFinite())
    throw std::invalid_argument("propagate_torque_free: non-finite state or time");
}

// Relative gap at or below which two moments count as equal (the caller's axisymmetric closed
// form, trajectory.cpp, uses the same 1e-14). Above it the elliptic form holds with k -> 0 or
// lambda -> 0 and stays exact: against the axisymmetric closed form the difference is the
// physical one, ~gap x rotation angle, measured for gaps 1e-8 .. 2e-14.
constexpr double kDistinct = 1e-14;

}  // namespace

AsymmetricTorqueFree::AsymmetricTorqueFree(const Vec3& inertia, const RotationState& s0) {
  check_input(inertia, s0, 0.0);
  s0_.q = s0.q.normalized();
  s0_.omega_body = s0.omega_body;
  spin_ = s0.omega_body.stableNorm();  // no underflow of the squares for tiny spins
  // Sort: lo < mid < hi.
  int lo = 0, mid = 1, hi = 2;
  if (inertia[lo] > inertia[mid]) std::swap(lo, mid);
  if (inertia[mid] > inertia[hi]) std::swap(mid, hi);
  if (inertia[lo] > inertia[mid]) std::swap(lo, mid);
  if (!(inertia[mid] - inertia[lo] > kDistinct * inertia[mid]) ||
      !(inertia[hi] - inertia[mid] > kDistinct * inertia[hi]))
    return;
  if (spin_ == 0.0) return;
  // Scale invariance: Euler's equations are unchanged by I -> c I and the motion of omega / s in
  // time s t is that of omega in t. Work with J = I / I_max, u = omega / |omega|, T = |omega| t.
  j_ = inertia / inertia[hi];
  const Vec3 u = s0.omega_body / spin_;
  const Vec3 ju2 = j_.cwiseProduct(u.cwiseProduct(u));  // J_i u_i^2
  im_ = mid;
  if (u[lo] == 0.0 && u[hi] == 0.0) {
    kind_ = Kind::kIntermediateAxis;  // unstable equilibrium, but exact: omega constant
    valid_ = true;
    return;
  }
  // L^2 - 2 E J_m = sum_i J_i u_i^2 (J_i - J_m): the sign picks the circled axis.
  const double s_mid = ju2[lo] * (j_[lo] - j_[mid]) + ju2[hi] * (j_[hi] - j_[mid]);
  if (s_mid == 0.0) return;  // on the separatrix
  ic_ = s_mid > 0.0 ? hi : lo;
  ie_ = s_mid > 0.0 ? lo : hi;
  const double je = j_[ie_], jm = j_[im_], jc = j_[ic_];
  // |2E J_c - L^2|, |L^2 - 2E J_e|, |L^2 - 2E J_m| as sums of same-signed terms.
  double p_c = 0.0, p_e = 0.0;
  for (int i = 0; i < 3; ++i) {
    p_c += ju2[i] * std::abs(jc - j_[i]);
    p_e += ju2[i] * std::abs(j_[i] - je);
  }
  const double p_m = std::abs(s_mid);
  const double dce = std::abs(jc - je), dcm = std::abs(jc - jm), dme = std::abs(jm - je);
  const double kc2 = dce * p_m / (dcm * p_e);  // 1 - k^2 = |J_c - J_e| P_m / (|J_c - J_m| P_e)
  const double k2 = dme * p_c / (dcm * p_e);   // k^2 (L&L sect. 37)
  if (!(kc2 >= kTorqueFreeSeparatrixMc) || !(k2 >= 0.0) || !(k2 < 1.0)) return;
  jac_ = JacobiElliptic(k2, kc2);

  // Amplitudes (L&L sect. 37, and its 1 <-> 3 exchange) and the rate of tau in T units.
  a_e_ = std::sqrt(p_c / (je * dce));
  a_m_ = std::sqrt(p_c / (jm * dcm));
  a_c_ = std::sqrt(p_e / (jc * dce));
  lambda_ = std::sqrt(dcm * p_e / (j_[0] * j_[1] * j_[2]));
  // Signs: omega_c keeps the sign of its initial value (dn > 0); with s_e = +1, Euler's equations
  // I_e w_e' = eps (I_m - I_c) w_m w_c (eps = +1 for (e, m, c) cyclic) need
  // s_m s_c = eps sign(I_c - I_m). (A negative omega_c is the image of a positive one under the
  // rotation by pi about axis e or m, which reverses two components.)
  s_c_ = u[ic_] >= 0.0 ? 1.0 : -1.0;
  const double eps = (im_ == (ie_ + 1) % 3) ? 1.0 : -1.0;
  s_m_ = eps * (jc > jm ? 1.0 : -1.0) * s_c_;
  // Initial amplitude am(tau0) = atan2(sn, cn), sn = u_m / (s_m a_m), cn = u_e / a_e, with the
  // common factor sqrt(P_c) dropped (defined also for P_c -> 0, pure spin about axis c).
  psi_e_ = std::sqrt(je / dce);
  psi_m_ = std::sqrt(jm / dcm);
  const double am0 = std::atan2(s_m_ * u[im_] * std::sqrt(jm * dcm), u[ie_] * std::sqrt(je * dce));
  tau0_ = jac_.F(am0);

  // Precession: L&L's phi' = L (J_1 w_1^2 + J_2 w_2^2) / (J_1^2 w_1^2 + J_2^2 w_2^2) over the two
  // non-circled axes, with w_e ~ cn / sqrt(J_e |J_c - J_e|) and w_m ~ sn / sqrt(J_m |J_c - J_m|),
  // is phi' = L / J_c + L (J_c - J_e) / (J_e J_c (1 - n sn^2)), n = J_c (J_e - J_m) /
  // (J_e (J_c - J_m)) < 0 (no pole on the real axis; no 1/n either, so J_e -> J_m is harmless).
  // Its integral over tau is the elliptic integral of the third kind Pi(n; am tau, k).
  l_ = std::sqrt((j_.cwiseProduct(u)).squaredNorm());
  n_ = jc * (je - jm) / (je * (jc - jm));
  phi_rate_c_ = l_ / jc;
  phi_coef_ = l_ * (jc - je) / (je * jc * lambda_);
  pi_complete_ = pi_complete(n_, kc2);
  double j0 = 0.0;
  const JacobiSnCnDn r0 = jac_.reduced(tau0_, j0);
  pi_j0_ = j0;
  pi_r0_ = pi_reduced(n_, r0);

  // Canonical frame: body axes relabelled cyclically, (c+1, c+2, c) -> (1, 2, 3); a rotation.
  Mat3 perm = Mat3::Zero();  // columns: body coordinates of the canonical axes
  perm((ic_ + 1) % 3, 0) = 1.0;
  perm((ic_ + 2) % 3, 1) = 1.0;
  perm(ic_, 2) = 1.0;
  q_perm_ = Quat(perm);
  const double sign0 = std::fmod(j0, 2.0) != 0.0 ? -1.0 : 1.0;
  Vec3 w_unused;
  const Quat m0 = nutation_spin(sign0 * r0.sn, sign0 * r0.cn, r0.dn, w_unused);
  q_left_ = s0_.q * q_perm_ * m0.conjugate();
  kind_ = Kind::kElliptic;
  valid_ = true;
}

Quat AsymmetricTorqueFree::nutation_spin(double sn, double cn, double dn, Vec3& w) const {
  w[ie_] = a_e_ * cn;
  w[im_] = s_m_ * a_m_ * sn;
  w[ic_] = s_c_ * a_c_ * dn;
  // Body-frame L / |L| = (sin theta sin psi, sin theta cos psi, cos theta) in the canonical frame
  // (L&L 35.1 with Rz(phi) Rx(theta) Rz(psi) body -> space). psi from the amplitude-free
  // proportional components (J_e w_e, J_m w_m) ~ (psi_e cn, s_m psi_m sn).
  Vec3 v;
  v[ie_] = psi_e_ * cn;
  v[im_] = s_m_ * psi_m_ * sn;
  const double psi = std::atan2(v[(ic_ + 1) % 3], v[(ic_ + 2) % 3]);
  const double theta = std::atan2(std::hypot(j_[ie_] * w[ie_], j_[im_] * w[im_]), j_[ic_] * w[ic_]);
  const Quat qx(std::cos(0.5 * theta), std::sin(0.5 * theta), 0.0, 0.0);
  const Quat qz(std::cos(0.5 * psi), 0.0, 0.0, std::sin(0.5 * psi));
  return qx * qz;
}

RotationState AsymmetricTorqueFree::at(double dt) const {
  if (!valid_) throw std::logic_error("AsymmetricTorqueFree::at: no analytic solution");
  if (!std::isfinite(dt)) throw std::invalid_argument("propagate_torque_free: non-finite time");
  RotationState out;
  if (kind_ == Kind::kIntermediateAxis) {
    out.omega_body = s0_.omega_body;
    out.q =
        (s0_.q * Quat(Eigen::AngleAxisd(s0_.omega_body[im_] * dt, Vec3::Unit(im_)))).normalized();
    return out;
  }
  const double t = spin_ * dt;
  const double tau = tau0_ + lambda_ * t;
  double j = 0.0;
  const JacobiSnCnDn r = jac_.reduced(tau, j);
  const double sign = std::fmod(j, 2.0) != 0.0 ? -1.0 : 1.0;
  Vec3 w;
  const Quat mt = nutation_spin(sign * r.sn, sign * r.cn, r.dn, w);
  // phi(t) - phi(0) = L T / J_c + coef [Pi(n; am tau) - Pi(n; am tau0)], with both Pi split as
  // 2 j Pi(n) + Pi(n; am r) so that the whole periods cancel exactly.
  const double d_pi = 2.0 * (j - pi_j0_) * pi_complete_ + (pi_reduced(n_, r) - pi_r0_);
  const double dphi = phi_rate_c_ * t + phi_coef_ * d_pi;
  const Quat qz(std::cos(0.5 * dphi), 0.0, 0.0, std::sin(0.5 * dphi));
  out.q = (q_left_ * qz * mt * q_perm_.conjugate()).normalized();
  out.omega_body = spin_ * w;
  return out;
}

std::optional<RotationState> propagate_torque_free_analytic(const Vec3& inertia,
                                                            const RotationState& s, double dt) {
  check_input(inertia, s, dt);
  if ((s.omega_body.array() == 0.0).all() || dt == 0.0)
    return RotationState{s.q.normalized(), s.omega_body};
  const AsymmetricTorqueFree sol(inertia, s);
  if (!sol.valid()) return std::nullopt;
  return sol.at(dt);
}

// ---------------------------------------------------------------------------------------------
// Numerical path

namespace {

// State (q_w, q_x, q_y, q_z, w) in scaled time tau = |omega0| t with w = omega / |omega0|, so
// every component is O(1) and one absolute tolerance fits all:
//   dq/dtau = 1/2 q (x) (0, w),   dw/dtau = -I^-1 (w x I w)   (Euler, paper eq. 2 with tau = 0).
// `direction` = -1 integrates backwards in t.
struct EulerRhs {
  Vec3 inertia;
  double direction;
  using Vec7 = Eigen::Matrix<double, 7, 1>;
  Vec7 operator()(double /*tau*/, const Vec7& y) const {
    const double qw = y[0];
    const Vec3 qv = y.segment<3>(1);
    const Vec3 w = y.segment<3>(4);
    Vec7 dy;
    // q (x) (0, w) = (-qv.w, qw w + qv x w)
    dy[0] = -0.5 * qv.dot(w);
    dy.segment<3>(1) = 0.5 * (qw * w + qv.cross(w));
    dy.segment<3>(4) = -(w.cross(inertia.cwiseProduct(w))).cwiseQuotient(inertia);
    return direction * dy;
  }
};

}  // namespace

RotationState propagate_torque_free_numeric(const Vec3& inertia, const RotationState& s,
                                            double dt_s, double rtol) {
  check_input(inertia, s, dt_s);
  if (!(rtol > 0.0 && rtol < 1.0))
    throw std::invalid_argument("propagate_torque_free: rtol " + std::to_string(rtol) +
                                " outside (0, 1)");
  const double spin = s.omega_body.norm();
  if (spin == 0.0 || dt_s == 0.0) return {s.q.normalized(), s.omega_body};
  Dopri5Options opt;
  opt.rtol = rtol;
  opt.atol = rtol;  // components are O(1) after scaling
  opt.h_min = 1e-14;
  Dopri5<7, EulerRhs> ode(EulerRhs{inertia, dt_s > 0.0 ? 1.0 : -1.0}, opt);
  EulerRhs::Vec7 y0;
  const Quat q0 = s.q.normalized();
  y0 << q0.w(), q0.x(), q0.y(), q0.z(), s.omega_body / spin;
  ode.reset(0.0, y0);
  const double tau_end = spin * std::abs(dt_s);
  while (ode.t() < tau_end) {
    if (!ode.step(tau_end))
      throw std::runtime_error("propagate_torque_free: step size underflow at tau = " +
                               std::to_string(ode.t()));
  }
  const EulerRhs::Vec7& y = ode.y();
  RotationState out;
  // The exact flow keeps |q| = 1; the integrator drifts by O(rtol), removed here.
  out.q = Quat(y[0], y[1], y[2], y[3]).normalized();
  out.omega_body = spin * y.segment<3>(4);
  return out;
}

}  // namespace fragsim::flight
