#include "api/summary_json.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "api/ground_bracket_json.h"
#include "api/hfd_attribution_json.h"
#include "core/run/precision.h"
#include "fragsim/version.h"

namespace fragsim::api {

namespace {

using Json = nlohmann::ordered_json;

Json vec3_json(const Vec3& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

Json estimate_pair(const run::Estimate& impacts, const run::Estimate& penetrations) {
  return {{"expected_impacts", impacts.mean},
          {"impacts_std_error", impacts.std_error},
          {"expected_penetrations", penetrations.mean},
          {"penetrations_std_error", penetrations.std_error}};
}

// A number that may be infinite (an ETA that cannot be reached): null in JSON.
Json finite_or_null(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

Json target_json(const run::TargetStatus& t) {
  Json j = {{"figure", t.figure}};
  if (!t.building.empty()) j["building"] = t.building;
  j["basis"] = t.basis;
  j["value"] = t.value;
  j["allowed"] = finite_or_null(t.allowed);
  j["met"] = t.met;
  j["unmeetable"] = t.unmeetable;
  j["note"] = t.note.empty() ? Json(nullptr) : Json(t.note);
  j["histories_needed"] = finite_or_null(t.histories_needed);
  return j;
}

}  // namespace

nlohmann::ordered_json precision_report_json(const run::PrecisionReport& p) {
  Json targets = Json::array();
  for (const auto& t : p.targets) targets.push_back(target_json(t));
  return {{"batches", p.batches},
          {"histories", p.histories},
          {"all_met", p.all_met},
          {"any_unmeetable", p.any_unmeetable},
          {"histories_needed", finite_or_null(p.histories_needed)},
          {"eta_s", finite_or_null(p.eta_s)},
          {"decay_exponent", p.decay_exponent},
          {"targets", std::move(targets)}};
}

namespace {

// ---- text rendering helpers ----

double num(const Json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return std::numeric_limits<double>::quiet_NaN();
  return it->get<double>();
}

std::string printf_string(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string g4(double v) {
  return std::isfinite(v) ? printf_string("%.4g", v) : "n/a";
}
std::string f1(double v) {
  return std::isfinite(v) ? printf_string("%.1f", v) : "n/a";
}

// A length in the presentation unit to one decimal, without its unit; and the unit.
std::string length1(double m, UnitSystem u) {
  return f1(present_length(m, u).value);
}
const char* length_unit(UnitSystem u) {
  return present_length(0.0, u).unit;
}
// An areal density in the presentation unit: "0.01794 per m²" / "1 per 600 ft²".
std::string density_text(double per_m2, UnitSystem u) {
  const Presented p = present_areal_density(per_m2, u);
  return g4(p.value) + " " + p.unit;
}

// "HFD ≥ 278.1 m: hazardous density reaches the site boundary in 36 of 36 sectors; extend the
// terrain".
std::string bound_note_text(double hfd_m, int sectors_cut, UnitSystem u) {
  return "HFD ≥ " + length1(hfd_m, u) + " " + length_unit(u) +
         ": hazardous density reaches the site boundary in " + std::to_string(sectors_cut) +
         " of 36 sectors; extend the terrain";
}

std::string vec3_text(const Json& j) {
  if (!j.is_array() || j.size() != 3) return "n/a";
  std::string out = "(";
  for (std::size_t k = 0; k < 3; ++k) {
    if (k > 0) out += ", ";
    out += f1(j[k].get<double>());
  }
  return out + ")";
}

// Site coordinates stay in the site's CRS unit, the metre; in US units they say so.
std::string coordinates_text(const Json& j, UnitSystem u) {
  return vec3_text(j) + (u == UnitSystem::kUs ? " m" : "");
}

// Characters as displayed: UTF-8 continuation bytes ("±" is two bytes) take no column.
std::size_t display_width(const std::string& s) {
  return static_cast<std::size_t>(std::count_if(
      s.begin(), s.end(), [](char ch) { return (static_cast<unsigned char>(ch) & 0xC0) != 0x80; }));
}

std::string pad_right(std::string s, std::size_t width) {
  const std::size_t w = display_width(s);
  if (w < width) s.append(width - w, ' ');
  return s;
}

std::string pad_left(std::string s, std::size_t width) {
  const std::size_t w = display_width(s);
  if (w < width) s.insert(0, width - w, ' ');
  return s;
}

std::string plus_minus(double mean, double se) {
  return g4(mean) + " ± " + g4(se);
}

// A target's figure, value and allowed value as read: in US units a length target ("..._m")
// loses its suffix and its values are in ft.
struct TargetText {
  std::string figure, value, allowed;
};
TargetText target_text(const Json& t, UnitSystem u) {
  std::string figure = t.value("figure", "");
  const bool length =
      u == UnitSystem::kUs && figure.size() > 2 && figure.compare(figure.size() - 2, 2, "_m") == 0;
  if (!length) return {figure, g4(num(t, "value")), g4(num(t, "allowed"))};
  figure.resize(figure.size() - 2);
  return {figure, g4(present_length(num(t, "value"), u).value) + " ft",
          g4(present_length(num(t, "allowed"), u).value) + " ft"};
}

// One line per target kind; building figures summarised by the worst one (largest value/allowed).
std::string precision_text(const Json& p, UnitSystem u) {
  const std::string state = p.value("all_met", false)          ? "all met"
                            : p.value("any_unmeetable", false) ? "not all can be met"
                                                               : "not all met";
  std::string out = "\nPrecision targets (" + state + ")\n";
  const Json* worst = nullptr;
  double worst_ratio = -1.0;
  int buildings = 0, buildings_met = 0;
  const Json targets = p.value("targets", Json::array());
  for (const auto& t : targets) {
    const double allowed = num(t, "allowed");
    if (t.value("figure", "").rfind("building_", 0) == 0) {
      ++buildings;
      buildings_met += t.value("met", false) ? 1 : 0;
      const double ratio = allowed > 0 ? num(t, "value") / allowed : INFINITY;
      if (ratio > worst_ratio) {
        worst_ratio = ratio;
        worst = &t;
      }
      continue;
    }
    const Json note = t.value("note", Json());
    const std::string verdict = t.value("met", false)          ? "  met"
                                : t.value("unmeetable", false) ? "  UNMEETABLE"
                                                               : "  NOT MET";
    const TargetText text = target_text(t, u);
    out += "  " + pad_right(text.figure, 28) + text.value + " (allowed " + text.allowed + ")" +
           verdict + (note.is_string() ? ": " + note.get<std::string>() : "") + "\n";
  }
  if (buildings > 0) {
    out += "  " + pad_right("building figures", 28) + std::to_string(buildings_met) + " of " +
           std::to_string(buildings) + " met";
    if (worst != nullptr)
      out += "; worst " + worst->value("building", "") + " " + worst->value("figure", "") + " " +
             worst->value("basis", "") + " " + g4(num(*worst, "value")) + " (allowed " +
             g4(num(*worst, "allowed")) + ")";
    out += "\n";
  }
  return out;
}

const Json* object_at(const Json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_object() ? &*it : nullptr;
}

// A distance that the site boundary may make a lower bound: "≥ 278.1" (no unit).
std::string bounded(double m, const Json& bound, UnitSystem u) {
  return (bound.is_string() && bound.get<std::string>() == "lower" ? "≥ " : "") + length1(m, u);
}

// The site boundary's line: how many sectors it cuts (in US units with their bearings) and the
// density on it.
std::string site_boundary_text(const Json& s, const Json& sb, double threshold, UnitSystem u) {
  const double edge = num(sb, "max_boundary_density_per_m2");
  const int cut = sb.value("hfd_sectors_cut", 0);
  std::string where = cut > 0 ? "hazardous in " + std::to_string(cut) + " of 36 sectors"
                              : std::string("not reached");
  if (const auto bounds = s.find("hfd_by_sector_bound");
      u == UnitSystem::kUs && cut > 0 && bounds != s.end() && bounds->is_array()) {
    std::vector<bool> lower;
    for (const auto& b : *bounds) lower.push_back(b == "lower");
    where += ", bearings " + sector_bearing_arcs(lower);
  }
  return where + " (density there up to " + density_text(edge, u) + ", " +
         printf_string("%.2g", edge / threshold) + " × the threshold)";
}

// The HFD lines: the distance and its band (each a lower bound where the site boundary cuts
// it), the threshold, the site boundary, the hazardous fragments that left the site.
template <class Line>
void hfd_text(const Json& s, const Line& line, UnitSystem u) {
  const std::string unit = length_unit(u);
  const Json bound = s.value("hfd_bound", Json());
  std::string hfd = bounded(num(s, "hazardous_fragment_distance_m"), bound, u) + " " + unit;
  if (bound == "lower") hfd += ", a lower bound";
  const Json band_bound = s.value("hfd_band_bound", Json::array({nullptr, nullptr}));
  if (const auto band = s.find("hazardous_fragment_distance_band_m");
      band != s.end() && band->is_array() && band->size() == 2 && band_bound.size() == 2)
    hfd += "  (±1 se band " + bounded((*band)[0].get<double>(), band_bound[0], u) + " .. " +
           bounded((*band)[1].get<double>(), band_bound[1], u) + " " + unit + ")";
  line("Hazardous fragment distance", hfd);
  const double threshold = num(s, "hfd_threshold_per_m2");
  const Presented area = present_area(1.0 / threshold, u);
  line("  threshold", density_text(threshold, u) + " (1 per " + f1(area.value) + " " + area.unit +
                          "), from " + coordinates_text(s.value("hfd_origin_m", Json()), u));
  for (const auto& [label, value] : hfd_attribution_text(s, u)) line(label, value);
  for (const auto& [label, value] : ground_bracket_text(s, u)) line(label, value);
  const Json* sb = object_at(s, "site_boundary");
  if (sb == nullptr) return;
  line("  site boundary", site_boundary_text(s, *sb, threshold, u));
  if (const Json* left = object_at(*sb, "left_site_hazardous")) {
    const auto histories = left->value("histories", std::int64_t{0});
    line("  left site while hazardous",
         plus_minus(num(*left, "fragments"), num(*left, "fragments_std_error")) +
             " real fragments (" + std::to_string(histories) + " histories)" +
             (histories > 0 ? ": where they land is not modelled" : ""));
  }
}

const char* bound_name(bool cut) {
  return cut ? "lower" : "none";
}

Json site_boundary_json(const run::RunResult& r) {
  const run::SiteBoundary& b = r.site_boundary;
  Json by_sector = Json::array(), by_sector_se = Json::array();
  for (const run::Estimate& e : b.left_hazardous_by_sector) {
    by_sector.push_back(e.mean);
    by_sector_se.push_back(e.std_error);
  }
  const std::string note = hfd_bound_note(r);
  return {{"hfd_sectors_cut", b.hfd_sectors_cut},
          {"max_boundary_density_per_m2", b.max_boundary_density_per_m2},
          {"left_site_hazardous",
           {{"histories", b.left_hazardous_histories},
            {"fragments", b.left_hazardous.mean},
            {"fragments_std_error", b.left_hazardous.std_error},
            {"by_sector_fragments", std::move(by_sector)},
            {"by_sector_std_error", std::move(by_sector_se)}}},
          {"note", note.empty() ? Json(nullptr) : Json(note)}};
}

Json buildings_json(const run::RunResult& r) {
  Json buildings = Json::array();
  for (const auto& b : r.buildings) {
    Json bj = {{"id", b.id}};
    bj.update(estimate_pair(b.impacts, b.penetrations));
    Json by_surface = Json::object();
    for (const auto s :
         {scene::SurfaceType::kWall, scene::SurfaceType::kRoof, scene::SurfaceType::kWindow}) {
      const auto k = static_cast<std::size_t>(s);
      by_surface[scene::surface_type_name(s)] =
          estimate_pair(b.impacts_by_surface[k], b.penetrations_by_surface[k]);
    }
    bj["by_surface"] = std::move(by_surface);
    bj["residual_ke_j"] = b.residual_ke_j.mean;
    bj["residual_ke_std_error_j"] = b.residual_ke_j.std_error;
    buildings.push_back(std::move(bj));
  }
  return buildings;
}

Json outcomes_json(const run::RunResult& r) {
  Json outcomes = Json::object();
  for (int k = 0; k < run::kOutcomeCount; ++k) {
    const auto o = static_cast<std::size_t>(k);
    outcomes[run::outcome_name(static_cast<run::Outcome>(k))] = {
        {"histories", r.outcome_histories[o]},
        {"fragments", r.outcome_fragments[o].mean},
        {"fragments_std_error", r.outcome_fragments[o].std_error}};
  }
  return outcomes;
}

Json timing_json(const run::Timing& t, bool profiled) {
  Json timing = {{"wall_s", t.wall_s},
                 {"parse_s", t.parse_s},
                 {"build_s", t.build_s},
                 {"threads", t.threads},
                 {"fragments_per_s", t.fragments_per_s},
                 {"fragments_per_s_per_thread", t.fragments_per_s_per_thread}};
  if (profiled) {  // only measured with settings.profile
    timing["integration_s"] = t.integration_s;
    timing["geometry_s"] = t.geometry_s;
    timing["tally_s"] = t.tally_s;
  }
  return timing;
}

Json stats_json(const run::RunStats& s) {
  return {{"rhs_evaluations", s.rhs_evaluations},
          {"integrator_steps", s.integrator_steps},
          {"chords", s.chords},
          {"scene_queries", s.scene_queries},
          {"chords_skipped", s.chords_skipped},
          {"ptn_triangle_tests", s.ptn_triangle_tests},
          {"bounces", s.bounces},
          {"ground_steps", s.ground_steps},
          {"ground_impacts", s.ground_impacts},
          {"takeoffs", s.takeoffs},
          {"ground_step_caps", s.ground_step_caps},
          {"energy_rises", s.energy_rises},
          {"fast_contacts", s.fast_contacts},
          {"fast_slides", s.fast_slides}};
}

}  // namespace

std::string hfd_bound_note(const run::RunResult& r) {
  const run::SiteBoundary& b = r.site_boundary;
  if (!b.hfd_cut) return "";
  return bound_note_text(r.hazardous_fragment_distance_m, b.hfd_sectors_cut, UnitSystem::kSi);
}

Provenance build_provenance() {
  return Provenance{kVersion, kGitSha, std::nullopt};
}

nlohmann::ordered_json summary_to_json(const run::RunResult& r, const run::Scenario& scenario,
                                       const Provenance& provenance) {
  Json out = {
      {"schema", kResultSchema},
      {"cancelled", r.cancelled},
      {"samples", r.samples},
      {"histories_done", r.histories_done},
      {"batches", r.batches},
      {"pilot_histories", r.pilot_histories},
      {"stop_reason", run::stop_reason_name(r.stop_reason)},
      {"real_fragments", r.real_fragments},
      {"seed", r.seed},
      {"hazardous_ke_j", scenario.settings.hazardous_ke_j},
      {"person_height_m", scenario.settings.person_height_m},
      {"hfd_threshold_per_m2", scenario.settings.hfd_threshold_per_m2},
      {"hfd_origin_m", vec3_json(r.hfd_origin_m)},
      {"hazardous_fragment_distance_m", r.hazardous_fragment_distance_m},
      {"hfd_bound", bound_name(r.site_boundary.hfd_cut)},
      {"hazardous_fragment_distance_band_m", {r.hfd_lower_m, r.hfd_upper_m}},
      {"hfd_band_bound",
       {bound_name(r.site_boundary.band_lower_cut), bound_name(r.site_boundary.band_upper_cut)}},
      {"hfd_by_sector_m", r.hfd_by_sector_m}};
  Json sector_bounds = Json::array();
  for (const bool cut : r.site_boundary.hfd_sector_cut) sector_bounds.push_back(bound_name(cut));
  out["hfd_by_sector_bound"] = std::move(sector_bounds);
  out["site_boundary"] = site_boundary_json(r);
  out["hfd_attribution"] = hfd_attribution_json(r.hfd_attribution, scenario);
  out["ground_bracket"] = ground_bracket_json(r.ground_bracket.get());
  out["max_ptn_density_per_m2"] = r.max_ptn_density_per_m2;
  if (r.max_ptn_triangle >= 0) {
    out["max_ptn_triangle"] = r.max_ptn_triangle;
    out["max_ptn_location_m"] = vec3_json(r.max_ptn_location_m);
  } else {
    out["max_ptn_triangle"] = nullptr;
    out["max_ptn_location_m"] = nullptr;
  }

  out["buildings"] = buildings_json(r);
  out["outcomes"] = outcomes_json(r);
  if (r.precision) out["precision"] = precision_report_json(*r.precision);
  out["timing"] = timing_json(r.timing, scenario.settings.profile);
  out["stats"] = stats_json(r.stats);
  Json prov = {{"version", provenance.version}, {"git_sha", provenance.git_sha}};
  if (provenance.scenario_sha256) prov["scenario_sha256"] = *provenance.scenario_sha256;
  out["provenance"] = std::move(prov);
  return out;
}

std::string render_summary_text(const nlohmann::ordered_json& s, UnitSystem u) {
  std::string out;
  const auto line = [&](const std::string& label, const std::string& value) {
    out += pad_right(label + " ", 30) + value + "\n";  // a space after a long label
  };
  if (s.value("cancelled", false))
    out += "CANCELLED: partial result of " + std::to_string(s.value("histories_done", 0)) +
           " histories, not a final result\n";
  // The stored note is in metres: in US units it is said again in feet.
  if (const Json* sb = object_at(s, "site_boundary"); sb && sb->value("note", Json()).is_string())
    out += "WARNING: " +
           (u == UnitSystem::kSi ? (*sb)["note"].get<std::string>()
                                 : bound_note_text(num(s, "hazardous_fragment_distance_m"),
                                                   sb->value("hfd_sectors_cut", 0), u)) +
           "\n";
  std::string samples = std::to_string(s.value("samples", std::int64_t{0}));
  if (s.value("stop_reason", std::string("samples")) != "samples")
    samples += " (" + std::to_string(s.value("batches", std::int64_t{1})) +
               " batches, stopped: " + s.value("stop_reason", std::string()) + ")";
  line("Samples (histories)", samples);
  line("Real fragments", g4(num(s, "real_fragments")));
  line("Seed", std::to_string(s.value("seed", std::uint64_t{0})));

  hfd_text(s, line, u);
  std::string max_ptn = density_text(num(s, "max_ptn_density_per_m2"), u);
  if (s.contains("max_ptn_location_m") && s["max_ptn_location_m"].is_array())
    max_ptn += " at " + coordinates_text(s["max_ptn_location_m"], u) + " (terrain triangle " +
               std::to_string(s.value("max_ptn_triangle", std::int64_t{-1})) + ")";
  line("Max PTN density", max_ptn);

  const Json& buildings = s.contains("buildings") ? s["buildings"] : Json::array();
  out += "\nBuildings";
  if (buildings.empty()) {
    out += ": none\n";
  } else {
    out += " (expected real fragments ± 1 standard error)\n";
    std::size_t id_width = 8;
    for (const auto& b : buildings)
      id_width = std::max(id_width, display_width(b.value("id", "")) + 2);
    out += "  " + pad_right("id", id_width) + pad_left("impacts", 24) +
           pad_left("penetrations", 24) + "\n";
    for (const auto& b : buildings) {
      out += "  " + pad_right(b.value("id", ""), id_width) +
             pad_left(plus_minus(num(b, "expected_impacts"), num(b, "impacts_std_error")), 24) +
             pad_left(plus_minus(num(b, "expected_penetrations"), num(b, "penetrations_std_error")),
                      24) +
             "\n";
    }
  }

  if (s.contains("outcomes") && s["outcomes"].is_object()) {
    out += "\nOutcomes\n  " + pad_right("outcome", 22) + pad_left("histories", 12) +
           pad_left("real fragments", 24) + "\n";
    for (const auto& [name, o] : s["outcomes"].items()) {
      out += "  " + pad_right(name, 22) +
             pad_left(std::to_string(o.value("histories", std::int64_t{0})), 12) +
             pad_left(plus_minus(num(o, "fragments"), num(o, "fragments_std_error")), 24) + "\n";
    }
  }

  if (s.contains("precision") && s["precision"].is_object())
    out += precision_text(s["precision"], u);

  if (s.contains("timing") && s["timing"].is_object()) {
    const Json& t = s["timing"];
    const int threads = t.value("threads", 1);
    out += "\nRun time " + printf_string("%.2f", num(t, "wall_s")) + " s (before it: parse " +
           printf_string("%.2f", num(t, "parse_s")) + " s, site build " +
           printf_string("%.2f", num(t, "build_s")) + " s) on " + std::to_string(threads) +
           (threads == 1 ? " thread" : " threads") + ": " +
           printf_string("%.0f", num(t, "fragments_per_s")) + " fragments/s (" +
           printf_string("%.0f", num(t, "fragments_per_s_per_thread")) + " per thread)\n";
    if (t.contains("integration_s"))
      out += "  profile: integration " + printf_string("%.2f", num(t, "integration_s")) +
             " s, geometry " + printf_string("%.2f", num(t, "geometry_s")) + " s, tally " +
             printf_string("%.2f", num(t, "tally_s")) + " s (summed over threads)\n";
  }
  return out;
}

}  // namespace fragsim::api
