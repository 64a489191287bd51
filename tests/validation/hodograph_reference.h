#pragma once
// Reference solution of planar point-mass flight with quadratic drag (constant g, rho, Cd; no
// wind) from the hodograph integrals (docs/physics.md, "Reference formulas"). With p = tan of
// the flight-path angle and u the horizontal speed, the equations of motion reduce exactly to
//   1/u^2 = 1/u0^2 + (k/g) (G(p0) - G(p)),   G(p) = p sqrt(1 + p^2) + asinh p,
//   dt = -u dp / g,   dx = -u^2 dp / g,   dz = -p u^2 dp / g,
// p falling monotonically from p0 = tan(elevation) at launch. The time, range and height are
// integrals in p, evaluated here by adaptive Gauss-Legendre quadrature to ~1e-15 relative, so
// the reference is exact to near double precision and independent of any ODE integrator.
// Header-only so that tests and benchmarks share it.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace fragsim::validation {

// Gauss-Legendre rule with kPoints nodes on [-1, 1]; nodes from Newton's method on the
// Legendre recurrence (accurate to a few ulp), so no tabulated constants are needed.
class GaussLegendreRule {
 public:
  static constexpr int kPoints = 20;

  GaussLegendreRule() {
    const double pi = std::acos(-1.0);
    for (int i = 0; i < kPoints; ++i) {
      // Tricomi's initial guess for the i-th root, then Newton.
      double x = std::cos(pi * (i + 0.75) / (kPoints + 0.5));
      double dp = 0.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = x;  // P_0, P_1
        for (int n = 2; n <= kPoints; ++n) {
          const double p2 = ((2.0 * n - 1.0) * x * p1 - (n - 1.0) * p0) / n;
          p0 = p1;
          p1 = p2;
        }
        dp = kPoints * (x * p1 - p0) / (x * x - 1.0);  // P_n'(x)
        const double dx = p1 / dp;
        x -= dx;
        if (std::abs(dx) <= 1e-17) break;
      }
      nodes_[i] = x;
      weights_[i] = 2.0 / ((1.0 - x * x) * dp * dp);
    }
  }

  template <class F>
  double apply(const F& f, double a, double b) const {
    const double mid = 0.5 * (a + b), half = 0.5 * (b - a);
    double sum = 0.0;
    for (int i = 0; i < kPoints; ++i) sum += weights_[i] * f(mid + half * nodes_[i]);
    return half * sum;
  }

 private:
  std::array<double, kPoints> nodes_{}, weights_{};
};

// Adaptive bisection: accept the two-halves sum when it agrees with the one-interval value to
// `tol` (absolute, split between halves) or to a few ulp of the value itself.
template <class F>
double adaptive_quadrature(const GaussLegendreRule& rule, const F& f, double a, double b,
                           double whole, double tol, int depth) {
  const double m = 0.5 * (a + b);
  const double left = rule.apply(f, a, m), right = rule.apply(f, m, b);
  const double sum = left + right;
  const double floor =
      8.0 * std::numeric_limits<double>::epsilon() * (std::abs(left) + std::abs(right));
  if (std::abs(sum - whole) <= std::max(tol, floor) || depth >= 40) return sum;
  return adaptive_quadrature(rule, f, a, m, left, 0.5 * tol, depth + 1) +
         adaptive_quadrature(rule, f, m, b, right, 0.5 * tol, depth + 1);
}

template <class F>
double integrate(const F& f, double a, double b, double rel_tol = 1e-15) {
  static const GaussLegendreRule rule;
  if (a == b) return 0.0;
  const double whole = rule.apply(f, a, b);
  return adaptive_quadrature(rule, f, a, b, whole, rel_tol * std::abs(whole), 0);
}

struct HodographPoint {
  double p;       // tan(flight-path angle)
  double t_s;     // time since launch
  double x_m;     // horizontal distance
  double z_m;     // height above launch
  double vx_mps;  // horizontal velocity u
  double vz_mps;  // vertical velocity p u
};

class HodographReference {
 public:
  // Launch from the origin at speed v0 and elevation in (0, pi/2); drag constant k = rho Cd A /
  // (2 m) in 1/m; gravity g.
  HodographReference(double v0_mps, double elevation_rad, double k_per_m, double g_mps2)
      : k_(k_per_m), g_(g_mps2) {
    if (!(elevation_rad > 0.0 && elevation_rad < 0.5 * std::acos(-1.0)) || !(v0_mps > 0.0) ||
        !(k_per_m >= 0.0) || !(g_mps2 > 0.0))
      throw std::invalid_argument(
          "HodographReference: need 0 < elevation < pi/2, v0, g > 0, k >= 0");
    u0_ = v0_mps * std::cos(elevation_rad);
    p0_ = std::tan(elevation_rad);
    g_p0_ = big_g(p0_);
  }

  static double big_g(double p) { return p * std::sqrt(1.0 + p * p) + std::asinh(p); }

  // Horizontal speed at slope p (p <= p0).
  double u(double p) const {
    return 1.0 / std::sqrt(1.0 / (u0_ * u0_) + k_ / g_ * (g_p0_ - big_g(p)));
  }

  // State at slope p <= p0 (integrals from p to p0).
  HodographPoint at(double p) const {
    HodographPoint s{};
    s.p = p;
    s.t_s = integrate([this](double q) { return u(q) / g_; }, p, p0_);
    s.x_m = integrate(
        [this](double q) {
          const double uq = u(q);
          return uq * uq / g_;
        },
        p, p0_);
    s.z_m = height(p);
    s.vx_mps = u(p);
    s.vz_mps = p * s.vx_mps;
    return s;
  }

  HodographPoint apex() const { return at(0.0); }

  // The descending point where z returns to 0 (launch level).
  HodographPoint landing() const {
    const double z_apex = height(0.0);
    // Descending branch: z(p) = z_apex + int_p^0 q u^2/g dq, increasing in p; dz/dp = -p u^2/g.
    auto z_of = [&](double p) {
      return z_apex + integrate(
                          [this](double q) {
                            const double uq = u(q);
                            return q * uq * uq / g_;
                          },
                          p, 0.0);
    };
    double hi = 0.0, lo = -p0_;  // vacuum lands at -p0, drag steeper
    while (z_of(lo) > 0.0) {
      hi = lo;
      lo *= 2.0;
      if (lo < -1e8) throw std::runtime_error("HodographReference: landing slope not bracketed");
    }
    double p = 0.5 * (lo + hi);
    for (int it = 0; it < 200; ++it) {
      const double z = z_of(p);
      if (z == 0.0) break;
      if (z > 0.0)
        hi = p;
      else
        lo = p;
      const double up = u(p);
      double p_next = p - z / (-p * up * up / g_);
      if (!(p_next > lo && p_next < hi)) p_next = 0.5 * (lo + hi);
      const bool done =
          std::abs(p_next - p) <= 4.0 * std::numeric_limits<double>::epsilon() * std::abs(p);
      p = p_next;
      if (done) break;
    }
    return at(p);
  }

  double u0() const { return u0_; }
  double p0() const { return p0_; }

 private:
  double height(double p) const {
    return integrate(
        [this](double q) {
          const double uq = u(q);
          return q * uq * uq / g_;
        },
        p, p0_);
  }

  double k_, g_, u0_ = 0.0, p0_ = 0.0, g_p0_ = 0.0;
};

}  // namespace fragsim::validation
