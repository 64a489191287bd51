// Surface materials: validation, numbering, and restitution lookup.
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/scene/site_builder.h"
#include "core/scene/validation.h"

namespace fragsim::scene {

const char* surface_type_name(SurfaceType s) {
  switch (s) {
    case SurfaceType::kTerrain: return "terrain";
    case SurfaceType::kWall: return "wall";
    case SurfaceType::kRoof: return "roof";
    case SurfaceType::kWindow: return "window";
  }
  return "unknown";
}

double Material::restitution_at(double normal_speed_mps) const {
  const auto& v = restitution.normal_speed_mps;
  const auto& e = restitution.e;
  if (v.empty()) return restitution.constant;
  // Table of e against normal impact speed (paper Fig. 2 gives such curves): piecewise linear,
  // held constant beyond the first and last points.
  if (!(normal_speed_mps > v.front())) return e.front();  // also NaN -> first value
  if (normal_speed_mps >= v.back()) return e.back();
  const auto hi = std::upper_bound(v.begin(), v.end(), normal_speed_mps);
  const std::size_t k = static_cast<std::size_t>(hi - v.begin());  // v[k-1] <= s < v[k]
  const double w = (normal_speed_mps - v[k - 1]) / (v[k] - v[k - 1]);
  return e[k - 1] + w * (e[k] - e[k - 1]);
}

bool Material::embeds(const Vec3& velocity, const Vec3& n, double density_kg_m3) const {
  if (!embedment) return false;
  const double speed = velocity.norm();
  if (!(speed >= embedment->min_speed_mps) || !(density_kg_m3 > 0.0)) return false;
  const double sigma = density_kg_m3 / embedment->bulk_density_kg_m3;
  const double theta_c = embedment->coefficient_deg * kDegToRad / std::sqrt(sigma);
  // Grazing angle between the velocity and the surface, moving into it.
  const double into = -velocity.dot(n);
  return into > 0.0 && into >= speed * std::sin(std::min(theta_c, 0.5 * kPi));
}

std::optional<MaterialSpec> builtin_ground_material(const std::string& name) {
  // Friction: the paper's values (0.5 hard surface, 0.9 soft ground). Restitution: the paper
  // prints no table (its Fig. 2 is a curve reaching about 0.55 for the hard surface), so these
  // are ILLUSTRATIVE: the velocity-dependent form of Pfeiffer & Bowen (1989, rockfall),
  // e(v_n) = e0 / (1 + (v_n / 9.144 m/s)^2), tabulated, with e0 = 0.55 (hard, the peak of the
  // paper's Fig. 2) and 0.35 (soft, chosen lower than hard; not sourced).
  double e0 = 0.0;
  MaterialSpec m;
  if (name == "hard") {
    m.friction = 0.5;
    e0 = 0.55;
  } else if (name == "soft") {
    m.friction = 0.9;
    e0 = 0.35;
  } else {
    return std::nullopt;
  }
  for (const double v : {0.0, 1.0, 2.0, 4.0, 7.0, 10.0, 15.0, 20.0, 30.0, 50.0, 100.0, 300.0}) {
    const double x = v / 9.144;
    m.restitution.normal_speed_mps.push_back(v);
    m.restitution.e.push_back(std::round(1e4 * e0 / (1.0 + x * x)) / 1e4);
  }
  m.restitution.constant = m.restitution.e.front();
  return m;
}

std::uint16_t material_id(const MaterialIds& ids, const std::string& name,
                          const std::string& field) {
  if (name.empty()) detail::fail(field, "missing material name");
  const auto it = ids.find(name);
  if (it == ids.end()) detail::fail(field, "unknown material \"" + name + "\"");
  return it->second;
}

namespace {

// The law's constants (F1-F5). D/L > 0: every ricochet loses speed, so a sequence of them ends.
void validate_fast_contact(const MaterialSpec& m, const std::string& field) {
  const FastContactSpec& f = *m.fast_contact;
  const std::string ff = field + ".fast_contact";
  if (m.embedment)
    detail::fail(ff,
                 "give embedment or fast_contact, not both (fast_contact has its own "
                 "critical angle)");
  detail::require_positive(f.bulk_density_kg_m3, ff + ".bulk_density_kg_m3");
  detail::require_positive(f.switch_speed_mps, ff + ".switch_speed_mps");
  detail::require_in(f.critical_angle_coefficient_deg, 0.0, 90.0,
                     ff + ".critical_angle_coefficient_deg");
  detail::require_positive(f.critical_angle_coefficient_deg,
                           ff + ".critical_angle_coefficient_deg");
  detail::require_positive(f.drag_to_lift_ratio, ff + ".drag_to_lift_ratio");
  detail::require_in(f.roughness_deg, 0.0, 45.0, ff + ".roughness_deg");
  detail::require_in(f.exit_angle_ratio, 0.0, 10.0, ff + ".exit_angle_ratio");
}

void validate_material(const MaterialSpec& m, const std::string& field);

// Every range names a constant the material has, low <= high, and the material is valid at
// both ends (the checks of the constant itself).
void validate_ranges(const MaterialSpec& m, const std::string& field) {
  for (const auto& [name, range] : m.ranges) {
    const std::string rf = field + ".ranges." + name;
    if (!material_constant(m, name))
      detail::fail(rf,
                   "the material has no such constant (a range is for friction, "
                   "rolling_resistance, a constant restitution, or a fast_contact constant)");
    if (!(range[0] <= range[1])) detail::fail(rf, "low end above the high end");
    for (std::size_t k = 0; k < 2; ++k) {
      MaterialSpec copy = m;
      copy.ranges.clear();
      set_material_constant(copy, name, range[k]);
      try {
        validate_material(copy, field);
      } catch (const InputError& e) {  // named by the range's end, with the constant's rule
        detail::fail(detail::indexed(rf, k), e.message());
      }
    }
  }
}

void validate_material(const MaterialSpec& m, const std::string& field) {
  detail::require_at_least(m.friction, 0.0, field + ".friction");
  detail::require_at_least(m.rolling_resistance, 0.0, field + ".rolling_resistance");
  const RestitutionSpec& r = m.restitution;
  const std::string rf = field + ".restitution";
  if (r.normal_speed_mps.empty() && r.e.empty()) {
    detail::require_in(r.constant, 0.0, 1.0, rf);
  } else {
    if (r.normal_speed_mps.size() != r.e.size())
      detail::fail(rf, "normal_speed_mps and e differ in length (" +
                           std::to_string(r.normal_speed_mps.size()) + " vs " +
                           std::to_string(r.e.size()) + ")");
    for (std::size_t k = 0; k < r.normal_speed_mps.size(); ++k) {
      const std::string sf = detail::indexed(rf + ".normal_speed_mps", k);
      detail::require_at_least(r.normal_speed_mps[k], 0.0, sf);
      if (k > 0 && !(r.normal_speed_mps[k] > r.normal_speed_mps[k - 1]))
        detail::fail(sf, "speeds must be strictly increasing");
      detail::require_in(r.e[k], 0.0, 1.0, detail::indexed(rf + ".e", k));
    }
  }
  if (m.penetration_ke_per_area_j_per_m2)
    detail::require_positive(*m.penetration_ke_per_area_j_per_m2,
                             field + ".penetration.ke_per_area_j_per_m2");
  if (m.embedment) {
    const std::string ef = field + ".embedment";
    detail::require_positive(m.embedment->bulk_density_kg_m3, ef + ".bulk_density_kg_m3");
    detail::require_positive(m.embedment->coefficient_deg, ef + ".coefficient_deg");
    detail::require_at_least(m.embedment->min_speed_mps, 0.0, ef + ".min_speed_mps");
  }
  if (m.fast_contact) validate_fast_contact(m, field);
  validate_ranges(m, field);
}

}  // namespace

MaterialIds SiteBuilder::build_materials(Site& site, const SiteSpec& spec) {
  if (spec.materials.size() > std::numeric_limits<std::uint16_t>::max())
    detail::fail("site.materials", "too many materials (limit 65535)");
  MaterialIds ids;
  site.materials_.clear();
  site.materials_.reserve(spec.materials.size());
  // std::map iterates in name order, so ids do not depend on the input's key order.
  for (const auto& [name, m] : spec.materials) {
    if (name.empty()) detail::fail("site.materials", "empty material name");
    validate_material(m, detail::material_field(name));
    Material out;
    out.name = name;
    out.friction = m.friction;
    out.rolling_resistance = m.rolling_resistance;
    out.restitution = m.restitution;
    if (m.penetration_ke_per_area_j_per_m2)
      out.penetration_ke_per_area_j_per_m2 = *m.penetration_ke_per_area_j_per_m2;
    out.embedment = m.embedment;
    out.fast_contact = m.fast_contact;
    ids.emplace(name, static_cast<std::uint16_t>(site.materials_.size()));
    site.materials_.push_back(std::move(out));
  }
  return ids;
}

// ---- named constants and their ranges (settings.ground_bracket) ----

namespace {

// Where each fast_contact constant lives in the spec.
double FastContactSpec::*fast_member(const std::string& name) {
  if (name == "switch_speed_mps") return &FastContactSpec::switch_speed_mps;
  if (name == "critical_angle_coefficient_deg")
    return &FastContactSpec::critical_angle_coefficient_deg;
  if (name == "drag_to_lift_ratio") return &FastContactSpec::drag_to_lift_ratio;
  if (name == "roughness_deg") return &FastContactSpec::roughness_deg;
  if (name == "exit_angle_ratio") return &FastContactSpec::exit_angle_ratio;
  return nullptr;
}

bool constant_restitution(const MaterialSpec& m) {
  return m.restitution.normal_speed_mps.empty();
}

}  // namespace

const std::vector<std::string>& material_constant_names() {
  static const std::vector<std::string> kNames = {"friction",
                                                  "rolling_resistance",
                                                  "restitution",
                                                  "switch_speed_mps",
                                                  "critical_angle_coefficient_deg",
                                                  "drag_to_lift_ratio",
                                                  "roughness_deg",
                                                  "exit_angle_ratio"};
  return kNames;
}

std::optional<double> material_constant(const MaterialSpec& m, const std::string& name) {
  if (name == "friction") return m.friction;
  if (name == "rolling_resistance") return m.rolling_resistance;
  if (name == "restitution")
    return constant_restitution(m) ? std::optional<double>(m.restitution.constant) : std::nullopt;
  const auto member = fast_member(name);
  if (member == nullptr || !m.fast_contact) return std::nullopt;
  return (*m.fast_contact).*member;
}

void set_material_constant(MaterialSpec& m, const std::string& name, double value) {
  if (name == "friction") {
    m.friction = value;
  } else if (name == "rolling_resistance") {
    m.rolling_resistance = value;
  } else if (name == "restitution") {
    m.restitution.constant = value;
  } else if (const auto member = fast_member(name); member != nullptr && m.fast_contact) {
    (*m.fast_contact).*member = value;
  } else {
    detail::fail("ranges." + name, "the material has no such constant");
  }
}

const std::map<std::string, std::array<double, 2>>& default_fast_contact_ranges() {
  static const std::map<std::string, std::array<double, 2>> kRanges = {
      {"switch_speed_mps", {20.0, 50.0}},
      {"critical_angle_coefficient_deg", {14.4, 21.6}},
      {"drag_to_lift_ratio", {0.5, 2.0}},
      {"roughness_deg", {0.0, 5.0}},
      {"exit_angle_ratio", {0.5, 2.0}}};
  return kRanges;
}

std::map<std::string, std::array<double, 2>> effective_ranges(const MaterialSpec& m) {
  std::map<std::string, std::array<double, 2>> out = m.ranges;
  if (m.fast_contact)
    for (const auto& [name, range] : default_fast_contact_ranges()) out.emplace(name, range);
  return out;
}

}  // namespace fragsim::scene
