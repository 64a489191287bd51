// The lane kernel (core/flight/lanes.h) against Dopri5::attempt on TrajectoryIntegrator's
// right-hand sides: every stage, the result and the error norm equal bit for bit in every lane,
// in both builds (AVX2 where the CPU has it, and SSE2), over random states far wider than flight
// (speeds 0.1-3,000 m/s, altitudes -2 to 40 km: out of the ISA table, steps from 1e-6 to 1e4, so
// some attempts overflow), with lanes of different Cd (constant and a Mach table), mass, area and
// gravity, in still air and in wind.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <type_traits>
#include <vector>

#include "core/flight/lanes.h"
#include "core/flight/trajectory.h"

namespace fragsim::flight {
namespace {

using ArcOde = Dopri5<7, TrajectoryIntegrator::ArcRhs>;
using TimeOde = Dopri5<6, TrajectoryIntegrator::Rhs>;

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
  double log_uniform(double lo, double hi) {
    return std::exp(uniform(std::log(lo), std::log(hi)));
  }
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

// One round: kLanes random flights, each lane's attempt by the scalar integrator and by the
// kernel; returns the number of values that differ.
template <int N, class Ode, class Kernel>
int differences(Inputs& in, const Air& air, bool estimate, Kernel kernel) {
  constexpr double kRtol = 1e-6;
  Dopri5Options opt;
  opt.rtol = kRtol;
  opt.atol = kRtol;
  FlightModel models[kLanes];
  LaneModels lanes{};
  LaneAttempt<N> a{};
  typename Ode::Stages expected[kLanes];
  double expected_err[kLanes];
  for (int l = 0; l < kLanes; ++l) {
    models[l] = in.model(air);
    lanes.model[l] = &models[l];
    Eigen::Matrix<double, N, 1> y0;
    if constexpr (N == 7)
      y0 << in.position(), in.velocity(), in.uniform(0, 100);
    else
      y0 << in.position(), in.velocity();
    using Rhs = std::conditional_t<N == 7, TrajectoryIntegrator::ArcRhs, TrajectoryIntegrator::Rhs>;
    Ode ode(Rhs{models[l]}, opt);
    const Eigen::Matrix<double, N, 1> f0 = ode.rhs()(0.0, y0);
    const double h = N == 7 ? in.log_uniform(1e-6, 1e4) : in.log_uniform(1e-7, 1e2);
    expected_err[l] = ode.attempt(0.0, y0, f0, h, expected[l], estimate);
    for (int i = 0; i < N; ++i) {
      a.y0.c[i][l] = y0[i];
      a.f0.c[i][l] = f0[i];
    }
    a.h[l] = h;
  }
  EXPECT_TRUE(lanes_supported(lanes));
  kernel(lanes, kRtol, kRtol, estimate, a);
  int diff = 0;
  for (int l = 0; l < kLanes; ++l) {
    const auto& e = expected[l];
    for (int i = 0; i < N; ++i) {
      diff += !same(a.k2.c[i][l], e.k2[i]) + !same(a.k3.c[i][l], e.k3[i]) +
              !same(a.k4.c[i][l], e.k4[i]) + !same(a.k5.c[i][l], e.k5[i]) +
              !same(a.k6.c[i][l], e.k6[i]) + !same(a.k7.c[i][l], e.k7[i]) +
              !same(a.y1.c[i][l], e.y1[i]);
    }
    diff += !same(a.err[l], expected_err[l]);
  }
  return diff;
}

template <int N, class Ode>
void expect_equal_bits(void (*kernel)(const LaneModels&, double, double, bool, LaneAttempt<N>&)) {
  Inputs in(20261130 + N);
  int diff = 0, rounds = 0;
  for (const Vec3& wind : {Vec3(0, 0, 0), Vec3(12.5, -3.25, 0.5)}) {
    for (const AtmosphereSpec& spec : {isa(wind), constant_air(wind)}) {
      const Air air(spec);
      for (int r = 0; r < 2500; ++r, ++rounds)
        diff += differences<N, Ode>(in, air, r % 5 != 0, kernel);
    }
  }
  EXPECT_EQ(diff, 0) << "over " << rounds << " rounds of " << kLanes << " lanes";
}

TEST(Lanes, PathLengthAttemptEqualsTheScalarAttemptBitForBit) {
  expect_equal_bits<7, ArcOde>(&attempt_lanes_sse2);
  if (lanes_have_avx2()) expect_equal_bits<7, ArcOde>(&attempt_lanes_avx2);
  expect_equal_bits<7, ArcOde>(&attempt_lanes);
}

TEST(Lanes, TimeAttemptEqualsTheScalarAttemptBitForBit) {
  expect_equal_bits<6, TimeOde>(&attempt_lanes_sse2);
  if (lanes_have_avx2()) expect_equal_bits<6, TimeOde>(&attempt_lanes_avx2);
  expect_equal_bits<6, TimeOde>(&attempt_lanes);
}

TEST(Lanes, SupportNeedsDragInEveryLaneAndOneAtmosphere) {
  Air air(isa(Vec3::Zero())), other(isa(Vec3::Zero()));
  FlightModel m{&air.atmosphere, &air.plate, kStandardGravity_mps2, 1e-3, 0.03, 0.0};
  FlightModel models[kLanes] = {m, m, m, m};
  LaneModels lanes{{&models[0], &models[1], &models[2], &models[3]}};
  EXPECT_TRUE(lanes_supported(lanes));
  models[2].area_m2 = 0.0;  // vacuum lane
  EXPECT_FALSE(lanes_supported(lanes));
  models[2] = m;
  models[3].atmosphere = &other.atmosphere;  // another atmosphere (another wind)
  EXPECT_FALSE(lanes_supported(lanes));
  models[3] = m;
  models[1].cd = nullptr;
  EXPECT_FALSE(lanes_supported(lanes));
}

}  // namespace
}  // namespace fragsim::flight
