// The lane kernel (core/flight/lanes.h) against Dopri5::attempt on TrajectoryIntegrator's
// right-hand sides: what is read after the attempt (k1, k7, the result y1, the continuous
// extension's sum of the stages) and the error norm equal bit for bit in every lane, lanes in path
// length and in time mixed, in both builds (AVX2 where the CPU has it, and SSE2), over random
// states far wider than flight (speeds 0.1-3,000 m/s, altitudes -2 to 40 km: out of the ISA table,
// steps from 1e-6 to 1e4, so some attempts overflow), with lanes of different Cd (constant and a
// Mach table), mass, area and gravity, in still air and in wind.
#include "core/flight/lanes.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <type_traits>
#include <vector>

#include "core/flight/trajectory.h"

namespace fragsim::flight {
namespace {

using ArcOde = Dopri5<7, TrajectoryIntegrator::ArcRhs>;
using TimeOde = Dopri5<6, TrajectoryIntegrator::Rhs>;
using LaneKernel = void (*)(const LaneIO (&)[kLanes], double, double);
constexpr double kRtol = 1e-6;

// Equal bits, or both NaN (a NaN's payload is not a result).
bool same(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b) ||
         (std::isnan(a) && std::isnan(b));
}

fragments::CdSpec constant_cd(double cd) {
  fragments::CdSpec s;
  s.constant = cd;
  return s;
}
// Illustrative transonic table (shape of a sphere's Cd against Mach).
fragments::CdSpec mach_table() {
  fragments::CdSpec s;
  s.mach = {0.0, 0.6, 0.8, 1.0, 1.2, 1.5, 2.0, 3.0};
  s.cd = {0.47, 0.5, 0.6, 0.95, 1.0, 0.95, 0.9, 0.85};
  return s;
}

struct Air {
  Atmosphere atmosphere;
  DragCoefficient plate{constant_cd(1.2)}, sphere{mach_table()};
  explicit Air(const AtmosphereSpec& spec) : atmosphere(spec) {}
};

AtmosphereSpec isa(Vec3 wind) {
  AtmosphereSpec s;
  s.wind_mps = wind;
  return s;
}
AtmosphereSpec constant_air(Vec3 wind) {
  AtmosphereSpec s;
  s.model = AtmosphereSpec::Model::kConstant;
  s.wind_mps = wind;
  return s;
}

class Inputs {
 public:
  explicit Inputs(std::uint64_t seed) : rng_(seed) {}
  double uniform(double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(rng_); }
  double log_uniform(double lo, double hi) { return std::exp(uniform(std::log(lo), std::log(hi))); }
  Vec3 position() { return {uniform(-3000, 3000), uniform(-3000, 3000), uniform(-2000, 40000)}; }
  Vec3 velocity() {
    Vec3 d(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    if (d.norm() < 1e-3) d = Vec3(1, 0, 0);
    return d.normalized() * log_uniform(0.1, 3000);
  }
  FlightModel model(const Air& air) {
    FlightModel m;
    m.atmosphere = &air.atmosphere;
    m.cd = uniform(0, 1) < 0.5 ? &air.plate : &air.sphere;
    m.mass_kg = log_uniform(1e-3, 50);
    m.area_m2 = log_uniform(1e-5, 0.1);
    m.gravity_mps2 = uniform(0, 1) < 0.9 ? kStandardGravity_mps2 : uniform(0, 20);
    m.altitude_offset_m = uniform(0, 1) < 0.5 ? 0.0 : uniform(-500, 2500);
    return m;
  }

 private:
  std::mt19937_64 rng_;
};

// One lane's expected attempt, by the scalar integrator on the same right-hand side.
template <int N, class Ode, class Rhs>
void scalar_attempt(const FlightModel& model, Inputs& in, std::vector<double>& y0,
                    std::vector<double>& f0, double& h, std::vector<double>& stages, double& err) {
  Dopri5Options opt;
  opt.rtol = opt.atol = kRtol;
  Eigen::Matrix<double, N, 1> y;
  if constexpr (N == 7)
    y << in.position(), in.velocity(), in.uniform(0, 100);
  else
    y << in.position(), in.velocity();
  Ode ode(Rhs{model}, opt);
  const Eigen::Matrix<double, N, 1> f = ode.rhs()(0.0, y);
  h = N == 7 ? in.log_uniform(1e-6, 1e4) : in.log_uniform(1e-7, 1e2);
  typename Ode::Stages k;
  err = ode.attempt(0.0, y, f, h, k, true);
  y0.assign(y.data(), y.data() + N);
  f0.assign(f.data(), f.data() + N);
  // What a lane writes: k1, k7, y1 and build_dense's sum of the stages (in its order).
  using namespace dopri5_tableau;
  Eigen::Matrix<double, N, 1> sum =
      d1 * k.k1 + d3 * k.k3 + d4 * k.k4 + d5 * k.k5 + d6 * k.k6 + d7 * k.k7;
  stages.clear();
  for (const Eigen::Matrix<double, N, 1>* v : {&k.k1, &k.k7, &k.y1, &sum})
    stages.insert(stages.end(), v->data(), v->data() + N);
}

// One round: kLanes random flights, each lane in path length or in time at random; returns the
// number of values that differ from the scalar attempts'.
int differences(Inputs& in, const Air& air, LaneKernel kernel) {
  FlightModel models[kLanes];
  std::vector<double> y0[kLanes], f0[kLanes], expected[kLanes];
  double h[kLanes], expected_err[kLanes], err[kLanes];
  std::vector<double> got[kLanes];
  LaneIO io[kLanes];
  for (int l = 0; l < kLanes; ++l) {
    models[l] = in.model(air);
    const bool in_time = in.uniform(0, 1) < 0.4;
    if (in_time)
      scalar_attempt<6, TimeOde, TrajectoryIntegrator::Rhs>(models[l], in, y0[l], f0[l], h[l],
                                                            expected[l], expected_err[l]);
    else
      scalar_attempt<7, ArcOde, TrajectoryIntegrator::ArcRhs>(models[l], in, y0[l], f0[l], h[l],
                                                              expected[l], expected_err[l]);
    got[l].assign(expected[l].size(), -1.0);
    const std::size_t n = y0[l].size();
    double* g = got[l].data();
    io[l] = {&models[l], y0[l].data(), f0[l].data(), h[l], {g, g + n, g + 2 * n, g + 3 * n},
             &err[l],    in_time};
    EXPECT_TRUE(lane_ready(models[l]));
  }
  kernel(io, kRtol, kRtol);
  int diff = 0;
  for (int l = 0; l < kLanes; ++l) {
    for (std::size_t j = 0; j < expected[l].size(); ++j) diff += !same(got[l][j], expected[l][j]);
    diff += !same(err[l], expected_err[l]);
  }
  return diff;
}

void expect_equal_bits(LaneKernel kernel) {
  Inputs in(20261130);
  int diff = 0, rounds = 0;
  for (const Vec3& wind : {Vec3(0, 0, 0), Vec3(12.5, -3.25, 0.5)}) {
    for (const AtmosphereSpec& spec : {isa(wind), constant_air(wind)}) {
      const Air air(spec);
      for (int r = 0; r < 2500; ++r, ++rounds) diff += differences(in, air, kernel);
    }
  }
  EXPECT_EQ(diff, 0) << "over " << rounds << " rounds of " << kLanes << " lanes";
}

TEST(Lanes, EachLaneEqualsTheScalarAttemptBitForBitInPathLengthOrTime) {
  expect_equal_bits(&attempt_lanes_sse2);
  if (lanes_have_avx2()) expect_equal_bits(&attempt_lanes_avx2);
  expect_equal_bits(&attempt_lanes);
}

TEST(Lanes, OnlyModelsWithDragGoIntoALane) {
  Air air(isa(Vec3::Zero()));
  FlightModel m{&air.atmosphere, &air.plate, kStandardGravity_mps2, 1e-3, 0.03, 0.0};
  EXPECT_TRUE(lane_ready(m));
  FlightModel vacuum = m;
  vacuum.area_m2 = 0.0;
  EXPECT_FALSE(lane_ready(vacuum));
  vacuum = m;
  vacuum.cd = nullptr;
  EXPECT_FALSE(lane_ready(vacuum));
  vacuum = m;
  vacuum.atmosphere = nullptr;
  EXPECT_FALSE(lane_ready(vacuum));
}

}  // namespace
}  // namespace fragsim::flight
