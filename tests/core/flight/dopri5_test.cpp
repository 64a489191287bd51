// Unit tests of the DOPRI5 integrator on ODEs with known solutions.
#include "core/flight/dopri5.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

namespace fragsim::flight {
namespace {

using V1 = Eigen::Matrix<double, 1, 1>;
using V2 = Eigen::Matrix<double, 2, 1>;

// y' = y, y(0) = 1: y = e^t.
struct Exponential {
  V1 operator()(double, const V1& y) const { return y; }
};
// y' = -2 t y^2, y(0) = 1: y = 1 / (1 + t^2). Nonlinear and non-autonomous.
struct Rational {
  V1 operator()(double t, const V1& y) const { return V1(-2.0 * t * y[0] * y[0]); }
};
double rational_exact(double t) {
  return 1.0 / (1.0 + t * t);
}
// Harmonic oscillator x'' = -x: (x, v) = (cos t, -sin t) from (1, 0).
struct Oscillator {
  V2 operator()(double, const V2& y) const { return V2(y[1], -y[0]); }
};
// y' = y^2, y(0) = 1: blows up at t = 1.
struct BlowUp {
  V1 operator()(double, const V1& y) const { return V1(y[0] * y[0]); }
};

template <int N, class Rhs>
void run_to(Dopri5<N, Rhs>& ode, double t_end) {
  while (ode.step(t_end)) {
  }
}

TEST(Dopri5, ExponentialGlobalErrorNearTolerance) {
  // For this non-stiff scalar problem the global error of DOPRI5 with local extrapolation is a
  // small multiple of rtol (error per step ~ rtol |y|, errors growing like e^t over one unit):
  // bound 10 rtol leaves room for that growth but fails if the step control or weights are off.
  for (double rtol : {1e-6, 1e-9}) {
    Dopri5<1, Exponential> ode(Exponential{}, {.rtol = rtol, .atol = rtol});
    ode.reset(0.0, V1(1.0));
    run_to(ode, 1.0);
    EXPECT_EQ(ode.t(), 1.0);
    const double rel = std::abs(ode.y()[0] - std::exp(1.0)) / std::exp(1.0);
    std::printf("exp: rtol %.0e  rel err %.2e  steps %ld  rejected %ld\n", rtol, rel,
                ode.steps_accepted(), ode.steps_rejected());
    EXPECT_LT(rel, 10.0 * rtol);
  }
}

TEST(Dopri5, ErrorShrinksWithTolerance) {
  // Oscillator over 10 periods; the global error must fall by at least 10x for each 100x in
  // rtol (tolerance proportionality; DOPRI5 typically gives ~50-100x).
  double prev = 1.0;
  for (double rtol : {1e-4, 1e-6, 1e-8, 1e-10}) {
    Dopri5<2, Oscillator> ode(Oscillator{}, {.rtol = rtol, .atol = rtol});
    ode.reset(0.0, V2(1.0, 0.0));
    const double t_end = 20.0 * std::numbers::pi;
    run_to(ode, t_end);
    const double err = (ode.y() - V2(std::cos(t_end), -std::sin(t_end))).norm();
    std::printf("oscillator: rtol %.0e  err %.2e  steps %ld\n", rtol, err, ode.steps_accepted());
    EXPECT_LT(err, prev / 10.0);
    prev = err;
  }
}

// Fixed step h: tolerance so loose that every step is accepted, h_max = h0 = h.
template <class Rhs, class Exact>
double fixed_step_error(double h, double t_end, double y0, const Exact& exact) {
  Dopri5<1, Rhs> ode(Rhs{}, {.rtol = 1e10, .atol = 1e10, .h_max = h});
  ode.reset(0.0, V1(y0), h);
  run_to(ode, t_end);
  EXPECT_EQ(ode.steps_rejected(), 0);
  return std::abs(ode.y()[0] - exact(t_end));
}

TEST(Dopri5, FifthOrderConvergenceAtFixedStep) {
  // Global error ~ C h^5: halving h divides it by ~32. Measured orders at h = 0.05, 0.025,
  // 0.0125 are 5.31 and 5.17 (approaching 5 from above); bound 5 +- 0.4. A wrong coefficient
  // drops the order to 4 or less. (At h = 0.1 higher terms still weigh: 5.53.)
  const double e1 = fixed_step_error<Rational>(0.05, 2.0, 1.0, rational_exact);
  const double e2 = fixed_step_error<Rational>(0.025, 2.0, 1.0, rational_exact);
  const double e3 = fixed_step_error<Rational>(0.0125, 2.0, 1.0, rational_exact);
  const double order1 = std::log2(e1 / e2), order2 = std::log2(e2 / e3);
  std::printf("fixed-step errors %.3e %.3e %.3e  orders %.3f %.3f\n", e1, e2, e3, order1, order2);
  EXPECT_NEAR(order1, 5.0, 0.4);
  EXPECT_NEAR(order2, 5.0, 0.4);
}

// One step of size h from the exact value at t0; dense-output error at t0 + theta h.
double dense_error_one_step(double t0, double h, double theta) {
  Dopri5<1, Rational> ode(Rational{}, {.rtol = 1e10, .atol = 1e10, .h_max = h});
  ode.reset(t0, V1(rational_exact(t0)), h);
  EXPECT_TRUE(ode.step(t0 + h));
  const double t = t0 + theta * h;
  return std::abs(ode.dense(t)[0] - rational_exact(t));
}

TEST(Dopri5, DenseOutputIsFourthOrder) {
  // Hairer's continuous extension is of order 4: its local error inside the step is C h^5, so
  // halving h divides it by ~32. Measured orders at h = 0.025, 0.0125, 0.00625 are 4.87-4.96
  // (errors 5e-11 down to 1e-14); bound 5 +- 0.3. A 3rd-order interpolant (e.g. cubic Hermite
  // on end values and slopes, or a wrong d_i) gives 4. At h = 0.1 the order at theta = 0.5 is
  // still pre-asymptotic (3.96), hence the small steps.
  for (double theta : {0.3, 0.5, 0.8}) {
    const double e1 = dense_error_one_step(0.4, 0.025, theta);
    const double e2 = dense_error_one_step(0.4, 0.0125, theta);
    const double e3 = dense_error_one_step(0.4, 0.00625, theta);
    const double o1 = std::log2(e1 / e2), o2 = std::log2(e2 / e3);
    std::printf("dense theta %.1f: errors %.3e %.3e %.3e  orders %.3f %.3f\n", theta, e1, e2, e3,
                o1, o2);
    EXPECT_NEAR(o1, 5.0, 0.3);
    EXPECT_NEAR(o2, 5.0, 0.3);
  }
}

TEST(Dopri5, DenseOutputMatchesEndsAndSlopes) {
  Dopri5<2, Oscillator> ode(Oscillator{}, {.rtol = 1e-6, .atol = 1e-6});
  ode.reset(0.0, V2(1.0, 0.0));
  ASSERT_TRUE(ode.step(10.0));
  ASSERT_TRUE(ode.step(10.0));
  const double t0 = ode.t_prev(), t1 = ode.t();
  // Values: interpolation of both ends up to rounding in y0 + (y1 - y0) (1e-15 on O(1) values).
  EXPECT_NEAR((ode.dense(t0) - ode.y_prev()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((ode.dense(t1) - ode.y()).norm(), 0.0, 1e-15);
  // Slopes: f at both ends (C1 across steps); rounding of (r2 +- h f)/h, 1e-12 on O(1).
  const V2 f0 = Oscillator{}(t0, ode.y_prev());
  EXPECT_NEAR((ode.dense_derivative(t0) - f0).norm(), 0.0, 1e-12);
  EXPECT_NEAR((ode.dense_derivative(t1) - ode.dy()).norm(), 0.0, 1e-12);
  // Interior derivative against a central difference of dense() (difference error ~h^2 f''' and
  // rounding 1e-16/1e-6: 1e-8 bound).
  const double tm = 0.5 * (t0 + t1), d = 1e-6;
  const V2 fd = (ode.dense(tm + d) - ode.dense(tm - d)) / (2.0 * d);
  EXPECT_NEAR((ode.dense_derivative(tm) - fd).norm(), 0.0, 1e-8);
}

TEST(Dopri5, DenseOutputAccurateOverAdaptiveRun) {
  // Over an adaptive run at rtol 1e-8 the interpolant stays within the same order as the step
  // values' global error (here < 1e-7 on unit amplitude; a broken interpolant errs by 1e-4+).
  Dopri5<2, Oscillator> ode(Oscillator{}, {.rtol = 1e-8, .atol = 1e-8});
  ode.reset(0.0, V2(1.0, 0.0));
  double worst = 0.0;
  while (ode.step(10.0)) {
    for (int i = 1; i < 10; ++i) {
      const double t = ode.t_prev() + (ode.t() - ode.t_prev()) * i / 10.0;
      worst = std::max(worst, (ode.dense(t) - V2(std::cos(t), -std::sin(t))).norm());
    }
  }
  std::printf("dense max error over run at rtol 1e-8: %.2e\n", worst);
  EXPECT_LT(worst, 1e-7);
}

TEST(Dopri5, StopsExactlyAtEndAndCountsEvaluations) {
  Dopri5<1, Exponential> ode(Exponential{}, {.rtol = 1e-7, .atol = 1e-7});
  ode.reset(0.0, V1(1.0));
  int steps = 0;
  while (ode.step(2.5)) {
    ++steps;
    EXPECT_LE(ode.t(), 2.5);
    EXPECT_GT(ode.t(), ode.t_prev());
  }
  EXPECT_EQ(ode.t(), 2.5);
  EXPECT_FALSE(ode.step(2.5));
  EXPECT_FALSE(ode.step(1.0));  // behind us: no step
  EXPECT_EQ(steps, ode.steps_accepted());
  // FSAL: 1 at reset + 1 for the initial-step guess + 6 per attempted step.
  EXPECT_EQ(ode.rhs_evaluations(), 2 + 6 * (ode.steps_accepted() + ode.steps_rejected()));
}

TEST(Dopri5, AutomaticInitialStepIsAccepted) {
  // Hairer's starting-step estimate targets an error well below tolerance: the first step must
  // be accepted at once and be neither tiny nor the whole interval.
  for (double rtol : {1e-3, 1e-6, 1e-10}) {
    Dopri5<2, Oscillator> ode(Oscillator{}, {.rtol = rtol, .atol = rtol});
    ode.reset(0.0, V2(1.0, 0.0));
    ASSERT_TRUE(ode.step(100.0));
    EXPECT_EQ(ode.steps_rejected(), 0) << "rtol " << rtol;
    EXPECT_GT(ode.t(), 1e-4);
    EXPECT_LT(ode.t(), 1.0);
  }
}

TEST(Dopri5, TruncateLastStepEqualsShorterStep) {
  Dopri5<1, Rational> ode(Rational{}, {.rtol = 1e-6, .atol = 1e-6});
  ode.reset(0.0, V1(1.0));
  // Step until the steps are full-sized (the first ones are ~1e-4 s, where interpolated and
  // integrated values coincide and the test could not tell them apart).
  do {
    ASSERT_TRUE(ode.step(5.0));
  } while (ode.t() - ode.t_prev() < 0.1);
  const double t0 = ode.t_prev(), t1 = ode.t();
  const V1 y0 = ode.y_prev();
  const double t_stop = t0 + 0.37 * (t1 - t0);
  // The interpolant of the full step differs from a real shorter step by ~rtol (measured
  // 9.2e-7 here); truncation must integrate, not interpolate.
  const double interpolated = ode.dense(t_stop)[0];
  const long evals = ode.rhs_evaluations();
  ode.truncate_last_step(t_stop);
  EXPECT_EQ(ode.t(), t_stop);
  EXPECT_EQ(ode.t_prev(), t0);
  EXPECT_EQ(ode.rhs_evaluations(), evals + 6);  // stages 2..7 retaken, k1 reused

  // Same as one step of that size from the same start (same arithmetic up to t0 + h rounding).
  Dopri5<1, Rational> ref(Rational{}, {.rtol = 1e10, .atol = 1e10, .h_max = t_stop - t0});
  ref.reset(t0, y0, t_stop - t0);
  ASSERT_TRUE(ref.step(t_stop));
  EXPECT_NEAR(ode.y()[0], ref.y()[0], 1e-15);
  EXPECT_GT(std::abs(ode.y()[0] - interpolated), 1e-12);
  EXPECT_NEAR(ode.dy()[0], Rational{}(t_stop, ode.y())[0], 1e-15);
  // Dense output now spans the truncated step, and is accurate there (rtol-level).
  EXPECT_NEAR(ode.dense(t_stop)[0], ode.y()[0], 1e-15);
  const double tm = 0.5 * (t0 + t_stop);
  EXPECT_NEAR(ode.dense(tm)[0], rational_exact(tm), 1e-6);

  // Out of range throws; t_stop == t() is a no-op.
  EXPECT_THROW(ode.truncate_last_step(t0), std::invalid_argument);
  EXPECT_THROW(ode.truncate_last_step(t_stop + 1.0), std::invalid_argument);
  ode.truncate_last_step(t_stop);
  EXPECT_EQ(ode.t(), t_stop);

  // Integration continues correctly from the truncated state (global error ~rtol).
  run_to(ode, 5.0);
  EXPECT_NEAR(ode.y()[0], rational_exact(5.0), 1e-6);
}

TEST(Dopri5, GivesUpOnBlowUp) {
  // y' = y^2 from 1 blows up at t = 1: the step size collapses below h_min and step() returns
  // false before t = 1 instead of looping or stepping past the singularity.
  Dopri5<1, BlowUp> ode(BlowUp{}, {.rtol = 1e-8, .atol = 1e-8, .h_min = 1e-10});
  ode.reset(0.0, V1(1.0));
  long n = 0;
  while (ode.step(2.0) && n < 100000) ++n;
  EXPECT_LT(n, 100000);
  EXPECT_LT(ode.t(), 1.0);
  EXPECT_GT(ode.t(), 0.999);
}

}  // namespace
}  // namespace fragsim::flight
