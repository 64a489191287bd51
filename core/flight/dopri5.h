#pragma once
// Adaptive Dormand-Prince 5(4) (Dormand & Prince 1980) with FSAL, PI step-size control and
// Hairer's 4th-order continuous extension (Hairer, Norsett & Wanner, Solving ODEs I, II.6),
// header-only, for a fixed-size state.
//
//   Dopri5<6, Rhs> ode(rhs, {.rtol = 1e-6});
//   ode.reset(t0, y0);
//   while (ode.step(t_end)) { ... ode.dense(t) for t in [ode.t_prev(), ode.t()] ... }
//
// Error norm: RMS over components of err_i / (atol_i + rtol * max(|y0_i|, |y1_i|)).
#include <Eigen/Core>
#include <cmath>
#include <limits>

namespace fragsim::flight {

struct Dopri5Options {
  double rtol = 1e-6;
  double atol = 1e-6;  // absolute tolerance, same for all components unless atol_vec is set
  double h_max = std::numeric_limits<double>::infinity();
  double h_min = 1e-12;  // step() returns false below this
  int max_rejections_per_step = 60;
};

template <int N, class Rhs>
class Dopri5 {
 public:
  using Vec = Eigen::Matrix<double, N, 1>;
  Dopri5(Rhs rhs, Dopri5Options opt);
  // Start at (t0, y0). h0 <= 0: initial step chosen automatically (Hairer's algorithm).
  void reset(double t0, const Vec& y0, double h0 = 0.0);
  // Take one accepted step, never past t_end. Returns false (state unchanged) when t() >= t_end
  // or the step size underflows h_min.
  bool step(double t_end);
  // Retake the last accepted step but end it at t_stop in (t_prev, t]: state becomes the step's
  // result at exactly t_stop (integrated, not interpolated). Used to stop on kinks/events.
  void truncate_last_step(double t_stop);

  double t() const;
  double t_prev() const;
  const Vec& y() const;
  const Vec& y_prev() const;
  const Vec& dy() const;          // f(t, y) at t()
  Vec dense(double t) const;      // valid on [t_prev(), t()]
  double next_step_size() const;  // proposal for the next step
  long rhs_evaluations() const;
  long steps_accepted() const;
  long steps_rejected() const;
  // ... implementation-defined private members ...
};

}  // namespace fragsim::flight
