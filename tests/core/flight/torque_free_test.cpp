// Exact asymmetric torque-free motion (torque_free.h): elliptic functions and integrals against
// quadrature and identities, the analytic motion against the DOPRI5 path, invariants, symmetry
// and degenerate cases.
#include "core/flight/torque_free.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

namespace fragsim::flight {
namespace {

// Composite Simpson on [a, b] with n (even) intervals.
template <class F>
double simpson(F f, double a, double b, int n) {
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4.0 : 2.0) * f(a + i * h);
  return s * h / 3.0;
}

double quat_distance(const Quat& a, const Quat& b) {  // up to sign
  return std::min((a.coeffs() - b.coeffs()).norm(), (a.coeffs() + b.coeffs()).norm());
}

double energy(const Vec3& inertia, const Vec3& w) {
  return 0.5 * w.dot(inertia.cwiseProduct(w));
}
Vec3 world_momentum(const Vec3& inertia, const RotationState& s) {
  return s.q * inertia.cwiseProduct(s.omega_body);
}
Vec3 euler_rhs(const Vec3& inertia, const Vec3& w) {
  return -(w.cross(inertia.cwiseProduct(w))).cwiseQuotient(inertia);
}

Quat random_quat(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return Quat(g(rng), g(rng), g(rng), g(rng)).normalized();
}

// --- Elliptic functions --------------------------------------------------------------------

TEST(TorqueFreeElliptic, CarlsonIntegralsMatchQuadrature) {
  // F(phi) and Pi(n; phi) of the Legendre forms by Simpson (smooth integrands, 4000 intervals:
  // error < 1e-14) against the Carlson forms, over m up to 1 - 1e-6 and n < 0: 1e-13 relative.
  for (double mc : {1.0, 0.7, 0.1, 1e-3, 1e-6}) {
    const double m = 1.0 - mc;
    const JacobiElliptic je(m, mc);
    for (double n : {0.0, -0.3, -4.0, -1e3}) {
      for (double phi : {0.3, 1.2, kPi / 2}) {
        const double f_ref =
            simpson([&](double t) { return 1.0 / std::sqrt(1.0 - m * std::sin(t) * std::sin(t)); },
                    0.0, phi, 4000);
        const double pi_ref = simpson(
            [&](double t) {
              const double s2 = std::sin(t) * std::sin(t);
              return 1.0 / ((1.0 - n * s2) * std::sqrt(1.0 - m * s2));
            },
            0.0, phi, 4000);
        if (mc >= 1e-3) {  // Simpson is not converged for the near-log-singular m -> 1 integrand
          EXPECT_NEAR(je.F(phi), f_ref, 1e-13 * f_ref) << mc << " " << phi;
        }
        const double s = std::sin(phi), c = std::cos(phi);
        const double pi_carlson =
            s * carlson_rf(c * c, mc + m * c * c, 1.0) +
            n / 3.0 * s * s * s * carlson_rj(c * c, mc + m * c * c, 1.0, 1.0 - n * s * s);
        if (mc >= 1e-3) {
          EXPECT_NEAR(pi_carlson, pi_ref, 1e-13 * pi_ref) << mc << " " << n << " " << phi;
        }
      }
    }
    // K against libstdc++ (argument k, so 1 - k^2 carries ~1e-16 / mc relative error).
    if (mc >= 0.1) {
      EXPECT_NEAR(je.K(), std::comp_ellint_1(std::sqrt(m)), 1e-14 * je.K());
    }
  }
  // R_J(x, y, z, z) = R_D(x, y, z); R_J(x, x, x, x) = x^-3/2; R_F(x, x, x) = x^-1/2.
  EXPECT_NEAR(carlson_rj(2.0, 2.0, 2.0, 2.0), std::pow(2.0, -1.5), 1e-15);
  EXPECT_NEAR(carlson_rf(3.0, 3.0, 3.0), 1.0 / std::sqrt(3.0), 1e-15);
  // R_J(0, 1, 2, 3) = 0.77688623778582 (Carlson 1995, test values).
  EXPECT_NEAR(carlson_rj(0.0, 1.0, 2.0, 3.0), 0.77688623778582, 1e-13);
  EXPECT_NEAR(carlson_rj(2.0, 3.0, 4.0, 5.0), 0.14297579667157, 1e-13);
  EXPECT_NEAR(carlson_rf(1.0, 2.0, 0.0), 1.3110287771461, 1e-12);
}

TEST(TorqueFreeElliptic, JacobiFunctionsIdentitiesAndInverse) {
  // sn^2 + cn^2 = 1, F(am(u)) = u (am unwrapped), d sn / du = cn dn by central differences,
  // m = 0: sin and cos; periodicity 4K. Tolerances: 1e-14 for identities, 1e-13 |u| for the
  // inverse, 1e-9 for the difference quotient (step 1e-5, error ~h^2).
  for (double mc : {1.0, 0.5, 1e-2, 1e-6}) {
    const double m = 1.0 - mc;
    const JacobiElliptic je(m, mc);
    double am_prev = 0.0;
    for (double u = -25.0; u <= 25.0; u += 0.173) {
      const JacobiSnCnDn f = je(u);
      EXPECT_NEAR(f.sn * f.sn + f.cn * f.cn, 1.0, 1e-15);
      EXPECT_NEAR(f.dn * f.dn + m * f.sn * f.sn, 1.0, 1e-14);
      // Unwrap am(u) = atan2(sn, cn) from the previous sample (am increases by < pi per step).
      double am = std::atan2(f.sn, f.cn);
      if (u > -25.0)
        am += 2.0 * kPi * std::round((am_prev - am) / (2.0 * kPi));
      else
        am = am - 2.0 * kPi * std::round((am - u * kPi / (2.0 * je.K())) / (2.0 * kPi));
      am_prev = am;
      EXPECT_NEAR(je.F(am), u, 1e-13 * std::max(1.0, std::abs(u))) << mc << " " << u;
      const double h = 1e-5;
      const JacobiSnCnDn fp = je(u + h), fm = je(u - h);
      EXPECT_NEAR((fp.sn - fm.sn) / (2 * h), f.cn * f.dn, 1e-9);
      EXPECT_NEAR((fp.cn - fm.cn) / (2 * h), -f.sn * f.dn, 1e-9);
      EXPECT_NEAR((fp.dn - fm.dn) / (2 * h), -m * f.sn * f.cn, 1e-9);
      const JacobiSnCnDn g = je(u + 4.0 * je.K());
      EXPECT_NEAR(g.sn, f.sn, 1e-13);
      EXPECT_NEAR(g.cn, f.cn, 1e-13);
    }
  }
  const JacobiElliptic circ(0.0, 1.0);
  EXPECT_NEAR(circ.K(), kPi / 2, 1e-15);
  for (double u : {-3.0, 0.5, 2.0, 100.0}) {
    EXPECT_NEAR(circ(u).sn, std::sin(u), 1e-14 * std::max(1.0, std::abs(u)));
    EXPECT_NEAR(circ(u).cn, std::cos(u), 1e-14 * std::max(1.0, std::abs(u)));
  }
  EXPECT_THROW(JacobiElliptic(1.0, 0.0), std::invalid_argument);
}

// --- Motion --------------------------------------------------------------------------------

TEST(TorqueFreeAnalytic, SatisfiesEulerEquationsInEveryAxisOrder) {
  // The sign rule for (omega_e, omega_m, omega_c) in each of the 6 axis orders and both signs
  // of omega_c: d omega / dt by central differences (h = 1e-5 s) against Euler's equations,
  // 1e-8. Also omega(0) reproduces the input to 1e-14.
  const double base[3] = {1.0, 1.7, 2.6};
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& p : perms) {
    const Vec3 inertia(base[p[0]], base[p[1]], base[p[2]]);
    for (const Vec3& w0 : {Vec3(0.9, -0.3, 0.5), Vec3(-0.4, 0.8, -0.6), Vec3(0.2, 0.3, -1.1),
                           Vec3(-1.0, -0.2, 0.1)}) {
      RotationState s;
      s.omega_body = w0;
      const AsymmetricTorqueFree sol(inertia, s);
      ASSERT_TRUE(sol.valid());
      EXPECT_NEAR((sol.at(0.0).omega_body - w0).norm(), 0.0, 1e-14);
      for (double t : {0.37, 2.9, -4.1}) {
        const double h = 1e-5;
        const Vec3 w = sol.at(t).omega_body;
        const Vec3 dw = (sol.at(t + h).omega_body - sol.at(t - h).omega_body) / (2 * h);
        EXPECT_NEAR((dw - euler_rhs(inertia, w)).norm(), 0.0, 1e-8)
            << inertia.transpose() << " | " << w0.transpose() << " t " << t;
      }
    }
  }
}

TEST(TorqueFreeAnalytic, MatchesDopriForRandomBodies) {
  // Random inertias (moments in [0.2, 3] kg m^2, any order), attitudes and spins (|omega| 0.5-20
  // rad/s), dt up to ~50 revolutions: analytic vs DOPRI5. The difference is the integrator's own
  // error, ~3e-11 x rtol/1e-12 per radian (it scales with rtol: measured worst 9.8e-9 at rtol
  // 1e-12, 9.8e-11 at 1e-14 over 296 rad): bounds 2e-8 at rtol 1e-12 and 3e-10 at rtol 1e-14
  // on q (up to sign) and on omega / |omega|. Covers both polhode families.
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> g;
  double worst_q = 0.0, worst_w = 0.0, worst_q14 = 0.0, worst_w14 = 0.0;
  int circ_hi = 0, circ_lo = 0, fallback = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 inertia(0.2 + 2.8 * u01(rng), 0.2 + 2.8 * u01(rng), 0.2 + 2.8 * u01(rng));
    RotationState s;
    s.q = random_quat(rng);
    const double spin = 0.5 + 19.5 * u01(rng);
    s.omega_body = Vec3(g(rng), g(rng), g(rng)).normalized() * spin;
    const double dt = u01(rng) * 50.0 * 2.0 * kPi / spin;
    const AsymmetricTorqueFree sol(inertia, s);
    if (!sol.valid()) {
      ++fallback;
      continue;
    }
    // Which family: L^2 > 2 E I_mid circles the largest axis.
    Vec3 sorted = inertia;
    std::sort(sorted.data(), sorted.data() + 3);
    const double l2 = inertia.cwiseProduct(s.omega_body).squaredNorm();
    (l2 > 2.0 * energy(inertia, s.omega_body) * sorted[1] ? circ_hi : circ_lo)++;
    const RotationState a = sol.at(dt);
    const RotationState n = propagate_torque_free_numeric(inertia, s, dt, 1e-12);
    const RotationState n14 = propagate_torque_free_numeric(inertia, s, dt, 1e-14);
    const double dq = quat_distance(a.q, n.q), dw = (a.omega_body - n.omega_body).norm() / spin;
    const double dq14 = quat_distance(a.q, n14.q);
    const double dw14 = (a.omega_body - n14.omega_body).norm() / spin;
    worst_q = std::max(worst_q, dq);
    worst_w = std::max(worst_w, dw);
    worst_q14 = std::max(worst_q14, dq14);
    worst_w14 = std::max(worst_w14, dw14);
    EXPECT_LE(dq, 2e-8) << "trial " << trial << " I " << inertia.transpose() << " w "
                        << s.omega_body.transpose() << " dt " << dt << " k'^2 " << sol.mc();
    EXPECT_LE(dw, 2e-8) << "trial " << trial;
    EXPECT_LE(dq14, 3e-10) << "trial " << trial;
    EXPECT_LE(dw14, 3e-10) << "trial " << trial;
  }
  std::printf(
      "analytic vs DOPRI5 (200 bodies, <= 50 rev): rtol 1e-12: q %.2e  omega %.2e; "
      "rtol 1e-14: q %.2e  omega %.2e  (families: %d around largest, %d around "
      "smallest, %d fallbacks)\n",
      worst_q, worst_w, worst_q14, worst_w14, circ_hi, circ_lo, fallback);
  EXPECT_GT(circ_hi, 20);
  EXPECT_GT(circ_lo, 20);
}

TEST(TorqueFreeAnalytic, ConservesInvariantsOverLongFlights) {
  // 1e5 rad of rotation in one call and in 100 calls: energy and world-frame angular momentum to
  // 1e-12 relative (the analytic flow conserves both identically; what is left is rounding in
  // the amplitudes and in the ~1e5 rad phase angle, ~1e-16 x 1e5).
  const Vec3 inertia(0.011, 0.023, 0.029);
  for (const Vec3& w0 : {Vec3(300.0, -500.0, 1200.0), Vec3(2000.0, 150.0, -400.0)}) {
    RotationState s0;
    s0.q = Quat(Eigen::AngleAxisd(0.4, Vec3(1, 1, 0).normalized()));
    s0.omega_body = w0;
    const double t = 1e5 / w0.norm();
    const double e0 = energy(inertia, w0);
    const Vec3 l0 = world_momentum(inertia, s0);
    RotationState once = propagate_torque_free(inertia, s0, t);
    RotationState steps = s0;
    for (int i = 0; i < 100; ++i) steps = propagate_torque_free(inertia, steps, t / 100);
    for (const RotationState& s : {once, steps}) {
      EXPECT_NEAR(energy(inertia, s.omega_body) / e0, 1.0, 1e-12);
      EXPECT_NEAR((world_momentum(inertia, s) - l0).norm() / l0.norm(), 0.0, 1e-12);
      EXPECT_NEAR(s.q.norm(), 1.0, 1e-15);
    }
    // The two routes agree to the phase rounding: ~1e-16 x 1e5 rad per route.
    const double d = quat_distance(once.q, steps.q);
    std::printf("1e5 rad: |L| drift %.1e  E drift %.1e  one call vs 100 calls %.1e\n",
                (world_momentum(inertia, once) - l0).norm() / l0.norm(),
                std::abs(energy(inertia, once.omega_body) / e0 - 1.0), d);
    EXPECT_LE(d, 1e-9);
  }
}

TEST(TorqueFreeAnalytic, BackwardUndoesForward) {
  // Propagating by dt and then by -dt (from the propagated state, a new solution) returns to the
  // start: 1e-12 over ~300 rad.
  const Vec3 inertia(2.0, 1.0, 3.0);
  RotationState s;
  s.q = Quat(Eigen::AngleAxisd(1.1, Vec3(1, -1, 2).normalized()));
  for (const Vec3& w : {Vec3(1.0, 0.6, -0.8), Vec3(-0.1, 2.0, 0.3)}) {
    s.omega_body = w * 20.0;
    const double dt = 300.0 / s.omega_body.norm();
    const RotationState fwd = propagate_torque_free(inertia, s, dt);
    const RotationState back = propagate_torque_free(inertia, fwd, -dt);
    EXPECT_NEAR((back.omega_body - s.omega_body).norm() / s.omega_body.norm(), 0.0, 1e-12);
    EXPECT_LE(quat_distance(back.q, s.q), 1e-12);
    // And backward first.
    const RotationState b2 = propagate_torque_free(inertia, s, -dt);
    const RotationState f2 = propagate_torque_free(inertia, b2, dt);
    EXPECT_LE(quat_distance(f2.q, s.q), 1e-12);
  }
}

TEST(TorqueFreeAnalytic, PureSpinAboutEachPrincipalAxis) {
  // omega along a principal axis (smallest, intermediate, largest; moments in mixed order):
  // constant omega and q0 (x) Rot(e_i, omega t). 1e-13 over 100 rad.
  const Vec3 inertia(0.3, 0.1, 0.2);
  RotationState s;
  s.q = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  for (int axis = 0; axis < 3; ++axis) {
    for (double w : {5.0, -3.0}) {
      s.omega_body = w * Vec3::Unit(axis);
      const double t = 100.0 / std::abs(w);
      const RotationState out = propagate_torque_free(inertia, s, t);
      const Quat expect = s.q * Quat(Eigen::AngleAxisd(w * t, Vec3::Unit(axis)));
      EXPECT_LE((out.omega_body - s.omega_body).norm(), 1e-13 * std::abs(w)) << axis;
      EXPECT_LE(quat_distance(out.q, expect), 1e-13) << axis << " " << w;
      EXPECT_TRUE(AsymmetricTorqueFree(inertia, s).valid());
    }
  }
}

TEST(TorqueFreeAnalytic, SmallWobbleAndKNearZero) {
  // Spin nearly about the largest or smallest axis with a 1e-3 .. 1e-9 wobble: k -> 0 and the
  // polhode shrinks to a point; analytic vs DOPRI5: 1e-9 over ~60 rad.
  const Vec3 inertia(1.0, 2.0, 3.0);
  RotationState s;
  s.q = Quat(Eigen::AngleAxisd(0.3, Vec3(0, 1, 1).normalized()));
  for (int axis : {0, 2}) {
    for (double eps : {1e-3, 1e-6, 1e-9}) {
      s.omega_body = 6.0 * Vec3::Unit(axis) + eps * Vec3(0.7, -0.5, 0.4);
      const AsymmetricTorqueFree sol(inertia, s);
      ASSERT_TRUE(sol.valid());
      EXPECT_LT(sol.m(), 1e-5);
      const RotationState a = sol.at(10.0);
      const RotationState n = propagate_torque_free_numeric(inertia, s, 10.0);
      EXPECT_LE(quat_distance(a.q, n.q), 1e-9) << axis << " " << eps;
      EXPECT_LE((a.omega_body - n.omega_body).norm(), 1e-9) << axis << " " << eps;
    }
  }
}

TEST(TorqueFreeAnalytic, NearSeparatrixFallsBackAndStaysAccurate) {
  // Spin close to the intermediate axis. 1 - k^2 ~ 1e-7 (inside kTorqueFreeSeparatrixMc): no
  // analytic solution, propagate_torque_free uses DOPRI5 (identical to the numeric path).
  // 1 - k^2 ~ 2e-5 and 2e-3 (outside): analytic, matches DOPRI5 to 1e-8 over 5 polhode periods.
  const Vec3 inertia(1.0, 2.0, 3.0);
  RotationState s;
  s.q = Quat(Eigen::AngleAxisd(0.5, Vec3(1, 0, 1).normalized()));
  s.omega_body = Vec3(3e-4, 3.0, 2e-4);
  const AsymmetricTorqueFree inside(inertia, s);
  EXPECT_FALSE(inside.valid());
  const RotationState p = propagate_torque_free(inertia, s, 7.0);
  const RotationState n = propagate_torque_free_numeric(inertia, s, 7.0, 1e-12);
  EXPECT_EQ(p.q.coeffs(), n.q.coeffs());
  EXPECT_FALSE(propagate_torque_free_analytic(inertia, s, 7.0).has_value());
  for (const Vec3& w : {Vec3(0.01, 3.0, 0.01), Vec3(-0.1, 3.0, -0.1)}) {
    s.omega_body = w;
    const AsymmetricTorqueFree sol(inertia, s);
    ASSERT_TRUE(sol.valid());
    const double t = 5.0 * sol.omega_period_s();
    const RotationState a = sol.at(t);
    const RotationState d = propagate_torque_free_numeric(inertia, s, t, 1e-12);
    std::printf("near separatrix 1 - k^2 = %.1e, %.0f s: q diff %.1e  omega diff %.1e\n", sol.mc(),
                t, quat_distance(a.q, d.q), (a.omega_body - d.omega_body).norm());
    EXPECT_LE(quat_distance(a.q, d.q), 1e-8);
    EXPECT_LE((a.omega_body - d.omega_body).norm(), 1e-8);
  }
}

TEST(TorqueFreeAnalytic, NearlyAxisymmetricMatchesClosedForm) {
  // Two moments 1e-10 apart (relative): the elliptic solution (k -> 0 or lambda -> 0) against the
  // exactly axisymmetric closed form, from which the motion departs by ~1e-10 x rotation angle.
  RotationState s;
  s.q = Quat(Eigen::AngleAxisd(0.9, Vec3(1, -2, 0.5).normalized()));
  s.omega_body = Vec3(1.5, 0.4, 2.0);
  const double t = 7.0;
  for (const auto& [sym, near] : {std::pair{Vec3(1, 1, 2), Vec3(1, 1 + 1e-10, 2)},
                                  std::pair{Vec3(1, 2, 2), Vec3(1, 2, 2 + 2e-10)}}) {
    const RotationState c = propagate_torque_free(sym, s, t);
    const AsymmetricTorqueFree sol(near, s);
    ASSERT_TRUE(sol.valid());
    const RotationState a = sol.at(t);
    EXPECT_LE(quat_distance(a.q, c.q), 1e-8);
    EXPECT_LE((a.omega_body - c.omega_body).norm(), 1e-8);
  }
}

TEST(TorqueFreeAnalytic, FastTumblingCostIndependentOfRevolutions) {
  // ~1e4 rad/s for 10 s (1.6e4 revolutions): the analytic path stays exact (invariants), and the
  // 10 s state equals 1000 steps of 10 ms up to the rounding each restart injects: a relative
  // 1e-16 change of the invariants shifts the phase by 1e-16 x the remaining angle (<= 1e5 rad),
  // a random walk over 1000 restarts of ~sqrt(1000) x 5e-12 = 2e-10 (measured 1.6e-10): 1e-9.
  const Vec3 inertia(4e-5, 7e-5, 9e-5);
  RotationState s0;
  s0.q = Quat(Eigen::AngleAxisd(2.0, Vec3(0.2, 1, 0.1).normalized()));
  s0.omega_body = Vec3(6000.0, -5000.0, 5500.0);
  const RotationState once = propagate_torque_free(inertia, s0, 10.0);
  RotationState steps = s0;
  for (int i = 0; i < 1000; ++i) steps = propagate_torque_free(inertia, steps, 0.01);
  EXPECT_LE(quat_distance(once.q, steps.q), 1e-9);
  EXPECT_LE((once.omega_body - steps.omega_body).norm() / s0.omega_body.norm(), 1e-9);
  EXPECT_NEAR(energy(inertia, once.omega_body) / energy(inertia, s0.omega_body), 1.0, 1e-12);
}

TEST(TorqueFreeAnalytic, TinyAndZeroSpinsAndBadInput) {
  const Vec3 inertia(1.0, 2.0, 3.0);
  RotationState s;
  s.q = Quat(Eigen::AngleAxisd(0.4, Vec3(1, 0, 0)));
  // Scale invariance: omega 1e-150 for 1e150 s is the motion of omega 1 for 1 s.
  s.omega_body = Vec3(0.8, -0.5, 1.1);
  const RotationState ref = propagate_torque_free(inertia, s, 1.0);
  RotationState tiny = s;
  tiny.omega_body *= 1e-150;
  const RotationState got = propagate_torque_free(inertia, tiny, 1e150);
  EXPECT_LE(quat_distance(got.q, ref.q), 1e-13);
  EXPECT_LE((got.omega_body * 1e150 - ref.omega_body).norm(), 1e-13);
  // The analytic solution itself also takes 1e-200 (its squares would underflow).
  tiny.omega_body = s.omega_body * 1e-200;
  const RotationState got200 = AsymmetricTorqueFree(inertia, tiny).at(1e200);
  EXPECT_LE(quat_distance(got200.q, ref.q), 1e-13);
  EXPECT_LE((got200.omega_body * 1e200 - ref.omega_body).norm(), 1e-13);
  // Zero spin, zero time.
  s.omega_body = Vec3::Zero();
  EXPECT_LE(quat_distance(propagate_torque_free_analytic(inertia, s, 3.0)->q, s.q), 1e-15);
  // Non-finite input.
  s.omega_body = Vec3(1, NAN, 0);
  EXPECT_THROW(propagate_torque_free_analytic(inertia, s, 1.0), std::invalid_argument);
  EXPECT_THROW(propagate_torque_free(inertia, s, 1.0), std::invalid_argument);
  s.omega_body = Vec3(1, 0, 0);
  EXPECT_THROW(propagate_torque_free_analytic(inertia, s, INFINITY), std::invalid_argument);
  EXPECT_THROW(propagate_torque_free_analytic(Vec3(1, -2, 3), s, 1.0), std::invalid_argument);
  // Equal moments: not this solver's case.
  s.omega_body = Vec3(1, 2, 3);
  EXPECT_FALSE(AsymmetricTorqueFree(Vec3(1, 1, 3), s).valid());
}

}  // namespace
}  // namespace fragsim::flight
