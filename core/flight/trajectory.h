#pragma once
// Integration of a fragment's translational flight, state (position, velocity) in local
// coordinates. Two independent variables, one after the other (docs/physics.md, "Integration"):
//  - path length through the air, s with ds/dt = |v - wind|, while drag dominates gravity
//    (k |v_rel|^2 >= kArcDragRatio g, R = 1): state (p, v, t), p' = v/|v_rel|, v' = a/|v_rel|,
//    t' = 1/|v_rel|. The drag-dominated decay v0 / (1 + k v0 t) of a fast fragment is
//    v0 e^(-k s) in s, which takes larger steps at equal error;
//  - time t from the first step end below that ratio to the end of the flight (gravity
//    dominates, |v_rel| may reach 0 at a vertical apex, where dt/ds is unbounded).
// Callers speak time either way: in s the step's times are its t components, and position(t)
// and velocity(t) find the step's theta with t(theta) = t on the dense output (a few Newton
// steps on one scalar polynomial). In t the v = 0 kink of -k|v|v is handled: when an accepted step
// straddles a vertical apex with (nearly) zero horizontal relative speed, the step is cut at the
// apex (located on the dense output) and integration restarts there, so no step integrates across
// the kink.
#include <limits>

#include "core/common/types.h"
#include "core/flight/dopri5.h"
#include "core/flight/flight_model.h"

namespace fragsim::flight {

class TrajectoryIntegrator {
 public:
  // Tolerances: rtol as given, atol = rtol x (1 m for positions, 1 m/s for velocities, 1 s for
  // the time component in s). Fragment flights span metres to kilometres at 1-1000 m/s, so the
  // relative term governs wherever a component is at flight scale, and the absolute term only
  // where it passes through zero (z at launch level, v_z at the apex), where it asks for
  // rtol-sized absolute errors in SI units. `arc_drag_ratio`: the switching rule's R (infinity:
  // time throughout, the integrator before path length was added; tests and benchmarks).
  TrajectoryIntegrator(const FlightModel& model, double rtol,
                       double arc_drag_ratio = kArcDragRatio);
  // Starts in s when the drag ratio at (position, velocity) is at least R, else in t.
  void reset(double t0, const Vec3& position, const Vec3& velocity);
  // One accepted step, not past t_end. False when no progress is possible.
  bool step(double t_end);
  // The last accepted step [t_prev, t] and its dense output.
  double t_prev() const;
  double t() const;
  Vec3 position(double t) const;
  Vec3 velocity(double t) const;
  void state(double t, Vec3& position, Vec3& velocity) const;  // both from one evaluation
  // The last step's dense output at the fraction theta in [0, 1] of its independent variable
  // (s or t): its time, position and velocity from one evaluation, without the time inversion.
  // Inline: called for every chord end (its outputs then stay in registers).
  void state_at_fraction(double theta, double& t, Vec3& position, Vec3& velocity) const {
    if (in_arc_) {
      const Vec7 y = arc_.dense_at_theta(theta);
      t = y[6];
      position = y.head<3>();
      velocity = y.segment<3>(3);
      return;
    }
    t = ode_.t_prev() + (ode_.t() - ode_.t_prev()) * theta;
    state(t, position, velocity);
  }
  // The last step's interval and its end state, what a caller reads after every step.
  struct StepEnd {
    double t0, t1;  // t_prev(), t()
    Vec3 p, v, a;   // position(), velocity(), acceleration()
  };
  // Inline: read after every step, and the caller's copy of it then folds into its own fields.
  StepEnd step_end() const {
    if (in_arc_) {
      const Vec7& y = arc_.y();
      return {arc_.y_prev()[6], y[6], y.head<3>(), y.segment<3>(3), arc_accel_};
    }
    const Vec6& y = ode_.y();
    return {ode_.t_prev(), ode_.t(), y.head<3>(), y.tail<3>(), ode_.dy().tail<3>()};
  }
  Vec3 position() const;  // at t()
  Vec3 velocity() const;
  Vec3 acceleration() const;  // at t()
  long rhs_evaluations() const;
  const FlightModel& model() const;
  // True while integrating in path length (the last step was taken in s).
  bool in_path_length() const { return in_arc_; }
  // Diagnostics (lifetime totals): accepted and rejected steps (both variables), steps accepted
  // in s, steps cut at a vertical apex, Newton iterations of position(t)/velocity(t) in s.
  long steps_accepted() const { return ode_.steps_accepted() + arc_.steps_accepted(); }
  long steps_rejected() const { return ode_.steps_rejected() + arc_.steps_rejected(); }
  long arc_steps() const { return arc_.steps_accepted(); }
  long apex_cuts() const { return apex_cuts_; }
  long time_inversion_iterations() const { return inversion_iterations_; }

  // Switching rule: s while drag is at least R = kArcDragRatio times gravity,
  // k |v_rel|^2 >= R g, checked at the end of every step; from the first step end below it, t to
  // the end of the flight (one way: falling, k |v_rel|^2 tends to g from below, so the ratio does
  // not come back above 1 in steady air). R = 1 is |v_rel| >= v_term = sqrt(g/k): t' = 1/|v_rel|
  // is bounded by 1/v_term and the drag-dominated start, where s pays off, is all in s.
  // Measured on the demo (--samples-scale 0.25, before the handover's first step was set): right-
  // hand sides per fragment 138.6 in t only, 115.5 / 112.2 / 109.7 / 108.1 / 104.1 at R = 8 / 4 /
  // 2 / 1 / 0.5; callgrind 470.0 M instructions at R = 4, 465.7 M at R = 1. Below 1 the saving in
  // evaluations did not show in instructions (an earlier version: R = 0.5 took 1.5 % more than
  // R = 4), and the s-phase would reach slow flight near the apex.
  static constexpr double kArcDragRatio = 1.0;

  // A step is cut at the apex only when the horizontal relative speed is below this fraction of
  // the largest vertical relative speed on the step: then -k|v|v is, over the step, within
  // k u^2 / 2 of the kinked k|v_z|v_z and its Taylor series in v_z (radius u) does not cover the
  // step. Above it the right-hand side is smooth on the step's scale and the error control
  // handles the apex like any other curvature. Measured against the hodograph reference (0.1 kg
  // steel sphere, 100 m/s): at 89.9 deg and rtol 1e-6 the cut takes the landing-time error from
  // 5.3e-6 to 2.2e-8 (+12 evaluations); a ratio of 0.01 misses the 89.99 deg apex at rtol 1e-8
  // (7.6e-9 instead of 6.1e-10); a ratio of 1 also cuts 88-89.5 deg apexes, which the error
  // control already resolves within 1e-6.
  static constexpr double kApexHorizontalRatio = 0.1;

 public:
  // The right-hand sides are public for the lane kernel's tests and benchmark
  // (core/flight/lanes.h), which compare it with DOPRI5 on these bit for bit.
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  using Vec7 = Eigen::Matrix<double, 7, 1>;
  // Right-hand side in t, (p, v)' = (v, a(p, v)). Holds its own copy of the model (two pointers
  // and a few numbers) so that the integrator can be copied freely.
  struct Rhs {
    static constexpr int kLaneState = 6;  // its attempts may go to a lane (core/flight/lanes.h)
    FlightModel model;
    Vec6 operator()(double /*t*/, const Vec6& y) const {
      Vec6 dy;
      dy.head<3>() = y.tail<3>();
      dy.tail<3>() = model.acceleration(y.head<3>(), y.tail<3>());
      return dy;
    }
  };
  // Right-hand side in s, (p, v, t)' = (v, a, 1) / |v_rel|.
  struct ArcRhs {
    static constexpr int kLaneState = 7;
    FlightModel model;
    // Forced inline (GCC otherwise calls it: +8 % instructions in the s-phase, callgrind).
    [[gnu::always_inline]] Vec7 operator()(double /*s*/, const Vec7& y) const {
      double speed;
      const Vec3 a = model.acceleration(y.head<3>(), y.segment<3>(3), speed);
      const double dt_ds = 1.0 / speed;
      Vec7 dy;
      dy.head<3>() = y.segment<3>(3) * dt_ds;
      dy.segment<3>(3) = a * dt_ds;
      dy[6] = dt_ds;
      return dy;
    }
  };

 private:
  // Private Methods
  bool arc_step(double t_end);
  void start_time_phase(double t0, const Vec3& p, const Vec3& v, double h0 = 0.0);
  bool drag_dominates(const Vec3& a) const;
  double arc_first_step(const Vec3& a, double speed) const;
  double arc_theta(double t) const;
  Vec3 arc_acceleration() const;  // at the end of the last step in s, from its derivative
  Vec7 arc_dense(double t) const { return arc_.dense_at_theta(arc_theta(t)); }
  void cut_at_apex_if_needed();

  // Private Members
  Dopri5<6, Rhs> ode_;
  Dopri5<7, ArcRhs> arc_;
  double arc_drag_ratio_;
  bool in_arc_ = false;
  bool leave_arc_ = false;   // the last step in s ended below the drag ratio: next one in t
  Vec3 arc_accel_{0, 0, 0};  // arc_acceleration() of the last step in s (read twice a step)
  Vec3 wind_{0, 0, 0};
  double last_cut_t_ = -std::numeric_limits<double>::infinity();
  long apex_cuts_ = 0;
  mutable long inversion_iterations_ = 0;
};

// Torque-free rigid rotation (paper eq. 2 with tau = 0): Euler's equations in the body frame and
// q' = 1/2 q (x) (0, omega_body). Closed form for zero spin and for spherical or axisymmetric
// inertia (two principal moments equal, e.g. cylinders, square cuboids, spheroids); exact
// Jacobi-elliptic solution for asymmetric bodies (core/flight/torque_free.h, Landau & Lifshitz
// sec. 37), whose cost does not grow with the number of revolutions. Only within ~1e-6 of the
// separatrix (spin about the intermediate axis) DOPRI5 at `rtol` with renormalised quaternion.
struct RotationState {
  Quat q = Quat::Identity();  // body -> site
  Vec3 omega_body{0, 0, 0};   // rad/s, body frame
};
RotationState propagate_torque_free(const Vec3& inertia_principal_kg_m2, const RotationState& s,
                                    double dt_s, double rtol = 1e-12);
// True when two principal moments are equal to within 1e-14 relative: propagate_torque_free then
// uses the axisymmetric closed form.
bool has_two_equal_moments(const Vec3& inertia_principal_kg_m2);

}  // namespace fragsim::flight
