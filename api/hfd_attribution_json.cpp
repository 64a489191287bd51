#include "api/hfd_attribution_json.h"

#include <algorithm>
#include <cstdio>

namespace fragsim::api {

namespace {

using Json = nlohmann::ordered_json;

const char* bound_name(bool cut) {
  return cut ? "lower" : "none";
}

// The HFD figures of one field alone, in the shape of the summary's own HFD fields.
Json figures_json(const run::HfdFigures& f) {
  Json sector_bounds = Json::array();
  for (const bool cut : f.cut.sectors) sector_bounds.push_back(bound_name(cut));
  return {{"hfd_m", f.hfd_m},
          {"hfd_bound", bound_name(f.cut.any())},
          {"hfd_band_m", {f.lower_m, f.upper_m}},
          {"hfd_band_bound", {bound_name(f.lower_cut.any()), bound_name(f.upper_cut.any())}},
          {"hfd_by_sector_m", f.by_sector_m},
          {"hfd_by_sector_bound", std::move(sector_bounds)}};
}

// The shares at the triangle that sets an HFD; null when no triangle does.
Json shares_json(const run::DensityShares& s) {
  if (s.triangle < 0) return nullptr;
  Json by_mechanism = Json::object();
  for (int m = 0; m < run::kPtnMechanismCount; ++m)
    by_mechanism[run::ptn_mechanism_name(static_cast<run::PtnMechanism>(m))] =
        s.by_mechanism[static_cast<std::size_t>(m)];
  return {{"triangle", s.triangle},
          {"distance_m", s.distance_m},
          {"density_per_m2", s.density_per_m2},
          {"share_by_mechanism", std::move(by_mechanism)},
          {"share_by_group", s.by_group.empty() ? Json(nullptr) : Json(s.by_group)}};
}

std::string f1(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

std::string percent(double share) {
  if (share > 0.0 && share < 0.005) return "<1 %";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0f %%", 100.0 * share);
  return buf;
}

std::string quoted(const std::string& name) {
  return "\"" + name + "\"";
}

// "ground 92 %, after_ricochet 8 %": the non-zero shares, largest first, at most `limit`.
std::string shares_text(std::vector<std::pair<double, std::string>> shares, std::size_t limit) {
  std::stable_sort(shares.begin(), shares.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::string out;
  std::size_t shown = 0;
  for (const auto& [share, name] : shares) {
    if (!(share > 0.0)) continue;
    if (shown == limit) return out + ", ...";
    out += (shown++ == 0 ? "" : ", ") + name + " " + percent(share);
  }
  return out;
}

// "ground 498.0 m, after_ricochet ≥ 310.2 m": each field's HFD alone, the farthest `limit`.
std::string alone_text(std::vector<std::pair<std::string, Json>> fields, std::size_t limit,
                       UnitSystem u) {
  std::stable_sort(fields.begin(), fields.end(), [](const auto& a, const auto& b) {
    return a.second.value("hfd_m", 0.0) > b.second.value("hfd_m", 0.0);
  });
  std::string out;
  for (std::size_t k = 0; k < fields.size(); ++k) {
    if (k == limit) return out + ", ... (" + std::to_string(fields.size()) + " in summary.json)";
    const auto& [name, f] = fields[k];
    const bool lower = f.value("hfd_bound", std::string()) == "lower";
    out += (out.empty() ? "" : ", ") + name + " " + (lower ? "≥ " : "") +
           f1(present_length(f.value("hfd_m", 0.0), u).value) + " " + present_length(0.0, u).unit;
  }
  return out;
}

}  // namespace

nlohmann::ordered_json hfd_attribution_json(const run::HfdAttribution& a,
                                            const run::Scenario& scenario) {
  Json mechanisms = Json::array(), by_mechanism = Json::object();
  for (int m = 0; m < run::kPtnMechanismCount; ++m) {
    const char* name = run::ptn_mechanism_name(static_cast<run::PtnMechanism>(m));
    mechanisms.push_back(name);
    by_mechanism[name] = figures_json(a.by_mechanism[static_cast<std::size_t>(m)]);
  }
  Json groups = Json::array(), by_group = Json::array();
  for (const auto& g : scenario.groups) groups.push_back(g.name);
  for (std::size_t g = 0; g < a.by_group.size(); ++g) {
    Json j = {{"group", g < scenario.groups.size() ? scenario.groups[g].name : std::string()}};
    j.update(figures_json(a.by_group[g]));
    by_group.push_back(std::move(j));
  }
  Json at_sector = Json::array();
  for (const auto& s : a.at_sector_hfd) at_sector.push_back(shares_json(s));
  return {{"mechanisms", std::move(mechanisms)},
          {"groups", std::move(groups)},
          {"by_mechanism", std::move(by_mechanism)},
          {"by_group", std::move(by_group)},
          {"by_group_omitted_reason",
           a.by_group_omitted_reason.empty() ? Json(nullptr) : Json(a.by_group_omitted_reason)},
          {"at_hfd", shares_json(a.at_hfd)},
          {"at_sector_hfd", std::move(at_sector)}};
}

std::vector<std::pair<std::string, std::string>> hfd_attribution_text(
    const nlohmann::ordered_json& summary, UnitSystem u) {
  std::vector<std::pair<std::string, std::string>> lines;
  const auto it = summary.find("hfd_attribution");
  if (it == summary.end() || !it->is_object()) return lines;
  const Json& a = *it;
  const Json names = a.value("groups", Json::array());
  if (const Json at = a.value("at_hfd", Json()); at.is_object()) {
    std::vector<std::pair<double, std::string>> mech, group;
    const Json by_mechanism = at.value("share_by_mechanism", Json::object());
    for (const auto& [name, share] : by_mechanism.items())
      mech.emplace_back(share.is_number() ? share.get<double>() : 0.0, name);
    const Json by_group = at.value("share_by_group", Json());
    for (std::size_t g = 0; by_group.is_array() && g < by_group.size() && g < names.size(); ++g)
      group.emplace_back(by_group[g].is_number() ? by_group[g].get<double>() : 0.0,
                         quoted(names[g].is_string() ? names[g].get<std::string>() : ""));
    std::string text = shares_text(mech, 3);
    if (!group.empty()) text += "; group " + shares_text(group, 3);
    lines.emplace_back("  set by (at its triangle)", text);
  }
  std::vector<std::pair<std::string, Json>> mechanisms, groups;
  const Json by_mechanism = a.value("by_mechanism", Json::object());
  const Json by_group = a.value("by_group", Json::array());
  for (const auto& [name, f] : by_mechanism.items()) mechanisms.emplace_back(name, f);
  for (const auto& g : by_group) groups.emplace_back(quoted(g.value("group", std::string())), g);
  if (!mechanisms.empty())
    lines.emplace_back("  HFD by mechanism alone", alone_text(mechanisms, 3, u));
  if (names.size() > 1 && !groups.empty())
    lines.emplace_back("  HFD by group alone", alone_text(groups, 4, u));
  if (const Json reason = a.value("by_group_omitted_reason", Json()); reason.is_string())
    lines.emplace_back("  HFD by group alone", "omitted: " + reason.get<std::string>());
  return lines;
}

}  // namespace fragsim::api
