// Presentation units (units.h).
#include "api/units.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

namespace fragsim::api {

namespace {

std::string printf_value(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

}  // namespace

std::optional<UnitSystem> parse_unit_system(std::string_view name) {
  if (name == "si") return UnitSystem::kSi;
  if (name == "us") return UnitSystem::kUs;
  return std::nullopt;
}

const char* unit_system_name(UnitSystem u) {
  return u == UnitSystem::kUs ? "us" : "si";
}

Presented present_length(double m, UnitSystem u) {
  return u == UnitSystem::kUs ? Presented{m / kFootM, "ft"} : Presented{m, "m"};
}

Presented present_energy(double j, UnitSystem u) {
  return u == UnitSystem::kUs ? Presented{j / kFootPoundJ, "ft-lb"} : Presented{j, "J"};
}

Presented present_mass(double kg, UnitSystem u) {
  return u == UnitSystem::kUs ? Presented{kg / kPoundKg, "lb"} : Presented{kg, "kg"};
}

Presented present_speed(double mps, UnitSystem u) {
  return u == UnitSystem::kUs ? Presented{mps / kFootM, "ft/s"} : Presented{mps, "m/s"};
}

Presented present_area(double m2, UnitSystem u) {
  return u == UnitSystem::kUs ? Presented{m2 / (kFootM * kFootM), "ft²"} : Presented{m2, "m²"};
}

Presented present_areal_density(double per_m2, UnitSystem u) {
  return u == UnitSystem::kUs ? Presented{per_m2 * k600SqFtM2, "per 600 ft²"}
                              : Presented{per_m2, "per m²"};
}

std::string format_length(double m, UnitSystem u, int decimals) {
  const Presented p = present_length(m, u);
  char format[16];
  std::snprintf(format, sizeof format, "%%.%df", decimals < 0 ? 0 : decimals > 9 ? 9 : decimals);
  return printf_value(format, p.value) + " " + p.unit;
}

std::string format_energy(double j, UnitSystem u) {
  const Presented p = present_energy(j, u);
  return printf_value("%.3g", p.value) + " " + p.unit;
}

std::string format_areal_density(double per_m2, UnitSystem u) {
  const Presented p = present_areal_density(per_m2, u);
  return printf_value("%.4g", p.value) + " " + p.unit;
}

double bearing_deg(double azimuth_ccw_from_x_deg) {
  double b = std::fmod(90.0 - azimuth_ccw_from_x_deg, 360.0) + 0.0;  // + 0.0: no "-0"
  if (b < 0.0) b += 360.0;
  return b >= 360.0 ? 0.0 : b;  // a tiny negative b + 360 rounds to 360
}

std::string sector_bearing_range(int sector) {
  // Azimuths [10k, 10k + 10) run clockwise from bearing 90 - 10k - 10 to 90 - 10k.
  const double from = bearing_deg(10.0 * sector + 10.0);
  double to = bearing_deg(10.0 * sector);
  if (to == 0.0) to = 360.0;
  return printf_value("%03.0f", from) + "°–" + printf_value("%03.0f", to) + "°";
}

std::string sector_bearing_arcs(const std::vector<bool>& sectors) {
  const int n = static_cast<int>(sectors.size());
  const auto on = [&](int k) { return sectors[static_cast<std::size_t>(((k % n) + n) % n)]; };
  int count = 0;
  for (int k = 0; k < n; ++k) count += on(k) ? 1 : 0;
  if (count == 0) return "";
  if (count == n) return "000°–360°";
  // Runs of adjacent sectors, each started where its azimuth-wise predecessor is off (so a run
  // across azimuth 0 is one run); listed in the order of their first bearing.
  std::vector<std::pair<double, std::string>> arcs;
  for (int first = 0; first < n; ++first) {
    if (!on(first) || on(first - 1)) continue;
    int last = first;
    while (on(last + 1)) ++last;
    const double from = bearing_deg(10.0 * last + 10.0);
    double to = bearing_deg(10.0 * first);
    if (to == 0.0) to = 360.0;
    arcs.emplace_back(from, printf_value("%03.0f", from) + "°–" + printf_value("%03.0f", to) + "°");
  }
  std::sort(arcs.begin(), arcs.end());
  std::string out;
  for (const auto& [from, text] : arcs) out += (out.empty() ? "" : ", ") + text;
  return out;
}

}  // namespace fragsim::api
