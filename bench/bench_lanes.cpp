// SIMD over histories, the attempt alone: how much faster one DOPRI5 attempt per lane runs in the
// lane kernel (core/flight/lanes.h, 4 lanes, AVX2 and SSE2 builds) than the scalar
// Dopri5::attempt, on attempts recorded from demo-like flights (illustrative fragments shaped
// like the demo's three groups, ISA air, flat ground at z = 0: see make_fragments), in path
// length and in time. Every kernel result is compared with the scalar one bit for bit.
//   build/bench/bench_lanes [fragments]      default 20000
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <numbers>
#include <random>
#include <type_traits>
#include <vector>

#include "core/flight/lanes.h"
#include "core/flight/trajectory.h"

using namespace fragsim;
using namespace fragsim::flight;

namespace {

constexpr double kRtol = 1e-6;
using ArcOde = Dopri5<7, TrajectoryIntegrator::ArcRhs>;
using TimeOde = Dopri5<6, TrajectoryIntegrator::Rhs>;

struct Fragment {
  FlightModel model;
  Vec3 velocity;
};

// Illustrative fragments like the demo's groups (examples/demo/scenario.json): steel cuboid case
// fragments (median 0.03 kg, 750 m/s, Cd 1.2, near horizontal), cylinder head closures (median
// 0.1 kg, 450 m/s, a Cd(Mach) table, steep up) and cuboid aft closures (0.05-0.6 kg, 350 m/s,
// Cd 1, down), in the demo's proportions 5 : 2 : 1. Area: a quarter of the surface (Cauchy's
// mean projected area of a convex body).
std::vector<Fragment> make_fragments(int n, const Atmosphere& air, const DragCoefficient& plate,
                                     const DragCoefficient& closure, const DragCoefficient& aft) {
  std::mt19937_64 rng(20261130);
  auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<>(lo, hi)(rng);
  };
  auto normal = [&](double mean, double sd, double lo, double hi) {
    for (;;) {
      const double x = std::normal_distribution<>(mean, sd)(rng);
      if (x >= lo && x <= hi) return x;
    }
  };
  auto cuboid_area = [](double mass, double b, double c) {
    const double a = std::cbrt(mass / 7850.0 / (b * c));
    return 0.5 * (a * a * b + a * a * b * c + a * a * c);  // 2 (ab + bc + ca) / 4
  };
  const double deg = std::numbers::pi / 180.0;
  std::vector<Fragment> out;
  for (int i = 0; i < n; ++i) {
    const double pick = uniform(0, 8);
    Fragment f;
    f.model.atmosphere = &air;
    double speed, elevation;
    if (pick < 5) {
      f.model.mass_kg = std::clamp(0.03 * std::exp(0.9 * normal(0, 1, -8, 8)), 0.005, 2.5);
      f.model.area_m2 = cuboid_area(f.model.mass_kg, 0.6, 0.1);
      f.model.cd = &plate;
      speed = normal(750, 120, 400, 1100);
      elevation = uniform(-12, 12) * deg;
    } else if (pick < 7) {
      f.model.mass_kg = std::clamp(0.1 * std::exp(0.8 * normal(0, 1, -8, 8)), 0.02, 4.0);
      const double r = std::cbrt(f.model.mass_kg / 7850.0 / (std::numbers::pi * 0.8));
      f.model.area_m2 = 0.5 * std::numbers::pi * r * r * (1.0 + 0.8);  // 2 pi r (r + l) / 4
      f.model.cd = &closure;
      speed = normal(450, 90, 200, 750);
      elevation = uniform(0, 40) * deg;
    } else {
      f.model.mass_kg = uniform(0.05, 0.6);
      f.model.area_m2 = cuboid_area(f.model.mass_kg, 0.7, 0.25);
      f.model.cd = &aft;
      speed = normal(350, 70, 150, 600);
      elevation = uniform(-40, 0) * deg;
    }
    const double azimuth = uniform(-std::numbers::pi, std::numbers::pi);
    f.velocity = speed * Vec3(std::cos(elevation) * std::cos(azimuth),
                              std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    out.push_back(f);
  }
  return out;
}

template <int N>
struct Recorded {
  std::vector<const FlightModel*> model;
  std::vector<Eigen::Matrix<double, N, 1>> y0, f0;
  std::vector<double> h;
  void add(const FlightModel* m, const Eigen::Matrix<double, N, 1>& y,
           const Eigen::Matrix<double, N, 1>& f, double step) {
    model.push_back(m);
    y0.push_back(y);
    f0.push_back(f);
    h.push_back(step);
  }
};

// Flies each fragment from 1.5 m to the ground (z = 0) as TrajectoryIntegrator does (path
// length while drag >= gravity, then time), recording each step's first attempt.
void record(const std::vector<Fragment>& fragments, Recorded<7>& arc, Recorded<6>& time) {
  Dopri5Options opt;
  opt.rtol = opt.atol = kRtol;
  for (const Fragment& f : fragments) {
    const Vec3 p0(0, 0, 1.5);
    ArcOde a(TrajectoryIntegrator::ArcRhs{f.model}, opt);
    Eigen::Matrix<double, 7, 1> y;
    y << p0, f.velocity, 0.0;
    a.reset(0.0, y);
    Vec3 p = p0, v = f.velocity;
    double t = 0.0;
    for (int i = 0; i < 10000; ++i) {
      const double speed = v.norm();
      if (!(f.model.acceleration(p, v).norm() >= 0.0)) break;
      const Vec3 drag = f.model.acceleration(p, v) + Vec3(0, 0, f.model.gravity_mps2);
      if (drag.norm() < f.model.gravity_mps2 || speed <= 0.0) break;
      arc.add(&f.model, a.y(), a.dy(), a.next_step_size());
      if (!a.step(1e9)) break;
      p = a.y().head<3>();
      v = a.y().segment<3>(3);
      t = a.y()[6];
      if (p.z() < 0.0) break;
    }
    if (p.z() < 0.0) continue;
    TimeOde o(TrajectoryIntegrator::Rhs{f.model}, opt);
    Eigen::Matrix<double, 6, 1> z;
    z << p, v;
    o.reset(t, z);
    for (int i = 0; i < 10000 && o.t() < 120.0; ++i) {
      time.add(&f.model, o.y(), o.dy(), std::min(o.next_step_size(), 120.0 - o.t()));
      if (!o.step(120.0)) break;
      if (o.y()[2] < 0.0) break;
    }
  }
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

using LaneKernel = void (*)(const LaneIO (&)[kLanes], double, double);

// Where a lane writes into a Dopri5's stages.
template <class Stages>
LaneOut out(Stages& k) {
  return {k.k1.data(), k.k7.data(), k.y1.data(), k.dense_sum.data()};
}

template <int N, class Ode>
void compare(const char* name, const Recorded<N>& r, LaneKernel kernel, const char* kernel_name,
             int repeat) {
  using Rhs = std::conditional_t<N == 7, TrajectoryIntegrator::ArcRhs, TrajectoryIntegrator::Rhs>;
  Dopri5Options opt;
  opt.rtol = opt.atol = kRtol;
  const std::size_t n = r.h.size() / kLanes * kLanes;
  std::vector<double> scalar_err(n), scalar_y(n);
  // Scalar: one integrator per fragment model, as the run builds one per history.
  std::vector<std::unique_ptr<Ode>> odes;
  for (std::size_t i = 0; i < n; ++i) odes.push_back(std::make_unique<Ode>(Rhs{*r.model[i]}, opt));
  double best_scalar = 1e30;
  for (int rep = 0; rep < repeat; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    typename Ode::Stages k;
    for (std::size_t i = 0; i < n; ++i) {
      scalar_err[i] = odes[i]->attempt(0.0, r.y0[i], r.f0[i], r.h[i], k, true);
      scalar_y[i] = k.y1[0] + k.k7[N - 1];
    }
    best_scalar = std::min(best_scalar, seconds_since(t0));
  }
  double best_lanes = 1e30;
  long differ = 0;
  std::vector<typename Ode::Stages> stages(kLanes);
  double err[kLanes];
  for (int rep = 0; rep < repeat; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < n; i += kLanes) {
      LaneIO io[kLanes];
      for (int l = 0; l < kLanes; ++l)
        io[l] = {r.model[i + l], r.y0[i + l].data(), r.f0[i + l].data(),
                 r.h[i + l],     out(stages[l]),     &err[l],
                 N == 6};
      kernel(io, kRtol, kRtol);
      if (rep == 0) {
        for (int l = 0; l < kLanes; ++l) {
          const double y = stages[l].y1[0] + stages[l].k7[N - 1];
          differ +=
              std::bit_cast<std::uint64_t>(err[l]) !=
                  std::bit_cast<std::uint64_t>(scalar_err[i + l]) ||
              std::bit_cast<std::uint64_t>(y) != std::bit_cast<std::uint64_t>(scalar_y[i + l]);
        }
      }
    }
    best_lanes = std::min(best_lanes, seconds_since(t0));
  }
  std::printf(
      "%-12s %-5s attempts %8zu   scalar %6.1f ns   lanes %6.1f ns   speed-up %.2f x   "
      "lanes differing from scalar: %ld\n",
      name, kernel_name, n, 1e9 * best_scalar / static_cast<double>(n),
      1e9 * best_lanes / static_cast<double>(n), best_scalar / best_lanes, differ);
}

// Whole flights, one at a time against kLanes at a time in lockstep: every lane steps its own
// flight with its own step control (Dopri5::first_trial / size_trial / conclude), the attempts
// of all lanes computed by one kernel call; a lane whose flight ends takes the next one. Phase
// s runs from launch to the handover (drag < g) or the ground, phase t from the handover to the
// ground or 120 s. The end states must equal the serial flights' bit for bit.
template <int N>
struct Flight {
  const FlightModel* model;
  Eigen::Matrix<double, N, 1> y0;
};

template <int N>
bool flight_over(const FlightModel& m, const Eigen::Matrix<double, N, 1>& y, double t) {
  if (y[2] < 0.0) return true;
  if constexpr (N == 7) {
    const Vec3 drag =
        m.acceleration(y.template head<3>(), y.template segment<3>(3)) + Vec3(0, 0, m.gravity_mps2);
    return !(drag.norm() >= m.gravity_mps2);
  } else {
    return t >= 120.0;
  }
}

template <int N, class Ode>
std::unique_ptr<Ode> start(const Flight<N>& f) {
  using Rhs = std::conditional_t<N == 7, TrajectoryIntegrator::ArcRhs, TrajectoryIntegrator::Rhs>;
  Dopri5Options opt;
  opt.rtol = opt.atol = kRtol;
  auto ode = std::make_unique<Ode>(Rhs{*f.model}, opt);
  ode->reset(0.0, f.y0);
  return ode;
}

constexpr double kEnd = 120.0;  // t_end of every step (the phase's own variable)

template <int N, class Ode>
std::vector<Eigen::Matrix<double, N, 1>> fly_serial(const std::vector<Flight<N>>& flights,
                                                    long& attempts) {
  std::vector<Eigen::Matrix<double, N, 1>> end(flights.size());
  for (std::size_t i = 0; i < flights.size(); ++i) {
    auto ode = start<N, Ode>(flights[i]);
    while (!flight_over<N>(*flights[i].model, ode->y(), ode->t()) &&
           ode->step(N == 7 ? 1e9 : kEnd)) {
    }
    attempts += (ode->rhs_evaluations() - 1) / 6;  // less reset()'s evaluations (see below)
    end[i] = ode->y();
  }
  return end;
}

template <int N, class Ode>
std::vector<Eigen::Matrix<double, N, 1>> fly_lockstep(const std::vector<Flight<N>>& flights,
                                                      LaneKernel kernel, double& occupancy) {
  struct Lane {
    std::unique_ptr<Ode> ode;
    std::size_t flight = 0;
    typename Ode::Trial trial{};
    bool busy = false;
  };
  std::vector<Eigen::Matrix<double, N, 1>> end(flights.size());
  Lane lanes[kLanes];
  std::size_t next = 0;
  auto take_next = [&](Lane& lane) {
    lane.busy = false;
    while (next < flights.size()) {
      const std::size_t i = next++;
      lane.ode = start<N, Ode>(flights[i]);
      lane.flight = i;
      const double t_end = N == 7 ? 1e9 : kEnd;
      if (flight_over<N>(*flights[i].model, lane.ode->y(), lane.ode->t()) ||
          !(lane.ode->t() < t_end)) {
        end[i] = lane.ode->y();
        continue;
      }
      lane.trial = lane.ode->first_trial(t_end);
      if (!lane.ode->size_trial(lane.trial)) {
        end[i] = lane.ode->y();
        continue;
      }
      lane.busy = true;
      return;
    }
  };
  for (Lane& lane : lanes) take_next(lane);
  long calls = 0, used = 0;
  typename Ode::Stages scratch;
  double scratch_err;
  for (;;) {
    int first_busy = -1;
    for (int l = 0; l < kLanes; ++l)
      if (lanes[l].busy && first_busy < 0) first_busy = l;
    if (first_busy < 0) break;
    LaneIO io[kLanes];
    double err[kLanes];
    for (int l = 0; l < kLanes; ++l) {
      const bool busy = lanes[l].busy;
      Lane& lane = lanes[busy ? l : first_busy];  // idle lanes repeat a busy one
      io[l] = {&lane.ode->rhs().model,
               lane.ode->y().data(),
               lane.ode->dy().data(),
               lane.trial.h,
               out(busy ? lane.ode->trial_stages() : scratch),
               busy ? &err[l] : &scratch_err,
               N == 6};
      used += busy;
    }
    ++calls;
    kernel(io, kRtol, kRtol);
    for (int l = 0; l < kLanes; ++l) {
      Lane& lane = lanes[l];
      if (!lane.busy) continue;
      lane.ode->count_attempt();
      lane.ode->trial_stages().has_dense_sum = true;
      lane.ode->trial_stages().has_dense_sum = true;
      const auto verdict = lane.ode->conclude(lane.trial, err[l]);
      bool over = verdict == Ode::Verdict::kFailed;
      if (verdict == Ode::Verdict::kAccepted) {
        over = flight_over<N>(*flights[lane.flight].model, lane.ode->y(), lane.ode->t()) ||
               !(lane.ode->t() < lane.trial.t_end);
        if (!over) lane.trial = lane.ode->first_trial(lane.trial.t_end);
      }
      if (!over) over = !lane.ode->size_trial(lane.trial);
      if (over) {
        end[lane.flight] = lane.ode->y();
        take_next(lane);
      }
    }
  }
  occupancy = static_cast<double>(used) / static_cast<double>(kLanes * calls);
  return end;
}

template <int N, class Ode>
void compare_flights(const char* name, const std::vector<Flight<N>>& flights, LaneKernel kernel,
                     const char* kernel_name, int repeat) {
  double best_serial = 1e30, best_lanes = 1e30, occupancy = 0.0;
  long attempts = 0;
  std::vector<Eigen::Matrix<double, N, 1>> serial, lanes;
  for (int rep = 0; rep < repeat; ++rep) {
    attempts = 0;
    auto t0 = std::chrono::steady_clock::now();
    serial = fly_serial<N, Ode>(flights, attempts);
    best_serial = std::min(best_serial, seconds_since(t0));
    t0 = std::chrono::steady_clock::now();
    lanes = fly_lockstep<N, Ode>(flights, kernel, occupancy);
    best_lanes = std::min(best_lanes, seconds_since(t0));
  }
  long differ = 0;
  for (std::size_t i = 0; i < flights.size(); ++i)
    for (int c = 0; c < N; ++c)
      differ +=
          std::bit_cast<std::uint64_t>(serial[i][c]) != std::bit_cast<std::uint64_t>(lanes[i][c]);
  std::printf(
      "%-12s %-5s flights %7zu  attempts %8ld   one at a time %6.1f ns   lockstep %6.1f ns"
      " per attempt   speed-up %.2f x   lanes busy %.1f %%   end values differing: %ld\n",
      name, kernel_name, flights.size(), attempts,
      1e9 * best_serial / static_cast<double>(attempts),
      1e9 * best_lanes / static_cast<double>(attempts), best_serial / best_lanes, 100.0 * occupancy,
      differ);
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 20000;
  const Atmosphere air{AtmosphereSpec{}};
  fragments::CdSpec plate_spec, aft_spec, closure_spec;
  plate_spec.constant = 1.2;
  aft_spec.constant = 1.0;
  closure_spec.mach = {0, 0.6, 0.8, 1, 1.2, 1.5, 2, 3};
  closure_spec.cd = {0.85, 0.9, 1.1, 1.5, 1.45, 1.35, 1.3, 1.3};
  const DragCoefficient plate(plate_spec), closure(closure_spec), aft(aft_spec);
  const std::vector<Fragment> fragments = make_fragments(n, air, plate, closure, aft);
  Recorded<7> arc;
  Recorded<6> time;
  record(fragments, arc, time);
  std::printf(
      "# %d illustrative demo-like fragments, rtol %.0e; %zu attempts in s, %zu in t; "
      "AVX2 %s; best of 5\n",
      n, kRtol, arc.h.size(), time.h.size(), lanes_have_avx2() ? "yes" : "no");
  constexpr int kRepeat = 5;
  // Phase starts: launch for s, and each recorded t-phase's first state for t.
  std::vector<Flight<7>> arc_flights;
  for (const Fragment& f : fragments) {
    Eigen::Matrix<double, 7, 1> y;
    y << 0.0, 0.0, 1.5, f.velocity, 0.0;
    arc_flights.push_back({&f.model, y});
  }
  std::vector<Flight<6>> time_flights;
  for (std::size_t i = 0; i < time.h.size(); ++i)
    if (i == 0 || time.model[i] != time.model[i - 1])
      time_flights.push_back({time.model[i], time.y0[i]});
  compare<7, ArcOde>("path length", arc, &attempt_lanes_sse2, "sse2", kRepeat);
  if (lanes_have_avx2())
    compare<7, ArcOde>("path length", arc, &attempt_lanes_avx2, "avx2", kRepeat);
  compare<6, TimeOde>("time", time, &attempt_lanes_sse2, "sse2", kRepeat);
  if (lanes_have_avx2()) compare<6, TimeOde>("time", time, &attempt_lanes_avx2, "avx2", kRepeat);
  std::printf("# whole flights of each phase, one at a time against %d in lockstep\n", kLanes);
  compare_flights<7, ArcOde>("path length", arc_flights, &attempt_lanes_sse2, "sse2", kRepeat);
  if (lanes_have_avx2())
    compare_flights<7, ArcOde>("path length", arc_flights, &attempt_lanes_avx2, "avx2", kRepeat);
  compare_flights<6, TimeOde>("time", time_flights, &attempt_lanes_sse2, "sse2", kRepeat);
  if (lanes_have_avx2())
    compare_flights<6, TimeOde>("time", time_flights, &attempt_lanes_avx2, "avx2", kRepeat);
  return 0;
}
