// Whole histories (run::run, bounce on) in the ground phase (core/impact/ground_phase.h;
// docs/physics.md, "Ground phase"): what a fragment does once it is on the terrain, checked
// against closed forms or against independent references written here (fixed-step RK4 of the
// 1-D equations of motion), through the full pipeline: sampling (fixed attitudes), the launch on
// the ground, records (fragments, trajectories with events) and outcomes.
//
// Steel bodies (7850 kg/m^3), a constant atmosphere of 1.225 kg/m^3 (flat_site_scenario). Each
// test states its tolerance. Set FRAGSIM_VALIDATION_VERBOSE=1 to print the measured errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/run/run.h"
#include "scenario_fixtures.h"

namespace fragsim::validation {
namespace {

constexpr double g = kStandardGravity_mps2;
constexpr double kRho = 1.225;  // flat_site_scenario's constant atmosphere
constexpr double kSteel = 7850.0;

// A measured figure, printed when FRAGSIM_VALIDATION_VERBOSE is set.
void measured(const std::string& what, double value) {
  if (std::getenv("FRAGSIM_VALIDATION_VERBOSE") != nullptr)
    std::printf("[ measured ] %s = %.3e\n", what.c_str(), value);
}

// Bounce on, every record kept, every history followed to its end (no harmless cut-off).
run::Scenario ground_scenario(double half_m, double cell_m, double mu, double mu_r, double e) {
  run::Scenario sc = flat_site_scenario(half_m, cell_m);
  scene::MaterialSpec& m = sc.site.materials["soil"];
  m.friction = mu;
  m.rolling_resistance = mu_r;
  m.restitution.constant = e;
  sc.settings.bounce = true;
  sc.settings.record_fragments = true;
  sc.settings.harmless_cutoff = false;
  return sc;
}

// A steel block [a, b, c] with centre `centre`, velocity `v` (the frame's velocity; launch speed
// 0) and a fixed attitude relative to the (identity unless changed) frame.
fragments::FragmentGroupSpec block_group(const Vec3& centre, const std::array<double, 3>& dims,
                                         const Vec3& v, const fragments::AttitudeSpec& att = {},
                                         std::int64_t samples = 2) {
  fragments::FragmentGroupSpec grp =
      sphere_group(centre, kSteel * dims[0] * dims[1] * dims[2], 0.0, 1.0, samples);
  grp.name = "block";
  grp.shape.type = fragments::ShapeType::kCuboid;
  grp.shape.density_kg_m3.reset();
  grp.shape.dims_m = {dims[0], dims[1], dims[2]};
  grp.frame.velocity_mps = v;
  grp.attitude = att;
  return grp;
}

// A steel sphere of mass m with centre `centre` and velocity `v`, no spin.
fragments::FragmentGroupSpec ball_group(const Vec3& centre, double mass_kg, const Vec3& v,
                                        std::int64_t samples = 2) {
  fragments::FragmentGroupSpec grp = sphere_group(centre, mass_kg, 0.0, 1.0, samples);
  grp.frame.velocity_mps = v;
  grp.attitude = fragments::AttitudeSpec{};
  return grp;
}

double ball_radius(double mass_kg) {
  return std::cbrt(3.0 * mass_kg / (4.0 * kPi * kSteel));
}

// R = Rz(yaw) Ry(-pitch) Rx(roll) (degrees), the frame's and the attitude's convention, written
// out here independently of the library.
Mat3 ypr(double yaw_deg, double pitch_deg, double roll_deg) {
  return (Eigen::AngleAxisd(yaw_deg * kDegToRad, Vec3::UnitZ()) *
          Eigen::AngleAxisd(-pitch_deg * kDegToRad, Vec3::UnitY()) *
          Eigen::AngleAxisd(roll_deg * kDegToRad, Vec3::UnitX()))
      .toRotationMatrix();
}

// Clearance of a block (half extents h, body -> site rotation R) above a plane with unit normal
// n: its support extent toward -n.
double block_clearance(const Vec3& half, const Mat3& R, const Vec3& n) {
  const Vec3 nb = R.transpose() * n;
  return half.x() * std::abs(nb.x()) + half.y() * std::abs(nb.y()) + half.z() * std::abs(nb.z());
}

// Yaw and pitch (degrees) of a frame whose z axis is the unit normal n (its x axis up the fall
// line): body z = (-sin p cos y, -sin p sin y, cos p) under ypr(y, p, 0).
std::array<double, 2> yaw_pitch_of_normal(const Vec3& n) {
  const double yaw = (std::abs(n.x()) + std::abs(n.y()) > 0.0) ? std::atan2(-n.y(), -n.x()) : 0.0;
  return {yaw / kDegToRad, std::acos(std::clamp(n.z(), -1.0, 1.0)) / kDegToRad};
}

// A mesh z = f(x, y) sampled on a lattice over [x0, x1] x [y0, y1] (two triangles per cell).
scene::MeshSpec lattice_mesh(double x0, double x1, double y0, double y1, double cell,
                             const std::function<double(double, double)>& f) {
  scene::MeshSpec mesh;
  const int nx = static_cast<int>(std::lround((x1 - x0) / cell)) + 1;
  const int ny = static_cast<int>(std::lround((y1 - y0) / cell)) + 1;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double x = x0 + cell * i, y = y0 + cell * j;
      mesh.vertices_m.emplace_back(x, y, f(x, y));
    }
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const std::int64_t v00 = j * nx + i, v10 = v00 + 1, v01 = v00 + nx, v11 = v01 + 1;
      mesh.triangles.push_back({v00, v10, v11});
      mesh.triangles.push_back({v00, v11, v01});
    }
  return mesh;
}

// The terrain's facet under (x, y) (input coordinates) of a built site: the surface point and the
// facet's unit normal, in input coordinates.
struct Facet {
  Vec3 point;
  Vec3 normal;
  // The centre of a body whose clearance above this facet's plane is `clearance`, straight above
  // the point (so that the facet is the one under the centre, where the launch looks).
  Vec3 centre(double clearance) const { return point + clearance / normal.z() * Vec3::UnitZ(); }
};
Facet facet_at(const scene::Site& site, double x, double y) {
  const Vec3 local = site.to_local(Vec3(x, y, 0.0));
  const std::int64_t tri = site.terrain_triangle_at(local.x(), local.y());
  EXPECT_GE(tri, 0);
  const double h = site.terrain_height(local.x(), local.y());
  return {site.to_input(Vec3(local.x(), local.y(), h)),
          site.terrain_triangle_normal(static_cast<std::uint32_t>(tri))};
}

// ---- 1. Sliding on level ground ----

// A block lying on its a x b face (attitude 0), launched on the ground along it: no drop, no
// impact, it slides to rest. Coulomb friction and drag, dv/dt = -mu g - k v^2 with
// k = rho Cd A / (2m), A its frontal area along the motion d = (0.6, 0.8, 0) on the ground (G14):
// |d_x| b c + |d_y| a c (the flight's area is surface / 4):
//   distance = ln(1 + k v0^2 / (mu g)) / (2k),  time = atan(v0 sqrt(k / (mu g))) / sqrt(mu g k);
// without drag v0^2 / (2 mu g) and v0 / (mu g). Tolerance: 1 % (the issue's); the model
// integrates at rtol 1e-6 and is expected far closer.
TEST(GroundPhaseHistory, BlockSlidesOnLevelGroundToTheCoulombDragDistance) {
  const double mu = 0.5;
  const std::array<double, 3> dims{0.1, 0.06, 0.02};
  const double m = kSteel * dims[0] * dims[1] * dims[2];
  const double area = 0.5 * (dims[0] * dims[1] + dims[1] * dims[2] + dims[2] * dims[0]);
  const Vec3 dir(0.6, 0.8, 0.0);
  const double ground_area = dir.x() * dims[1] * dims[2] + dir.y() * dims[0] * dims[2];
  double worst_d = 0.0, worst_t = 0.0;
  for (const double cd : {1.0, 0.0}) {
    for (const double v0 : {20.0, 80.0, 150.0}) {
      const double k = kRho * cd * ground_area / (2.0 * m);
      const double d =
          cd > 0.0 ? std::log(1.0 + k * v0 * v0 / (mu * g)) / (2.0 * k) : v0 * v0 / (2.0 * mu * g);
      const double t = cd > 0.0 ? std::atan(v0 * std::sqrt(k / (mu * g))) / std::sqrt(mu * g * k)
                                : v0 / (mu * g);
      run::Scenario sc = ground_scenario(1500.0, 25.0, mu, 0.1, 0.3);
      const Vec3 p0 = Vec3(0.37, -0.21, 0.5 * dims[2]) - 0.5 * d * dir;  // the path centred
      fragments::FragmentGroupSpec grp = block_group(p0, dims, v0 * dir);
      grp.cd.constant = cd;
      sc.groups = {grp};
      const run::RunResult r = run::run(sc);
      ASSERT_EQ(r.fragments.size(), 2u);
      EXPECT_EQ(r.stats.ground_step_caps, 0);
      const std::string tag = "cd " + std::to_string(cd) + " v0 " + std::to_string(v0);
      for (const auto& f : r.fragments) {
        EXPECT_EQ(f.outcome, run::Outcome::kGround) << tag;
        EXPECT_EQ(f.bounces, 0u) << tag;  // started on the ground: no impact
        EXPECT_EQ(f.ground_impacts, 0u) << tag;
        EXPECT_EQ(f.takeoffs, 0u) << tag;
        EXPECT_NEAR(f.area_m2, area, 1e-12 * area) << tag;  // the flight's: surface / 4
        const Vec3 moved = f.end_position_m - p0;
        const double along = moved.dot(dir);
        EXPECT_NEAR(along, d, 0.01 * d) << tag;
        EXPECT_NEAR(f.ground_path_m, d, 0.01 * d) << tag;
        EXPECT_NEAR(f.end_time_s, t, 0.01 * t) << tag;
        EXPECT_LT(std::abs(moved.x() * dir.y() - moved.y() * dir.x()), 1e-6 * d)
            << tag;                                                     // straight
        EXPECT_NEAR(f.end_position_m.z(), 0.5 * dims[2], 1e-6) << tag;  // on its face throughout
        worst_d = std::max(worst_d, std::abs(along - d) / d);
        worst_t = std::max(worst_t, std::abs(f.end_time_s - t) / t);
      }
    }
  }
  measured("slide: distance rel. error", worst_d);
  measured("slide: time rel. error", worst_t);
}

// ---- 2. Slip, then roll ----

struct SlipRoll {
  double t_slip, v_slip, x_slip;  // end of the slip
  double t_end, x_end;            // rest
};

// Independent reference for a sphere launched at v0 without spin on level ground (I = 2/5 m R^2):
// slip, x' = v, v' = -mu g - k v^2, (omega R)' = 5/2 mu g, until v = omega R; then roll,
// v' = -5/7 (mu_r g + k v^2), to rest. Fixed-step RK4 at h = 1e-4 s (the motion's time scales are
// > 0.1 s: truncation ~1e-14 relative); the slip end and the stop are interpolated linearly
// within their step (error ~ a h^2 ~ 1e-7 m).
SlipRoll slip_then_roll_reference(double v0, double mu, double mu_r, double k) {
  using S = std::array<double, 3>;  // x, v, u = omega R
  const double h = 1e-4;
  const auto rk4 = [h](const S& y, const std::function<S(const S&)>& f) {
    const auto add = [](const S& a, const S& b, double s) {
      return S{a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]};
    };
    const S k1 = f(y), k2 = f(add(y, k1, h / 2)), k3 = f(add(y, k2, h / 2)), k4 = f(add(y, k3, h));
    S out;
    for (int i = 0; i < 3; ++i) out[i] = y[i] + h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
    return out;
  };
  const auto slip = [&](const S& y) { return S{y[1], -mu * g - k * y[1] * y[1], 2.5 * mu * g}; };
  const auto roll = [&](const S& y) {
    return S{y[1], -5.0 / 7.0 * (mu_r * g + k * y[1] * y[1]), 0.0};
  };
  SlipRoll out{};
  S y{0.0, v0, 0.0};
  double t = 0.0;
  for (;;) {
    const S n = rk4(y, slip);
    const double s0 = y[1] - y[2], s1 = n[1] - n[2];
    if (s1 <= 0.0) {
      const double f = s0 / (s0 - s1);
      out.t_slip = t + f * h;
      out.x_slip = y[0] + f * (n[0] - y[0]);
      out.v_slip = y[1] + f * (n[1] - y[1]);
      break;
    }
    y = n;
    t += h;
  }
  // The roll from the slip's end state (restarted there: the law changes at that instant).
  y = S{out.x_slip, out.v_slip, 0.0};
  t = out.t_slip;
  for (;;) {
    const S n = rk4(y, roll);
    if (n[1] <= 0.0) {
      const double f = y[1] / (y[1] - n[1]);
      out.t_end = t + f * h;
      out.x_end = y[0] + f * (n[0] - y[0]);
      break;
    }
    y = n;
    t += h;
  }
  return out;
}

// A steel ball (1 kg) launched on level ground sliding without spin: friction at the contact
// point slows it and spins it up until it rolls, then rolling resistance stops it. Without drag
// (textbook): slip ends at t1 = 2 v0 / (7 mu g) after 12 v0^2 / (49 mu g) at 5/7 v0, then it rolls
// (5/7 v0)^2 / (2 * 5/7 mu_r g). With drag: against the RK4 reference above. The end of the slip
// is found in the trajectory record where the deceleration drops (slip: >= mu g; roll: 5/7 (mu_r
// g + k v^2), below mu g / 2 here). Tolerance 1 % on every figure (the issue's).
TEST(GroundPhaseHistory, BallSlipsThenRollsToTheReferenceDistance) {
  const double mu = 0.4, mu_r = 0.05, mass = 1.0;
  const double R = ball_radius(mass);
  const double area = kPi * R * R;
  const Vec3 dir(-0.8, 0.6, 0.0);
  double worst = 0.0;
  for (const double cd : {0.0, 1.0}) {
    for (const double v0 : {5.0, 15.0, 30.0}) {
      const double k = kRho * cd * area / (2.0 * mass);
      SlipRoll ref{};
      if (cd == 0.0) {
        ref.t_slip = 2.0 * v0 / (7.0 * mu * g);
        ref.x_slip = 12.0 * v0 * v0 / (49.0 * mu * g);
        ref.v_slip = 5.0 / 7.0 * v0;
        ref.x_end = ref.x_slip + ref.v_slip * ref.v_slip / (2.0 * 5.0 / 7.0 * mu_r * g);
        ref.t_end = ref.t_slip + ref.v_slip / (5.0 / 7.0 * mu_r * g);
        // The RK4 reference agrees with the closed form (a check of the reference itself).
        const SlipRoll rk = slip_then_roll_reference(v0, mu, mu_r, 0.0);
        EXPECT_NEAR(rk.x_end, ref.x_end, 1e-6 * ref.x_end);
        EXPECT_NEAR(rk.v_slip, ref.v_slip, 1e-9 * ref.v_slip);
      } else {
        ref = slip_then_roll_reference(v0, mu, mu_r, k);
        // Drag matters by more than the tolerance (2.6 % at 5 m/s, far more at 30 m/s).
        EXPECT_LT(ref.x_end, 0.98 * slip_then_roll_reference(v0, mu, mu_r, 0.0).x_end);
      }
      run::Scenario sc = ground_scenario(1500.0, 25.0, mu, mu_r, 0.3);
      sc.settings.record_trajectories = true;
      const Vec3 p0 = Vec3(0.41, 0.23, R) - 0.5 * ref.x_end * dir;
      fragments::FragmentGroupSpec grp = ball_group(p0, mass, v0 * dir);
      grp.cd.constant = cd;
      sc.groups = {grp};
      const run::RunResult r = run::run(sc);
      ASSERT_EQ(r.fragments.size(), 2u);
      ASSERT_EQ(r.trajectories.size(), 2u);
      EXPECT_EQ(r.stats.ground_step_caps, 0);
      const std::string tag = "cd " + std::to_string(cd) + " v0 " + std::to_string(v0);
      for (std::size_t h = 0; h < 2; ++h) {
        const auto& f = r.fragments[h];
        const auto& tr = r.trajectories[h];
        EXPECT_EQ(f.outcome, run::Outcome::kGround) << tag;
        EXPECT_EQ(f.bounces, 0u) << tag;
        EXPECT_EQ(f.takeoffs, 0u) << tag;
        const double along = (f.end_position_m - p0).dot(dir);
        EXPECT_NEAR(along, ref.x_end, 0.01 * ref.x_end) << tag;
        EXPECT_NEAR(f.ground_path_m, ref.x_end, 0.01 * ref.x_end) << tag;
        EXPECT_NEAR(f.end_time_s, ref.t_end, 0.01 * ref.t_end) << tag;
        EXPECT_NEAR(f.end_position_m.z(), R, 1e-6) << tag;
        worst = std::max({worst, std::abs(along - ref.x_end) / ref.x_end,
                          std::abs(f.end_time_s - ref.t_end) / ref.t_end});
        // The slip's end in the record: the last point ending a piece decelerating faster than
        // mu g / 2; every piece before it slips, every piece after it rolls.
        const std::size_t n = tr.t_s.size();
        ASSERT_GE(n, 4u) << tag;
        std::vector<int> slipping;  // per piece (i-1, i), i >= 1; -1 for a zero-length piece
        for (std::size_t i = 1; i < n; ++i) {
          const double dt = tr.t_s[i] - tr.t_s[i - 1];
          if (!(dt > 1e-9)) {
            slipping.push_back(-1);
            continue;
          }
          const double dec = (tr.velocity_mps[i - 1].norm() - tr.velocity_mps[i].norm()) / dt;
          slipping.push_back(dec > 0.5 * mu * g ? 1 : 0);
        }
        std::size_t j = 0;  // the slip's last point
        for (std::size_t i = 1; i < n; ++i)
          if (slipping[i - 1] == 1) j = i;
        ASSERT_GT(j, 0u) << tag;
        for (std::size_t i = 1; i < n; ++i) {
          if (slipping[i - 1] < 0) continue;
          EXPECT_EQ(slipping[i - 1], i <= j ? 1 : 0) << tag << " piece " << i;
        }
        const double v_slip = tr.velocity_mps[j].norm();
        EXPECT_NEAR(v_slip, ref.v_slip, 0.01 * ref.v_slip) << tag;
        EXPECT_NEAR(tr.t_s[j], ref.t_slip, 0.01 * ref.t_slip) << tag;
        const double x_slip = (tr.position_m[j] - p0).dot(dir);
        EXPECT_NEAR(x_slip, ref.x_slip, 0.01 * ref.x_slip) << tag;
        worst = std::max({worst, std::abs(v_slip - ref.v_slip) / ref.v_slip,
                          std::abs(tr.t_s[j] - ref.t_slip) / ref.t_slip,
                          std::abs(x_slip - ref.x_slip) / ref.x_slip});
      }
    }
  }
  measured("slip-roll: worst rel. error", worst);
}

// ---- 3, 4. Slopes ----

// A grid terrain z = x tan(theta) over [-100, 100]^2 (10 m cells).
scene::GridTerrainSpec slope_grid(double theta) {
  return square_grid(-100.0, 21, [&](int i, int) { return std::tan(theta) * (-100.0 + 10.0 * i); });
}

// Below the friction angle (mu 0.5: 26.57 deg) a block put down on its face with a small velocity
// along the slope, in any of 8 directions, stops and stays. Its speed falls at least at
// g (mu cos - sin) (friction against the motion, gravity's along-slope pull at most g sin), so it
// travels at most v^2 / (2 g (mu cos - sin)) (0.67 mm at 25 deg from 2 cm/s); asserted: that bound
// (+ 1 um: the rest rule's allowance), < 1 mm, outcome ground, at rest within 10 s.
TEST(GroundPhaseHistory, BlockRestsOnSlopesBelowTheFrictionAngle) {
  const double mu = 0.5;
  const std::array<double, 3> dims{0.1, 0.06, 0.02};
  double worst_moved = 0.0, worst_time = 0.0;
  for (const double deg : {10.0, 20.0, 25.0}) {
    const double th = deg * kDegToRad;
    run::Scenario sc = ground_scenario(100.0, 10.0, mu, 0.1, 0.3);
    sc.site.terrain.geometry = slope_grid(th);
    const Vec3 n(-std::sin(th), 0.0, std::cos(th));
    const Vec3 up_slope(std::cos(th), 0.0, std::sin(th));
    const double x0 = 3.3, y0 = 4.4;
    const Vec3 centre = Vec3(x0, y0, std::tan(th) * x0) + 0.5 * dims[2] * n;
    std::vector<double> speeds;
    sc.groups.push_back(block_group(centre, dims, Vec3::Zero(), {0.0, deg, 0.0}));
    speeds.push_back(0.0);
    for (const double speed : {0.005, 0.01, 0.02}) {
      for (int a = 0; a < 8; ++a) {
        const double az = a * kPi / 4.0;
        const Vec3 v = speed * (std::cos(az) * up_slope + std::sin(az) * Vec3::UnitY());
        sc.groups.push_back(block_group(centre, dims, v, {0.0, deg, 0.0}));
        speeds.push_back(speed);
      }
    }
    const run::RunResult r = run::run(sc);
    ASSERT_EQ(r.fragments.size(), 2 * speeds.size());
    EXPECT_EQ(r.stats.ground_step_caps, 0);
    const double dec_min = g * (mu * std::cos(th) - std::sin(th));
    for (const auto& f : r.fragments) {
      const double v = speeds[f.group];
      const std::string tag = std::to_string(deg) + " deg, group " + std::to_string(f.group);
      EXPECT_EQ(f.outcome, run::Outcome::kGround) << tag;
      EXPECT_EQ(f.takeoffs, 0u) << tag;
      const double moved = (f.end_position_m - centre).norm();
      EXPECT_LT(moved, 1e-3) << tag;
      EXPECT_LE(moved, v * v / (2.0 * dec_min) + 1e-6) << tag;
      EXPECT_LT(f.end_time_s, 10.0) << tag;
      EXPECT_LE(f.end_time_s, v / dec_min + 1e-6) << tag;  // the same argument for the time
      worst_moved = std::max(worst_moved, moved);
      worst_time = std::max(worst_time, f.end_time_s);
    }
  }
  measured("rest on slope: largest displacement [m]", worst_moved);
  measured("rest on slope: latest rest [s]", worst_time);
}

// Above the friction angle (35 deg, mu 0.5), from rest, in vacuum: straight down the fall line at
// a = g (sin - mu cos); after T = 3 s (max_flight_time_s) it has gone 1/2 a T^2 = 7.24 m (1 %) and
// not sideways (< 1 mm), still on its face (centre c/2 from the plane, 1e-6 m). The block lies on
// the slope turned 30 deg within it (frame pitched onto the slope, attitude yaw 30).
TEST(GroundPhaseHistory, BlockSlidesDownASteepSlopeAtTheCoulombAcceleration) {
  const double mu = 0.5, deg = 35.0, T = 3.0;
  const double th = deg * kDegToRad;
  const std::array<double, 3> dims{0.1, 0.06, 0.02};
  run::Scenario sc = ground_scenario(100.0, 10.0, mu, 0.1, 0.3);
  sc.site.terrain.geometry = slope_grid(th);
  sc.settings.max_flight_time_s = T;
  const Vec3 n(-std::sin(th), 0.0, std::cos(th));
  const Vec3 down_slope(-std::cos(th), 0.0, -std::sin(th));
  const double x0 = 43.3, y0 = -2.7;
  const Vec3 centre = Vec3(x0, y0, std::tan(th) * x0) + 0.5 * dims[2] * n;
  fragments::FragmentGroupSpec grp = block_group(centre, dims, Vec3::Zero(), {30.0, 0.0, 0.0});
  grp.frame.pitch_deg = deg;
  grp.cd.constant = 0.0;
  sc.groups = {grp};
  const run::RunResult r = run::run(sc);
  ASSERT_EQ(r.fragments.size(), 2u);
  EXPECT_EQ(r.stats.ground_step_caps, 0);
  const double expected = 0.5 * g * (std::sin(th) - mu * std::cos(th)) * T * T;
  for (const auto& f : r.fragments) {
    EXPECT_EQ(f.outcome, run::Outcome::kMaxFlightTime);
    EXPECT_NEAR(f.end_time_s, T, 1e-9);
    const Vec3 d = f.end_position_m - centre;
    EXPECT_NEAR(d.dot(down_slope), expected, 0.01 * expected);
    EXPECT_LT(std::abs(d.y()), 1e-3);
    EXPECT_NEAR(d.dot(n), 0.0, 1e-6);
    EXPECT_EQ(f.bounces, 0u);
    measured("steep slope: distance rel. error", std::abs(d.dot(down_slope) - expected) / expected);
    measured("steep slope: sideways drift [m]", std::abs(d.y()));
  }
}

// The ground step cap (settings.max_ground_steps, a safety cap): the same block sliding down
// the 35 deg slope, stopped after 3 ground steps while still sliding, ends as ground_step_cap
// (not `ground`, which means at rest), is counted in stats.ground_step_caps, and ends where it
// was stopped: moving, on the slope, short of where the uncapped slide is at T.
TEST(GroundPhaseHistory, AHistoryStoppedByTheGroundStepCapHasItsOwnOutcome) {
  const double mu = 0.5, deg = 35.0;
  const double th = deg * kDegToRad;
  const std::array<double, 3> dims{0.1, 0.06, 0.02};
  run::Scenario sc = ground_scenario(100.0, 10.0, mu, 0.1, 0.3);
  sc.site.terrain.geometry = slope_grid(th);
  sc.settings.max_flight_time_s = 3.0;
  sc.settings.max_ground_steps = 3;
  const Vec3 n(-std::sin(th), 0.0, std::cos(th));
  const double x0 = 43.3;
  const Vec3 centre = Vec3(x0, 0.0, std::tan(th) * x0) + 0.5 * dims[2] * n;
  fragments::FragmentGroupSpec grp = block_group(centre, dims, Vec3::Zero(), {}, 5);
  grp.frame.pitch_deg = deg;
  sc.groups = {grp};
  const run::RunResult r = run::run(sc);
  const auto count = [&](run::Outcome o) {
    return r.outcome_histories[static_cast<std::size_t>(o)];
  };
  EXPECT_EQ(count(run::Outcome::kGroundStepCap), 5);
  EXPECT_EQ(count(run::Outcome::kGround), 0);
  EXPECT_EQ(r.stats.ground_step_caps, 5);
  EXPECT_GT(r.outcome_fragments[static_cast<std::size_t>(run::Outcome::kGroundStepCap)].mean, 0.0);
  ASSERT_EQ(r.fragments.size(), 5u);
  for (const auto& f : r.fragments) {
    EXPECT_EQ(f.outcome, run::Outcome::kGroundStepCap);
    EXPECT_STREQ(run::outcome_name(f.outcome), "ground_step_cap");
    EXPECT_GT(f.end_velocity_mps.norm(), 0.0);  // still sliding
    EXPECT_LT(f.end_time_s, 3.0);
    EXPECT_NEAR((f.end_position_m - centre).dot(n), 0.0, 1e-6);
  }
}

// Just above the friction angle the same law holds, only the acceleration is small: from rest on
// slopes with tan(theta) = mu (1 + eps), eps = 5 %, 2 %, 1 %, 0.1 % (mu 0.5, vacuum), after T = 3 s
// the block has slid 1/2 g (sin - mu cos) T^2 (0.98 m ... 2.0 cm) down the fall line (1 %), within
// the ground step cap (the run's stats), outcome max_flight_time.
TEST(GroundPhaseHistory, BlockSlidesFromRestJustAboveTheFrictionAngle) {
  const double mu = 0.5, T = 3.0;
  const std::array<double, 3> dims{0.1, 0.06, 0.02};
  for (const double eps : {0.05, 0.02, 0.01, 0.001}) {
    const double th = std::atan(mu * (1.0 + eps));
    run::Scenario sc = ground_scenario(100.0, 10.0, mu, 0.1, 0.3);
    sc.site.terrain.geometry = slope_grid(th);
    sc.settings.max_flight_time_s = T;
    const Vec3 n(-std::sin(th), 0.0, std::cos(th));
    const Vec3 down_slope(-std::cos(th), 0.0, -std::sin(th));
    const Vec3 centre = Vec3(43.3, -2.7, std::tan(th) * 43.3) + 0.5 * dims[2] * n;
    fragments::FragmentGroupSpec grp =
        block_group(centre, dims, Vec3::Zero(), {0.0, th / kDegToRad, 0.0});
    grp.cd.constant = 0.0;
    sc.groups = {grp};
    const run::RunResult r = run::run(sc);
    ASSERT_EQ(r.fragments.size(), 2u);
    const std::string tag = "tan(theta) = mu (1 + " + std::to_string(eps) + ")";
    EXPECT_EQ(r.stats.ground_step_caps, 0) << tag;
    const double expected = 0.5 * g * (std::sin(th) - mu * std::cos(th)) * T * T;
    const auto& f = r.fragments[0];
    EXPECT_EQ(f.outcome, run::Outcome::kMaxFlightTime) << tag << ": ended at t = " << f.end_time_s;
    const double got = (f.end_position_m - centre).dot(down_slope);
    EXPECT_NEAR(got, expected, 0.01 * expected) << tag << ", ground steps " << r.stats.ground_steps;
    measured("near-critical slope " + tag + ": distance rel. error",
             std::abs(got - expected) / expected);
    measured("near-critical slope " + tag + ": ground steps (2 histories)",
             static_cast<double>(r.stats.ground_steps));
  }
}

// ---- 5. Take-off at a convex edge ----

// A plateau (z = 0 for x <= 0) falling away at 30 deg beyond x = 0 (mesh terrain, 5 m cells). A
// body sliding toward the edge at 40 m/s leaves the ground there (its velocity has 20 m/s along
// the downslope's normal, far above the 0.5 m/s take-off speed) and flies in vacuum. From the
// take-off state in the trajectory record (event take_off: position, velocity), the centre's
// parabola meets the downslope plane offset by the body's clearance h (sphere: R; block at
// attitude 0: its support extent toward the plane) where
//   n . (p0 + v0 t - 1/2 g t^2 z) = h   (the larger root),
// n the downslope's unit normal, the plane through the edge. The first terrain impact after the
// take-off must be there within 1 % of the ballistic range (|landing - p0|), and at that time
// within 1 % of the flight time.
TEST(GroundPhaseHistory, TakesOffAtAConvexEdgeAndLandsOnTheBallisticPoint) {
  const double deg = 30.0;
  const double s = std::tan(deg * kDegToRad);
  const Vec3 n(std::sin(deg * kDegToRad), 0.0, std::cos(deg * kDegToRad));
  const std::array<double, 3> dims{0.1, 0.06, 0.02};
  for (const bool round : {true, false}) {
    run::Scenario sc = ground_scenario(100.0, 10.0, 0.3, 0.05, 0.2);
    sc.site.terrain.geometry = lattice_mesh(
        -50.0, 300.0, -20.0, 20.0, 5.0, [&](double x, double) { return x <= 0.0 ? 0.0 : -s * x; });
    sc.settings.record_trajectories = true;
    sc.settings.max_flight_time_s = 20.0;
    const double mass = 0.5;
    const double R = ball_radius(mass);
    const double h_off =
        round ? R : block_clearance(0.5 * Vec3(dims[0], dims[1], dims[2]), Mat3::Identity(), n);
    fragments::FragmentGroupSpec grp =
        round ? ball_group(Vec3(-29.7, 0.3, R), mass, Vec3(40.0, 0.0, 0.0))
              : block_group(Vec3(-29.7, 0.3, 0.5 * dims[2]), dims, Vec3(40.0, 0.0, 0.0));
    grp.cd.constant = 0.0;
    sc.groups = {grp};
    const run::RunResult r = run::run(sc);
    ASSERT_EQ(r.trajectories.size(), 2u);
    EXPECT_EQ(r.stats.ground_step_caps, 0);
    const std::string tag = round ? "sphere" : "block";
    for (std::size_t hh = 0; hh < 2; ++hh) {
      const auto& f = r.fragments[hh];
      const auto& tr = r.trajectories[hh];
      EXPECT_GE(f.takeoffs, 1u) << tag;
      std::size_t k = 0;
      while (k < tr.t_s.size() && tr.event[k] != run::TrajectoryEvent::kTakeOff) ++k;
      ASSERT_LT(k, tr.t_s.size()) << tag << ": no take-off";
      std::size_t j = k + 1;
      while (j < tr.t_s.size() && tr.event[j] != run::TrajectoryEvent::kTerrainImpact) ++j;
      ASSERT_LT(j, tr.t_s.size()) << tag << ": no landing";
      const Vec3 p0 = tr.position_m[k], v0 = tr.velocity_mps[k];
      EXPECT_NEAR(p0.x(), 0.0, 1e-3) << tag;  // at the edge (centre over it)
      EXPECT_GT(v0.x(), 30.0) << tag;
      // a t^2 + b t + c = 0 with a < 0, c < 0 (the centre starts closer to the extended plane
      // than h): the larger root.
      const double a = -0.5 * g * n.z(), b = n.dot(v0), c = n.dot(p0) - h_off;
      const double t_fly = (-b - std::sqrt(b * b - 4.0 * a * c)) / (2.0 * a);
      const Vec3 land = p0 + v0 * t_fly - 0.5 * g * t_fly * t_fly * Vec3::UnitZ();
      const double range = (land - p0).norm();
      EXPECT_GT(range, 100.0) << tag;
      const double err = (tr.position_m[j] - land).norm();
      EXPECT_LT(err, 0.01 * range) << tag << ": landed at (" << tr.position_m[j].transpose()
                                   << "), expected (" << land.transpose() << ")";
      EXPECT_NEAR(tr.t_s[j] - tr.t_s[k], t_fly, 0.01 * t_fly) << tag;
      measured("edge take-off (" + tag + "): landing error / range", err / range);
    }
  }
}

// ---- 6. Valleys and pits ----

// A V-valley along y = 0 (both sides 35 deg, floor level; mu 0.5: steeper than the friction
// angle) and a conical pit (30 deg walls; mu 0.3), meshed on 2 m cells, restitution 0.2.
struct Hollow {
  const char* name;
  std::function<double(double, double)> f;
  double wall_deg;
  double mu;
  double x, y;  // release point
  // The centre's horizontal distance from the floor line / the pit's axis.
  double offset(const Vec3& p) const {
    return std::string(name) == "valley" ? std::abs(p.y()) : std::hypot(p.x(), p.y());
  }
};
std::vector<Hollow> hollows() {
  const double s_valley = std::tan(35.0 * kDegToRad), s_pit = std::tan(30.0 * kDegToRad);
  return {
      {"valley", [=](double, double y) { return s_valley * std::abs(y); }, 35.0, 0.5, 0.6, 6.3},
      {"pit", [=](double x, double y) { return s_pit * std::hypot(x, y); }, 30.0, 0.3, 7.3, 5.1}};
}
constexpr std::array<double, 3> kHollowBlock{0.08, 0.05, 0.02};
constexpr double kHollowBallMass = 1.0;

// The hollow's scenario with a block (on its a x b face, body z along the facet's normal) and a
// ball released at rest, touching the facet at the release point: groups 0 and 1, 4 histories each.
run::Scenario hollow_scenario(const Hollow& h, std::shared_ptr<const scene::Site>& site) {
  run::Scenario sc = ground_scenario(40.0, 2.0, h.mu, 0.1, 0.2);
  sc.site.terrain.geometry = lattice_mesh(-40.0, 40.0, -40.0, 40.0, 2.0, h.f);
  sc.settings.max_ground_steps = 20000;
  site = scene::Site::build(sc.site);
  const Facet fa = facet_at(*site, h.x, h.y);
  const auto yp = yaw_pitch_of_normal(fa.normal);
  const Vec3 half = 0.5 * Vec3(kHollowBlock[0], kHollowBlock[1], kHollowBlock[2]);
  EXPECT_NEAR(block_clearance(half, ypr(yp[0], yp[1], 0.0), fa.normal), half.z(), 1e-12);
  sc.groups = {
      block_group(fa.centre(half.z()), kHollowBlock, Vec3::Zero(), {yp[0], yp[1], 0.0}, 4),
      ball_group(fa.centre(ball_radius(kHollowBallMass)), kHollowBallMass, Vec3::Zero(), 4)};
  return sc;
}

// Released at rest on a side (flights between allowed), every body ends at rest (outcome ground)
// on the floor: its centre within 5 cm of the floor line / the pit's axis horizontally, and
// within its lowest possible distance from the floor line / the pit's bottom (at most its
// bounding radius / cos(wall)) + 3 cm; it went down the side (ground path > 5 m); no history at
// the ground step cap.
TEST(GroundPhaseHistory, ComesToRestOnTheFloorOfAValleyAndAtTheBottomOfAPit) {
  for (const Hollow& h : hollows()) {
    std::shared_ptr<const scene::Site> site;
    const run::Scenario sc = hollow_scenario(h, site);
    const run::RunResult r = run::run(sc, site);
    ASSERT_EQ(r.fragments.size(), 8u);
    EXPECT_EQ(r.stats.ground_step_caps, 0) << h.name;
    const double block_radius =
        0.5 * std::sqrt(kHollowBlock[0] * kHollowBlock[0] + kHollowBlock[1] * kHollowBlock[1] +
                        kHollowBlock[2] * kHollowBlock[2]);
    for (const auto& f : r.fragments) {
      const std::string tag = std::string(h.name) + (f.group == 0 ? " block" : " ball");
      const double radius = f.group == 0 ? block_radius : ball_radius(kHollowBallMass);
      EXPECT_EQ(f.outcome, run::Outcome::kGround) << tag;
      const Vec3& e = f.end_position_m;
      const double off = h.offset(e);
      const double dist = std::string(h.name) == "valley" ? std::hypot(e.y(), e.z()) : e.norm();
      EXPECT_LT(off, 0.05) << tag << " rests at (" << e.transpose() << ")";
      EXPECT_LT(dist, radius / std::cos(h.wall_deg * kDegToRad) + 0.03)
          << tag << " rests at (" << e.transpose() << ")";
      EXPECT_GT(f.ground_path_m, 5.0) << tag;
      measured(tag + ": rest offset from the floor [m]", off);
    }
  }
}

// ---- 7. Energy ----

// The translational mechanical energy per mass E = 1/2 |v|^2 + g z along a recorded history,
// checked by the rules below (every drop allowed, no rise beyond `slack` * `scale`), for bodies
// launched without spin:
// * at every point E <= its launch value (at launch the total energy, translational +
//   rotational, equals E; drag, friction and impacts never add any, and rotational energy >= 0);
// * every piece of flight (a pair of consecutive points of which the later is a flight step's
//   end, or a landing reached from flight): E does not rise (drag only removes energy);
// * sliders (every shape but the sphere; they do not rotate on the ground): E does not rise from
//   any point to the next, except across an impact ending a flight that started with a rebound
//   (the impulse may have given the body spin, which a later impact may turn back into speed);
// * spheres keep their spin on the ground, and after an impact a spinning ball may legitimately
//   speed up while it slips: only the first two rules apply to them.
struct EnergyAudit {
  double slack = 1e-6;
  double worst_rise = -1e300;  // largest rise / scale over the checked pairs (negative: none)
  std::int64_t checked = 0, flight = 0, skipped = 0, failures = 0;
  void fail(const std::string& msg) {
    if (++failures <= 20) ADD_FAILURE() << msg;  // the first few in full
  }
  void check(const run::TrajectoryRecord& tr, bool slider, double scale, const std::string& tag) {
    using E = run::TrajectoryEvent;
    const auto energy = [&](std::size_t i) {
      return 0.5 * tr.velocity_mps[i].squaredNorm() + g * tr.position_m[i].z();
    };
    if (tr.t_s.empty() || tr.event.front() != E::kLaunch) {
      fail(tag + ": no launch point");
      return;
    }
    const double tol = slack * scale, e0 = energy(0);
    bool spinning = false;  // a slider that may spin (its flight began with a rebound)
    for (std::size_t i = 0; i < tr.t_s.size(); ++i) {
      if (!(std::isfinite(tr.t_s[i]) && tr.position_m[i].allFinite() &&
            tr.velocity_mps[i].allFinite())) {
        fail(tag + ": non-finite point " + std::to_string(i));
        return;
      }
      const double e = energy(i);
      if (e > e0 + tol)
        fail(tag + ": point " + std::to_string(i) + " (" + run::trajectory_event_name(tr.event[i]) +
             ") above the launch energy by " + std::to_string((e - e0) / scale) + " of the scale");
      if (i == 0) continue;
      if (tr.t_s[i] < tr.t_s[i - 1])
        fail(tag + ": time runs backwards at point " + std::to_string(i));
      const E prev = tr.event[i - 1], cur = tr.event[i];
      const bool flight_piece = cur == E::kFlight || ((prev == E::kTakeOff || prev == E::kFlight) &&
                                                      (cur == E::kTerrainImpact || cur == E::kEnd));
      const bool checked_pair = slider ? !(prev == E::kTerrainImpact && spinning) : flight_piece;
      if (checked_pair) {
        const double rise = (e - energy(i - 1)) / scale;
        worst_rise = std::max(worst_rise, rise);
        ++checked;
        flight += flight_piece ? 1 : 0;
        if (e > energy(i - 1) + tol) {
          char where[256];
          std::snprintf(
              where, sizeof where,
              " from point %zu (%s, t %.9g, z %.6f) to %zu (%s, t %.9g, z %.6f) by %.3e of "
              "the scale %.4g J/kg",
              i - 1, run::trajectory_event_name(prev), tr.t_s[i - 1], tr.position_m[i - 1].z(), i,
              run::trajectory_event_name(cur), tr.t_s[i], tr.position_m[i].z(), rise, scale);
          fail(tag + (slider ? " (slider)" : " (sphere)") + ": energy rises" + where);
        }
      } else {
        ++skipped;
      }
      // A rebound (an impact and the take-off it starts, at one instant) may leave a slider
      // spinning; on the ground it has no rotation, and a crest take-off gives it none.
      if (cur == E::kTakeOff) spinning = prev == E::kTerrainImpact && tr.t_s[i] == tr.t_s[i - 1];
      if (cur == E::kGround) spinning = false;
    }
  }
};

// The histories of the valley and pit test above, audited. Scale: g * (the release height above
// the floor + 1 m); slack 1e-6 of it (the integrator runs at rtol 1e-6).
TEST(GroundPhaseHistory, EnergyNeverRisesInAValleyOrAPit) {
  EnergyAudit audit;
  for (const Hollow& h : hollows()) {
    std::shared_ptr<const scene::Site> site;
    run::Scenario sc = hollow_scenario(h, site);
    sc.settings.record_trajectories = true;
    const run::RunResult r = run::run(sc, site);
    ASSERT_EQ(r.trajectories.size(), 8u);
    for (const auto& tr : r.trajectories) {
      const std::string tag = std::string(h.name) + (tr.group == 0 ? " block" : " ball") +
                              " history " + std::to_string(tr.history);
      audit.check(tr, tr.group == 0, g * (tr.position_m.front().z() + 1.0), tag);
    }
  }
  EXPECT_EQ(audit.failures, 0) << "(the first 20 are reported above)";
  EXPECT_GT(audit.checked, 100);
  measured("valley/pit energy: worst rise / scale", audit.worst_rise);
}

// Along 10,000 random ground histories on random bumpy terrain (a grid on 3 m cells, sum of four
// sines, slopes <= 30 deg; mu 0.4, mu_r 0.1, e 0.3, drag Cd 1), launched on the ground without
// spin at random speeds 0-30 m/s along the facet under them, in random directions: blocks of
// random size (2-15 cm edges) and attitude, and spheres (0.05-2 kg). The energy audit above, with
// the slack 1e-6 of the history's scale 1/2 v0^2 + g (z0 - lowest terrain) + g * 1 m. Also: every
// history ends with a named outcome (ground, left_site, max_flight_time), all recorded numbers
// finite, no history at the ground step cap. About 3 s on 2 threads.
TEST(GroundPhaseHistory, EnergyNeverRisesAlongRandomGroundHistories) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  // Terrain: sum of 4 sines, a_i |k_i| = tan(30 deg) / 4, wavelengths 15-60 m (5-20 cells).
  struct Wave {
    double kx, ky, a, phase;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 4; ++i) {
    const double lambda = 15.0 + 45.0 * U(rng), az = 2.0 * kPi * U(rng);
    const double kk = 2.0 * kPi / lambda;
    const double phase = 2.0 * kPi * U(rng);
    waves.push_back(
        {kk * std::cos(az), kk * std::sin(az), std::tan(30.0 * kDegToRad) / 4.0 / kk, phase});
  }
  const auto height = [&](double x, double y) {
    double z = 0.0;
    for (const Wave& w : waves) z += w.a * std::sin(w.kx * x + w.ky * y + w.phase);
    return z;
  };
  run::Scenario sc = ground_scenario(150.0, 10.0, 0.4, 0.1, 0.3);
  scene::GridTerrainSpec grid;
  grid.origin_m = {-150.0, -150.0};
  grid.spacing_m = 3.0;
  grid.nx = grid.ny = 101;
  double z_min = 1e9;
  for (int j = 0; j < grid.ny; ++j)
    for (int i = 0; i < grid.nx; ++i) {
      grid.elevation_m.push_back(height(-150.0 + 3.0 * i, -150.0 + 3.0 * j));
      z_min = std::min(z_min, grid.elevation_m.back());
    }
  sc.site.terrain.geometry = grid;
  sc.settings.record_trajectories = true;
  sc.settings.max_recorded_trajectories = 1000000;
  const auto site = scene::Site::build(sc.site);

  constexpr int kBatches = 4, kGroupsPerBatch = 250, kSamples = 10;  // batches: bounded memory
  EnergyAudit audit;
  std::int64_t histories = 0, step_caps = 0;
  std::array<std::int64_t, run::kOutcomeCount> outcomes{};
  const auto t_start = std::chrono::steady_clock::now();
  for (int batch = 0; batch < kBatches; ++batch) {
    sc.groups.clear();
    std::vector<bool> is_block;
    for (int gi = 0; gi < kGroupsPerBatch; ++gi) {
      const bool block = (gi % 2) == 0;
      const double x = -100.0 + 200.0 * U(rng);
      const double y = -100.0 + 200.0 * U(rng);
      const Facet fa = facet_at(*site, x, y);
      const auto yp = yaw_pitch_of_normal(fa.normal);  // the local frame on the facet
      fragments::FragmentGroupSpec grp;
      double clearance = 0.0;
      if (block) {
        std::array<double, 3> dims{};
        for (double& d : dims) d = 0.02 + 0.13 * U(rng);
        fragments::AttitudeSpec att;
        att.yaw_deg = 360.0 * U(rng) - 180.0;
        att.pitch_deg = std::asin(2.0 * U(rng) - 1.0) / kDegToRad;  // uniform rotations
        att.roll_deg = 360.0 * U(rng) - 180.0;
        clearance = block_clearance(
            0.5 * Vec3(dims[0], dims[1], dims[2]),
            ypr(yp[0], yp[1], 0.0) * ypr(att.yaw_deg, att.pitch_deg, att.roll_deg), fa.normal);
        grp = block_group(Vec3::Zero(), dims, Vec3::Zero(), att, kSamples);
      } else {
        const double mass = 0.05 + 1.95 * U(rng);
        clearance = ball_radius(mass);
        grp = ball_group(Vec3::Zero(), mass, Vec3::Zero(), kSamples);
      }
      // Launched touching the facet, velocity along it (local frame: elevation 0, any azimuth).
      grp.frame.origin_m = fa.centre(clearance);
      grp.frame.yaw_deg = yp[0];
      grp.frame.pitch_deg = yp[1];
      grp.speed_mps.kind = fragments::Distribution::Kind::kUniform;
      grp.speed_mps.min = 0.0;
      grp.speed_mps.max = 30.0;
      grp.direction.elevation_min_deg = grp.direction.elevation_max_deg = 0.0;
      grp.cd.constant = 1.0;
      sc.groups.push_back(grp);
      is_block.push_back(block);
    }
    const run::RunResult r = run::run(sc, site);
    ASSERT_EQ(r.fragments.size(), static_cast<std::size_t>(kGroupsPerBatch * kSamples));
    ASSERT_EQ(r.trajectories.size(), r.fragments.size());
    step_caps += r.stats.ground_step_caps;
    for (std::size_t k = 0; k < r.fragments.size(); ++k) {
      const run::FragmentRecord& f = r.fragments[k];
      const run::TrajectoryRecord& tr = r.trajectories[k];
      ASSERT_EQ(tr.group, f.group);
      ASSERT_EQ(tr.history, f.history);
      ++histories;
      ++outcomes[static_cast<std::size_t>(f.outcome)];
      const std::string tag = "batch " + std::to_string(batch) + " group " +
                              std::to_string(f.group) + " history " + std::to_string(f.history);
      if (!(f.outcome == run::Outcome::kGround || f.outcome == run::Outcome::kLeftSite ||
            f.outcome == run::Outcome::kMaxFlightTime))
        audit.fail(tag + ": outcome " + run::outcome_name(f.outcome));
      if (!(f.end_position_m.allFinite() && f.end_velocity_mps.allFinite() &&
            std::isfinite(f.end_time_s) && std::isfinite(f.ground_path_m)))
        audit.fail(tag + ": non-finite record");
      const double scale = 0.5 * tr.velocity_mps.front().squaredNorm() +
                           g * (tr.position_m.front().z() - z_min) + g * 1.0;
      audit.check(tr, is_block[f.group], scale, tag);
    }
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  EXPECT_EQ(step_caps, 0) << "histories stopped by max_ground_steps";
  EXPECT_EQ(audit.failures, 0) << "(the first 20 are reported above)";
  EXPECT_EQ(histories, 10000);
  EXPECT_GT(audit.flight, 10000);  // the terrain does throw bodies into the air
  EXPECT_GT(audit.checked, 100000);
  EXPECT_GT(outcomes[static_cast<std::size_t>(run::Outcome::kGround)], 5000);  // most come to rest
  measured("energy: worst rise / scale", audit.worst_rise);
  measured("energy: pairs checked", static_cast<double>(audit.checked));
  measured("energy: of them flight", static_cast<double>(audit.flight));
  measured("energy: pairs not checked (sphere ground pieces, impacts after spinning flight)",
           static_cast<double>(audit.skipped));
  measured("energy: failures", static_cast<double>(audit.failures));
  measured("energy: step caps", static_cast<double>(step_caps));
  measured("energy: outcome ground", static_cast<double>(outcomes[0]));
  measured("energy: outcome left_site", static_cast<double>(outcomes[3]));
  measured("energy: outcome max_flight_time", static_cast<double>(outcomes[2]));
  measured("energy: wall time [s]", wall);
}

}  // namespace
}  // namespace fragsim::validation
