// The ground phase (core/impact/ground_phase.h) against closed forms: Coulomb sliding with and
// without drag, slip-then-roll, rest below and sliding above the friction angle, edges (take-off,
// impacts, creases), pits, toppling onto a face, and the energy that never rises. Tolerances are
// stated per test; the integrator runs at rtol 1e-9 here unless the test says otherwise.
#include "core/impact/ground_phase.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <random>
#include <vector>

#include "core/fragments/sampling.h"

namespace fragsim::impact {
namespace {

constexpr double g = kStandardGravity_mps2;

// A grid terrain z = slope * x over [-200, 200]^2 (10 m cells): one plane, many triangles.
std::shared_ptr<const scene::Site> slope_site(double slope, double friction, double rolling) {
  scene::SiteSpec spec;
  scene::GridTerrainSpec grid;
  grid.origin_m = {-200.0, -200.0};
  grid.spacing_m = 10.0;
  grid.nx = grid.ny = 41;
  for (int j = 0; j < grid.ny; ++j)
    for (int i = 0; i < grid.nx; ++i) grid.elevation_m.push_back(slope * (-200.0 + 10.0 * i));
  spec.terrain.geometry = grid;
  spec.terrain.material = "ground";
  scene::MaterialSpec m;
  m.friction = friction;
  m.rolling_resistance = rolling;
  spec.materials["ground"] = m;
  return scene::Site::build(spec);
}

// A terrain given as a mesh z = f(x, y) sampled on a lattice over [-half, half]^2.
std::shared_ptr<const scene::Site> mesh_site(double half, double cell,
                                             const std::function<double(double, double)>& f,
                                             const scene::MaterialSpec& m) {
  scene::SiteSpec spec;
  scene::MeshSpec mesh;
  const int n = static_cast<int>(std::lround(2.0 * half / cell)) + 1;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = -half + cell * i, y = -half + cell * j;
      mesh.vertices_m.emplace_back(x, y, f(x, y));
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const std::int64_t v00 = j * n + i, v10 = v00 + 1, v01 = v00 + n, v11 = v01 + 1;
      mesh.triangles.push_back({v00, v10, v11});
      mesh.triangles.push_back({v00, v11, v01});
    }
  spec.terrain.geometry = mesh;
  spec.terrain.material = "ground";
  spec.materials["ground"] = m;
  return scene::Site::build(spec);
}

scene::MaterialSpec material(double mu, double mu_r, double e) {
  scene::MaterialSpec m;
  m.friction = mu;
  m.rolling_resistance = mu_r;
  m.restitution.constant = e;
  return m;
}

// Gravity, and drag with a constant density and Cd when cd > 0 (k = rho Cd A / 2m).
struct Air {
  flight::Atmosphere atmosphere;
  flight::DragCoefficient cd;
  flight::FlightModel model;
  Air(double cd_value, double area_m2, double mass_kg)
      : atmosphere([] {
          flight::AtmosphereSpec a;
          a.model = flight::AtmosphereSpec::Model::kConstant;
          a.density_kg_m3 = 1.225;
          return a;
        }()),
        cd([&] {
          fragments::CdSpec c;
          c.constant = cd_value;
          return c;
        }()) {
    model.atmosphere = &atmosphere;
    model.cd = &cd;
    model.gravity_mps2 = g;
    model.area_m2 = cd_value > 0.0 ? area_m2 : 0.0;
    model.mass_kg = mass_kg;
  }
  double k() const { return 1.225 * cd.at_mach(0.0) * model.area_m2 / (2.0 * model.mass_kg); }
};

// Bodies: a flat steel plate 0.1 x 0.06 x 0.01 m (body axes = site axes: lies on its large
// face), or a solid steel sphere of 5 cm diameter.
GroundBody plate(const Quat& q = Quat::Identity()) {
  fragments::ShapeSpec s;
  s.type = fragments::ShapeType::kCuboid;
  s.dims_m = {0.1, 0.06, 0.01};
  const auto mp = fragments::mass_properties(s, 7850.0 * 0.1 * 0.06 * 0.01, std::nullopt);
  GroundBody b;
  b.shape = fragments::contact_body(s.type, mp);
  b.mass_kg = mp.mass_kg;
  b.attitude = q;
  b.flat_tol_m = 1e-6 * fragments::bounding_radius(b.shape);
  return b;
}
GroundBody sphere() {
  fragments::ShapeSpec s;
  s.type = fragments::ShapeType::kSphere;
  s.dims_m = {0.05};
  const auto mp =
      fragments::mass_properties(s, 7850.0 * kPi / 6.0 * 0.05 * 0.05 * 0.05, std::nullopt);
  GroundBody b;
  b.shape = fragments::contact_body(s.type, mp);
  b.mass_kg = mp.mass_kg;
  b.flat_tol_m = 1e-6 * fragments::bounding_radius(b.shape);
  return b;
}

// The plate as a polyhedron (its 8 corners), and a random rock: the hull of 40 points in a
// 0.3 x 0.2 x 0.12 m box, granite density (2700 kg/m^3), 5 kg.
GroundBody polyhedron_body(const std::vector<Vec3>& pts, std::optional<double> density, double mass,
                           const Quat& q) {
  const fragments::ShapeSpec s = fragments::polyhedron_shape(pts, density);
  const auto mp = fragments::mass_properties(s, mass, std::nullopt);
  GroundBody b;
  b.shape = fragments::contact_body(s.type, mp);
  b.mass_kg = mp.mass_kg;
  b.attitude = q;
  b.flat_tol_m = 1e-6 * fragments::bounding_radius(b.shape);
  return b;
}
GroundBody plate_polyhedron(const Quat& q = Quat::Identity()) {
  std::vector<Vec3> corners;
  for (int k = 0; k < 8; ++k)
    corners.emplace_back(k & 1 ? 0.05 : -0.05, k & 2 ? 0.03 : -0.03, k & 4 ? 0.005 : -0.005);
  return polyhedron_body(corners, std::nullopt, 7850.0 * 0.1 * 0.06 * 0.01, q);
}
GroundBody rock(std::uint64_t seed, const Quat& q) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> pts;
  for (int i = 0; i < 40; ++i) pts.emplace_back(0.15 * u(rng), 0.1 * u(rng), 0.06 * u(rng));
  return polyhedron_body(pts, 2700.0, 5.0, q);
}

GroundSettings settings(double rtol = 1e-9) {
  GroundSettings s;
  s.t_max_s = 1000.0;
  s.rtol = rtol;
  return s;
}

// A start on the terrain at (x, y), velocity v (put along the plane by the ground phase).
GroundState start_at(const scene::Site& site, const GroundBody& body, double x, double y,
                     const Vec3& v, const Vec3& omega = Vec3::Zero()) {
  GroundState s;
  s.triangle = static_cast<std::uint32_t>(site.terrain_triangle_at(x, y));
  const Vec3& n = site.terrain_triangle_normal(s.triangle);
  s.position_m =
      Vec3(x, y, site.terrain_height(x, y) + ground_clearance(body, body.attitude, n) / n.z());
  s.velocity_mps = v;
  s.omega_radps = omega;
  return s;
}

// Records everything the phase reports.
class Recorder : public GroundObserver {
 public:
  bool on_segment(const GroundSegment& s) override {
    segments.push_back(s);
    return stop_after_m > 0.0 && (covered += (s.b - s.a).norm()) > stop_after_m;
  }
  void on_impact(const GroundImpact& i) override { impacts.push_back(i); }
  std::vector<GroundSegment> segments;
  std::vector<GroundImpact> impacts;
  double stop_after_m = 0.0, covered = 0.0;
};

GroundResult run(const scene::Site& site, const Air& air, const GroundBody& body,
                 const GroundState& s0, Recorder& rec, const GroundSettings& gs = settings()) {
  return move_on_ground(site, air.model, body, gs, s0, rec);
}

// ---- level ground ----

// Coulomb sliding without drag: stops after v0^2 / (2 mu g) in time v0 / (mu g) (1e-9).
TEST(GroundPhase, SlideOnLevelGroundStopsAtTheCoulombDistance) {
  const auto site = slope_site(0.0, 0.5, 0.1);
  const GroundBody body = plate();
  const Air air(0.0, 0.0, body.mass_kg);
  const double v0 = 12.0, mu = 0.5;
  const GroundState s0 = start_at(*site, body, 0.3, 0.7, Vec3(v0 * 0.6, v0 * 0.8, 0.0));
  Recorder rec;
  const GroundResult r = run(*site, air, body, s0, rec);
  EXPECT_EQ(r.end, GroundEnd::kRest);
  const double d = v0 * v0 / (2 * mu * g);
  EXPECT_NEAR(r.path_m, d, 1e-9 * d);
  EXPECT_NEAR((r.state.position_m - s0.position_m).norm(), d, 1e-9 * d);
  EXPECT_NEAR(r.state.t_s, v0 / (mu * g), 1e-9);
  EXPECT_NEAR(r.state.position_m.z(), s0.position_m.z(), 1e-12);  // at its clearance throughout
  EXPECT_LT(r.steps, 60);  // a closed-form motion: few steps (edges of 10 m cells included)
}

// With drag (still air, constant rho and Cd): dv/dt = -mu g - k v^2, so
//   distance = ln(1 + k v0^2 / (mu g)) / (2k),  time = atan(v0 sqrt(k / (mu g))) / sqrt(mu g k),
// k = rho Cd A / (2m) with A the plate's frontal area along its motion on the ground (G14):
// 0.06 x 0.01 m sliding flat along x, 0.1 x 0.01 m along y, not the flight's area given to the
// model (0.004 m^2).
TEST(GroundPhase, SlideWithDragOnLevelGroundFollowsTheClosedForm) {
  const auto site = slope_site(0.0, 0.9, 0.1);
  const GroundBody body = plate();
  const Air air(1.2, 0.004, body.mass_kg);
  const double mu = 0.9;
  for (const bool along_y : {false, true}) {
    const double k = air.k() * (along_y ? 0.1 * 0.01 : 0.06 * 0.01) / 0.004;
    const Vec3 dir = along_y ? Vec3::UnitY() : Vec3::UnitX();
    for (const double v0 : {5.0, 30.0, 60.0}) {
      const Vec3 p0 = -150.0 * dir + 0.35 * Vec3(dir.y(), dir.x(), 0.0);
      const GroundState s0 = start_at(*site, body, p0.x(), p0.y(), v0 * dir);
      Recorder rec;
      const GroundResult r = run(*site, air, body, s0, rec);
      ASSERT_EQ(r.end, GroundEnd::kRest) << v0;
      const double d = std::log(1.0 + k * v0 * v0 / (mu * g)) / (2.0 * k);
      const double t = std::atan(v0 * std::sqrt(k / (mu * g))) / std::sqrt(mu * g * k);
      // 1e-6 relative, and the rest rule's allowance (the last micrometre in closed form).
      EXPECT_NEAR(r.path_m, d, 1e-6 * d + kRestTravel_m) << v0 << " along y " << along_y;
      EXPECT_NEAR(r.state.t_s, t, 1e-6 * t) << v0 << " along y " << along_y;
      EXPECT_NEAR(r.state.position_m.dot(Vec3(dir.y(), dir.x(), 0.0)), 0.35, 1e-9);
    }
  }
}

// A sphere sliding without spin on level ground (no drag): Coulomb slip decelerates it at mu g
// and spins it up at 5/2 mu g / R until v = omega R at t1 = 2 v0 / (7 mu g), v1 = 5/7 v0, after
// 12 v0^2 / (49 mu g); then it rolls with rolling resistance at 5/7 mu_r g for
// v1^2 / (2 * 5/7 mu_r g). (Textbook; e.g. Marion & Thornton, ex. 10.)
TEST(GroundPhase, SphereSlipsThenRolls) {
  const double mu = 0.4, mu_r = 0.05, v0 = 9.0;
  const auto site = slope_site(0.0, mu, mu_r);
  const GroundBody body = sphere();
  const Air air(0.0, 0.0, body.mass_kg);
  const GroundState s0 = start_at(*site, body, -100.0, 1.0, Vec3(v0, 0.0, 0.0));
  Recorder rec;
  const GroundResult r = run(*site, air, body, s0, rec);
  ASSERT_EQ(r.end, GroundEnd::kRest);
  const double slip = 12.0 * v0 * v0 / (49.0 * mu * g);
  const double v1 = 5.0 / 7.0 * v0;
  const double roll = v1 * v1 / (2.0 * 5.0 / 7.0 * mu_r * g);
  EXPECT_NEAR(r.path_m, slip + roll, 1e-7 * (slip + roll));
  const double t_total = 2.0 * v0 / (7.0 * mu * g) + v1 / (5.0 / 7.0 * mu_r * g);
  EXPECT_NEAR(r.state.t_s, t_total, 1e-7 * t_total);
  // The roll speed right after the slip: 5/7 v0 (the piece ending nearest t1).
  const double t1 = 2.0 * v0 / (7.0 * mu * g);
  double best = 1e9, v_at = 0.0;
  for (const auto& sg : rec.segments)
    if (std::abs(sg.tb - t1) < best) {
      best = std::abs(sg.tb - t1);
      v_at = sg.vb.norm();
    }
  EXPECT_LT(best, 1e-9);
  EXPECT_NEAR(v_at, v1, 1e-7 * v1);
}

// ---- slopes ----

// Above the friction angle (tan theta > mu), from rest: down the fall line with
// a = g (sin theta - mu cos theta), no sideways drift.
TEST(GroundPhase, SlidesDownTheFallLineAboveTheFrictionAngle) {
  const double slope = 0.6, mu = 0.5;
  const auto site = slope_site(slope, mu, 0.1);
  const GroundBody body = plate(Quat(Eigen::AngleAxisd(-std::atan(slope), Vec3::UnitY())));
  const Air air(0.0, 0.0, body.mass_kg);
  const double th = std::atan(slope);
  const double a = g * (std::sin(th) - mu * std::cos(th));
  const GroundState s0 = start_at(*site, body, 150.0, 0.3, Vec3::Zero());
  GroundSettings gs = settings();
  const double T = 4.0;
  gs.t_max_s = T;
  Recorder rec;
  const GroundResult r = run(*site, air, body, s0, rec, gs);
  EXPECT_EQ(r.end, GroundEnd::kMaxTime);
  EXPECT_NEAR(r.path_m, 0.5 * a * T * T, 1e-9 * 0.5 * a * T * T);
  EXPECT_NEAR(r.state.position_m.y(), 0.3, 1e-9);  // no drift across the fall line
  EXPECT_NEAR(r.state.velocity_mps.norm(), a * T, 1e-9 * a * T);
}

// Below the friction angle a body put down with a small velocity in any direction stops within
// v^2 / (2 g (mu cos theta - sin theta)) (the least deceleration) and stays: no creep. From
// 1 cm/s it moves less than 1 mm in the 10 s allowed.
TEST(GroundPhase, RestsOnASlopeBelowTheFrictionAngle) {
  const double mu = 0.5;
  for (const double deg : {20.0, 25.0}) {
    const double slope = std::tan(deg * kDegToRad);
    const auto site = slope_site(slope, mu, 0.1);
    const GroundBody body = plate(Quat(Eigen::AngleAxisd(-deg * kDegToRad, Vec3::UnitY())));
    const Air air(0.0, 0.0, body.mass_kg);
    const double th = deg * kDegToRad;
    const double dec = g * (mu * std::cos(th) - std::sin(th));
    for (int k = 0; k < 16; ++k) {
      const double az = k * kPi / 4.0, speed = k < 8 ? 0.01 : 0.05;
      const Vec3 v =
          speed * Vec3(std::cos(az) * std::cos(th), std::sin(az), std::cos(az) * std::sin(th));
      const GroundState s0 = start_at(*site, body, 3.0, 4.0, v);
      GroundSettings gs = settings();
      gs.t_max_s = 10.0;
      Recorder rec;
      const GroundResult r = run(*site, air, body, s0, rec, gs);
      EXPECT_EQ(r.end, GroundEnd::kRest) << deg << " deg, az " << az;
      const double moved = (r.state.position_m - s0.position_m).norm();
      EXPECT_LE(moved, speed * speed / (2.0 * dec) + 1e-9) << deg << " deg, az " << az;
      if (speed <= 0.01) {
        EXPECT_LT(moved, 1e-3);
      }
    }
  }
}

// A slide across a slope (the pull across the motion turns it: no straight line, G3) comes to
// rest where an independent integration of the in-plane equations puts it:
//   du/dt = g sin(th) e_down - mu g cos(th) u / |u|
// (RK4 with steps shrinking with the speed, 1 % of it per step near the stop). The ground phase
// closes in on such a stop in steps of half the predicted time (G10). Its rest point must be
// within a few rtol of the path (2.7-9.2 m) of the reference: 2e-8 m at rtol 1e-9, 5e-5 m at
// rtol 1e-6 (measured 1.6e-9 and 9.7e-6).
TEST(GroundPhase, SlideAcrossASlopeRestsWhereTheInPlaneEquationsPutIt) {
  const double mu = 0.5, deg = 20.0, th = deg * kDegToRad;
  const auto site = slope_site(std::tan(th), mu, 0.1);
  const GroundBody body = plate(Quat(Eigen::AngleAxisd(-th, Vec3::UnitY())));
  const Air air(0.0, 0.0, body.mass_kg);
  const Vec3 e_down = -Vec3(std::cos(th), 0.0, std::sin(th)), e_across = Vec3::UnitY();
  for (const double az_deg : {60.0, 90.0, 135.0}) {  // from the fall line, downhill = 0
    const double az = az_deg * kDegToRad, speed = 6.0;
    const Vec2 u0 = speed * Vec2(std::cos(az), std::sin(az));
    // The reference in the plane's coordinates (down, across).
    const auto rate = [&](const Vec2& u) -> Vec2 {
      return Vec2(g * std::sin(th), 0.0) - (mu * g * std::cos(th) / u.norm()) * u;
    };
    Vec2 u = u0, x = Vec2::Zero();
    while (u.norm() > 1e-9) {
      const double dt = std::min(1e-4, 0.01 * u.norm() / (mu * g * std::cos(th)));
      const Vec2 k1 = rate(u), k2 = rate(u + 0.5 * dt * k1), k3 = rate(u + 0.5 * dt * k2),
                 k4 = rate(u + dt * k3);
      x += dt * (u + dt / 6.0 * (k1 + k2 + k3));  // position: RK4 for x' = u, u' = rate(u)
      u += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    for (const double rtol : {1e-9, 1e-6}) {
      const GroundState s0 = start_at(*site, body, 3.0, 4.0, u0.x() * e_down + u0.y() * e_across);
      Recorder rec;
      const GroundResult r = run(*site, air, body, s0, rec, settings(rtol));
      ASSERT_EQ(r.end, GroundEnd::kRest) << az_deg << " deg";
      const Vec3 moved = r.state.position_m - s0.position_m;
      const Vec2 got(moved.dot(e_down), moved.dot(e_across));
      EXPECT_NEAR((got - x).norm(), 0.0, rtol < 1e-7 ? 2e-8 : 5e-5)
          << az_deg << " deg, rtol " << rtol << ": reference (" << x.transpose() << "), got ("
          << got.transpose() << ")";
      EXPECT_GT(x.norm(), 2.5);
    }
  }
}

// A ball thrown across a slope without spin slips, the slip turning as it ends (G4, G7: the
// pull across it), then rolls to rest (G5, G10). Both ends are approached in half steps; the rest
// point must converge with the tolerance: at rtol 1e-9 and 1e-6 within 1e-8 m and 3e-5 m of the
// same at rtol 1e-12 (rest 2.0-5.6 m from the start; measured 1.2e-9 and 2.5e-6 m).
TEST(GroundPhase, BallAcrossASlopeSlipsRollsAndRestsConvergently) {
  const double deg = 10.0, th = deg * kDegToRad;
  const auto site = slope_site(std::tan(th), 0.5, 0.3);
  const GroundBody body = sphere();
  const Air air(0.0, 0.0, body.mass_kg);
  const Vec3 e_down = -Vec3(std::cos(th), 0.0, std::sin(th)), e_across = Vec3::UnitY();
  for (const double az_deg : {45.0, 90.0, 135.0}) {
    const double az = az_deg * kDegToRad;
    const GroundState s0 =
        start_at(*site, body, 3.0, 4.0, 4.0 * (std::cos(az) * e_down + std::sin(az) * e_across));
    const auto rest_at = [&](double rtol) {
      Recorder rec;
      const GroundResult r = run(*site, air, body, s0, rec, settings(rtol));
      EXPECT_EQ(r.end, GroundEnd::kRest) << az_deg << " deg, rtol " << rtol;
      return r.state.position_m;
    };
    const Vec3 ref = rest_at(1e-12);
    EXPECT_GT((ref - s0.position_m).norm(), 1.0);
    EXPECT_LT((rest_at(1e-9) - ref).norm(), 1e-8) << az_deg << " deg";
    EXPECT_LT((rest_at(1e-6) - ref).norm(), 3e-5) << az_deg << " deg";
  }
}

// Sliding up the fall line: constant deceleration g (sin + mu cos), at every piece's end the
// closed form, the stop at v0 / a, and rest there (below the friction angle).
TEST(GroundPhase, SlidingUphillFollowsTheClosedFormAndStays) {
  const double slope = 0.2, mu = 0.5;
  const auto site = slope_site(slope, mu, 0.1);
  const double th = std::atan(slope);
  const GroundBody body = plate(Quat(Eigen::AngleAxisd(-th, Vec3::UnitY())));
  const Air air(0.0, 0.0, body.mass_kg);
  const double a = g * (std::sin(th) + mu * std::cos(th));
  const double v0 = 25.0;
  const GroundState s0 =
      start_at(*site, body, -150.0, 3.3, v0 * Vec3(std::cos(th), 0.0, std::sin(th)));
  Recorder rec;
  const GroundResult r = run(*site, air, body, s0, rec);
  EXPECT_EQ(r.end, GroundEnd::kRest);
  double worst_s = 0.0, worst_v = 0.0;
  for (const auto& sg : rec.segments) {
    const double t = sg.tb - s0.t_s;
    worst_s =
        std::max(worst_s, std::abs((sg.b - s0.position_m).norm() - (v0 * t - 0.5 * a * t * t)));
    worst_v = std::max(worst_v, std::abs(sg.vb.norm() - std::max(0.0, v0 - a * t)));
  }
  EXPECT_LT(worst_s, 1e-8 * v0 * v0 / a);
  EXPECT_LT(worst_v, 1e-3 * v0);  // the last piece ends a hair before the stop (then snaps)
  EXPECT_NEAR(r.state.t_s, v0 / a, 1e-6 * v0 / a);
  EXPECT_NEAR(r.path_m, v0 * v0 / (2 * a), 1e-8 * v0 * v0 / (2 * a));
  EXPECT_GT(rec.segments.size(), 8u);  // 10 m cells, diagonals: many coplanar pieces
}

// ---- edges ----

// A plateau ending in a 30 degree downslope along x = 0. Rolling at 40 m/s over the crest the
// body takes off at the edge (it would need a pulling normal force to follow it).
//
// Its speed there, closed form: the solid sphere (I = 2/5 m R^2) starts rolling without slip
// (omega R = v0) 30 m before the edge on the level plateau, in vacuum (Cd 0: no drag). Rolling,
// the resistance mu_r N = mu_r m g at the contact decelerates the centre at k mu_r g with
// k = 1 / (1 + I / (m R^2)) = 5/7 (ground_forces.h, G5), so at the edge
//   v = sqrt(v0^2 - 2 k mu_r g L) = sqrt(1600 - 2 (5/7) 0.1 g 30) = 39.4712 m/s,
// and it still rolls: omega R = v. Tolerance 1e-4 m/s: the integrator runs at rtol 1e-9 and the
// edge is found to 1e-6 m. With k = 1 (the spin's inertia ignored) v would be 39.2577 m/s,
// 0.21 m/s (2000 tolerances) lower, so this fails if the rolling inertia is lost.
TEST(GroundPhase, TakesOffAtAConvexEdge) {
  const double drop = std::tan(30.0 * kDegToRad);
  const auto site = mesh_site(
      100.0, 5.0, [&](double x, double) { return x <= 0.0 ? 0.0 : -drop * x; },
      material(0.5, 0.1, 0.2));
  const GroundBody body = sphere();
  const Air air(0.0, 0.0, body.mass_kg);
  const double R = body.shape.half_m.x();
  const GroundState s0 =
      start_at(*site, body, -30.0, 1.0, Vec3(40.0, 0.0, 0.0), Vec3(0.0, 40.0 / R, 0.0));
  Recorder rec;
  const GroundResult r = run(*site, air, body, s0, rec);
  ASSERT_EQ(r.end, GroundEnd::kTakeOff);
  EXPECT_NEAR(r.state.position_m.x(), 0.0, 1e-6);    // at the edge
  EXPECT_NEAR(r.state.velocity_mps.z(), 0.0, 1e-9);  // still along the plateau
  const double v0 = 40.0, L = 30.0, mu_r = 0.1, k = 1.0 / (1.0 + 2.0 / 5.0);
  const double v_edge = std::sqrt(v0 * v0 - 2.0 * k * mu_r * g * L);  // 39.4712 m/s
  EXPECT_NEAR(r.state.velocity_mps.x(), v_edge, 1e-4);
  EXPECT_NEAR(r.state.omega_radps.y() * R, v_edge, 1e-4);  // still rolling
  EXPECT_TRUE(rec.impacts.empty());
}

// Slowly over a gentle convex edge (the take-off normal speed below the take-off speed) the
// hop is contracted into an impact at the edge; into a concave edge it is an impact: in both
// the kinetic energy does not rise, and the body goes on along the new plane.
TEST(GroundPhase, SlowEdgesAreImpactsThatNeverAddEnergy) {
  for (const double sign : {1.0, -1.0}) {  // +1: the ground falls away (convex), -1: rises
    const double slope = 0.05;
    const auto site = mesh_site(
        100.0, 5.0, [&](double x, double) { return x <= 0.0 ? 0.0 : -sign * slope * x; },
        material(0.5, 0.1, 0.3));
    const GroundBody body = plate();
    const Air air(0.0, 0.0, body.mass_kg);
    const GroundState s0 = start_at(*site, body, -3.0, 1.0, Vec3(8.0, 0.0, 0.0));
    Recorder rec;
    const GroundResult r = run(*site, air, body, s0, rec);
    ASSERT_FALSE(rec.impacts.empty()) << sign;
    const GroundImpact& i = rec.impacts.front();
    EXPECT_NEAR(i.position_m.x(), 0.0, 1e-6);
    EXPECT_LE(i.velocity_after_mps.squaredNorm(),
              i.velocity_before_mps.squaredNorm() * (1 + 1e-12));
    EXPECT_NE(r.end, GroundEnd::kTakeOff) << sign;
    EXPECT_GT(r.state.position_m.x(), 0.0);  // on beyond the edge
  }
}

// ---- valleys and pits ----

// A V-valley along y = 0 (both sides 35 deg, steeper than the friction angle 26.6 deg), its
// floor level: a body released on one side slides down, crosses, is caught in the crease and
// rests on the floor line, well within the step cap. (Restitution 0: the crossing does not
// bounce it off the ground, which would end the ground phase; tests/validation follows whole
// histories.)
TEST(GroundPhase, RestsAtTheBottomOfAVValley) {
  const double s = std::tan(35.0 * kDegToRad);
  const auto site = mesh_site(
      50.0, 2.0, [&](double, double y) { return s * std::abs(y); }, material(0.5, 0.1, 0.0));
  for (const GroundBody& body : {plate(), sphere()}) {
    const Air air(0.0, 0.0, body.mass_kg);
    const GroundState s0 = start_at(*site, body, 0.3, 6.1, Vec3::Zero());
    Recorder rec;
    GroundSettings gs = settings();
    gs.max_steps = 2000;
    const GroundResult r = run(*site, air, body, s0, rec, gs);
    EXPECT_EQ(r.end, GroundEnd::kRest) << static_cast<int>(body.shape.type);
    EXPECT_NEAR(r.state.position_m.y(), 0.0, 0.02) << static_cast<int>(body.shape.type);
    EXPECT_LT(r.steps, 2000);
  }
}

// A pit: an inverted cone, 30 deg walls. Released on a wall the body ends at rest at the bottom.
TEST(GroundPhase, RestsAtTheBottomOfAPit) {
  const double s = std::tan(30.0 * kDegToRad);
  const auto site = mesh_site(
      40.0, 2.0, [&](double x, double y) { return s * std::hypot(x, y); },
      material(0.3, 0.05, 0.0));
  for (const GroundBody& body : {plate(), sphere()}) {
    const Air air(0.0, 0.0, body.mass_kg);
    const GroundState s0 = start_at(*site, body, 7.3, 5.1, Vec3::Zero());
    Recorder rec;
    GroundSettings gs = settings();
    gs.max_steps = 5000;
    const GroundResult r = run(*site, air, body, s0, rec, gs);
    EXPECT_EQ(r.end, GroundEnd::kRest) << static_cast<int>(body.shape.type);
    EXPECT_LT(std::hypot(r.state.position_m.x(), r.state.position_m.y()), 0.05)
        << static_cast<int>(body.shape.type);
  }
}

// ---- energy ----

// Along random ground histories on random bumpy terrain the mechanical energy
// E = 1/2 m v^2 + 1/2 omega.I omega + m g z never rises: not along a piece, not at an edge, not at
// an impact, not at a stop (relative slack 1e-9 for rounding and the integrator).
TEST(GroundPhase, EnergyNeverRises) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const auto site = mesh_site(
      100.0, 4.0,
      [](double x, double y) {
        return 2.0 * std::sin(0.11 * x) * std::cos(0.07 * y) + 0.8 * std::sin(0.37 * x + 0.5 * y);
      },
      material(0.4, 0.08, 0.3));
  int histories = 0;
  for (const bool round : {false, true}) {
    for (int h = 0; h < 200; ++h) {
      GroundBody body = round ? sphere()
                              : plate(fragments::uniform_rotation(
                                    0.5 * (1 + U(rng)), 0.5 * (1 + U(rng)), 0.5 * (1 + U(rng))));
      const Air air(1.0, 0.002, body.mass_kg);
      const Vec3 v(20.0 * U(rng), 20.0 * U(rng), 0.0);
      const Vec3 omega = round ? Vec3(30.0 * U(rng), 30.0 * U(rng), 30.0 * U(rng)) : Vec3::Zero();
      const GroundState s0 = start_at(*site, body, 60.0 * U(rng), 60.0 * U(rng), v, omega);
      const double I = body.shape.inertia_kg_m2.x();  // sphere: isotropic
      const auto energy = [&](const Vec3& p, const Vec3& vv, const Vec3& w) {
        return 0.5 * body.mass_kg * vv.squaredNorm() + (round ? 0.5 * I * w.squaredNorm() : 0.0) +
               body.mass_kg * g * p.z();
      };
      Recorder rec;
      GroundSettings gs = settings(1e-7);
      gs.max_steps = 20000;
      const GroundResult r = run(*site, air, body, s0, rec, gs);
      ASSERT_NE(r.end, GroundEnd::kStepCap);
      double e_prev = energy(s0.position_m, s0.velocity_mps, s0.omega_radps);
      const double scale = e_prev - body.mass_kg * g * (-10.0) + 1e-3;
      for (const auto& sg : rec.segments) {
        const double e = energy(sg.b, sg.vb, sg.omega_b);
        ASSERT_LE(e, e_prev + 1e-9 * scale) << "history " << h << " round " << round;
        e_prev = e;
        ASSERT_TRUE(sg.b.allFinite() && sg.vb.allFinite());
      }
      ++histories;
    }
  }
  EXPECT_EQ(histories, 400);
}

// ---- toppling (G13) ----

// Mechanical energy per the first piece of the path: before (the start) and after settling.
double energy(const GroundBody& b, const Vec3& p, const Vec3& v) {
  return 0.5 * b.mass_kg * v.squaredNorm() + b.mass_kg * g * p.z();
}

// The plate's thinnest body axis (z) along the plane's normal at attitude q, to 1e-12.
bool lies_flat(const Quat& q, const Vec3& n) {
  return std::abs(std::abs((q.conjugate() * n).z()) - 1.0) < 1e-12;
}

// A plate put down balanced on an edge (its centre over it), tipped 45 degrees onto an edge, or
// on a corner, on level ground: it falls flat as it enters the ground phase. Its centre drops to
// the flat clearance (half its thickness, 1e-15 m) at once, its speed is kept (the potential
// energy is dissipated: the energy drops by m g times the drop), it slides the Coulomb distance
// (1e-9) and rests flat, lower than it started.
TEST(GroundPhase, PlateOnAnEdgeOrACornerTopplesFlatAndComesToRestLower) {
  const auto site = slope_site(0.0, 0.5, 0.1);
  const Vec3 n = Vec3::UnitZ();
  const double v0 = 6.0, mu = 0.5;
  for (const Vec3& down : {Vec3(0.0, 0.03, 0.005), Vec3(0.0, 1.0, 1.0), Vec3(0.05, 0.03, 0.005)}) {
    const GroundBody body = plate(Quat::FromTwoVectors(down.normalized(), -n));
    const Air air(0.0, 0.0, body.mass_kg);
    const GroundState s0 = start_at(*site, body, 0.3, 0.7, Vec3(v0, 0.0, 0.0));
    ASSERT_GT(s0.position_m.z(), 0.005 + 1e-3);  // on its edge or corner, not flat
    Recorder rec;
    const GroundResult r = run(*site, air, body, s0, rec);
    ASSERT_EQ(r.end, GroundEnd::kRest);
    ASSERT_FALSE(rec.segments.empty());
    const GroundSegment& first = rec.segments.front();
    EXPECT_NEAR(first.a.z(), 0.005, 1e-15);
    EXPECT_EQ(first.va, s0.velocity_mps);
    const double drop = s0.position_m.z() - first.a.z();
    EXPECT_NEAR(energy(body, s0.position_m, s0.velocity_mps) - energy(body, first.a, first.va),
                body.mass_kg * g * drop, 1e-12);
    EXPECT_TRUE(lies_flat(r.state.attitude, n));
    EXPECT_NEAR(r.state.position_m.z(), 0.005, 1e-15);
    EXPECT_LT(r.state.position_m.z(), s0.position_m.z() - 1e-3);
    const double d = v0 * v0 / (2 * mu * g);
    EXPECT_NEAR(r.path_m, d, 1e-9 * d);
  }
}

// On a 20 degree slope (mu 0.9: it comes to rest) a plate on an edge or in a random attitude
// settles onto the plane's face: its resting face normal along -n (1e-12) and its centre at that
// face's clearance above the plane (1e-12 m). The energy (kinetic + m g z) never rises on entry
// (1e-12 of its size).
TEST(GroundPhase, OnASlopeTheSettledFaceIsThePlanes) {
  const double slope = std::tan(20.0 * kPi / 180.0);
  const auto site = slope_site(slope, 0.9, 0.1);
  const Vec3 n = site->terrain_triangle_normal(
      static_cast<std::uint32_t>(site->terrain_triangle_at(3.3, 1.7)));
  ASSERT_NEAR(n.x(), -std::sin(20.0 * kPi / 180.0), 1e-12);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Quat q = trial == 0 ? Quat::FromTwoVectors(Vec3(0.0, 1.0, 1.0).normalized(), -n)
                              : fragments::uniform_rotation(u(rng), u(rng), u(rng));
    const GroundBody body = plate(q);
    const Air air(0.0, 0.0, body.mass_kg);
    const Vec3 v(2.0 * (u(rng) - 0.5), 2.0 * (u(rng) - 0.5), 0.0);
    const GroundState s0 = start_at(*site, body, 3.3, 1.7, v);
    Recorder rec;
    const GroundResult r = run(*site, air, body, s0, rec);
    ASSERT_EQ(r.end, GroundEnd::kRest) << trial;
    const double e0 = energy(body, s0.position_m, s0.velocity_mps);
    for (const GroundSegment& sg : rec.segments)
      EXPECT_LE(energy(body, sg.a, sg.va), e0 + 1e-12 * std::abs(e0)) << trial;
    // At rest: a body axis along -n, the centre at that face's clearance above the plane.
    const Quat& qr = r.state.attitude;
    EXPECT_NEAR((qr.conjugate() * n).cwiseAbs().maxCoeff(), 1.0, 1e-12) << trial;
    const Vec3& p = r.state.position_m;
    const double height = n.dot(p - Vec3(p.x(), p.y(), site->terrain_height(p.x(), p.y())));
    EXPECT_NEAR(height, ground_clearance(body, qr, n), 1e-12) << trial;
    // The least rotation into that rest (to 1e-12 rad: the grid's triangles differ in normal by
    // rounding, and crossing one turns the attitude by that much).
    EXPECT_LT(qr.angularDistance(fragments::toppled_attitude(body.shape, q, n)), 1e-12) << trial;
    if (trial == 0) {
      EXPECT_TRUE(lies_flat(qr, n));
      EXPECT_NEAR(height, 0.005, 1e-12);
    }
  }
}

// A plate already lying flat (turned about the normal, either face down) is not touched: its
// attitude comes out bit for bit, its centre stays at its height exactly.
TEST(GroundPhase, AFlatPlateIsLeftExactlyAsItWas) {
  const auto site = slope_site(0.0, 0.5, 0.1);
  for (int k = 0; k < 6; ++k) {
    const Quat q = Quat(Eigen::AngleAxisd(0.41 * k, Vec3::UnitZ())) *
                   Quat(Eigen::AngleAxisd(k % 2 ? kPi : 0.0, Vec3::UnitX()));
    const GroundBody body = plate(q);
    const Air air(0.0, 0.0, body.mass_kg);
    const GroundState s0 = start_at(*site, body, 0.3, 0.7, Vec3(4.0, 1.0, 0.0));
    Recorder rec;
    const GroundResult r = run(*site, air, body, s0, rec);
    ASSERT_EQ(r.end, GroundEnd::kRest);
    EXPECT_EQ(r.state.attitude.coeffs(), q.coeffs()) << k;
    EXPECT_EQ(rec.segments.front().a.z(), s0.position_m.z()) << k;
  }
}

// ---- termination ----

TEST(GroundPhase, ObserverStopsAndStepCapEnds) {
  const auto site = slope_site(0.0, 0.5, 0.1);
  const GroundBody body = plate();
  const Air air(0.0, 0.0, body.mass_kg);
  const GroundState s0 = start_at(*site, body, 0.0, 0.0, Vec3(20.0, 0.0, 0.0));
  Recorder rec;
  rec.stop_after_m = 15.0;
  const GroundResult r = run(*site, air, body, s0, rec);
  EXPECT_EQ(r.end, GroundEnd::kStoppedByObserver);
  EXPECT_NEAR(r.path_m, rec.covered, 1e-12);
  Recorder rec2;
  GroundSettings gs = settings();
  gs.max_steps = 1;
  EXPECT_EQ(run(*site, air, body, s0, rec2, gs).end, GroundEnd::kStepCap);
}

// ---- materials by zone ----

namespace zones {

// Level grid over [-200, 200]^2 in 10 m cells: "a" (the base) where x < 0, zone "b" for x > 0.
std::shared_ptr<const scene::Site> two_zone_site(const scene::MaterialSpec& a,
                                                 const scene::MaterialSpec& b) {
  scene::SiteSpec spec;
  scene::GridTerrainSpec grid;
  grid.origin_m = {-200.0, -200.0};
  grid.spacing_m = 10.0;
  grid.nx = grid.ny = 41;
  grid.elevation_m.assign(41 * 41, 0.0);
  spec.terrain.geometry = grid;
  spec.terrain.material = "a";
  spec.terrain.zones = {{"b", {{0, -200}, {200, -200}, {200, 200}, {0, 200}}}};
  spec.materials["a"] = a;
  spec.materials["b"] = b;
  return scene::Site::build(spec);
}

std::shared_ptr<const scene::Site> one_material_site(const scene::MaterialSpec& m) {
  return two_zone_site(m, m);
}

// A slide wholly inside one zone is the single-material slide of that zone's material, to the
// last bit (the same triangles, the same law).
TEST(GroundPhaseZones, ASlideInEachZoneIsThatMaterialsSlide) {
  const scene::MaterialSpec a = material(0.3, 0.1, 0.2), b = material(0.8, 0.05, 0.4);
  const auto zoned = two_zone_site(a, b);
  const GroundBody body = plate();
  const Air air(0.0, 0.0, body.mass_kg);
  for (const double x0 : {-150.0, 30.0}) {
    const auto alone = one_material_site(x0 < 0 ? a : b);
    const Vec3 v(5.0, 2.0, 0.0);  // 1.6 m (b) to 4.9 m (a): inside the zone it starts in
    Recorder r1, r2;
    const GroundResult z = run(*zoned, air, body, start_at(*zoned, body, x0, 3.3, v), r1);
    const GroundResult s = run(*alone, air, body, start_at(*alone, body, x0, 3.3, v), r2);
    EXPECT_EQ(z.end, GroundEnd::kRest);
    EXPECT_EQ(z.state.position_m, s.state.position_m) << x0;
    EXPECT_EQ(z.state.t_s, s.state.t_s) << x0;
    EXPECT_EQ(z.steps, s.steps) << x0;
  }
}

// Crossing the boundary x = 0 on the ground switches Coulomb's law there: deceleration mu_a g
// up to the boundary, mu_b g beyond it, so the plate stops at x = (v0^2 - 2 mu_a g d) / (2 mu_b
// g) (relative 1e-8: the boundary crossing is found by the integrator's event search), and the
// same slide the other way round stops where the mirrored closed form says.
TEST(GroundPhaseZones, CrossingAZoneBoundarySwitchesTheLawAtTheBoundary) {
  const double mu_a = 0.3, mu_b = 0.8, d = 12.0, v0 = 14.0;
  const auto site = two_zone_site(material(mu_a, 0.1, 0.2), material(mu_b, 0.1, 0.2));
  const GroundBody body = plate();
  const Air air(0.0, 0.0, body.mass_kg);
  Recorder rec;
  const GroundResult r = run(*site, air, body, start_at(*site, body, -d, 3.3, Vec3(v0, 0, 0)), rec);
  ASSERT_EQ(r.end, GroundEnd::kRest);
  const double x_stop = (v0 * v0 - 2 * mu_a * g * d) / (2 * mu_b * g);
  EXPECT_NEAR(site->to_input(r.state.position_m).x(), x_stop, 1e-8 * (d + x_stop));
  const double t_stop = (v0 - std::sqrt(v0 * v0 - 2 * mu_a * g * d)) / (mu_a * g) +
                        std::sqrt(v0 * v0 - 2 * mu_a * g * d) / (mu_b * g);
  EXPECT_NEAR(r.state.t_s, t_stop, 1e-8 * t_stop);
  // From b into a: deceleration mu_b g first.
  Recorder back;
  const GroundResult rb =
      run(*site, air, body, start_at(*site, body, d, 3.3, Vec3(-v0, 0, 0)), back);
  ASSERT_EQ(rb.end, GroundEnd::kRest);
  const double x_back = -(v0 * v0 - 2 * mu_b * g * d) / (2 * mu_a * g);
  EXPECT_NEAR(site->to_input(rb.state.position_m).x(), x_back, 1e-8 * (d - x_back));
}

}  // namespace zones

// ---- polyhedra ----

// The plate given as its 8 corners moves as the cuboid plate: on the 20 degree slope and on the
// bumpy terrain, from random attitudes and velocities, the same end, end state (1e-9 m, m/s) and
// path (1e-9 relative).
TEST(GroundPhase, CubePolyhedronMovesAsTheCuboid) {
  const auto slope = slope_site(std::tan(20.0 * kPi / 180.0), 0.9, 0.1);
  const auto bumpy = mesh_site(
      100.0, 4.0,
      [](double x, double y) {
        return 2.0 * std::sin(0.11 * x) * std::cos(0.07 * y) + 0.8 * std::sin(0.37 * x + 0.5 * y);
      },
      material(0.4, 0.08, 0.3));
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    const scene::Site& site = trial % 2 ? *bumpy : *slope;
    const Quat q = fragments::uniform_rotation(u(rng), u(rng), u(rng));
    const GroundBody a = plate(q), b = plate_polyhedron(q);
    const Air air(1.0, 0.002, a.mass_kg);
    const Vec3 v(10.0 * (u(rng) - 0.5), 10.0 * (u(rng) - 0.5), 0.0);
    const double x = 40.0 * (u(rng) - 0.5), y = 40.0 * (u(rng) - 0.5);
    Recorder ra, rb;
    GroundSettings gs = settings(1e-7);
    gs.max_steps = 20000;
    const GroundResult r1 = run(site, air, a, start_at(site, a, x, y, v), ra, gs);
    const GroundResult r2 = run(site, air, b, start_at(site, b, x, y, v), rb, gs);
    ASSERT_EQ(r1.end, r2.end) << trial;
    EXPECT_NEAR((r1.state.position_m - r2.state.position_m).norm(), 0.0, 1e-9) << trial;
    EXPECT_NEAR((r1.state.velocity_mps - r2.state.velocity_mps).norm(), 0.0, 1e-9) << trial;
    EXPECT_NEAR(r1.path_m, r2.path_m, 1e-9 * (1.0 + r1.path_m)) << trial;
    EXPECT_EQ(r1.impacts, r2.impacts) << trial;
  }
}

// Random rocks (a new hull each history) on the bumpy terrain, 200 histories: the mechanical
// energy never rises along the path (relative slack 1e-9, as for the plate), every history ends
// (no step cap), nothing is NaN, and a rock at rest lies on a face (its support along -n a face
// of the hull: the clearance equals that face's offset).
TEST(GroundPhase, RocksNeverGainEnergyAndAlwaysEnd) {
  std::mt19937_64 rng(19);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const auto site = mesh_site(
      100.0, 4.0,
      [](double x, double y) {
        return 2.0 * std::sin(0.11 * x) * std::cos(0.07 * y) + 0.8 * std::sin(0.37 * x + 0.5 * y);
      },
      material(0.5, 0.08, 0.3));
  int rests = 0;
  for (int h = 0; h < 200; ++h) {
    const GroundBody body = rock(
        1000 + h,
        fragments::uniform_rotation(0.5 * (1 + U(rng)), 0.5 * (1 + U(rng)), 0.5 * (1 + U(rng))));
    const Air air(1.0, 0.01, body.mass_kg);
    const Vec3 v(15.0 * U(rng), 15.0 * U(rng), 0.0);
    const GroundState s0 = start_at(*site, body, 60.0 * U(rng), 60.0 * U(rng), v);
    Recorder rec;
    GroundSettings gs = settings(1e-7);
    gs.max_steps = 20000;
    const GroundResult r = run(*site, air, body, s0, rec, gs);
    ASSERT_NE(r.end, GroundEnd::kStepCap) << h;
    double e_prev = energy(body, s0.position_m, s0.velocity_mps);
    const double scale = e_prev - body.mass_kg * g * (-10.0) + 1e-3;
    for (const auto& sg : rec.segments) {
      ASSERT_TRUE(sg.b.allFinite() && sg.vb.allFinite()) << h;
      const double e = energy(body, sg.b, sg.vb);
      ASSERT_LE(e, e_prev + 1e-9 * scale) << "history " << h;
      e_prev = e;
    }
    for (const auto& i : rec.impacts)
      EXPECT_LE(energy(body, i.position_m, i.velocity_after_mps),
                energy(body, i.position_m, i.velocity_before_mps) + 1e-9 * scale);
    if (r.end == GroundEnd::kRest) {
      ++rests;
      const Vec3& n = site->terrain_triangle_normal(r.state.triangle);
      const Vec3 down = r.state.attitude.conjugate() * (-n);
      const auto& p = *body.shape.polyhedron;
      double best = 0.0;
      for (std::size_t f = 0; f < p.normals().size(); ++f)
        best = std::max(best, p.normals()[f].dot(down));
      EXPECT_GT(best, 1.0 - 1e-9) << h;  // a face lies on the plane
    }
  }
  std::printf("[ measured ] 200 rock ground histories: %d came to rest\n", rests);
  EXPECT_GT(rests, 20);
}

}  // namespace
}  // namespace fragsim::impact
