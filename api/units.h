#pragma once
// How numbers are presented to a person (docs/units.md): SI, or US customary as used in US
// explosives-safety practice (DoD 6055.09-M / DESR 6055.09: distances in ft, energies in ft-lb,
// fragment densities per 600 ft^2). SI stays the unit of storage, of the API and of the core:
// these functions only convert a figure for display and name its unit.
//
// Factors (exact by definition, NIST SP 811 Appendix B): 1 ft = 0.3048 m; 1 lb = 0.45359237 kg;
// 1 lbf = 4.4482216152605 N, so 1 ft-lb = 1.3558179483314004 J; 600 ft^2 = 55.741824 m^2.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace fragsim::api {

enum class UnitSystem { kSi, kUs };

inline constexpr double kFootM = 0.3048;
inline constexpr double kPoundKg = 0.45359237;
inline constexpr double kFootPoundJ = 1.3558179483314004;
inline constexpr double k600SqFtM2 = 600.0 * kFootM * kFootM;  // 55.741824 m^2

// "si" or "us"; nullopt otherwise.
std::optional<UnitSystem> parse_unit_system(std::string_view name);
const char* unit_system_name(UnitSystem u);  // "si" | "us"

// A figure converted for display and its unit's symbol.
struct Presented {
  double value = 0.0;
  const char* unit = "";
};
Presented present_length(double m, UnitSystem u);              // m | ft
Presented present_energy(double j, UnitSystem u);              // J | ft-lb
Presented present_mass(double kg, UnitSystem u);               // kg | lb
Presented present_speed(double mps, UnitSystem u);             // m/s | ft/s
Presented present_area(double m2, UnitSystem u);               // m² | ft²
Presented present_areal_density(double per_m2, UnitSystem u);  // per m² | per 600 ft²

// "138.8 m" / "455.4 ft" with `decimals` digits after the point.
std::string format_length(double m, UnitSystem u, int decimals = 1);
// "79 J" / "58.3 ft-lb" with 3 significant digits.
std::string format_energy(double j, UnitSystem u);
// "0.01794 per m²" / "1 per 600 ft²" with 4 significant digits.
std::string format_areal_density(double per_m2, UnitSystem u);

// The compass bearing (degrees clockwise from +y, taken as grid north, in [0, 360)) of an
// azimuth measured counter-clockwise from +x, as the HFD sectors are (core/run/hfd.h).
double bearing_deg(double azimuth_ccw_from_x_deg);
// HFD sector k (azimuth [10k, 10k + 10) from +x toward +y) as the bearing range it covers,
// clockwise: "080°–090°" for sector 0.
std::string sector_bearing_range(int sector);
// The sectors marked true (36 of them, as sector_bearing_range numbers them) as arcs of
// adjacent sectors, clockwise, in order of bearing: "080°–100°, 350°–010°" (an arc may cross
// north); "000°–360°" when all are; "" when none is.
std::string sector_bearing_arcs(const std::vector<bool>& sectors);

}  // namespace fragsim::api
