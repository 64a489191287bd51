// Experiment toward fewer right-hand sides per flight (issue 27; docs/benchmarks.md §1): the
// same DOPRI5 on the same drag flight with time t or path length s as the independent variable.
// In s the state is (p, v, t) with p' = v/|v|, v' = a/|v|, t' = 1/|v|: the drag-dominated start
// of a fast fragment, v(t) = v0 / (1 + k v0 t) in t, is v0 e^(-k s) in s, an exponential without
// the pole-like decay, and needs fewer and larger steps. This prints the work (right-hand sides
// to landing) and the landing-range error against a rtol 1e-12 run in t, for the bare DOPRI5 in t
// and in s, and for the run's TrajectoryIntegrator (s while drag >= g, then t; docs/physics.md).
// The fragment is illustrative of the demo's main group: a 0.03 kg steel plate, Cd 1.2, 1e-3 m²
// presented area, 750 m/s, ISA, launched 1.5 m above flat ground (the ground at z = 0).
//
//   build/bench/bench_arc_length
#include <cmath>
#include <cstdio>
#include <numbers>

#include "core/flight/dopri5.h"
#include "core/flight/flight_model.h"
#include "core/flight/trajectory.h"

using namespace fragsim;
using namespace fragsim::flight;

namespace {

struct Landing {
  double x_m = 0.0;
  long rhs = 0;
};

// Steps until z <= 0, then bisects the dense output for the crossing; x there.
template <class Ode>
Landing land(Ode& ode) {
  while (ode.step(1e9))
    if (ode.y()[2] <= 0) break;
  double a = ode.t_prev(), b = ode.t();
  for (int k = 0; k < 200; ++k) {
    const double c = 0.5 * (a + b);
    (ode.dense(c)[2] > 0 ? a : b) = c;
  }
  return {ode.dense(0.5 * (a + b))[0], ode.rhs_evaluations()};
}

// The same landing with the run's integrator (time from the state, dense output by time).
Landing land(TrajectoryIntegrator& ti) {
  while (ti.step(1e9))
    if (ti.position().z() <= 0) break;
  double a = ti.t_prev(), b = ti.t();
  for (int k = 0; k < 200; ++k) {
    const double c = 0.5 * (a + b);
    (ti.position(c).z() > 0 ? a : b) = c;
  }
  return {ti.position(0.5 * (a + b)).x(), ti.rhs_evaluations()};
}

}  // namespace

int main() {
  AtmosphereSpec as;
  as.model = AtmosphereSpec::Model::kIsa;
  const Atmosphere atm(as);
  fragments::CdSpec cs;
  cs.constant = 1.2;
  const DragCoefficient cd(cs);
  FlightModel m;
  m.atmosphere = &atm;
  m.cd = &cd;
  m.mass_kg = 0.03;
  m.area_m2 = 1.0e-3;
  using V6 = Eigen::Matrix<double, 6, 1>;
  using V7 = Eigen::Matrix<double, 7, 1>;
  const auto in_t = [&](double, const V6& y) {
    V6 d;
    d.head<3>() = y.tail<3>();
    d.tail<3>() = m.acceleration(y.head<3>(), y.tail<3>());
    return d;
  };
  const auto in_s = [&](double, const V7& y) {
    const Vec3 v = y.segment<3>(3);
    const double speed = v.norm();
    V7 d;
    d.head<3>() = v / speed;
    d.segment<3>(3) = m.acceleration(y.head<3>(), v) / speed;
    d[6] = 1.0 / speed;
    return d;
  };
  std::printf(
      "elevation  rtol   | variable t: rhs  range error m | variable s: rhs  range error m | "
      "TrajectoryIntegrator: rhs  range error m\n");
  for (const double elev_deg : {2.0, 10.0, 30.0}) {
    const double e = elev_deg * std::numbers::pi / 180.0, v0 = 750.0;
    V6 y0;
    y0 << 0, 0, 1.5, v0 * std::cos(e), 0, v0 * std::sin(e);
    V7 z0;
    z0 << y0, 0.0;
    Dopri5Options tight;
    tight.rtol = tight.atol = 1e-12;
    Dopri5<6, decltype(in_t)> ref(in_t, tight);
    ref.reset(0, y0);
    const double x_ref = land(ref).x_m;
    for (const double rtol : {1e-4, 1e-5, 1e-6, 1e-7}) {
      Dopri5Options o;
      o.rtol = o.atol = rtol;
      Dopri5<6, decltype(in_t)> a(in_t, o);
      a.reset(0, y0);
      Dopri5<7, decltype(in_s)> b(in_s, o);
      b.reset(0, z0);
      TrajectoryIntegrator c(m, rtol);
      c.reset(0, y0.head<3>(), y0.tail<3>());
      const Landing la = land(a), lb = land(b), lc = land(c);
      std::printf("%5.1f deg  %.0e | %14ld  %13.2e | %14ld  %13.2e | %24ld  %13.2e\n", elev_deg,
                  rtol, la.rhs, std::abs(la.x_m - x_ref), lb.rhs, std::abs(lb.x_m - x_ref), lc.rhs,
                  std::abs(lc.x_m - x_ref));
    }
  }
}
