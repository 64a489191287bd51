// Whole histories under the fast-contact law (core/impact/fast_contact.h; F1-F6 in
// core/scene/site_spec.h): a fragment skipping at 300-700 m/s over a flat soil plane, compared
// with the hop sequence written out here in closed form.
//
// In vacuum over a level plane every hop is the textbook parabola: it leaves the contact height at
// speed u and angle phi and comes back to it at the same speed and angle after
//   range R = u^2 sin(2 phi) / g,  time T = 2 u sin(phi) / g.
// At each contact (speed v_k, grazing angle theta_k) the law gives
//   v_{k+1}^2 = (v_k^2 + v_s^2) exp(-4 (D/L) (theta_k + r)) - v_s^2,  theta_{k+1} = ratio (theta_k
//   + r)
// (here the F6 floor asin(0.5 / v) < 0.1 deg never binds), until theta_k >= theta_c (embedded) or
// v < v_s (then the rigid bounce takes over and the comparison ends). The launch is h above the
// contact height, so the first contact is the parabola's: t_1 = (v_z0 + sqrt(v_z0^2 + 2 g h)) / g.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/run/run.h"
#include "scenario_fixtures.h"

namespace fragsim::validation {
namespace {

constexpr double kSteel = 7850.0;
constexpr double kG = kStandardGravity_mps2;
constexpr double kLift = 0.1;  // launch height above the contact height [m]

struct Contact {
  double t_s = 0.0, x_m = 0.0, speed_mps = 0.0, theta_rad = 0.0;
};

struct HopSequence {
  std::vector<Contact> contacts;  // every terrain contact under the law
  bool embedded = false;          // the last contact embeds (else it left the regime: v < v_s)
};

// The closed-form sequence above for the default soil law (v_s 30, D/L 1, r 2 deg, ratio 1)
// and steel (theta_c = 18 deg / sqrt(7850 / 1700)).
HopSequence closed_form_hops(double v0, double theta0_deg) {
  const scene::FastContactSpec law;
  const double theta_c =
      law.critical_angle_coefficient_deg * kDegToRad / std::sqrt(kSteel / law.bulk_density_kg_m3);
  const double vs2 = law.switch_speed_mps * law.switch_speed_mps;
  const double vx = v0 * std::cos(theta0_deg * kDegToRad),
               vz0 = v0 * std::sin(theta0_deg * kDegToRad);
  const double vz1 = std::sqrt(vz0 * vz0 + 2 * kG * kLift);  // downward speed at contact height
  HopSequence s;
  Contact c{(vz1 - vz0) / kG, 0.0, std::hypot(vx, vz1), std::atan2(vz1, vx)};
  c.x_m = vx * c.t_s;
  for (;;) {
    s.contacts.push_back(c);
    if (c.theta_rad >= theta_c) {
      s.embedded = true;
      return s;
    }
    const double theta_e = c.theta_rad + law.roughness_deg * kDegToRad;
    const double out2 =
        (c.speed_mps * c.speed_mps + vs2) * std::exp(-4 * law.drag_to_lift_ratio * theta_e) - vs2;
    if (!(out2 >= vs2)) return s;  // slower than v_s: out of the law's regime
    const double u = std::sqrt(out2), phi = law.exit_angle_ratio * theta_e;
    c.t_s += 2 * u * std::sin(phi) / kG;
    c.x_m += u * u * std::sin(2 * phi) / kG;
    c.speed_mps = u;
    c.theta_rad = phi;
  }
}

// One steel fragment (sphere or a flat square plate, no spin, level attitude) launched along +x
// at theta0 below the horizon from kLift above its contact height, over a 40 km x 40 km soil
// plane with the default fast_contact law, bounce on, air of density `air` (Cd 0.47).
run::Scenario skipping_scenario(bool plate, double v0, double theta0_deg, double air) {
  run::Scenario sc = flat_site_scenario(20000.0, 1000.0);
  sc.site.materials["soil"].fast_contact = scene::FastContactSpec{};
  sc.atmosphere.density_kg_m3 = air;
  sc.settings.bounce = true;
  sc.settings.record_fragments = true;
  sc.settings.record_trajectories = true;
  sc.settings.harmless_cutoff = false;
  sc.settings.hazardous_ke_j = 1e-9;
  const double mass = 1.0;
  double clearance = std::cbrt(3.0 * mass / (4.0 * kPi * kSteel));  // sphere radius
  auto g = sphere_group(Vec3(0, 0, 0), mass, v0, 1.0, 1);
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = -theta0_deg;
  g.direction.azimuth_min_deg = g.direction.azimuth_max_deg = 0.0;
  g.attitude = fragments::AttitudeSpec{};
  if (plate) {  // 0.1 x 0.1 m, thickness giving 1 kg of steel: lies on its 0.1 x 0.1 face
    const double thick = mass / (kSteel * 0.01);
    g.shape.type = fragments::ShapeType::kCuboid;
    g.shape.density_kg_m3.reset();
    g.shape.dims_m = {0.1, 0.1, thick};
    clearance = 0.5 * thick;
  }
  g.frame.origin_m.z() = clearance + kLift;
  sc.groups = {g};
  return sc;
}

// The recorded terrain contacts (and the take-off following each, if any) of the only history.
struct Recorded {
  std::vector<double> t;
  std::vector<Vec3> p, v_in, v_out;  // v_out empty-padded (NaN) where no take-off follows
};

Recorded recorded_contacts(const run::TrajectoryRecord& tr) {
  Recorded r;
  for (std::size_t i = 0; i < tr.t_s.size(); ++i) {
    if (tr.event[i] == run::TrajectoryEvent::kTerrainImpact) {
      r.t.push_back(tr.t_s[i]);
      r.p.push_back(tr.position_m[i]);
      r.v_in.push_back(tr.velocity_mps[i]);
      r.v_out.push_back(Vec3::Constant(std::nan("")));
    } else if (tr.event[i] == run::TrajectoryEvent::kTakeOff && !r.v_out.empty()) {
      r.v_out.back() = tr.velocity_mps[i];
    }
  }
  return r;
}

double grazing_rad(const Vec3& v) {
  return std::atan2(-v.z(), v.head<2>().norm());
}
double elevation_rad(const Vec3& v) {
  return std::atan2(v.z(), v.head<2>().norm());
}

// Vacuum, sphere and plate, 300-700 m/s at 2-8 deg: every contact's time, position, speed and
// angle against the closed form, and the end (embedded at the last contact).
//
// Tolerances: the integrator runs at rtol 1e-6, which would bound a general trajectory's error.
// Gravity alone, though, is a quadratic in t, which the 5th-order integrator and its dense output
// reproduce exactly, so what is left is rounding in the contact root and in the law: measured
// <= 9e-14 relative (printed). Asserted: 1e-10 relative on time, distance and speed and 1e-10 rad
// on angles, four decades of slack over the rounding and four under rtol. A law off by a factor
// (exp(-2 ...) for exp(-4 ...)), a missing roughness or a slide after a contact moves these by
// percent.
TEST(FastContactHistory, VacuumHopsFollowTheClosedForm) {
  struct Case {
    bool plate;
    double v0, theta0_deg;
  };
  for (const Case& k :
       {Case{false, 300, 2}, Case{false, 700, 2}, Case{false, 500, 5}, Case{false, 300, 8},
        Case{true, 300, 2}, Case{true, 700, 2}, Case{true, 500, 5}}) {
    SCOPED_TRACE(testing::Message()
                 << (k.plate ? "plate " : "sphere ") << k.v0 << " m/s, " << k.theta0_deg << " deg");
    const HopSequence expect = closed_form_hops(k.v0, k.theta0_deg);
    ASSERT_TRUE(expect.embedded);  // on this soil every case ends embedded, not slowed
    const run::RunResult res = run::run(skipping_scenario(k.plate, k.v0, k.theta0_deg, 0.0));
    ASSERT_EQ(res.trajectories.size(), 1u);
    const Recorded got = recorded_contacts(res.trajectories[0]);
    ASSERT_EQ(got.t.size(), expect.contacts.size());
    EXPECT_EQ(res.stats.fast_contacts, static_cast<std::int64_t>(expect.contacts.size()));
    EXPECT_EQ(res.stats.fast_slides, 0);
    double worst = 0.0;
    for (std::size_t i = 0; i < got.t.size(); ++i) {
      const Contact& c = expect.contacts[i];
      const double rel_t = std::abs(got.t[i] - c.t_s) / c.t_s;
      const double rel_x = std::abs(got.p[i].x() - c.x_m) / std::max(c.x_m, 1.0);
      const double rel_v = std::abs(got.v_in[i].norm() - c.speed_mps) / c.speed_mps;
      const double d_th = std::abs(grazing_rad(got.v_in[i]) - c.theta_rad);
      worst = std::max({worst, rel_t, rel_x, rel_v, d_th});
      EXPECT_LT(rel_t, 1e-10) << "contact " << i;
      EXPECT_LT(rel_x, 1e-10) << "contact " << i;
      EXPECT_LT(rel_v, 1e-10) << "contact " << i;
      EXPECT_LT(d_th, 1e-10) << "contact " << i;
      EXPECT_NEAR(got.p[i].y(), 0.0, 1e-9);
    }
    std::printf("%s %g m/s %g deg: %zu contacts, worst relative deviation %.2e\n",
                k.plate ? "plate" : "sphere", k.v0, k.theta0_deg, got.t.size(), worst);
    ASSERT_EQ(res.fragments.size(), 1u);
    const run::FragmentRecord& f = res.fragments[0];
    EXPECT_EQ(f.outcome, run::Outcome::kEmbedded);
    EXPECT_NEAR(f.end_position_m.x(), expect.contacts.back().x_m,
                1e-10 * expect.contacts.back().x_m);
    EXPECT_NEAR(f.end_time_s, expect.contacts.back().t_s, 1e-10 * expect.contacts.back().t_s);
  }
}

// In air (1.225 kg/m^3, Cd 0.47) there is no closed form for the hops. What is exact: each
// take-off is the law applied to the recorded contact velocity (speed ratio and exit angle, to
// rounding: 1e-9), and drag steepens the descent, so every contact's grazing angle is at least
// the previous exit angle (the descending branch of a dragged trajectory is steeper than the
// ascending one at the same height). The sequence still ends embedded, sooner than in vacuum.
// Observed (500 m/s, 2 deg): sphere contacts at 2.01, 7.80, 11.8 deg after exits of 4.01 and
// 9.80 deg, embedded at 1.5 km (vacuum: 5 contacts, 8.5 km); the plate embeds at its second.
TEST(FastContactHistory, InAirEachExitIsTheLawAndDescentsSteepen) {
  const scene::FastContactSpec law;
  const double vs2 = law.switch_speed_mps * law.switch_speed_mps;
  for (bool plate : {false, true}) {
    SCOPED_TRACE(plate ? "plate" : "sphere");
    const run::RunResult res = run::run(skipping_scenario(plate, 500, 2, 1.225));
    const Recorded got = recorded_contacts(res.trajectories.at(0));
    ASSERT_GE(got.t.size(), 2u);
    for (std::size_t i = 0; i < got.t.size(); ++i) {
      if (std::isnan(got.v_out[i].x())) {
        EXPECT_EQ(i + 1, got.t.size()) << "only the last contact has no take-off";
        continue;
      }
      const double v = got.v_in[i].norm(), theta_e = grazing_rad(got.v_in[i]) + 2.0 * kDegToRad;
      const double law_speed = std::sqrt((v * v + vs2) * std::exp(-4 * theta_e) - vs2);
      EXPECT_NEAR(got.v_out[i].norm(), law_speed, 1e-9 * v) << "contact " << i;
      EXPECT_NEAR(elevation_rad(got.v_out[i]), theta_e, 1e-9) << "contact " << i;
      if (i + 1 < got.t.size()) {
        EXPECT_GE(grazing_rad(got.v_in[i + 1]), elevation_rad(got.v_out[i])) << "contact " << i;
      }
    }
    EXPECT_EQ(res.fragments.at(0).outcome, run::Outcome::kEmbedded);
    EXPECT_EQ(res.stats.fast_slides, 0);
    EXPECT_LE(got.t.size(), closed_form_hops(500, 2).contacts.size());
  }
}

}  // namespace
}  // namespace fragsim::validation

namespace fragsim::validation {
namespace {

// A fragment skimming the soil below person height, PTN density per crossed triangle (paper eqs.
// 37-39): with roughness 0 and exit_angle_ratio 0 every ricochet leaves at the F6 floor angle
// asin(0.5 m/s / v) (~0.1 deg at 300 m/s: hops of 2 v 0.5 / g ~ 30 m, 1.3 cm high), so the
// sphere's centre stays within the prisms [0, H] the whole way and keeps > 200 m/s (each contact
// keeps exp(-2 theta) of its speed, theta ~ 0.0017 rad). A prism crossed along x, horizontally,
// presents H x (its width across the path) = H c for both triangles of a square cell of side c,
// so each triangle the path crosses gets, once (the first crossing counts), w / (H c), with w the
// history's real fragments. The path's slope s tilts the projection: H c cos(s) + (c^2 / 2) sin(s)
// (the prism's top), at most 1.3 % more on the first descent (0.27 deg) and ~0.5 % after: the
// tolerance is 1.5 % below w / (H c) and nothing above it.
TEST(FastContactHistory, ASkimBelowPersonHeightGivesEachCrossedTriangleOneOverHTimesWidth) {
  constexpr double kCell = 10.0, kH = 1.8, kCount = 3.0;
  run::Scenario sc = flat_site_scenario(100.0, kCell);
  auto& plane = std::get<scene::PlaneTerrainSpec>(sc.site.terrain.geometry);
  plane.extent_m = {-100.0, -50.0, 3000.0, 50.0};
  scene::FastContactSpec law;
  law.roughness_deg = 0.0;
  law.exit_angle_ratio = 0.0;
  sc.site.materials["soil"].fast_contact = law;
  sc.atmosphere.density_kg_m3 = 0.0;
  sc.settings.bounce = true;
  sc.settings.person_height_m = kH;
  const double mass = 1.0, radius = std::cbrt(3.0 * mass / (4.0 * kPi * kSteel));
  auto g = sphere_group(Vec3(-50.0, 5.0, radius + kLift), mass, 300.0, kCount, 1);
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = 0.0;
  g.direction.azimuth_min_deg = g.direction.azimuth_max_deg = 0.0;
  sc.groups = {g};
  // The tally walks chords of the path whose sagitta is at most sagitta_m (default 5 cm): a path
  // skimming 3 cm above the ground would have chords dipping below it, out of the prisms' bottom
  // (found by this test: 2 of 598 triangles missed at 5 cm). 1 mm keeps every chord above it.
  sc.settings.sagitta_m = 1e-3;
  const run::RunResult r = run::run(sc);
  ASSERT_EQ(r.outcome_histories[static_cast<int>(run::Outcome::kLeftSite)], 1);
  EXPECT_GT(r.stats.fast_contacts, 50);
  EXPECT_EQ(r.stats.fast_slides, 0);
  const double expected = kCount / (kH * kCell);
  // The cells of the row y in [0, 10] from x = 0 to 2990: two triangles each (lattice layout:
  // cell (i, j) holds triangles 2 (j nx + i) and 2 (j nx + i) + 1, nx = 310, the row j = 5).
  const std::int64_t nx = 310, j = 5;
  int checked = 0;
  for (std::int64_t i = 10; i < 309; ++i) {
    for (std::int64_t t = 2 * (j * nx + i); t <= 2 * (j * nx + i) + 1; ++t) {
      const double d = r.ptn_density_per_m2[static_cast<std::size_t>(t)];
      EXPECT_LE(d, expected * (1.0 + 1e-12)) << "triangle " << t;
      EXPECT_GE(d, expected * (1.0 - 0.015)) << "triangle " << t;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 598);
  // Nothing off the row.
  double elsewhere = 0.0;
  for (std::size_t t = 0; t < r.ptn_density_per_m2.size(); ++t)
    if (static_cast<std::int64_t>(t) / 2 / nx != j) elsewhere += r.ptn_density_per_m2[t];
  EXPECT_EQ(elsewhere, 0.0);
}

}  // namespace
}  // namespace fragsim::validation
