// The pilot estimate of fragments landing beyond the terrain (reach.h).
#include "core/run/reach.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "core/common/roots.h"
#include "core/flight/atmosphere.h"
#include "core/flight/flight_model.h"
#include "core/flight/trajectory.h"
#include "core/fragments/sampling.h"

namespace fragsim::run {
namespace {

// A launch point within this below the terrain still counts as on it (as the run's launch check).
constexpr double kLaunchContact_m = 1e-6;

struct Landing {
  Vec3 p{0, 0, 0};
  Vec3 v{0, 0, 0};
};

// Where the point mass first comes down to z = ground_z (local), located on the dense output;
// nothing when it is still up at t_max or after max_steps steps. Gravity and quadratic drag in
// the run's atmosphere (paper eqs. 3-5, flight::FlightModel).
std::optional<Landing> fly_to_level(const flight::FlightModel& model, const Vec3& p0,
                                    const Vec3& v0, double ground_z, double t_max,
                                    const ReachOptions& opt) {
  if (p0.z() <= ground_z && v0.z() <= 0.0) return Landing{p0, v0};
  flight::TrajectoryIntegrator integ(model, opt.rtol);
  integ.reset(0.0, p0, v0);
  const auto height = [&](double t) { return integ.position(t).z() - ground_z; };
  for (std::int64_t k = 0; k < opt.max_steps; ++k) {
    if (!integ.step(t_max)) return std::nullopt;
    const double z1 = integ.position().z() - ground_z;
    if (z1 > 0.0) continue;
    const double t0 = integ.t_prev(), t1 = integ.t();
    const RootBracket b = illinois(height, t0, t1, height(t0), z1, 1e-9);
    return Landing{integ.position(b.hi), integ.velocity(b.hi)};
  }
  return std::nullopt;
}

bool on_terrain(const scene::Site& site, const Vec2& xy) {
  return site.terrain_triangle_at(xy.x(), xy.y()) >= 0;
}

// The frame origin (local) can launch fragments: over the terrain, not under it, not inside a
// building.
bool launches_on_site(const scene::Site& site, const Vec3& o) {
  if (!on_terrain(site, o.head<2>())) return false;
  if (o.z() < site.terrain_height(o.x(), o.y()) - kLaunchContact_m) return false;
  return !(site.has_buildings() && site.inside_building(o));
}

// Horizontal distance from `o` along unit `dir` to where the terrain first ends, knowing that
// it has ended by `beyond_m`: marched in 1/1024 of that, then bisected to a millimetre.
double terrain_edge_along(const scene::Site& site, const Vec2& o, const Vec2& dir,
                          double beyond_m) {
  constexpr int kMarch = 1024;
  double in = 0.0, out = beyond_m;
  for (int k = 1; k <= kMarch; ++k) {
    const double s = beyond_m * k / kMarch;
    if (!on_terrain(site, o + s * dir)) {
      out = s;
      break;
    }
    in = s;
  }
  for (int it = 0; it < 64 && out - in > 1e-3; ++it) {  // 64: a bound whatever the distances
    const double mid = 0.5 * (in + out);
    (on_terrain(site, o + mid * dir) ? in : out) = mid;
  }
  return 0.5 * (in + out);
}

// What the pilot of one group found.
struct Pilot {
  std::int64_t beyond = 0;
  double farthest_m = -1.0;
  Vec2 farthest_dir{1, 0};
};

void fly_pilot(const Scenario& sc, const scene::Site& site, const flight::Atmosphere& atmosphere,
               std::uint32_t g, std::int64_t k_pilot, const ReachOptions& opt, Pilot& out) {
  const fragments::FragmentGroupSpec& group = sc.groups[g];
  const flight::DragCoefficient cd(group.cd);
  const Vec3 origin = site.to_local(group.frame.origin_m);
  // The launch level; an origin up to kLaunchContact_m under the terrain launches from itself.
  const double ground_z = std::min(site.terrain_height(origin.x(), origin.y()), origin.z());
  flight::FlightModel model;
  model.atmosphere = &atmosphere;
  model.cd = &cd;
  model.gravity_mps2 = sc.gravity_mps2;
  model.altitude_offset_m = site.altitude_offset_m();
  for (std::int64_t h = 0; h < k_pilot; ++h) {
    const fragments::FragmentInit f =
        fragments::sample_fragment(group, g, static_cast<std::uint64_t>(h), sc.settings.seed);
    model.area_m2 = f.body.presented_area_m2;
    model.mass_kg = f.body.mass_kg;
    const auto land = fly_to_level(model, site.to_local(f.position_m), f.velocity_mps, ground_z,
                                   sc.settings.max_flight_time_s, opt);
    if (!land || on_terrain(site, land->p.head<2>())) continue;
    if (0.5 * f.body.mass_kg * land->v.squaredNorm() < sc.settings.hazardous_ke_j) continue;
    ++out.beyond;
    const Vec2 d = land->p.head<2>() - origin.head<2>();
    if (d.norm() > out.farthest_m) {
      out.farthest_m = d.norm();
      out.farthest_dir = d.norm() > 0.0 ? Vec2(d / d.norm()) : Vec2(1, 0);
    }
  }
}

ReachWarning make_warning(const Scenario& sc, const scene::Site& site, std::uint32_t g,
                          std::int64_t k_pilot, const Pilot& p) {
  const fragments::FragmentGroupSpec& group = sc.groups[g];
  ReachWarning w;
  w.group = g;
  w.group_name = group.name;
  w.count = group.count;
  w.pilot = k_pilot;
  w.beyond = p.beyond;
  w.fraction = static_cast<double>(p.beyond) / static_cast<double>(k_pilot);
  w.fraction_se = std::sqrt(w.fraction * (1.0 - w.fraction) / static_cast<double>(k_pilot));
  w.real_fragments = group.count * w.fraction;
  w.hazardous_ke_j = sc.settings.hazardous_ke_j;
  w.farthest_m = p.farthest_m;
  const double az = std::atan2(p.farthest_dir.y(), p.farthest_dir.x()) / kDegToRad;
  w.farthest_azimuth_deg = az < 0.0 ? az + 360.0 : az;
  const Vec2 o = site.to_local(group.frame.origin_m).head<2>();
  w.terrain_edge_m = terrain_edge_along(site, o, p.farthest_dir, p.farthest_m);
  return w;
}

// ---- message formatting ----

double round_significant(double x, int digits) {
  if (!(x > 0.0)) return x;
  const double scale = std::pow(10.0, digits - 1 - static_cast<int>(std::floor(std::log10(x))));
  return std::round(x * scale) / scale;
}

// 1230 -> "1,230" (x >= 0, a whole number).
std::string with_separators(double x) {
  const std::string digits = std::to_string(std::llround(x));
  std::string out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

// A figure to `digits` significant digits: thousands separated from 100 on, else "%.*g".
std::string about(double x, int digits) {
  if (x >= 100.0) return with_separators(round_significant(x, digits));
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*g", digits, x);
  return buf;
}

// A percentage: whole from 10 % on, two significant digits below.
std::string percent(double fraction) {
  const double p = 100.0 * fraction;
  return p >= 9.5 ? with_separators(p) : about(p, 2);
}

}  // namespace

std::int64_t pilot_size(std::size_t groups, const ReachOptions& options) {
  if (groups == 0) return options.pilot_per_group;
  const std::int64_t share = options.pilot_budget / static_cast<std::int64_t>(groups);
  return std::max<std::int64_t>(1, std::min(options.pilot_per_group, share));
}

std::vector<ReachWarning> groups_beyond_terrain(const Scenario& sc, const scene::Site& site,
                                                const ReachOptions& options) {
  std::vector<std::uint32_t> eligible;
  for (std::uint32_t g = 0; g < sc.groups.size(); ++g)
    if (launches_on_site(site, site.to_local(sc.groups[g].frame.origin_m))) eligible.push_back(g);
  const std::int64_t k_pilot = pilot_size(eligible.size(), options);
  const flight::Atmosphere atmosphere(sc.atmosphere);
  std::vector<ReachWarning> warnings;
  for (const std::uint32_t g : eligible) {
    Pilot p;
    fly_pilot(sc, site, atmosphere, g, k_pilot, options, p);
    if (p.beyond > 0) warnings.push_back(make_warning(sc, site, g, k_pilot, p));
  }
  return warnings;
}

std::string reach_field(const ReachWarning& w) {
  return "fragment_groups[" + std::to_string(w.group) + "]";
}

std::string reach_message(const ReachWarning& w) {
  char ke[32];
  std::snprintf(ke, sizeof ke, "%g", w.hazardous_ke_j);
  const long azimuth = std::lround(w.farthest_azimuth_deg) % 360;
  const std::string what = w.plain() ? "about " + percent(w.fraction) + " % of its fragments (~" +
                                           about(w.real_fragments, 2) + " real fragments) land"
                                     : "a few of its fragments (one pilot fragment of " +
                                           std::to_string(w.pilot) + ", ~" +
                                           about(w.real_fragments, 2) + " real fragments) can land";
  const std::string advice =
      w.plain() ? "Where they land is not modelled and the hazardous fragment distance may be cut "
                  "by the site boundary (the run says whether it is): extend the terrain."
                : "Where they land is not modelled; the run says whether the site boundary cuts "
                  "the hazardous fragment distance.";
  return reach_field(w) + " (\"" + w.group_name + "\"): " + what +
         " beyond the terrain while still hazardous (>= " + ke + " J); the farthest about " +
         about(w.farthest_m, 3) + " m from its origin toward azimuth " + std::to_string(azimuth) +
         " deg, where the terrain ends at " + about(w.terrain_edge_m, 3) + " m. " + advice +
         " (Estimate from " + std::to_string(w.pilot) + " drag trajectories, " +
         std::to_string(w.beyond) + " of them beyond, standard error " + percent(w.fraction_se) +
         " %, over flat ground at the launch level; no terrain relief, no bounce.)";
}

}  // namespace fragsim::run
