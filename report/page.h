#pragma once
// The report page under construction and how its numbers are written (report_html.cpp and the
// section files): each figure is converted to the report's units and carries its summary.json
// key (a JSON pointer) and SI value.
#include <cmath>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "api/units.h"
#include "report/report_html.h"
#include "report/report_inputs.h"

namespace fragsim::report {

using Json = nlohmann::ordered_json;
using api::UnitSystem;

inline std::string printf_string(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// How a figure is converted and shown.
// kCoordinate: a position in the site's CRS (metres), never converted (docs/units.md).
enum class Kind {
  kLength,
  kCoordinate,
  kEnergy,
  kMass,
  kSpeed,
  kDensity,
  kCount,
  kError,
  kSeconds,
  kPlain
};

inline const char* kind_name(Kind k) {
  switch (k) {
    case Kind::kLength: return "length";
    case Kind::kCoordinate: return "coordinate";
    case Kind::kEnergy: return "energy";
    case Kind::kMass: return "mass";
    case Kind::kSpeed: return "speed";
    case Kind::kDensity: return "density";
    case Kind::kCount: return "count";
    case Kind::kError: return "error";
    case Kind::kSeconds: return "seconds";
    case Kind::kPlain: return "plain";
  }
  return "plain";
}

inline api::Presented present(double si, Kind k, UnitSystem u) {
  switch (k) {
    case Kind::kLength: return api::present_length(si, u);
    case Kind::kEnergy: return api::present_energy(si, u);
    case Kind::kMass: return api::present_mass(si, u);
    case Kind::kSpeed: return api::present_speed(si, u);
    case Kind::kDensity: return api::present_areal_density(si, u);
    case Kind::kSeconds: return {si, "s"};
    case Kind::kCoordinate: return {si, "m"};
    default: return {si, ""};
  }
}

// Digits shown: lengths to 0.1, densities 4 significant, counts 3, errors 2.
inline std::string shown(double v, Kind k) {
  if (!std::isfinite(v)) return "n/a";
  switch (k) {
    case Kind::kLength:
    case Kind::kCoordinate: return printf_string("%.1f", v);
    case Kind::kDensity: return printf_string("%.4g", v);
    case Kind::kError: return printf_string("%.2g", v);
    case Kind::kSeconds: return printf_string("%.3g", v);
    case Kind::kPlain: return printf_string("%.17g", v);
    default: return std::abs(v) >= 1000 ? printf_string("%.0f", v) : printf_string("%.3g", v);
  }
}

inline const Json* at_pointer(const Json& j, const std::string& pointer) {
  try {
    const Json::json_pointer p(pointer);
    return j.contains(p) ? &j.at(p) : nullptr;
  } catch (const std::exception&) {
    return nullptr;
  }
}

class Page {
 public:
  Page(const ReportInputs& in, UnitSystem u) : in_(in), u_(u) {}

  std::string html;
  const ReportInputs& in() const { return in_; }
  UnitSystem units() const { return u_; }
  const Json& summary() const { return in_.summary; }

  void raw(std::string_view s) { html += s; }
  void text(std::string_view s) { html += escape_html(s); }
  void tag(const char* name, std::string_view content, const char* cls = nullptr) {
    html += std::string("<") + name + (cls ? std::string(" class=\"") + cls + "\"" : "") + ">";
    text(content);
    html += std::string("</") + name + ">";
  }

  // A summary.json figure: "<span ...>138.8</span> m" (unit appended unless `with_unit` false).
  std::string num(const std::string& pointer, Kind k, bool with_unit = true) const {
    const Json* v = at_pointer(in_.summary, pointer);
    if (v == nullptr || !v->is_number()) return "n/a";
    return value(v->get<double>(), k, with_unit, pointer);
  }
  // A figure not in summary.json (the boundary, settings): no data-key.
  std::string value(double si, Kind k, bool with_unit = true, const std::string& key = "") const {
    const api::Presented p = present(si, k, u_);
    std::string s = "<span class=\"num\"";
    if (!key.empty()) s += " data-key=\"" + escape_html(key) + "\"";
    s += " data-si=\"" + printf_string("%.17g", si) + "\" data-kind=\"" + kind_name(k) + "\">" +
         shown(p.value, k) + "</span>";
    if (with_unit && *p.unit) s += std::string(k == Kind::kDensity ? " " : "\u00a0") + p.unit;
    return s;
  }
  // A compare.json figure (a paired comparison, ReportInputs::compare): its key is a pointer
  // into compare.json, marked data-source="compare".
  std::string cnum(const std::string& pointer, Kind k, bool with_unit = true) const {
    const Json* v = in_.compare ? at_pointer(*in_.compare, pointer) : nullptr;
    if (v == nullptr || !v->is_number()) return "n/a";
    std::string s = value(v->get<double>(), k, with_unit, pointer);
    s.insert(std::string("<span class=\"num\"").size(), " data-source=\"compare\"");
    return s;
  }
  std::string pm(const std::string& mean, const std::string& se, Kind k) const {
    return num(mean, k, false) + " ± " + num(se, Kind::kError, false);
  }
  // "≥ " when summary.json marks the figure a lower bound.
  std::string bound_mark(const std::string& pointer) const {
    const Json* b = at_pointer(in_.summary, pointer);
    return b != nullptr && b->is_string() && b->get<std::string>() == "lower" ? "≥ " : "";
  }

  void row(std::initializer_list<std::string> cells, bool head = false) {
    html += "<tr>";
    for (const auto& c : cells) html += (head ? "<th>" : "<td>") + c + (head ? "</th>" : "</td>");
    html += "</tr>";
  }
  void kv(std::string_view key, const std::string& value_html) {
    html += "<tr><th scope=\"row\">" + escape_html(key) + "</th><td>" + value_html + "</td></tr>";
  }

 private:
  const ReportInputs& in_;
  UnitSystem u_;
};

inline std::string esc(std::string_view s) {
  return escape_html(s);
}

inline std::string str_or(const Json& j, const char* key, const std::string& fallback) {
  const auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : fallback;
}

// ---- sections (sections_*.cpp) ----
void warnings(Page& p);        // what limits the figures, first
void site_section(Page& p);    // 3. the site
void groups_section(Page& p);  // 4. the fragment groups and the settings
void settings_section(Page& p);
void sector_table(Page& p);  // 5. results: tables
void buildings_table(Page& p);
void outcomes_table(Page& p);
void convergence_section(Page& p);                     // 6.
void attribution_section(Page& p);                     // 7.
void limitations_section(Page& p);                     // 8.
void comparison_warning(Page& p, std::string& items);  // the findings' line for a comparison
void comparison_section(Page& p);                      // 5. results: the paired comparison

// Words and captions.
std::string threshold_words(const Json& summary, UnitSystem u);
std::string map_caption(const ReportInputs& in, UnitSystem u);
std::string overview_caption(UnitSystem u);
std::string rose_caption(UnitSystem u);
std::string profile_caption(UnitSystem u);

}  // namespace fragsim::report
