#pragma once
// Adaptive Dormand-Prince 5(4) (Dormand & Prince 1980) with FSAL, PI step-size control and
// Hairer's 4th-order continuous extension (Hairer, Norsett & Wanner, Solving ODEs I, II.6),
// header-only, for a fixed-size state.
//
//   Dopri5<6, Rhs> ode(rhs, {.rtol = 1e-6});
//   ode.reset(t0, y0);
//   while (ode.step(t_end)) { ... ode.dense(t) for t in [ode.t_prev(), ode.t()] ... }
//
// `Rhs` is a callable `Vec rhs(double t, const Vec& y)` (any expression convertible to Vec).
// Error norm: RMS over components of err_i / (atol + rtol * max(|y0_i|, |y1_i|)).
// No heap allocation: every vector is a fixed-size Eigen vector held by value.
// The stages live in two sets, the accepted step's and a scratch set for attempts, so that an
// accepted step costs no copies of stages, and the continuous extension's coefficients are built
// on first use (about half the flight steps of a typical run never ask for them: steps above
// everything). Not thread-safe even through const methods (the first dense call builds them).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/flight/lanes.h"

namespace fragsim::flight {

struct Dopri5Options {
  double rtol = 1e-6;
  double atol = 1e-6;  // absolute tolerance, same for all components (scale the state instead)
  double h_max = std::numeric_limits<double>::infinity();
  double h_min = 1e-12;  // step() returns false below this
  int max_rejections_per_step = 60;
};

// Butcher tableau of DOPRI5 (Dormand & Prince 1980; Hairer, Norsett & Wanner 1993, II.5,
// Table 5.2), the 4th-order error weights e = b - b_hat, and the coefficients d of Hairer's
// continuous extension (HNW 1993, II.6, dense output of DOPRI5). The dense-output polynomial
// b_i(theta) built from d below was checked symbolically against all eight order-4 conditions
// (sum b_i = theta, ..., sum b_i a_ij a_jk c_k = theta^4/24) for every theta, and b_i(1) = b_i.
namespace dopri5_tableau {
inline constexpr double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
inline constexpr double a21 = 1.0 / 5;
inline constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
inline constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
inline constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561,
                        a54 = -212.0 / 729;
inline constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247,
                        a64 = 49.0 / 176, a65 = -5103.0 / 18656;
// 5th-order weights (= a7j: the last stage is f at the new point, hence FSAL); b2 = b7 = 0.
inline constexpr double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784,
                        b6 = 11.0 / 84;
// e = b - b_hat (b_hat = 4th-order embedded weights); e2 = 0.
inline constexpr double e1 = 71.0 / 57600, e3 = -71.0 / 16695, e4 = 71.0 / 1920,
                        e5 = -17253.0 / 339200, e6 = 22.0 / 525, e7 = -1.0 / 40;
// Continuous extension; d2 = 0.
inline constexpr double d1 = -12715105075.0 / 11282082432, d3 = 87487479700.0 / 32700410799,
                        d4 = -10690763975.0 / 1880347072, d5 = 701980252875.0 / 199316789632,
                        d6 = -1453857185.0 / 822651844, d7 = 69997945.0 / 29380423;
}  // namespace dopri5_tableau

template <int N, class Rhs>
class Dopri5 {
 public:
  using Vec = Eigen::Matrix<double, N, 1>;

  Dopri5(Rhs rhs, Dopri5Options opt) : rhs_(std::move(rhs)), opt_(opt) {}
  // Not copyable: the stage sets are left uninitialised until the first step (below), and a
  // copy would read indeterminate values.
  Dopri5(const Dopri5&) = delete;
  Dopri5& operator=(const Dopri5&) = delete;

  // Start at (t0, y0). h0 <= 0: initial step chosen automatically (Hairer's algorithm).
  void reset(double t0, const Vec& y0, double h0 = 0.0) {
    t_ = t_prev_ = t0;
    Stages& acc = stages_[acc_];
    acc.y1 = y_prev_ = y0;
    acc.k7 = rhs_(t0, y0);
    ++rhs_evals_;
    h_ = 0.0;
    log_facold_ = kLogErrFloor;
    rejected_last_ = false;
    r2_.setZero();
    r3_.setZero();
    r4_.setZero();
    r5_.setZero();
    dense_ready_ = true;
    h_next_ = h0 > 0.0 ? std::min(h0, opt_.h_max) : initial_step();
  }

  // One attempt's stages k1..k7 and its 5th-order result y1 (k7 = f(t0 + h, y1)).
  // Left uninitialised (zeroing both sets showed in profiles: one integrator per history):
  // reset() sets y1 and k7 of the accepted set, and nothing reads the rest before a step.
  // A lane's attempt (core/flight/lanes.h) writes k1, k7, y1 and dense_sum = sum_i d_i k_i (the
  // continuous extension's r5 / h, summed as build_dense sums it) instead of k2..k6.
  struct Stages {
    Vec k1, k2, k3, k4, k5, k6, k7, y1, dense_sum;
    bool has_dense_sum = false;
  };

  // Take one accepted step, never past t_end. Returns false (state unchanged) when t() >= t_end
  // or the step size underflows h_min.
  bool step(double t_end) {
    if (!(t_ < t_end)) return false;
    Trial trial = first_trial(t_end);
    for (;;) {
      if (!size_trial(trial)) return false;
      // FSAL: dy() = f(t_, y()) is the first stage.
      double err;
      if (!attempt_in_lanes(trial.h, err))
        err = attempt(t_, y(), dy(), trial.h, trial_stages(), true);
      switch (conclude(trial, err)) {
        case Verdict::kAccepted: return true;
        case Verdict::kFailed: return false;
        case Verdict::kRetry: break;
      }
    }
  }

  // The same step in halves, for a caller that computes the attempts itself (the lane kernel,
  // core/flight/lanes.h): `first_trial`, then per attempt `size_trial` (false: no step possible),
  // the attempt from (t(), y(), dy()) over trial.h into trial_stages() (all of k1..k7 and y1
  // with has_dense_sum false, or k1, k7, y1 and dense_sum with has_dense_sum true: the dense
  // output reads one or the other), `count_attempt()`, and `conclude` with its error norm.
  // step() is exactly this loop.
  struct Trial {
    double t_end, h;
    bool last = false;
    int rejections = 0;
  };
  enum class Verdict { kAccepted, kRetry, kFailed };
  Trial first_trial(double t_end) const { return {t_end, std::min(h_next_, opt_.h_max)}; }
  bool size_trial(Trial& trial) const {
    if (!(trial.h >= opt_.h_min)) return false;  // also catches NaN
    // Stretch the last step by up to 1 % rather than leave a sliver before t_end (Hairer).
    trial.last = false;
    if (t_ + 1.01 * trial.h >= trial.t_end) {
      trial.h = trial.t_end - t_;
      trial.last = true;
    }
    return true;
  }
  Stages& trial_stages() { return stages_[1 - acc_]; }
  // A right-hand side with `kLaneState` (TrajectoryIntegrator's, core/flight/lanes.h) posts its
  // attempts to the thread's lane runner when one is set and takes the model; true when it did.
  bool attempt_in_lanes(double h, double& err) {
    if constexpr (requires { Rhs::kLaneState; }) {
      AttemptLanes* lanes = thread_attempt_lanes;
      if (lanes == nullptr) return false;
      Stages& k = trial_stages();
      if (!lanes->attempt(rhs_.model, N, y().data(), dy().data(), h, opt_.rtol, opt_.atol,
                          {k.k1.data(), k.k7.data(), k.y1.data(), k.dense_sum.data()}, err))
        return false;
      k.has_dense_sum = true;
      count_attempt();
      return true;
    } else {
      (void)h;
      (void)err;
      return false;
    }
  }
  void count_attempt() { rhs_evals_ += 6; }
  Verdict conclude(Trial& trial, double err) {
    // PI step-size control (Gustafsson 1991, ACM TOMS 17; in the form of Hairer's DOPRI5 code,
    // whose "beta" damps step-size oscillation): h_new = h / fac with
    // fac = err^(1/5 - 0.75 beta) / err_old^beta / safety, fac limited to [1/facmax, 1/facmin].
    constexpr double kSafety = 0.9, kFacMin = 0.2, kFacMax = 10.0, kBeta = 0.04;
    constexpr double kExpo1 = 0.2 - 0.75 * kBeta;
    const double h = trial.h;
    if (err <= 1.0) {
      // err^expo1 / err_old^beta as one exp of logs (pow twice per step showed in profiles);
      // err = 0 (e.g. a polynomial solution) gives log = -inf, fac = 0, clamped below.
      const double log_err = std::log(err);
      double fac = std::exp(kExpo1 * log_err - kBeta * log_facold_);
      fac = std::clamp(fac / kSafety, 1.0 / kFacMax, 1.0 / kFacMin);
      double h_new = h / fac;
      if (rejected_last_) h_new = std::min(h_new, h);  // no growth right after a rejection
      log_facold_ = std::max(log_err, kLogErrFloor);   // err_old >= 1e-4 as in Hairer's code
      rejected_last_ = false;
      t_prev_ = t_;
      y_prev_ = y();
      t_ = trial.last ? trial.t_end : t_ + h;
      h_ = t_ - t_prev_;
      acc_ = 1 - acc_;  // the attempt's stages (with y1 and k7 = f(t, y1)) are the step's
      dense_ready_ = false;
      h_next_ = h_new;
      ++accepted_;
      return Verdict::kAccepted;
    }
    ++rejected_;
    rejected_last_ = true;
    if (++trial.rejections > opt_.max_rejections_per_step) {
      h_next_ = h;
      return Verdict::kFailed;
    }
    // NaN/Inf error (e.g. the right-hand side blew up): shrink by the largest allowed factor.
    const double fac11 = std::isfinite(err) ? std::pow(err, kExpo1) : 1.0 / kFacMin;
    trial.h = h / std::min(1.0 / kFacMin, fac11 / kSafety);
    return Verdict::kRetry;
  }

  // Retake the last accepted step but end it at t_stop in (t_prev, t]: state becomes the step's
  // result at exactly t_stop (integrated, not interpolated). Used to stop on kinks/events.
  void truncate_last_step(double t_stop) {
    if (!(t_stop > t_prev_ && t_stop <= t_))
      throw std::invalid_argument("Dopri5::truncate_last_step: t_stop " + std::to_string(t_stop) +
                                  " outside (" + std::to_string(t_prev_) + ", " +
                                  std::to_string(t_) + "]");
    if (t_stop == t_) return;
    // The accepted step's first stage is f(t_prev, y_prev).
    attempt(t_prev_, y_prev_, stages_[acc_].k1, t_stop - t_prev_, stages_[1 - acc_], false);
    acc_ = 1 - acc_;
    t_ = t_stop;
    h_ = t_ - t_prev_;
    dense_ready_ = false;
  }

  double t() const { return t_; }
  double t_prev() const { return t_prev_; }
  const Vec& y() const { return stages_[acc_].y1; }
  const Vec& y_prev() const { return y_prev_; }
  const Vec& dy() const { return stages_[acc_].k7; }  // f(t, y) at t()

  // Hairer's continuous extension on [t_prev(), t()], theta = (t - t_prev)/h:
  //   y(theta) = y0 + theta (r2 + (1-theta) (r3 + theta (r4 + (1-theta) r5)))
  // with r2 = y1 - y0, r3 = h k1 - r2, r4 = r2 - h k7 - r3, r5 = h sum d_i k_i (HNW II.6).
  // It matches y0, y1, f0 and f1 at the ends (C1 across steps) and is 4th order inside.
  Vec dense(double t) const {
    if (h_ == 0.0) return y();
    return dense_at_theta((t - t_prev_) / h_);
  }
  // The same at theta in [0, 1] (for callers that locate theta by another component).
  Vec dense_at_theta(double th) const {
    ensure_dense();
    const double th1 = 1.0 - th;
    return y_prev_ + th * (r2_ + th1 * (r3_ + th * (r4_ + th1 * r5_)));
  }
  // Time derivative of dense(t).
  Vec dense_derivative(double t) const {
    if (h_ == 0.0) return dy();
    ensure_dense();
    const double th = (t - t_prev_) / h_, th1 = 1.0 - th;
    return (r2_ + (1.0 - 2.0 * th) * r3_ + th * (2.0 - 3.0 * th) * r4_ +
            (2.0 * th * th1 * (1.0 - 2.0 * th)) * r5_) /
           h_;
  }

  // The continuous extension's coefficients on the last step, for callers that evaluate a few
  // linear functionals of y many times (the event functions of the ground phase): for a row
  // vector c, c.y(theta) = c.y0 + theta (c.r2 + (1-theta) (c.r3 + theta (c.r4 + (1-theta) c.r5))).
  struct DenseCoefficients {
    const Vec &y0, &r2, &r3, &r4, &r5;
    double t0, h;
  };
  DenseCoefficients dense_coefficients() const {
    ensure_dense();
    return {y_prev_, r2_, r3_, r4_, r5_, t_prev_, h_};
  }

  // One DOPRI5 step of size h from (t0, y0) with f0 = f(t0, y0) into `k`: the stages, the
  // 5th-order result k.y1 and k.k7 = f(t0 + h, y1). Returns the scaled error norm when `estimate`
  // is set (else 0). f0 and y0 must not be in `k`.
  // Public for the lane kernel (core/flight/lanes.h), whose tests and benchmark compare every
  // lane with it bit for bit; it changes only the counter of right-hand sides.
  double attempt(double t0, const Vec& y0, const Vec& f0, double h, Stages& k, bool estimate) {
    using namespace dopri5_tableau;
    k.k1 = f0;
    k.has_dense_sum = false;
    k.k2 = rhs_(t0 + c2 * h, y0 + h * (a21 * k.k1));
    k.k3 = rhs_(t0 + c3 * h, y0 + h * (a31 * k.k1 + a32 * k.k2));
    k.k4 = rhs_(t0 + c4 * h, y0 + h * (a41 * k.k1 + a42 * k.k2 + a43 * k.k3));
    k.k5 = rhs_(t0 + c5 * h, y0 + h * (a51 * k.k1 + a52 * k.k2 + a53 * k.k3 + a54 * k.k4));
    k.k6 = rhs_(t0 + h, y0 + h * (a61 * k.k1 + a62 * k.k2 + a63 * k.k3 + a64 * k.k4 + a65 * k.k5));
    k.y1 = y0 + h * (b1 * k.k1 + b3 * k.k3 + b4 * k.k4 + b5 * k.k5 + b6 * k.k6);
    k.k7 = rhs_(t0 + h, k.y1);
    rhs_evals_ += 6;
    if (!estimate) return 0.0;
    const Vec err = h * (e1 * k.k1 + e3 * k.k3 + e4 * k.k4 + e5 * k.k5 + e6 * k.k6 + e7 * k.k7);
    return scaled_rms(err, y0, k.y1);
  }

  // RMS of v_i / (atol + rtol * max(|a_i|, |b_i|)).
  double scaled_rms(const Vec& v, const Vec& a, const Vec& b) const {
    const Vec sc = (opt_.atol + opt_.rtol * a.cwiseAbs().cwiseMax(b.cwiseAbs()).array()).matrix();
    return std::sqrt(v.cwiseQuotient(sc).squaredNorm() / static_cast<double>(N));
  }

  double next_step_size() const { return h_next_; }  // proposal for the next step
  // Counters accumulate over the object's lifetime (reset() does not clear them).
  long rhs_evaluations() const { return rhs_evals_; }
  long steps_accepted() const { return accepted_; }
  long steps_rejected() const { return rejected_; }
  const Rhs& rhs() const { return rhs_; }
  const Dopri5Options& options() const { return opt_; }

 private:
  // Coefficients of the continuous extension for the accepted step [t_prev_, t_], built on the
  // first call after the step (the stages stay until the next accepted step). The test inline,
  // the build out of line (a call for every dense evaluation showed in profiles).
  void ensure_dense() const {
    if (!dense_ready_) build_dense();
  }
  [[gnu::noinline]] void build_dense() const {
    using namespace dopri5_tableau;
    const Stages& k = stages_[acc_];
    r2_ = k.y1 - y_prev_;
    r3_ = h_ * k.k1 - r2_;
    r4_ = r2_ - h_ * k.k7 - r3_;
    if (k.has_dense_sum)
      r5_ = h_ * k.dense_sum;
    else
      r5_ = h_ * (d1 * k.k1 + d3 * k.k3 + d4 * k.k4 + d5 * k.k5 + d6 * k.k6 + d7 * k.k7);
    dense_ready_ = true;
  }

  // Starting step size (HNW 1993, II.4, "Starting step size"): h0 = 0.01 ||y0|| / ||f0||, one
  // explicit Euler step to estimate the second derivative, then h1 = (0.01 / max(||f0||,
  // ||f''||))^(1/5); h = min(100 h0, h1). Norms are the error norm's, so the result is in the
  // same tolerance units as the step control. Costs one evaluation of f.
  double initial_step() {
    const Vec& y0 = y();
    const Vec& f0 = dy();
    const double d0 = scaled_rms(y0, y0, y0);
    const double d1 = scaled_rms(f0, y0, y0);
    double h0 = (d0 < 1e-10 || d1 < 1e-10) ? 1e-6 : 0.01 * d0 / d1;
    h0 = std::min(h0, opt_.h_max);
    const Vec y1 = y0 + h0 * f0;
    const Vec f1 = rhs_(t_ + h0, y1);
    ++rhs_evals_;
    const double d2 = scaled_rms(f1 - f0, y0, y0) / h0;
    const double der = std::max(d1, d2);
    const double h1 = der <= 1e-15 ? std::max(1e-6, h0 * 1e-3) : std::pow(0.01 / der, 0.2);
    return std::min({100.0 * h0, h1, opt_.h_max});
  }

  // Private Members
  Rhs rhs_;
  Dopri5Options opt_;
  double t_ = 0.0, t_prev_ = 0.0;
  double h_ = 0.0;       // size of the last accepted (or truncated) step
  double h_next_ = 0.0;  // controller's proposal
  static constexpr double kLogErrFloor = -9.210340371976182;  // ln(1e-4)
  double log_facold_ = kLogErrFloor;  // ln of the previous accepted error norm
  bool rejected_last_ = false;
  Vec y_prev_ = Vec::Zero();
  // stages_[acc_]: the last accepted (or truncated) step's stages, its y1 = y() and k7 = dy();
  // after reset() only y1 and k7 are set. The other set is the scratch for attempts, so a failed
  // step() leaves the accepted step and its dense output intact.
  Stages stages_[2];
  int acc_ = 0;
  mutable bool dense_ready_ = true;
  mutable Vec r2_, r3_, r4_, r5_;  // set by reset() and ensure_dense()
  long rhs_evals_ = 0, accepted_ = 0, rejected_ = 0;
};

}  // namespace fragsim::flight
