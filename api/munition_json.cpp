// Munition description to fragment groups (munition_json.h).
#include "api/munition_json.h"

#include <cmath>
#include <optional>

#include "api/explosives.h"
#include "api/group_json.h"
#include "api/limits.h"
#include "api/scenario_json.h"
#include "core/fragments/distribution.h"
#include "core/fragments/munition.h"
#include "core/fragments/sampling.h"

namespace fragsim::api {

namespace {

using fragments::CaseGeometry;

constexpr double kMaxMass_kg = 1e7;  // a 10,000 t case is beyond any munition
constexpr double kMaxChargeToMetal = 1e3;
constexpr double kFractionSumTolerance = 1e-6;
constexpr double kDefaultSteelDensity = 7850.0;  // illustrative: a carbon steel

std::string num(double v) {
  return format_number(v);
}

CaseGeometry read_geometry(const ObjectReader& o) {
  const std::string g = o.string("geometry");
  if (g == "cylinder") return CaseGeometry::kCylinder;
  if (g == "sphere") return CaseGeometry::kSphere;
  if (g == "sandwich") return CaseGeometry::kSandwich;
  fail(o.at("geometry"), "must be one of cylinder, sphere, sandwich (got \"" + g + "\")");
}

std::optional<double> positive(const ObjectReader& o, const char* key, double hi) {
  const auto v = o.optional_number(key);
  if (v) check_gt_le(*v, 0.0, hi, o.at(key));
  return v;
}

// The case: its mass (given, or from density and geometry) and the wall geometry Mott needs.
struct Case {
  double mass_kg = 0.0;
  std::optional<double> density, inner_diameter, wall, length;
};

Case read_case(const Json& j, CaseGeometry g, MunitionGroups& out) {
  const ObjectReader o(j, "case",
                       std::vector<std::string>{"mass_kg", "density_kg_m3", "inner_diameter_m",
                                                "wall_thickness_m", "length_m"});
  Case c;
  c.density = positive(o, "density_kg_m3", limits::kMaxDensity_kg_m3);
  c.inner_diameter = positive(o, "inner_diameter_m", limits::kMaxDimension_m);
  c.wall = positive(o, "wall_thickness_m", limits::kMaxDimension_m);
  c.length = positive(o, "length_m", limits::kMaxDimension_m);
  if (const auto m = positive(o, "mass_kg", kMaxMass_kg)) {
    c.mass_kg = *m;
    out.steps.push_back("case mass " + num(c.mass_kg) + " kg (given)");
    return c;
  }
  if (g == CaseGeometry::kSandwich) fail(o.at("mass_kg"), "is required for geometry sandwich");
  for (const char* key : {"density_kg_m3", "inner_diameter_m", "wall_thickness_m"})
    o.require(key);  // "case.density_kg_m3: is required" when the mass is to be computed
  if (g == CaseGeometry::kCylinder) {
    o.require("length_m");
    c.mass_kg = fragments::cylinder_wall_mass_kg(*c.density, *c.inner_diameter, *c.wall, *c.length);
    out.steps.push_back("case mass " + num(c.mass_kg) + " kg = pi t (d + t) L rho (wall only)");
  } else {
    c.mass_kg = fragments::sphere_shell_mass_kg(*c.density, *c.inner_diameter, *c.wall);
    out.steps.push_back("case mass " + num(c.mass_kg) + " kg = pi/6 ((d + 2t)^3 - d^3) rho");
  }
  return c;
}

double read_charge_to_metal(const Json& j, double case_mass, MunitionGroups& out) {
  const ObjectReader o(j, "charge", std::vector<std::string>{"mass_kg", "charge_to_metal_ratio"});
  const auto c = positive(o, "mass_kg", kMaxMass_kg);
  const auto r = positive(o, "charge_to_metal_ratio", kMaxChargeToMetal);
  if (c.has_value() == r.has_value())
    fail("charge", "give exactly one of mass_kg and charge_to_metal_ratio");
  const double ratio = r ? *r : *c / case_mass;
  check_gt_le(ratio, 0.0, kMaxChargeToMetal, r ? o.at("charge_to_metal_ratio") : o.at("mass_kg"));
  out.steps.push_back("C/M " + num(ratio) + (r ? " (given)" : " = " + num(*c) + " kg / case mass"));
  return ratio;
}

struct ExplosiveValues {
  double sqrt_2e = 0.0;
  std::optional<double> mott_b_si;
};

// explosive.name in the table, or nullptr without a name.
const Explosive* table_entry(const ObjectReader& o) {
  if (!o.has("name")) return nullptr;
  const std::string name = o.string("name");
  if (const Explosive* e = find_explosive(name)) return e;
  std::string names;
  for (const Explosive& x : explosives())
    names += (names.empty() ? "" : ", ") + std::string(x.name);
  fail(o.at("name"), "unknown explosive \"" + name + "\" (the table has " + names +
                         "; or give gurney_velocity_mps and mott_constant_si)");
}

double read_gurney(const ObjectReader& o, const Explosive* table, MunitionGroups& out) {
  if (const auto v = positive(o, "gurney_velocity_mps", fragments::kSpeedRange.hi)) {
    out.steps.push_back("sqrt(2E) " + num(*v) + " m/s (given)");
    return *v;
  }
  if (!table) fail(o.at("gurney_velocity_mps"), "is required without a name");
  const std::string label(table->name), source(table->gurney_source);
  out.steps.push_back("sqrt(2E) " + num(table->gurney_velocity_mps) + " m/s: " + label + ", " +
                      source);
  if (!table->gurney_verified)
    out.notes.push_back("sqrt(2E) of " + label + " is unverified (" + source + ")");
  return table->gurney_velocity_mps;
}

std::optional<double> read_mott_constant(const ObjectReader& o, const Explosive* table,
                                         MunitionGroups& out) {
  if (o.has("mott_constant_si") && o.has("mott_constant_us"))
    fail("explosive", "give at most one of mott_constant_si and mott_constant_us");
  if (const auto b = positive(o, "mott_constant_si", 1e3)) {
    out.steps.push_back("Mott B " + num(*b) + " kg^(1/2) m^(-7/6) (given)");
    return b;
  }
  const auto bu = positive(o, "mott_constant_us", 1e2);
  if (!bu && !(table && table->mott_constant_us > 0.0)) return std::nullopt;
  const double b_us = bu ? *bu : table->mott_constant_us;
  const double b_si = fragments::mott_constant_si_from_us(b_us);
  std::string step =
      "Mott B " + num(b_us) + " oz^(1/2) in^(-7/6) = " + num(b_si) + " kg^(1/2) m^(-7/6)";
  if (bu) {
    out.steps.push_back(step + " (given)");
    return b_si;
  }
  const std::string label(table->name), source(table->mott_source);
  out.steps.push_back(step + ": " + label + ", " + source);
  if (!table->mott_verified)
    out.notes.push_back("the Mott constant of " + label + " is unverified: illustrative (" +
                        source + ")");
  return b_si;
}

ExplosiveValues read_explosive(const Json& j, MunitionGroups& out) {
  const ObjectReader o(j, "explosive",
                       std::vector<std::string>{"name", "gurney_velocity_mps", "mott_constant_si",
                                                "mott_constant_us"});
  const Explosive* table = table_entry(o);
  ExplosiveValues e;
  e.sqrt_2e = read_gurney(o, table, out);
  e.mott_b_si = read_mott_constant(o, table, out);
  return e;
}

// Mott's scale: fragments.mu_kg, or B t^(5/6) d^(1/3) (1 + t/d) squared for a cylinder.
double read_mu(const ObjectReader& f, CaseGeometry g, const Case& c, const ExplosiveValues& e,
               MunitionGroups& out) {
  if (const auto mu = positive(f, "mu_kg", fragments::kMassRange.hi)) {
    out.steps.push_back("Mott mu " + num(*mu) + " kg (given; mean mass 2 mu = " + num(2 * *mu) +
                        " kg)");
    return *mu;
  }
  if (g != CaseGeometry::kCylinder)
    fail(f.at("mu_kg"),
         "is required for this geometry (Mott's case formula is for cylindrical cases)");
  if (!e.mott_b_si)
    fail(f.at("mu_kg"),
         "is required: no Mott constant (give explosive.mott_constant_si, "
         "explosive.mott_constant_us, or an explosive of the table that has one)");
  if (!c.wall) fail("case.wall_thickness_m", "is required to compute Mott's mu");
  if (!c.inner_diameter) fail("case.inner_diameter_m", "is required to compute Mott's mu");
  const double mu = fragments::mott_scale_kg(*e.mott_b_si, *c.wall, *c.inner_diameter);
  out.steps.push_back("Mott mu = (B t^(5/6) d^(1/3) (1 + t/d))^2 = " + num(mu) + " kg, t " +
                      num(*c.wall) + " m, d " + num(*c.inner_diameter) +
                      " m (mean mass 2 mu = " + num(2 * mu) + " kg)");
  return mu;
}

struct Zone {
  std::string name;
  double polar_lo = 0.0, polar_hi = 180.0, fraction = 1.0;
};

std::vector<Zone> read_zones(const Json& j) {
  const Json& arr = read_array(j, "zones");
  if (arr.empty()) fail("zones", "needs at least one zone");
  std::vector<Zone> zones;
  double sum = 0.0;
  for (std::size_t k = 0; k < arr.size(); ++k) {
    const std::string p = index_path("zones", k);
    const ObjectReader o(arr[k], p, std::vector<std::string>{"name", "polar_deg", "fraction"});
    Zone z;
    z.name = o.string_or("name", "zone " + std::to_string(k));
    const auto a = read_vec2(o.require("polar_deg"), o.at("polar_deg"));
    check_in(a[0], 0.0, 180.0, index_path(o.at("polar_deg"), 0));
    check_in(a[1], 0.0, 180.0, index_path(o.at("polar_deg"), 1));
    if (!(a[0] < a[1]))
      fail(o.at("polar_deg"), "min must be < max (got [" + num(a[0]) + ", " + num(a[1]) + "])");
    z.polar_lo = a[0];
    z.polar_hi = a[1];
    z.fraction = o.number("fraction");
    check_gt_le(z.fraction, 0.0, 1.0, o.at("fraction"));
    sum += z.fraction;
    zones.push_back(z);
  }
  if (std::fabs(sum - 1.0) > kFractionSumTolerance)
    fail("zones", "the fractions must sum to 1 (got " + num(std::round(sum * 1e9) / 1e9) + ")");
  return zones;
}

// The nose frame {origin_m, yaw_deg, pitch_deg, velocity_mps}: the munition's axis is its +x.
struct NoseFrame {
  Json origin, velocity;
  double yaw = 0.0, pitch = 0.0;
};

NoseFrame read_frame(const Json& j) {
  const ObjectReader o(
      j, "frame", std::vector<std::string>{"origin_m", "yaw_deg", "pitch_deg", "velocity_mps"});
  NoseFrame f;
  const Vec3 origin = read_position(o.require("origin_m"), o.at("origin_m"));
  const Vec3 v = o.vec3_or("velocity_mps", Vec3::Zero());
  check_abs_le(v, limits::kMaxFrameSpeed_mps, o.at("velocity_mps"));
  f.origin = Json::array({origin.x(), origin.y(), origin.z()});
  f.velocity = Json::array({v.x(), v.y(), v.z()});
  f.yaw = o.number_or("yaw_deg", 0.0);
  f.pitch = o.number_or("pitch_deg", 0.0);
  return f;
}

// What every zone's group shares.
struct GroupCommon {
  Json mass, shape, cd, frame;
  std::int64_t samples = 1;
  double speed = 0.0, count_total = 0.0;
};

// A zone [a, b] of polar angle from the nose as a group: the group frame's +z is the nose (yaw
// kept, pitch - 90: R = Rz(yaw) Ry(90 - pitch) maps +z where the nose frame maps +x), so polar
// angle theta is elevation 90 - theta over the whole azimuth.
Json zone_group(const std::string& munition, const Zone& z, const GroupCommon& c) {
  Json g = {{"name", munition + ": " + z.name + " (polar " + num(z.polar_lo) + "-" +
                         num(z.polar_hi) + " deg)"},
            {"count", c.count_total * z.fraction},
            {"samples", c.samples},
            {"frame", c.frame},
            {"shape", c.shape},
            {"mass_kg", c.mass},
            {"speed_mps", c.speed},
            {"direction",
             {{"elevation_deg", {90.0 - z.polar_hi, 90.0 - z.polar_lo}},
              {"azimuth_deg", {-180.0, 180.0}}}},
            {"cd", c.cd}};
  return g;
}

// Mott's law on [min_kg, max_kg] as the groups' mass distribution; a problem is named by the
// munition's own keys ("fragments.max_kg: must be > min").
fragments::Distribution mass_law(const ObjectReader& f, double mu) {
  fragments::Distribution d;
  d.kind = fragments::Distribution::Kind::kMott;
  d.mu = mu;
  if (const auto v = f.optional_number("min_kg")) {
    d.has_min = true;
    d.min = *v;
  }
  if (const auto v = f.optional_number("max_kg")) {
    d.has_max = true;
    d.max = *v;
  }
  const std::string problem = d.validate(fragments::kMassRange.lo, fragments::kMassRange.hi);
  if (problem.empty()) return d;
  const std::string field = problem.substr(0, problem.find(':'));
  const std::string rest = problem.substr(problem.find(':') + 2);
  if (field == "min") fail(f.at("min_kg"), rest);
  if (field == "max") fail(f.at("max_kg"), rest);
  fail("fragments", "Mott's law with mu " + num(mu) + " kg: " + rest);
}

MunitionGroups finish_groups(const ObjectReader& o, const ObjectReader& f, const std::string& name,
                             const Case& c, double mu, GroupCommon& common, MunitionGroups& out) {
  const fragments::Distribution d = mass_law(f, mu);
  const double n0 = fragments::mott_fragment_count(c.mass_kg, mu);
  const double lo = d.has_min ? d.min : 0.0;
  const double hi = d.has_max ? d.max : fragments::kMassRange.hi;
  const double in_range = fragments::mott_survival(lo, mu) - fragments::mott_survival(hi, mu);
  common.count_total = n0 * in_range;
  out.steps.push_back("N0 = case mass / (2 mu) = " + num(n0) + " fragments; " + num(in_range) +
                      " of them in [" + num(lo) + ", " + num(hi) +
                      "] kg: " + num(common.count_total));
  common.mass = detail::distribution_to_json(d);
  common.samples = f.integer("samples", 1, kMaxSamplesPerGroup);
  common.cd = f.require("cd");
  if (const Json* shape = f.find("shape")) {
    common.shape = *shape;
  } else {
    const double rho = c.density.value_or(kDefaultSteelDensity);
    common.shape = {{"type", "cuboid"}, {"density_kg_m3", rho}};
    out.steps.push_back("shape: cubes of density " + num(rho) + " kg/m^3 (default" +
                        (c.density ? ", the case's" : ": illustrative steel") + ")");
  }
  const NoseFrame nose = read_frame(o.require("frame"));
  common.frame = {{"origin_m", nose.origin},
                  {"yaw_deg", nose.yaw},
                  {"pitch_deg", nose.pitch - 90.0},
                  {"roll_deg", 0.0},
                  {"velocity_mps", nose.velocity}};
  const std::vector<Zone> zones = read_zones(o.require("zones"));
  for (const Zone& z : zones) {
    Json g = zone_group(name, z, common);
    // Checked as a scenario reads it: shape, cd and samples are named under fragments.
    detail::parse_fragment_group(g, "fragments");
    out.steps.push_back(g["name"].get<std::string>() + ": fraction " + num(z.fraction) +
                        ", count " + num(g["count"].get<double>()));
    out.groups.push_back(std::move(g));
  }
  return out;
}

}  // namespace

MunitionGroups groups_from_munition(const Json& j) {
  MunitionGroups out;
  const ObjectReader o(j, "",
                       std::vector<std::string>{"name", "description", "geometry", "case", "charge",
                                                "explosive", "fragments", "frame", "zones"});
  const std::string name = o.string("name");
  if (name.empty()) fail("name", "must not be empty");
  const CaseGeometry g = read_geometry(o);
  const Case c = read_case(o.require("case"), g, out);
  const double ratio = read_charge_to_metal(o.require("charge"), c.mass_kg, out);
  const ExplosiveValues e = read_explosive(o.require("explosive"), out);
  const ObjectReader f(
      o.require("fragments"), "fragments",
      std::vector<std::string>{"mu_kg", "min_kg", "max_kg", "samples", "cd", "shape"});
  const double mu = read_mu(f, g, c, e, out);
  GroupCommon common;
  common.speed = fragments::gurney_velocity(e.sqrt_2e, ratio, g);
  out.steps.push_back("Gurney speed V = sqrt(2E) / sqrt(M/C + " +
                      num(fragments::gurney_constant(g)) + ") = " + num(common.speed) +
                      " m/s (no spread)");
  if (common.speed > fragments::kSpeedRange.hi)
    fail("explosive", "the Gurney speed " + num(common.speed) + " m/s exceeds " +
                          num(fragments::kSpeedRange.hi) + " m/s");
  return finish_groups(o, f, name, c, mu, common, out);
}

}  // namespace fragsim::api
