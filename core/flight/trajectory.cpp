#include "core/flight/trajectory.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/flight/torque_free.h"

namespace fragsim::flight {

// ---------------------------------------------------------------------------------------------
// TrajectoryIntegrator

namespace {

Dopri5Options translation_options(double rtol) {
  if (!(rtol > 0.0 && rtol < 1.0))
    throw std::invalid_argument("TrajectoryIntegrator: rtol " + std::to_string(rtol) +
                                " outside (0, 1)");
  Dopri5Options opt;
  opt.rtol = rtol;
  opt.atol = rtol;  // x 1 m or 1 m/s: see the constructor's comment in the header
  return opt;
}

}  // namespace

TrajectoryIntegrator::TrajectoryIntegrator(const FlightModel& model, double rtol,
                                           double arc_drag_ratio)
    : ode_(Rhs{model}, translation_options(rtol)),
      arc_(ArcRhs{model}, translation_options(rtol)),
      arc_drag_ratio_(arc_drag_ratio) {
  if (model.atmosphere != nullptr) wind_ = model.atmosphere->wind();
}

void TrajectoryIntegrator::reset(double t0, const Vec3& position, const Vec3& velocity) {
  double speed;
  const Vec3 a = model().acceleration(position, velocity, speed);
  in_arc_ = speed > 0.0 && drag_dominates(a);
  leave_arc_ = false;
  if (!in_arc_) {
    start_time_phase(t0, position, velocity);
    return;
  }
  Vec7 y0;
  y0 << position, velocity, t0;
  arc_.reset(0.0, y0, arc_first_step(a, speed));
  arc_accel_ = arc_acceleration();
}

// First step in s: drag alone is v' = -k_eff v in s (k_eff = |a_drag| / |v_rel|^2), whose local
// error over a step h is of order (k_eff h)^5 |v|, so h = rtol^(1/5) / k_eff is at the scale the
// controller settles to (measured on the demo's plates: the controller's first steps are 1-1.5 x
// this; Hairer's automatic start, designed for t, began 100 x below and took two extra steps).
// rtol^(1/5) is kept per thread for the last rtol seen: a run builds one integrator per history
// with the same rtol, and the pow showed in profiles (0.24 % of the demo's instructions).
double TrajectoryIntegrator::arc_first_step(const Vec3& a, double speed) const {
  static thread_local double rtol_seen = -1.0, root_seen = 0.0;
  const double rtol = arc_.options().rtol;
  if (rtol != rtol_seen) {
    root_seen = std::pow(rtol, 0.2);
    rtol_seen = rtol;
  }
  const double drag = (a + Vec3(0.0, 0.0, model().gravity_mps2)).norm();
  return root_seen * speed * speed / drag;
}

bool TrajectoryIntegrator::step(double t_end) {
  if (in_arc_ && arc_step(t_end)) return true;
  if (!ode_.step(t_end)) return false;
  cut_at_apex_if_needed();
  return true;
}

// One step in s. False after handing the flight over to t: when the last step ended below the
// drag ratio, or this one fails or would end past t_end (then t restarts at its start).
bool TrajectoryIntegrator::arc_step(double t_end) {
  const double inf = std::numeric_limits<double>::infinity();
  const bool ok = !leave_arc_ && arc_.step(inf);
  if (ok && arc_.y()[6] <= t_end) {
    arc_accel_ = arc_acceleration();
    leave_arc_ = !drag_dominates(arc_accel_);
    return true;
  }
  const Vec7 y = ok ? arc_.y_prev() : arc_.y();
  in_arc_ = false;
  // Below the drag ratio: a fifth of the s-controller's proposal, as a time step (dt = ds/|v_rel|),
  // saves the automatic start's evaluation and its too-small first steps. Measured on the
  // work-precision case (docs/benchmarks.md §3): the whole proposal cost accuracy (range error
  // 7.4e-4 at rtol 1e-4, against 1.0e-5 with a fifth and 9.2e-6 with the automatic start); a
  // fifth keeps the automatic start's accuracy with 5 % fewer right-hand sides.
  const double h0 = leave_arc_ ? 0.2 * arc_.next_step_size() * arc_.dy()[6] : 0.0;
  start_time_phase(y[6], y.head<3>(), y.segment<3>(3), h0);
  return false;
}

// h0 <= 0: the first step chosen automatically.
void TrajectoryIntegrator::start_time_phase(double t0, const Vec3& p, const Vec3& v, double h0) {
  Vec6 y0;
  y0 << p, v;
  ode_.reset(t0, y0, h0);
  last_cut_t_ = -std::numeric_limits<double>::infinity();
}

// The switching rule: drag |a + g e_z| at least R g.
bool TrajectoryIntegrator::drag_dominates(const Vec3& a) const {
  const double g = model().gravity_mps2;
  return (a + Vec3(0.0, 0.0, g)).norm() >= arc_drag_ratio_ * g;
}

// theta in [0, 1] of the last step in s with t(theta) = t, t(theta) the time component of the
// dense output (increasing: t' = 1/|v_rel| > 0). Start: the cubic Hermite interpolant of the
// inverse, theta(t), from the ends' dt/ds; then safeguarded Newton on the quartic t(theta), to
// ~1e-16 in theta (3.4 iterations on average on the demo, the last one confirming).
double TrajectoryIntegrator::arc_theta(double t) const {
  const auto c = arc_.dense_coefficients();
  const double span = arc_.y()[6] - c.y0[6], dt = t - c.y0[6];
  if (!(dt > 0.0) || c.h == 0.0) return 0.0;
  if (!(dt < span)) return 1.0;
  // t(theta) - t0 = theta (a + (1-theta) (b + theta (d + (1-theta) e))).
  const double a = c.r2[6], b = c.r3[6], d = c.r4[6], e = c.r5[6];
  const double u = dt / span, m0 = span / (a + b), m1 = span / (a - b - d);
  double th =
      std::clamp(u * u * (3.0 - 2.0 * u) + u * (1.0 - u) * ((1.0 - u) * m0 - u * m1), 0.0, 1.0);
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 60; ++it) {
    ++inversion_iterations_;
    const double th1 = 1.0 - th;
    const double f = th * (a + th1 * (b + th * (d + th1 * e))) - dt;
    if (f == 0.0) break;
    (f < 0.0 ? lo : hi) = th;
    const double df = a + (1.0 - 2.0 * th) * b + th * (2.0 - 3.0 * th) * d +
                      2.0 * th * th1 * (1.0 - 2.0 * th) * e;
    double next = th - f / df;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    // Quadratic convergence with |t''/2t'| <~ 1 on a step (dt/ds changes by a small factor
    // over an accepted step): after a Newton step below 1e-9 the error is below ~1e-18.
    const bool done = std::abs(next - th) <= 1e-9;
    th = next;
    if (done) break;
  }
  return th;
}

// The kink of -k|v_rel| v_rel at v_rel = 0 (docs/physics.md, "Reference formulas": the v = 0 kink):
// with no horizontal relative speed, v_z' = -g - k|v_z|v_z has a v_z''' that jumps by 4 k g^2 at
// the apex, so a Runge-Kutta step across it drops to low order and its error estimate is
// unreliable. If the accepted step [t_prev, t] has v_z,rel changing sign while the horizontal
// relative speed is small (kApexHorizontalRatio), locate v_z,rel = 0 on the dense output and retake
// the step to end there; the next step then starts at the apex and sees a smooth solution.
void TrajectoryIntegrator::cut_at_apex_if_needed() {
  const double t0 = ode_.t_prev(), t1 = ode_.t();
  if (t0 == last_cut_t_) return;  // this step starts at the apex just cut: v_z,rel(t0) ~ 0
  const Vec6& y0 = ode_.y_prev();
  const Vec6& y1 = ode_.y();
  const double s0 = y0[5] - wind_.z(), s1 = y1[5] - wind_.z();
  if (!(s0 * s1 < 0.0)) return;
  // A zero within the velocity tolerance of an end of the step is harmless: near v_rel = 0 the
  // kinked and the smooth branch differ by 2 k v_z^2, so crossing there perturbs v by
  // ~2 k tol_v^2 h, far below tol_v.
  const Dopri5Options& opt = ode_.options();
  const Vec3 vr0 = y0.tail<3>() - wind_, vr1 = y1.tail<3>() - wind_;
  const double tol0 = opt.atol + opt.rtol * vr0.norm(), tol1 = opt.atol + opt.rtol * vr1.norm();
  if (std::abs(s0) <= tol0 || std::abs(s1) <= tol1) return;
  const double u = std::max(vr0.head<2>().norm(), vr1.head<2>().norm());
  if (u > kApexHorizontalRatio * std::max(std::abs(s0), std::abs(s1))) return;

  // Safeguarded Newton on the dense output's v_z(t) - w_z, bracketed by [a, b] (the dense output
  // interpolates both ends exactly, so the bracket is valid); falls back to bisection when a
  // Newton step leaves the bracket. Converges to a few ulp of t.
  double a = t0, b = t1, fa = s0;
  double t = t0 + (t1 - t0) * s0 / (s0 - s1);  // regula falsi start
  const double t_tol =
      4.0 * std::numeric_limits<double>::epsilon() * std::max(std::abs(t1), t1 - t0);
  for (int it = 0; it < 100; ++it) {
    const double f = ode_.dense(t)[5] - wind_.z();
    if (f == 0.0) break;
    if ((f < 0.0) == (fa < 0.0)) {
      a = t;
      fa = f;
    } else {
      b = t;
    }
    const double df = ode_.dense_derivative(t)[5];
    double t_next = t - f / df;
    if (!(t_next > a && t_next < b)) t_next = 0.5 * (a + b);
    const bool done = std::abs(t_next - t) <= t_tol || b - a <= t_tol;
    t = t_next;
    if (done) break;
  }
  t = std::clamp(t, std::nextafter(t0, t1), t1);
  ode_.truncate_last_step(t);
  last_cut_t_ = ode_.t();
  ++apex_cuts_;
}

double TrajectoryIntegrator::t_prev() const {
  return in_arc_ ? arc_.y_prev()[6] : ode_.t_prev();
}
double TrajectoryIntegrator::t() const {
  return in_arc_ ? arc_.y()[6] : ode_.t();
}
Vec3 TrajectoryIntegrator::position(double t) const {
  return in_arc_ ? Vec3(arc_dense(t).head<3>()) : Vec3(ode_.dense(t).head<3>());
}
Vec3 TrajectoryIntegrator::velocity(double t) const {
  return in_arc_ ? Vec3(arc_dense(t).segment<3>(3)) : Vec3(ode_.dense(t).tail<3>());
}
void TrajectoryIntegrator::state(double t, Vec3& position, Vec3& velocity) const {
  if (in_arc_) {
    const Vec7 y = arc_dense(t);
    position = y.head<3>();
    velocity = y.segment<3>(3);
  } else {
    const Vec6 y = ode_.dense(t);
    position = y.head<3>();
    velocity = y.tail<3>();
  }
}
Vec3 TrajectoryIntegrator::position() const {
  return in_arc_ ? Vec3(arc_.y().head<3>()) : Vec3(ode_.y().head<3>());
}
Vec3 TrajectoryIntegrator::velocity() const {
  return in_arc_ ? Vec3(arc_.y().segment<3>(3)) : Vec3(ode_.y().tail<3>());
}
Vec3 TrajectoryIntegrator::acceleration() const {
  return in_arc_ ? arc_accel_ : Vec3(ode_.dy().tail<3>());
}
// In s: dv/ds = a/|v_rel| and dt/ds = 1/|v_rel|.
Vec3 TrajectoryIntegrator::arc_acceleration() const {
  return arc_.dy().segment<3>(3) / arc_.dy()[6];
}
long TrajectoryIntegrator::rhs_evaluations() const {
  return ode_.rhs_evaluations() + arc_.rhs_evaluations();
}
const FlightModel& TrajectoryIntegrator::model() const {
  return ode_.rhs().model;
}

// ---------------------------------------------------------------------------------------------
// Torque-free rotation

namespace {

// Relative tolerance for "equal" principal moments. Moments computed from equal dimensions by
// the same formula agree to the last bit or so; treating moments that differ by d (relative) as
// equal changes the motion by ~d |omega| t, negligible at this level.
constexpr double kEqualInertia = 1e-14;

bool nearly_equal(double a, double b) {
  return std::abs(a - b) <= kEqualInertia * std::max(std::abs(a), std::abs(b));
}

// Axisymmetric (and spherical) closed form. With I_s the distinct moment about body axis e_s and
// I_p the other two, the body-frame angular velocity precesses about e_s at
// Omega = (I_s - I_p) omega_s / I_p (Landau & Lifshitz, Mechanics, sects. 33 and 36), and the
// attitude is
//   R(t) = Rot(L_w, |L| t / I_p) R0 Rot(e_s, -Omega t),   L_w = R0 I omega0 (constant),
// which gives omega_body = L_body / I_p - Omega e_s, i.e. I omega_body = L_body: the motion with
// constant world angular momentum. Spherical inertia is Omega = 0: rotation by |omega| t.
RotationState axisymmetric_closed_form(const Vec3& inertia, int s, double i_perp,
                                       const RotationState& st, double dt) {
  const Vec3 l_body = inertia.cwiseProduct(st.omega_body);
  const Vec3 l_world = st.q * l_body;
  const double l_norm = l_world.norm();
  const double omega_s = (inertia[s] - i_perp) * st.omega_body[s] / i_perp;
  const Vec3 e_s = Vec3::Unit(s);
  const Quat a(Eigen::AngleAxisd(l_norm * dt / i_perp, l_world / l_norm));
  const Quat b(Eigen::AngleAxisd(-omega_s * dt, e_s));
  RotationState out;
  out.q = (a * st.q * b).normalized();
  // L_body(t) = B^T L_body(0); omega = I^-1 L.
  out.omega_body = (b.conjugate() * l_body).cwiseQuotient(inertia);
  return out;
}

}  // namespace

bool has_two_equal_moments(const Vec3& inertia) {
  return nearly_equal(inertia[0], inertia[1]) || nearly_equal(inertia[1], inertia[2]) ||
         nearly_equal(inertia[2], inertia[0]);
}

RotationState propagate_torque_free(const Vec3& inertia_principal_kg_m2, const RotationState& s,
                                    double dt_s, double rtol) {
  const Vec3& inertia = inertia_principal_kg_m2;
  if (!(inertia.minCoeff() > 0.0) || !inertia.allFinite())
    throw std::invalid_argument("propagate_torque_free: principal moments must be finite and > 0");
  if (!std::isfinite(dt_s) || !s.omega_body.allFinite() || !s.q.coeffs().allFinite())
    throw std::invalid_argument("propagate_torque_free: non-finite state or time");
  const double spin = s.omega_body.norm();
  if (spin == 0.0 || dt_s == 0.0) return {s.q.normalized(), s.omega_body};

  // Two equal moments: closed form about the distinct one (any axis if all three are equal).
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    if (nearly_equal(inertia[i], inertia[j]))
      return axisymmetric_closed_form(inertia, k, 0.5 * (inertia[i] + inertia[j]), s, dt_s);
  }

  if (!(rtol > 0.0 && rtol < 1.0))
    throw std::invalid_argument("propagate_torque_free: rtol " + std::to_string(rtol) +
                                " outside (0, 1)");
  // Three distinct moments: the exact elliptic-function solution (torque_free.h, Landau &
  // Lifshitz sect. 37), O(1) in the number of revolutions; DOPRI5 only within ~1e-6 (in 1 - k^2)
  // of the separatrix, where the analytic form loses accuracy.
  if (std::optional<RotationState> exact = propagate_torque_free_analytic(inertia, s, dt_s))
    return *exact;
  return propagate_torque_free_numeric(inertia, s, dt_s, rtol);
}

}  // namespace fragsim::flight
