// Drag coefficient tables and the translational right-hand side.
#include "core/flight/flight_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/common/error.h"

namespace fragsim::flight {
namespace {

fragments::CdSpec table(std::vector<double> mach, std::vector<double> cd) {
  fragments::CdSpec s;
  s.mach = std::move(mach);
  s.cd = std::move(cd);
  return s;
}

TEST(DragCoefficient, Constant) {
  fragments::CdSpec s;
  s.constant = 0.47;
  const DragCoefficient cd(s);
  EXPECT_TRUE(cd.is_constant());
  for (double m : {0.0, 0.5, 3.0, 100.0}) EXPECT_EQ(cd.at_mach(m), 0.47);
  EXPECT_EQ(DragCoefficient().at_mach(2.0), 1.0);  // default Cd 1
}

TEST(DragCoefficient, PiecewiseLinearClamped) {
  const DragCoefficient cd(table({0.5, 1.0, 2.0}, {0.5, 0.9, 0.7}));
  EXPECT_FALSE(cd.is_constant());
  // Exact arithmetic on these values up to one rounding: 1e-15.
  EXPECT_NEAR(cd.at_mach(0.75), 0.7, 1e-15);
  EXPECT_NEAR(cd.at_mach(1.5), 0.8, 1e-15);
  EXPECT_NEAR(cd.at_mach(1.9), 0.72, 1e-15);
  EXPECT_EQ(cd.at_mach(0.5), 0.5);
  EXPECT_EQ(cd.at_mach(1.0), 0.9);
  EXPECT_EQ(cd.at_mach(2.0), 0.7);
  EXPECT_EQ(cd.at_mach(0.0), 0.5);  // clamped below
  EXPECT_EQ(cd.at_mach(7.0), 0.7);  // clamped above
}

// The lookup through the table's uniform grid finds the node std::upper_bound finds, so the value
// is the interpolation's to the bit: uneven spacing (nodes closer than a grid cell, long gaps),
// every node, its neighbouring doubles and random Mach numbers.
TEST(DragCoefficient, GridLookupIsTheBinarySearchToTheBit) {
  const std::vector<double> mach = {0.0, 0.6, 0.6000001, 0.8, 1.0, 1.05, 1.2, 1.5, 2.0, 9.0};
  const std::vector<double> cdv = {0.85, 0.9, 0.91, 1.1, 1.5, 1.48, 1.45, 1.35, 1.3, 1.1};
  const DragCoefficient cd(table(mach, cdv));
  const auto reference = [&](double m) {
    if (!(m > mach.front())) return cdv.front();
    if (m >= mach.back()) return cdv.back();
    const std::size_t j =
        static_cast<std::size_t>(std::upper_bound(mach.begin(), mach.end(), m) - mach.begin());
    const double w = (m - mach[j - 1]) / (mach[j] - mach[j - 1]);
    return cdv[j - 1] + w * (cdv[j] - cdv[j - 1]);
  };
  std::vector<double> probes;
  for (const double m : mach)
    for (const double q : {std::nextafter(m, -1.0), m, std::nextafter(m, 10.0)})
      probes.push_back(q);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-0.5, 9.5);
  for (int k = 0; k < 20000; ++k) probes.push_back(u(rng));
  for (int k = 0; k <= 900; ++k) probes.push_back(k * 0.01);  // across every grid cell edge
  for (const double m : probes) ASSERT_EQ(cd.at_mach(m), reference(m)) << "Mach " << m;
}

TEST(DragCoefficient, SinglePointTableIsConstant) {
  const DragCoefficient cd(table({0.8}, {0.6}));
  EXPECT_TRUE(cd.is_constant());
  EXPECT_EQ(cd.at_mach(3.0), 0.6);
}

TEST(DragCoefficient, RejectsBadTables) {
  EXPECT_THROW(DragCoefficient(table({0.5, 1.0}, {0.5})), InputError);
  EXPECT_THROW(DragCoefficient(table({1.0, 1.0}, {0.5, 0.6})), InputError);
  EXPECT_THROW(DragCoefficient(table({1.0, 0.5}, {0.5, 0.6})), InputError);
  EXPECT_THROW(DragCoefficient(table({0.5, 1.0}, {0.5, -0.1})), InputError);
  fragments::CdSpec s;
  s.constant = -1.0;
  EXPECT_THROW(DragCoefficient{s}, InputError);
}

TEST(FlightModel, GravityAndQuadraticDragWithWind) {
  AtmosphereSpec spec;
  spec.model = AtmosphereSpec::Model::kConstant;
  spec.density_kg_m3 = 1.2;
  spec.wind_mps = Vec3(3.0, 0.0, 0.0);
  const Atmosphere atm(spec);
  fragments::CdSpec cs;
  cs.constant = 0.5;
  const DragCoefficient cd(cs);
  FlightModel m{&atm, &cd, 9.81, 0.01, 0.2, 0.0};
  const Vec3 v(13.0, 0.0, 4.0);
  // k = rho Cd A / (2 m) = 0.015 /m; v_rel = (10, 0, 4), |v_rel| = sqrt(116).
  const double k = 0.015, s = std::sqrt(116.0);
  const Vec3 expect(-k * s * 10.0, 0.0, -9.81 - k * s * 4.0);
  // Same few operations in another order: 1e-14 relative.
  EXPECT_NEAR((m.acceleration(Vec3(0, 0, 50), v) - expect).norm(), 0.0, 1e-14 * expect.norm());
  // Moving with the wind: gravity only.
  EXPECT_NEAR((m.acceleration(Vec3::Zero(), Vec3(3, 0, 0)) - Vec3(0, 0, -9.81)).norm(), 0.0, 1e-15);
}

TEST(FlightModel, VacuumWhenNoAtmosphereOrArea) {
  FlightModel m;
  EXPECT_EQ(m.acceleration(Vec3::Zero(), Vec3(100, 20, 5)), Vec3(0, 0, -kStandardGravity_mps2));
  const Atmosphere atm(AtmosphereSpec{});
  const DragCoefficient cd;
  FlightModel m2{&atm, &cd, 9.81, 0.0, 1.0, 0.0};
  EXPECT_EQ(m2.acceleration(Vec3::Zero(), Vec3(100, 20, 5)), Vec3(0, 0, -9.81));
}

TEST(FlightModel, MachTableUsesIsaAtOffsetAltitude) {
  const Atmosphere atm(AtmosphereSpec{});
  const DragCoefficient cd(table({0.0, 1.0, 2.0}, {0.4, 1.0, 0.8}));
  FlightModel m{&atm, &cd, 9.80665, 0.002, 0.05, 1500.0};
  const Vec3 p(10.0, 0.0, 500.0), v(300.0, 0.0, -100.0);  // altitude 2000 m
  const double h = 2000.0, speed = v.norm();
  const double mach = speed / Atmosphere::isa_sound_speed(h);
  const double cdv = mach < 1.0 ? 0.4 + 0.6 * mach : 1.0 - 0.2 * (mach - 1.0);
  const double k = 0.5 * Atmosphere::isa_density(h) * cdv * 0.002 / 0.05;
  const Vec3 expect = Vec3(0, 0, -9.80665) - k * speed * v;
  // Table vs closed form (<1e-9 each in rho and a) dominates: 1e-8 relative.
  EXPECT_NEAR((m.acceleration(p, v) - expect).norm(), 0.0, 1e-8 * expect.norm());
  // The offset matters: at altitude 500 m the drag differs by several percent.
  FlightModel m0 = m;
  m0.altitude_offset_m = 0.0;
  EXPECT_GT((m0.acceleration(p, v) - expect).norm(), 1e-2 * expect.norm());
}

}  // namespace
}  // namespace fragsim::flight
