// Launch frame conventions, direction and rotation samplers (chi-square), and sample_fragment:
// determinism, slot contract, frame velocity, weight, fixed or random attitude, no NaN, no heap
// allocation.
#include "core/fragments/sampling.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "tests/core/fragments/chi_square.h"

// Counting global allocator: lets a test assert that sample_fragment never touches the heap.
// Kept out of line: inlined into call sites, GCC 12 would pair `new` with `free` and warn
// (-Wmismatched-new-delete), although the replacement pair is consistent.
namespace {
std::atomic<long> g_heap_allocations{0};
}
[[gnu::noinline]] void* operator new(std::size_t n) {
  g_heap_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void operator delete(void* p) noexcept {
  std::free(p);
}
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}

namespace fragsim::fragments {
namespace {

using testing::EqualProbabilityBins;

constexpr int kSamples = 100000;
constexpr std::uint64_t kSeed = 977;
constexpr double kMinP = 1e-4;  // see distribution_test.cpp

void expect_vec_near(const Vec3& got, const Vec3& want, double tol) {
  EXPECT_LE((got - want).norm(), tol)
      << "got (" << got.transpose() << ") want (" << want.transpose() << ")";
}

// ---------------------------------------------------------------------------------------------
// Frame rotation. Tolerance 1e-15 (a few roundings of sin/cos of the angles).

TEST(FrameRotation, Conventions) {
  FrameSpec f;
  f.yaw_deg = 90.0;  // yaw from +x toward +y
  expect_vec_near(frame_rotation(f) * Vec3::UnitX(), Vec3::UnitY(), 1e-15);
  f = FrameSpec{};
  f.pitch_deg = 30.0;  // positive pitch raises the nose (+x) toward +z
  const double c30 = std::cos(30 * kDegToRad), s30 = 0.5;
  expect_vec_near(frame_rotation(f) * Vec3::UnitX(), Vec3(c30, 0, s30), 1e-15);
  f = FrameSpec{};
  f.roll_deg = 90.0;  // right-handed about body x: +y goes to +z
  expect_vec_near(frame_rotation(f) * Vec3::UnitY(), Vec3::UnitZ(), 1e-15);
  // Order: roll, then pitch, then yaw. Yaw 90 + pitch 30 puts the nose at (0, cos30, sin30).
  f = FrameSpec{};
  f.yaw_deg = 90.0;
  f.pitch_deg = 30.0;
  expect_vec_near(frame_rotation(f) * Vec3::UnitX(), Vec3(0, c30, s30), 1e-15);
  // Roll does not move the nose.
  f.roll_deg = 45.0;
  expect_vec_near(frame_rotation(f) * Vec3::UnitX(), Vec3(0, c30, s30), 1e-15);
  // Proper rotation.
  const Mat3 r = frame_rotation(f);
  EXPECT_LE((r * r.transpose() - Mat3::Identity()).norm(), 1e-15);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-15);
}

TEST(AttitudeRotation, IsTheFrameConventionOfItsAngles) {
  // Bit-identical to frame_rotation of the same angles: one convention, one formula.
  for (const AttitudeSpec a :
       {AttitudeSpec{}, AttitudeSpec{90.0, 0.0, 0.0}, AttitudeSpec{-30.0, 45.0, 10.0},
        AttitudeSpec{200.0, -75.0, 135.0}}) {
    FrameSpec f;
    f.yaw_deg = a.yaw_deg;
    f.pitch_deg = a.pitch_deg;
    f.roll_deg = a.roll_deg;
    EXPECT_EQ(attitude_rotation(a), frame_rotation(f));
  }
  EXPECT_EQ(attitude_rotation(AttitudeSpec{}), Mat3::Identity());
}

// ---------------------------------------------------------------------------------------------
// Direction sampling

TEST(SampleDirection, RangeEnds) {
  DirectionSpec d;
  d.elevation_min_deg = 10;
  d.elevation_max_deg = 60;
  d.azimuth_min_deg = -45;
  d.azimuth_max_deg = 30;
  const auto el = [](const Vec3& v) { return std::asin(v.z()) / kDegToRad; };
  const auto az = [](const Vec3& v) { return std::atan2(v.y(), v.x()) / kDegToRad; };
  EXPECT_NEAR(el(sample_direction(d, 0.0, 0.0)), 10.0, 1e-12);
  EXPECT_NEAR(el(sample_direction(d, 1.0, 0.0)), 60.0, 1e-12);
  EXPECT_NEAR(az(sample_direction(d, 0.5, 0.0)), -45.0, 1e-12);
  EXPECT_NEAR(az(sample_direction(d, 0.5, 1.0)), 30.0, 1e-12);
  // Full sphere: poles reachable, unit length.
  const DirectionSpec full;
  expect_vec_near(sample_direction(full, 1.0, 0.3), Vec3::UnitZ(), 1e-15);
  expect_vec_near(sample_direction(full, 0.0, 0.3), -Vec3::UnitZ(), 1e-15);
  EXPECT_NEAR(sample_direction(full, 0.3, 0.7).norm(), 1.0, 1e-15);
}

// Bins unit vectors into n_el x n_az cells of equal area within the ranges (sin(elevation)
// slices x azimuth slices) and returns the chi-square test. Vectors outside the ranges fail.
testing::ChiSquareResult direction_fit(const DirectionSpec& d, int n_el, int n_az,
                                       const std::function<Vec3(int)>& draw, const char* name) {
  const double s_lo = std::sin(d.elevation_min_deg * kDegToRad);
  const double s_hi = std::sin(d.elevation_max_deg * kDegToRad);
  const double a_lo = d.azimuth_min_deg * kDegToRad, a_hi = d.azimuth_max_deg * kDegToRad;
  EqualProbabilityBins bins(static_cast<std::size_t>(n_el * n_az));
  int outside = 0;
  for (int i = 0; i < kSamples; ++i) {
    const Vec3 v = draw(i);
    const double fs = (v.z() - s_lo) / (s_hi - s_lo);
    double az = std::atan2(v.y(), v.x());
    if (az < a_lo - 1e-12) az += 2 * kPi;  // ranges may extend past +-180
    const double fa = (az - a_lo) / (a_hi - a_lo);
    if (fs < -1e-12 || fs > 1 + 1e-12 || fa < -1e-12 || fa > 1 + 1e-12) ++outside;
    const int ie = std::clamp(static_cast<int>(fs * n_el), 0, n_el - 1);
    const int ia = std::clamp(static_cast<int>(fa * n_az), 0, n_az - 1);
    bins.add_bin(static_cast<std::size_t>(ie * n_az + ia));
  }
  EXPECT_EQ(outside, 0) << name;
  const auto r = bins.test();
  std::printf("[ measured ] %-38s chi2 = %7.2f  dof = %d  p = %.4g\n", name, r.statistic, r.dof,
              r.p_value);
  return r;
}

Vec3 direction_from_stream(const DirectionSpec& d, std::uint32_t group, int i) {
  const RandomStream rng(kSeed, group, static_cast<std::uint64_t>(i));
  return sample_direction(d, rng.uniform(kSlotDirection, 0), rng.uniform(kSlotDirection, 1));
}

TEST(SampleDirection, ChiSquareRestrictedRange) {
  DirectionSpec d;
  d.elevation_min_deg = 10;
  d.elevation_max_deg = 60;
  d.azimuth_min_deg = -45;
  d.azimuth_max_deg = 30;
  const auto r = direction_fit(
      d, 10, 10, [&](int i) { return direction_from_stream(d, 1, i); },
      "direction el [10,60] az [-45,30]");
  EXPECT_GT(r.p_value, kMinP);
}

TEST(SampleDirection, ChiSquareFullSphere) {
  const DirectionSpec d;
  const auto r = direction_fit(
      d, 10, 10, [&](int i) { return direction_from_stream(d, 2, i); }, "direction full sphere");
  EXPECT_GT(r.p_value, kMinP);
}

TEST(SampleDirection, ChiSquareRejectsUniformElevation) {
  // A plausible bug: elevation uniform in angle instead of in its sine. Must give p < 1e-6.
  DirectionSpec d;
  d.elevation_min_deg = 10;
  d.elevation_max_deg = 60;
  const auto wrong = [&](int i) {
    const RandomStream rng(kSeed, 3, static_cast<std::uint64_t>(i));
    const double el = (10.0 + 50.0 * rng.uniform(kSlotDirection, 0)) * kDegToRad;
    const double az = (-180.0 + 360.0 * rng.uniform(kSlotDirection, 1)) * kDegToRad;
    return Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  };
  const auto r = direction_fit(d, 10, 10, wrong, "REJECT uniform elevation angle");
  EXPECT_LT(r.p_value, 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Uniform rotation (Shoemake 1992)

Quat rotation_from_stream(std::uint32_t group, int i) {
  const RandomStream rng(kSeed, group, static_cast<std::uint64_t>(i));
  return uniform_rotation(rng.uniform(kSlotOrientation, 0), rng.uniform(kSlotOrientation, 1),
                          rng.uniform(kSlotOrientation2, 0));
}

TEST(UniformRotation, UnitNorm) {
  // |q| = 1 to 1e-15 for 100k draws, and at the extreme uniforms.
  double worst = 0.0;
  for (int i = 0; i < kSamples; ++i)
    worst = std::max(worst, std::fabs(rotation_from_stream(4, i).norm() - 1.0));
  for (double u : {0x1p-54, 0.5, 1.0 - 0x1p-54}) {
    worst = std::max(worst, std::fabs(uniform_rotation(u, u, u).norm() - 1.0));
  }
  std::printf("[ measured ] uniform_rotation worst | |q| - 1 |: %.3g\n", worst);
  EXPECT_LE(worst, 1e-15);
}

TEST(UniformRotation, RotatedAxesUniformOnSphere) {
  // Under a Haar-uniform rotation every body axis points uniformly on the sphere: test the
  // rotated x axis and z axis in 10 x 10 equal-area cells.
  const DirectionSpec full;
  const auto rx = direction_fit(
      full, 10, 10, [](int i) { return Vec3(rotation_from_stream(5, i) * Vec3::UnitX()); },
      "uniform_rotation: rotated x axis");
  EXPECT_GT(rx.p_value, kMinP);
  const auto rz = direction_fit(
      full, 10, 10, [](int i) { return Vec3(rotation_from_stream(5, i) * Vec3::UnitZ()); },
      "uniform_rotation: rotated z axis");
  EXPECT_GT(rz.p_value, kMinP);
}

TEST(UniformRotation, ChiSquareRejectsUniformEulerAngles) {
  // The classic mistake: yaw, pitch, roll each uniform. The nose then crowds the poles.
  const DirectionSpec full;
  const auto wrong = [](int i) {
    const RandomStream rng(kSeed, 6, static_cast<std::uint64_t>(i));
    FrameSpec f;
    f.yaw_deg = 360.0 * rng.uniform(kSlotOrientation, 0) - 180.0;
    f.pitch_deg = 180.0 * rng.uniform(kSlotOrientation, 1) - 90.0;
    f.roll_deg = 360.0 * rng.uniform(kSlotOrientation2, 0) - 180.0;
    return Vec3(frame_rotation(f) * Vec3::UnitX());
  };
  const auto r = direction_fit(full, 10, 10, wrong, "REJECT uniform Euler angles");
  EXPECT_LT(r.p_value, 1e-6);
}

// ---------------------------------------------------------------------------------------------
// sample_fragment

FragmentGroupSpec test_group() {
  FragmentGroupSpec g;
  g.name = "casing";
  g.count = 250.0;
  g.samples = 1000;
  g.frame.origin_m = Vec3(100.0, -20.0, 3.5);
  g.frame.yaw_deg = 30.0;
  g.frame.pitch_deg = 10.0;
  g.frame.roll_deg = 5.0;
  g.shape.type = ShapeType::kEllipsoid;
  g.shape.density_kg_m3 = 7850.0;
  g.shape.aspect = {1.0, 1.5, 3.0};
  g.mass_kg.kind = Distribution::Kind::kLognormal;
  g.mass_kg.median = 0.05;
  g.mass_kg.sigma_ln = 0.8;
  g.speed_mps.kind = Distribution::Kind::kNormal;
  g.speed_mps.mean = 900.0;
  g.speed_mps.sigma = 80.0;
  g.direction.elevation_min_deg = -10.0;
  g.direction.elevation_max_deg = 40.0;
  g.direction.azimuth_min_deg = -60.0;
  g.direction.azimuth_max_deg = 60.0;
  g.spin_radps.kind = Distribution::Kind::kUniform;
  g.spin_radps.min = 0.0;
  g.spin_radps.max = 200.0;
  return g;
}

// Every field; the orientation too unless `same_orientation` is false.
void expect_identical(const FragmentInit& a, const FragmentInit& b, bool same_orientation = true) {
  EXPECT_EQ(a.group, b.group);
  EXPECT_EQ(a.history, b.history);
  EXPECT_EQ(a.weight, b.weight);
  EXPECT_EQ(a.shape, b.shape);
  EXPECT_EQ(a.body.mass_kg, b.body.mass_kg);
  EXPECT_EQ(a.body.dims_m, b.body.dims_m);
  EXPECT_EQ(a.body.inertia_kg_m2, b.body.inertia_kg_m2);
  EXPECT_EQ(a.body.surface_m2, b.body.surface_m2);
  EXPECT_EQ(a.body.presented_area_m2, b.body.presented_area_m2);
  EXPECT_EQ(a.position_m, b.position_m);
  EXPECT_EQ(a.velocity_mps, b.velocity_mps);
  if (same_orientation) {
    EXPECT_EQ(a.orientation.coeffs(), b.orientation.coeffs());
  }
  EXPECT_EQ(a.omega_body_radps, b.omega_body_radps);
  EXPECT_EQ(a.launch_speed_mps, b.launch_speed_mps);
  EXPECT_EQ(a.launch_direction, b.launch_direction);
}

TEST(SampleFragment, DeterministicBitIdentical) {
  const auto g = test_group();
  for (std::uint64_t h : {0ull, 1ull, 999ull, 1ull << 40}) {
    expect_identical(sample_fragment(g, 2, h, kSeed), sample_fragment(g, 2, h, kSeed));
  }
}

TEST(SampleFragment, GroupLaunchConstantsGiveThePerHistoryDraw) {
  // The run's path: the group's launch constants (truncated mass and speed distributions, frame,
  // elevation bounds) computed once, reused for many histories, against the slot contract's
  // per-history values; and a slot's two variates read from one block as a pair.
  const auto g = test_group();
  const GroupLaunch launch(g);
  for (std::uint64_t h : {0ull, 17ull, 123456ull}) {
    const auto f = sample_fragment(launch, 2, h, kSeed);
    const RandomStream rng(kSeed, 2, h);
    EXPECT_EQ(f.body.mass_kg,
              g.mass_kg.sample(rng.uniform(kSlotMass), kMassRange.lo, kMassRange.hi));
    EXPECT_EQ(f.launch_speed_mps,
              g.speed_mps.sample(rng.uniform(kSlotSpeed), kSpeedRange.lo, kSpeedRange.hi));
    const Vec3 dir = sample_direction(g.direction, rng.uniform(kSlotDirection, 0),
                                      rng.uniform(kSlotDirection, 1));
    EXPECT_EQ(f.launch_direction, Vec3(frame_rotation(g.frame) * dir));
    for (std::uint32_t slot : {kSlotDirection, kSlotOrientation, kSlotSpinAxis}) {
      const auto u = rng.uniform_pair(slot);
      EXPECT_EQ(u[0], rng.uniform(slot, 0));
      EXPECT_EQ(u[1], rng.uniform(slot, 1));
    }
  }
}

TEST(SampleFragment, HistoriesGroupsAndSeedsDiffer) {
  const auto g = test_group();
  const auto a = sample_fragment(g, 2, 7, kSeed);
  for (const auto& b : {sample_fragment(g, 2, 8, kSeed), sample_fragment(g, 3, 7, kSeed),
                        sample_fragment(g, 2, 7, kSeed + 1)}) {
    EXPECT_NE(a.body.mass_kg, b.body.mass_kg);
    EXPECT_NE(a.launch_speed_mps, b.launch_speed_mps);
    EXPECT_NE(a.launch_direction, b.launch_direction);
    EXPECT_NE(a.orientation.coeffs(), b.orientation.coeffs());
    EXPECT_NE(a.omega_body_radps, b.omega_body_radps);
  }
}

TEST(SampleFragment, SlotContract) {
  // Each variable is the group's distribution applied to its fixed slot of the history's stream.
  const auto g = test_group();
  const std::uint32_t gi = 4;
  const std::uint64_t h = 12345;
  const auto f = sample_fragment(g, gi, h, kSeed);
  const RandomStream rng(kSeed, gi, h);
  EXPECT_EQ(f.body.mass_kg, g.mass_kg.sample(rng.uniform(kSlotMass), kMassRange.lo, kMassRange.hi));
  EXPECT_EQ(f.launch_speed_mps,
            g.speed_mps.sample(rng.uniform(kSlotSpeed), kSpeedRange.lo, kSpeedRange.hi));
  const Vec3 dir =
      sample_direction(g.direction, rng.uniform(kSlotDirection, 0), rng.uniform(kSlotDirection, 1));
  expect_vec_near(f.launch_direction, frame_rotation(g.frame) * dir, 1e-15);
  const double spin = g.spin_radps.sample(rng.uniform(kSlotSpin, 0), 0.0, 1e300);
  EXPECT_NEAR(f.omega_body_radps.norm(), spin, 1e-13 * spin);
  EXPECT_EQ(f.group, gi);
  EXPECT_EQ(f.history, h);
  EXPECT_EQ(f.shape, ShapeType::kEllipsoid);
}

TEST(SampleFragment, FixedOrRandomDoesNotShiftOtherVariables) {
  // Making mass and speed fixed leaves direction, orientation and spin unchanged (fixed slots).
  auto g = test_group();
  const auto a = sample_fragment(g, 1, 42, kSeed);
  g.mass_kg = Distribution::fixed(0.1);
  g.speed_mps = Distribution::fixed(500.0);
  const auto b = sample_fragment(g, 1, 42, kSeed);
  EXPECT_EQ(b.body.mass_kg, 0.1);
  EXPECT_EQ(b.launch_speed_mps, 500.0);
  EXPECT_EQ(a.launch_direction, b.launch_direction);
  EXPECT_EQ(a.orientation.coeffs(), b.orientation.coeffs());
  EXPECT_EQ(a.omega_body_radps, b.omega_body_radps);
}

TEST(SampleFragment, FrameVelocityPositionAndWeight) {
  auto g = test_group();
  const auto still = sample_fragment(g, 0, 5, kSeed);
  g.frame.velocity_mps = Vec3(30.0, -12.0, 4.0);
  const auto moving = sample_fragment(g, 0, 5, kSeed);
  // Same explosion-induced part; the frame velocity adds (tolerance 1e-12 m/s on ~1000 m/s).
  EXPECT_EQ(still.launch_direction, moving.launch_direction);
  EXPECT_EQ(still.launch_speed_mps, moving.launch_speed_mps);
  expect_vec_near(moving.velocity_mps - still.velocity_mps, g.frame.velocity_mps, 1e-12);
  expect_vec_near(moving.velocity_mps,
                  moving.launch_speed_mps * moving.launch_direction + g.frame.velocity_mps, 1e-12);
  EXPECT_NEAR(moving.launch_direction.norm(), 1.0, 1e-15);
  EXPECT_EQ(moving.position_m, g.frame.origin_m);
  EXPECT_EQ(moving.weight, 0.25);  // count 250 / samples 1000
  g.count = 1.0;
  g.samples = 3;
  EXPECT_EQ(sample_fragment(g, 0, 5, kSeed).weight, 1.0 / 3.0);
}

TEST(SampleFragment, FrameOrientsTheLaunch) {
  // Direction pinned to local +x (zero-width ranges); yaw 90 sends it to site +y.
  auto g = test_group();
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = 0.0;
  g.direction.azimuth_min_deg = g.direction.azimuth_max_deg = 0.0;
  g.frame.yaw_deg = 90.0;
  g.frame.pitch_deg = g.frame.roll_deg = 0.0;
  const auto f = sample_fragment(g, 0, 0, kSeed);
  expect_vec_near(f.launch_direction, Vec3::UnitY(), 1e-15);
}

// Largest entry of |a - b|.
double max_abs_difference(const Mat3& a, const Mat3& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

TEST(SampleFragment, DefaultAttitudeIsTheUniformRotationOfTheSlots) {
  // Without `attitude` the orientation is, bit for bit, the frame times Shoemake's rotation of the
  // two orientation slots, as before the key existed.
  const auto g = test_group();
  ASSERT_FALSE(g.attitude.has_value());
  for (std::uint32_t gi : {0u, 3u}) {
    for (std::uint64_t h : {0ull, 1ull, 77ull, 1ull << 40}) {
      const RandomStream rng(kSeed, gi, h);
      const Quat q_local =
          uniform_rotation(rng.uniform(kSlotOrientation, 0), rng.uniform(kSlotOrientation, 1),
                           rng.uniform(kSlotOrientation2, 0));
      const Quat want = (Quat(frame_rotation(g.frame)) * q_local).normalized();
      EXPECT_EQ(sample_fragment(g, gi, h, kSeed).orientation.coeffs(), want.coeffs())
          << "group " << gi << " history " << h;
    }
  }
}

TEST(SampleFragment, FixedAttitudeIsFrameTimesAttitude) {
  // Every history gets R_frame * R_attitude (tolerance 1e-15: one matrix-quaternion-matrix round
  // trip of a product of rotations).
  auto g = test_group();
  for (const AttitudeSpec a : {AttitudeSpec{}, AttitudeSpec{20.0, -35.0, 70.0},
                               AttitudeSpec{-170.0, 89.0, -120.0}, AttitudeSpec{0.0, 90.0, 0.0}}) {
    g.attitude = a;
    const Mat3 want = frame_rotation(g.frame) * attitude_rotation(a);
    double worst = 0.0;
    for (std::uint64_t h = 0; h < 200; ++h) {
      const Mat3 got = sample_fragment(g, 1, h, kSeed).orientation.toRotationMatrix();
      worst = std::max(worst, max_abs_difference(got, want));
    }
    std::printf("[ measured ] attitude (%g, %g, %g): worst |R - R_frame R_attitude| %.3g\n",
                a.yaw_deg, a.pitch_deg, a.roll_deg, worst);
    EXPECT_LE(worst, 1e-15);
  }
}

TEST(SampleFragment, ZeroAttitudeInALevelFrameAlignsBodyWithSite) {
  // A cuboid [a, b, c] lies on its a x b face: body z = site z, body x = site x.
  auto g = test_group();
  g.frame.yaw_deg = g.frame.pitch_deg = g.frame.roll_deg = 0.0;
  g.attitude = AttitudeSpec{};
  const Mat3 r = sample_fragment(g, 0, 9, kSeed).orientation.toRotationMatrix();
  EXPECT_LE(max_abs_difference(r, Mat3::Identity()), 1e-15);
  // Pitch 90 stands the body's x axis up.
  g.attitude = AttitudeSpec{0.0, 90.0, 0.0};
  expect_vec_near(sample_fragment(g, 0, 9, kSeed).orientation * Vec3::UnitX(), Vec3::UnitZ(),
                  1e-15);
}

TEST(SampleFragment, FixedAttitudeDoesNotShiftOtherVariables) {
  // A fixed attitude only skips the orientation slots: mass, size, speed, direction and spin are
  // bit-identical with and without it.
  auto g = test_group();
  auto fixed = g;
  fixed.attitude = AttitudeSpec{10.0, 20.0, 30.0};
  for (std::uint64_t h : {0ull, 5ull, 4242ull}) {
    const auto a = sample_fragment(g, 2, h, kSeed);
    const auto b = sample_fragment(fixed, 2, h, kSeed);
    expect_identical(a, b, /*same_orientation=*/false);
    EXPECT_NE(a.orientation.coeffs(), b.orientation.coeffs());
  }
}

TEST(SampleFragment, MassPropertiesFollowTheSampledMass) {
  const auto g = test_group();
  for (std::uint64_t h = 0; h < 100; ++h) {
    const auto f = sample_fragment(g, 0, h, kSeed);
    // Density-scaled ellipsoid: volume pi abc / 6 = m / rho to 1e-14.
    const double v = kPi / 6.0 * f.body.dims_m.prod();
    EXPECT_NEAR(v, f.body.mass_kg / 7850.0, 1e-14 * v);
    EXPECT_NEAR(f.body.dims_m[2] / f.body.dims_m[0], 3.0, 1e-14);
    EXPECT_NEAR(f.orientation.norm(), 1.0, 1e-15);
  }
}

TEST(SampleFragment, NeverNaNForValidGroups) {
  // A spread of valid groups, including a point mass, a table speed, polar direction ranges and
  // a normal mass truncated by the physical range (0, inf) near zero.
  std::vector<FragmentGroupSpec> groups;
  groups.push_back(test_group());
  {
    auto g = test_group();
    g.shape = ShapeSpec{};
    g.shape.type = ShapeType::kPoint;
    g.area_m2 = 0.002;
    g.mass_kg = Distribution{};
    g.mass_kg.kind = Distribution::Kind::kNormal;
    g.mass_kg.mean = 0.001;
    g.mass_kg.sigma = 0.01;
    g.direction.elevation_min_deg = 90.0;
    g.direction.elevation_max_deg = 90.0;
    groups.push_back(g);
  }
  {
    auto g = test_group();
    g.shape = ShapeSpec{};
    g.shape.type = ShapeType::kCylinder;
    g.shape.dims_m = {0.02, 0.1};
    g.speed_mps = Distribution{};
    g.speed_mps.kind = Distribution::Kind::kTable;
    g.speed_mps.table_values = {0.0, 100.0, 200.0, 1500.0};
    g.speed_mps.table_cdf = {0.0, 0.0, 0.5, 1.0};
    g.direction = DirectionSpec{};
    g.spin_radps = Distribution::fixed(0.0);
    groups.push_back(g);
  }
  int bad = 0;
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    for (std::uint64_t h = 0; h < 20000; ++h) {
      const auto f = sample_fragment(groups[gi], static_cast<std::uint32_t>(gi), h, kSeed);
      const bool ok = f.velocity_mps.allFinite() && f.orientation.coeffs().allFinite() &&
                      f.omega_body_radps.allFinite() && f.body.inertia_kg_m2.allFinite() &&
                      std::isfinite(f.body.presented_area_m2) && f.body.mass_kg > 0.0 &&
                      f.body.presented_area_m2 > 0.0 && f.launch_speed_mps >= 0.0;
      bad += !ok;
    }
  }
  EXPECT_EQ(bad, 0);
}

TEST(SampleFragment, NoHeapAllocation) {
  // Runs once per history in the hot loop: must not allocate (counted by the global operator new
  // above). Table distributions and density-scaled ellipsoids exercise the heaviest paths.
  auto g = test_group();
  g.speed_mps = Distribution{};
  g.speed_mps.kind = Distribution::Kind::kTable;
  g.speed_mps.table_values = {100.0, 200.0, 1500.0};
  g.speed_mps.table_cdf = {0.0, 0.5, 1.0};
  double sink = sample_fragment(g, 0, 0, kSeed).body.mass_kg;  // warm-up
  const long before = g_heap_allocations.load();
  for (std::uint64_t h = 1; h <= 1000; ++h) sink += sample_fragment(g, 0, h, kSeed).body.mass_kg;
  const long after = g_heap_allocations.load();
  EXPECT_EQ(after - before, 0);
  EXPECT_GT(sink, 0.0);
  // The counter works: a vector allocates.
  std::vector<double>* v = new std::vector<double>(10);
  EXPECT_GT(g_heap_allocations.load(), after);
  delete v;
}

}  // namespace
}  // namespace fragsim::fragments
