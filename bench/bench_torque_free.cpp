// Torque-free rotation of asymmetric bodies: cost per call of the exact elliptic-function solution
// (propagate_torque_free, core/flight/torque_free.h) against the DOPRI5 path it replaced
// (propagate_torque_free_numeric at rtol 1e-12), for spins of 10, 1e3 and 1e5 rad/s over 1 s, and
// the largest difference between the two (quaternion up to sign; omega relative to |omega|).
//
//   build/bench/bench_torque_free [bodies]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "core/flight/torque_free.h"
#include "core/flight/trajectory.h"

using namespace fragsim;
using namespace fragsim::flight;

namespace {

struct Case {
  Vec3 inertia;
  RotationState s;
};

volatile double g_sink = 0.0;  // keeps the timed calls from being optimised away

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  const int bodies = argc > 1 ? std::max(1, std::atoi(argv[1])) : 16;
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> g;
  std::vector<Case> cases;
  while (static_cast<int>(cases.size()) < bodies) {
    // Fragment-like moments (1e-5 .. 1e-4 kg m^2), random attitude and spin direction.
    Case c;
    c.inertia = Vec3(1e-5 + 9e-5 * u01(rng), 1e-5 + 9e-5 * u01(rng), 1e-5 + 9e-5 * u01(rng));
    const double a = g(rng), b = g(rng), d = g(rng), e = g(rng);
    c.s.q = Quat(a, b, d, e).normalized();
    const double x = g(rng), y = g(rng), z = g(rng);
    c.s.omega_body = Vec3(x, y, z).normalized();
    if (AsymmetricTorqueFree(c.inertia, c.s).valid()) cases.push_back(c);  // skip fallbacks
  }
  const double dt = 1.0;
  std::printf("# %d asymmetric bodies, dt = %.1f s, DOPRI5 at rtol 1e-12, 1 thread\n", bodies, dt);
  std::printf("%-10s %12s %14s %14s %12s %12s\n", "spin", "rad/call", "analytic_ns", "dopri5_ns",
              "max_dq", "max_dw_rel");
  for (double spin : {10.0, 1e3, 1e5}) {
    // Analytic: repeat to get a stable per-call time.
    const int reps = 20000 / bodies + 1;
    double sink = 0.0;
    std::vector<RotationState> exact(cases.size());
    auto t0 = std::chrono::steady_clock::now();
    for (int r = 0; r < reps; ++r) {
      for (std::size_t i = 0; i < cases.size(); ++i) {
        RotationState s = cases[i].s;
        s.omega_body *= spin;
        exact[i] = propagate_torque_free(cases[i].inertia, s, dt * (1.0 + 1e-9 * r));
        sink += exact[i].q.w();
      }
    }
    const double ns_analytic = 1e9 * seconds_since(t0) / (reps * static_cast<double>(cases.size()));
    // Recompute at exactly dt for the comparison.
    for (std::size_t i = 0; i < cases.size(); ++i) {
      RotationState s = cases[i].s;
      s.omega_body *= spin;
      exact[i] = propagate_torque_free(cases[i].inertia, s, dt);
    }
    // DOPRI5: one pass (its cost grows with the angle; 1e5 rad takes ~0.1 s per call).
    const std::size_t n_num = spin > 1e4 ? std::min<std::size_t>(cases.size(), 4) : cases.size();
    double max_dq = 0.0, max_dw = 0.0;
    t0 = std::chrono::steady_clock::now();
    std::vector<RotationState> num(n_num);
    for (std::size_t i = 0; i < n_num; ++i) {
      RotationState s = cases[i].s;
      s.omega_body *= spin;
      num[i] = propagate_torque_free_numeric(cases[i].inertia, s, dt, 1e-12);
    }
    const double ns_dopri = 1e9 * seconds_since(t0) / static_cast<double>(n_num);
    for (std::size_t i = 0; i < n_num; ++i) {
      const Quat& a = exact[i].q;
      const Quat& b = num[i].q;
      max_dq = std::max(
          max_dq, std::min((a.coeffs() - b.coeffs()).norm(), (a.coeffs() + b.coeffs()).norm()));
      max_dw = std::max(max_dw, (exact[i].omega_body - num[i].omega_body).norm() / spin);
    }
    g_sink = sink;
    std::printf("%-10.0e %12.0f %14.0f %14.0f %12.2e %12.2e\n", spin, spin * dt, ns_analytic,
                ns_dopri, max_dq, max_dw);
  }
  return 0;
}
