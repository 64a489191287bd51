#pragma once
// Integration of a fragment's translational flight, state (position, velocity) in local
// coordinates, with the v = 0 kink of -k|v|v handled: when an accepted step straddles a vertical
// apex with (nearly) zero horizontal relative speed, the step is cut at the apex (located on the
// dense output) and integration restarts there, so no step integrates across the kink.
#include "core/common/types.h"
#include "core/flight/flight_model.h"

namespace fragsim::flight {

class TrajectoryIntegrator {
 public:
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
  // ... implementation-defined private members ...
};

// Torque-free rigid rotation (paper eq. 2 with tau = 0): Euler's equations in the body frame and
// q' = 1/2 q (x) (0, omega_body). Spherical inertia or zero spin: closed form. Otherwise DOPRI5 at
// `rtol` with renormalised quaternion.
struct RotationState {
  Quat q = Quat::Identity();  // body -> site
  Vec3 omega_body{0, 0, 0};   // rad/s, body frame
};
RotationState propagate_torque_free(const Vec3& inertia_principal_kg_m2, const RotationState& s,
                                    double dt_s, double rtol = 1e-12);

}  // namespace fragsim::flight
