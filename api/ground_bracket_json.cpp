#include "api/ground_bracket_json.h"

#include <algorithm>
#include <cstdio>

namespace fragsim::api {

namespace {

using Json = nlohmann::ordered_json;

Json figures_json(const run::BracketFigures& f, bool with_value) {
  Json j = Json::object();
  if (with_value) j["value"] = f.value;
  j["hfd_m"] = f.hfd_m;
  j["hfd_bound"] = f.hfd_lower_bound ? "lower" : "none";
  j["hfd_band_m"] = {f.hfd_lower_m, f.hfd_upper_m};
  j["building_impacts"] = f.building_impacts;
  j["building_penetrations"] = f.building_penetrations;
  return j;
}

double number(const Json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : 0.0;
}

std::string fmt(const char* format, double a, double b = 0.0, double c = 0.0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, format, a, b, c);
  return buf;
}

// A length as "%.1f m" / "%.1f ft".
std::string length_text(double m, UnitSystem u) {
  const Presented p = present_length(m, u);
  return fmt("%.1f ", p.value) + p.unit;
}

// "422 m (low 0) … 139 m (high 5)": the HFD at both ends, with a "≥" where the boundary cuts it.
// The constants' values stay as the scenario gives them (SI).
std::string ends_text(const Json& row, UnitSystem u) {
  const auto end = [&](const char* which) {
    const Json e = row.value(which, Json::object());
    const bool lower = e.value("hfd_bound", std::string()) == "lower";
    return (lower ? "≥ " : "") + length_text(number(e, "hfd_m"), u) + " at " +
           fmt("%g", number(e, "value"));
  };
  return end("low") + ", " + end("high");
}

}  // namespace

Json ground_bracket_json(const run::GroundBracket* b) {
  if (b == nullptr) return Json(nullptr);
  Json rows = Json::array();
  for (const run::BracketRow& r : b->rows) {
    rows.push_back({{"constant", r.constant},
                    {"nominal", r.nominal},
                    {"low", figures_json(r.low, true)},
                    {"high", figures_json(r.high, true)},
                    {"hfd_swing_m", std::abs(r.high.hfd_m - r.low.hfd_m)}});
  }
  double lo = b->nominal.hfd_m, hi = b->nominal.hfd_m;
  bool bound = b->nominal.hfd_lower_bound;
  for (const run::BracketRow& r : b->rows) {
    for (const run::BracketFigures* f : {&r.low, &r.high}) {
      lo = std::min(lo, f->hfd_m);
      hi = std::max(hi, f->hfd_m);
      bound = bound || f->hfd_lower_bound;
    }
  }
  return {{"material", b->material},
          {"samples_scale", b->samples_scale},
          {"histories_per_run", b->histories_per_run},
          {"cancelled", b->cancelled},
          {"nominal", figures_json(b->nominal, false)},
          {"hfd_range_m", {lo, hi}},
          {"hfd_range_bound", bound ? "lower" : "none"},
          {"rows", std::move(rows)}};
}

std::vector<std::pair<std::string, std::string>> ground_bracket_text(const Json& summary,
                                                                     UnitSystem u) {
  std::vector<std::pair<std::string, std::string>> lines;
  const auto it = summary.find("ground_bracket");
  if (it == summary.end() || !it->is_object()) return lines;
  const Json& b = *it;
  const Json range = b.value("hfd_range_m", Json::array());
  if (range.is_array() && range.size() == 2) {
    const bool lower = b.value("hfd_range_bound", std::string()) == "lower";
    lines.emplace_back("  ground-model bracket",
                       fmt("HFD %.1f … ", present_length(range[0].get<double>(), u).value) +
                           length_text(range[1].get<double>(), u) +
                           (lower ? " (some ends are lower bounds)" : "") + " over the ranges of " +
                           b.value("material", std::string()) + "'s constants; nominal " +
                           length_text(number(b.value("nominal", Json::object()), "hfd_m"), u) +
                           " at the same " + fmt("%.0f", number(b, "histories_per_run")) +
                           " histories per run");
  }
  for (const Json& row : b.value("rows", Json::array()))
    lines.emplace_back("    " + row.value("constant", std::string()), ends_text(row, u));
  if (b.value("cancelled", false)) lines.emplace_back("    (incomplete)", "cancelled");
  return lines;
}

}  // namespace fragsim::api
