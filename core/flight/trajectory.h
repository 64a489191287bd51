#pragma once
// Integration of a fragment's translational flight, state (position, velocity) in local
// coordinates, with the v = 0 kink of -k|v|v handled: when an accepted step straddles a vertical
// apex with (nearly) zero horizontal relative speed, the step is cut at the apex (located on the
// dense output) and integration restarts there, so no step integrates across the kink.
#include "core/common/types.h"
#include "core/flight/dopri5.h"
#include "core/flight/flight_model.h"

namespace fragsim::flight {

class TrajectoryIntegrator {
 public:
  // Tolerances: rtol as given, atol = rtol x (1 m for positions, 1 m/s for velocities). Fragment
  // flights span metres to kilometres at 1-1000 m/s, so the relative term governs wherever a
  // component is at flight scale, and the absolute term only where it passes through zero (z at
  // launch level, v_z at the apex), where it asks for rtol-sized absolute errors in SI units.
  TrajectoryIntegrator(const FlightModel& model, double rtol);
  void reset(double t0, const Vec3& position, const Vec3& velocity);
  // One accepted step, not past t_end. False when no progress is possible.
  bool step(double t_end);
  // The last accepted step [t_prev, t] and its dense output.
  double t_prev() const;
  double t() const;
  Vec3 position(double t) const;
  Vec3 velocity(double t) const;
  Vec3 position() const;  // at t()
  Vec3 velocity() const;
  Vec3 acceleration() const;  // at t()
  long rhs_evaluations() const;
  const FlightModel& model() const;
  // Diagnostics (lifetime totals): accepted and rejected steps, steps cut at a vertical apex.
  long steps_accepted() const { return ode_.steps_accepted(); }
  long steps_rejected() const { return ode_.steps_rejected(); }
  long apex_cuts() const { return apex_cuts_; }

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

 private:
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  // Right-hand side (p, v)' = (v, a(p, v)). Holds its own copy of the model (two pointers and
  // a few numbers) so that the integrator can be copied freely.
  struct Rhs {
    FlightModel model;
    Vec6 operator()(double /*t*/, const Vec6& y) const {
      Vec6 dy;
      dy.head<3>() = y.tail<3>();
      dy.tail<3>() = model.acceleration(y.head<3>(), y.tail<3>());
      return dy;
    }
  };

  // Private Methods
  void cut_at_apex_if_needed();

  // Private Members
  Dopri5<6, Rhs> ode_;
  Vec3 wind_{0, 0, 0};
  double last_cut_t_ = -std::numeric_limits<double>::infinity();
  long apex_cuts_ = 0;
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
