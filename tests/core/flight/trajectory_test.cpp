// TrajectoryIntegrator mechanics (dense output, stopping, apex cut) and torque-free rotation
// closed forms. Physics accuracy against closed forms is in tests/validation.
#include "core/flight/trajectory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace fragsim::flight {
namespace {

struct SteadyAir {
  Atmosphere atm;
  DragCoefficient cd;
  FlightModel model;
  explicit SteadyAir(Vec3 wind = Vec3::Zero(), double cd_value = 0.47)
      : atm(constant_air(wind)), cd(constant_cd(cd_value)) {
    model = FlightModel{&atm, &cd, 9.80665, 6.6e-4, 0.1, 0.0};
  }
  static AtmosphereSpec constant_air(Vec3 wind) {
    AtmosphereSpec s;
    s.model = AtmosphereSpec::Model::kConstant;
    s.wind_mps = wind;
    return s;
  }
  static fragments::CdSpec constant_cd(double c) {
    fragments::CdSpec s;
    s.constant = c;
    return s;
  }
};

TEST(TrajectoryIntegrator, DenseOutputIsContinuousAcrossSteps) {
  SteadyAir s;
  TrajectoryIntegrator ti(s.model, 1e-6);
  ti.reset(0.0, Vec3::Zero(), Vec3(80.0, 10.0, 60.0));
  Vec3 p_end = ti.position(), v_end = ti.velocity();
  int steps = 0;
  while (ti.step(8.0)) {
    ++steps;
    // The new step's interpolant starts where the previous step ended (bitwise: y_prev is
    // the previous y; the interpolant reproduces it up to y0 + (y1 - y0) rounding, 1e-13 m).
    EXPECT_NEAR((ti.position(ti.t_prev()) - p_end).norm(), 0.0, 1e-12);
    EXPECT_NEAR((ti.velocity(ti.t_prev()) - v_end).norm(), 0.0, 1e-12);
    EXPECT_NEAR((ti.position(ti.t()) - ti.position()).norm(), 0.0, 1e-12);
    p_end = ti.position();
    v_end = ti.velocity();
    // acceleration() is the model at the end state (FSAL stage), to rounding.
    EXPECT_NEAR((ti.acceleration() - s.model.acceleration(ti.position(), ti.velocity())).norm(),
                0.0, 1e-13);
  }
  EXPECT_EQ(ti.t(), 8.0);
  EXPECT_GT(steps, 3);
  EXPECT_FALSE(ti.step(8.0));
  EXPECT_EQ(ti.model().area_m2, s.model.area_m2);
  // Six per step attempt and per apex cut, one at each start. This flight (drag 1.9 g at
  // launch) starts in s and hands over to t below drag = g, with the first step in t taken from
  // the s-controller's proposal (no evaluation for an automatic first step).
  EXPECT_GT(ti.arc_steps(), 0);
  EXPECT_EQ(ti.rhs_evaluations(),
            2 + 6 * (ti.steps_accepted() + ti.steps_rejected()) + 6 * ti.apex_cuts());
}

TEST(TrajectoryIntegrator, CutsAtVerticalApexOnly) {
  // Vertical launch, no wind: exactly one apex cut, ending a step near v_z = 0. The zero is
  // found on the interpolant of the step that crossed the kink, which is degraded there
  // (measured |v_z| = 6.8e-4 m/s at the cut); the rest of the crossing then perturbs v by only
  // ~2 k v_z^2 h ~ 1e-9 m/s. Bound 1e-2 m/s; uncut steps end ~1 m/s (g x step) from the apex.
  {
    SteadyAir s;
    TrajectoryIntegrator ti(s.model, 1e-6);
    ti.reset(0.0, Vec3::Zero(), Vec3(0.0, 0.0, 100.0));
    bool at_apex = false;
    while (ti.step(30.0) && ti.position().z() > -100.0) {
      if (ti.apex_cuts() == 1 && !at_apex) {
        at_apex = true;
        EXPECT_LT(std::abs(ti.velocity().z()), 1e-2);
      }
    }
    EXPECT_EQ(ti.apex_cuts(), 1);
  }
  // Steep but not vertical (u = 100 cos 89.9 deg = 0.17 m/s, within 0.1 x the step's vertical
  // speeds): still cut.
  {
    SteadyAir s;
    TrajectoryIntegrator ti(s.model, 1e-6);
    const double e = 89.9 * kDegToRad;
    ti.reset(0.0, Vec3::Zero(), 100.0 * Vec3(std::cos(e), 0.0, std::sin(e)));
    while (ti.step(30.0) && ti.position().z() > -100.0) {
    }
    EXPECT_EQ(ti.apex_cuts(), 1);
  }
  // A 45 degree launch has a smooth apex: no cut.
  {
    SteadyAir s;
    TrajectoryIntegrator ti(s.model, 1e-6);
    ti.reset(0.0, Vec3::Zero(), Vec3(70.0, 0.0, 70.0));
    while (ti.step(30.0) && ti.position().z() > -100.0) {
    }
    EXPECT_EQ(ti.apex_cuts(), 0);
  }
  // Vertical launch in a horizontal wind: the relative velocity never vanishes, no cut.
  {
    SteadyAir s(Vec3(10.0, 0.0, 0.0));
    TrajectoryIntegrator ti(s.model, 1e-6);
    ti.reset(0.0, Vec3::Zero(), Vec3(0.0, 0.0, 100.0));
    while (ti.step(30.0) && ti.position().z() > -100.0) {
    }
    EXPECT_EQ(ti.apex_cuts(), 0);
  }
  // Vertical launch in a vertical wind (updraft 5 m/s): the kink is at v_z = 5 m/s; cut there.
  {
    SteadyAir s(Vec3(0.0, 0.0, 5.0));
    TrajectoryIntegrator ti(s.model, 1e-6);
    ti.reset(0.0, Vec3::Zero(), Vec3(0.0, 0.0, 100.0));
    bool checked = false;
    while (ti.step(30.0) && ti.position().z() > -100.0) {
      if (ti.apex_cuts() == 1 && !checked) {
        checked = true;
        EXPECT_LT(std::abs(ti.velocity().z() - 5.0), 1e-2);
      }
    }
    EXPECT_EQ(ti.apex_cuts(), 1);
  }
}

TEST(TrajectoryIntegrator, RejectsBadTolerance) {
  SteadyAir s;
  EXPECT_THROW(TrajectoryIntegrator(s.model, 0.0), std::invalid_argument);
  EXPECT_THROW(TrajectoryIntegrator(s.model, 1.5), std::invalid_argument);
}

double rotation_angle(const Quat& a, const Quat& b) {
  return 2.0 * std::acos(std::min(1.0, std::abs(a.dot(b))));
}

TEST(TorqueFree, ZeroSpinKeepsAttitude) {
  RotationState s;
  s.q = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  const RotationState out = propagate_torque_free(Vec3(1, 2, 3), s, 5.0);
  EXPECT_NEAR(rotation_angle(out.q, s.q), 0.0, 1e-7);  // acos near 1 loses half the digits
  EXPECT_EQ(out.omega_body, Vec3::Zero());
}

TEST(TorqueFree, SphericalRotatesAboutFixedAxisAtSpinRate) {
  // Spherical inertia: omega constant; attitude q0 (x) exp(omega t / 2): rotation angle
  // |omega| t about the world axis R0 omega. Closed form in the code: 1e-12 rad.
  RotationState s;
  s.q = Quat(Eigen::AngleAxisd(0.3, Vec3(0, 1, 0)));
  s.omega_body = Vec3(0.2, -0.4, 0.1);
  const double t = 2.5;
  const RotationState out = propagate_torque_free(Vec3(2, 2, 2), s, t);
  const Quat expect =
      s.q * Quat(Eigen::AngleAxisd(s.omega_body.norm() * t, s.omega_body.normalized()));
  EXPECT_NEAR((out.q.coeffs() - expect.coeffs()).norm(), 0.0, 1e-12);
  EXPECT_NEAR((out.omega_body - s.omega_body).norm(), 0.0, 1e-15);
  // The relative rotation angle is |omega| t.
  const Eigen::AngleAxisd rel(s.q.conjugate() * out.q);
  EXPECT_NEAR(rel.angle(), s.omega_body.norm() * t, 1e-12);
}

TEST(TorqueFree, RejectsBadInput) {
  RotationState s;
  s.omega_body = Vec3(1, 0, 0);
  EXPECT_THROW(propagate_torque_free(Vec3(1, 0, 3), s, 1.0), std::invalid_argument);
  EXPECT_THROW(propagate_torque_free(Vec3(1, 2, 3), s, NAN), std::invalid_argument);
  EXPECT_THROW(propagate_torque_free(Vec3(1, 2, 3), s, 1.0, 0.0), std::invalid_argument);
}

TEST(TorqueFree, BackwardUndoesForward) {
  // Asymmetric body (numerical path) and axisymmetric (closed form): propagating by -dt returns
  // to the start; numerical error ~rtol per unit of rotation, 1e-9 bound at rtol 1e-12.
  RotationState s;
  s.q = Quat(Eigen::AngleAxisd(1.1, Vec3(1, -1, 2).normalized()));
  s.omega_body = Vec3(1.0, 0.6, -0.8);
  for (const Vec3& inertia : {Vec3(1, 2, 3), Vec3(2, 2, 3.5)}) {
    const RotationState fwd = propagate_torque_free(inertia, s, 3.0);
    const RotationState back = propagate_torque_free(inertia, fwd, -3.0);
    EXPECT_NEAR((back.omega_body - s.omega_body).norm(), 0.0, 1e-9);
    EXPECT_NEAR(std::abs(back.q.dot(s.q)), 1.0, 1e-15);
    EXPECT_NEAR((back.q.toRotationMatrix() - s.q.toRotationMatrix()).norm(), 0.0, 1e-9);
  }
}

}  // namespace
}  // namespace fragsim::flight
