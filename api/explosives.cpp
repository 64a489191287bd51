// The built-in explosives table (explosives.h). Every number carries its source; those that could
// not be checked against a source text here are marked unverified and reported as illustrative
// whenever a munition uses them.
#include "api/explosives.h"

#include <algorithm>
#include <cctype>

#include "core/fragments/munition.h"

namespace fragsim::api {

namespace {

// Gurney velocities: Cooper, P. W. (1996), Explosives Engineering, Wiley-VCH, Table 27.2, as
// listed in issue 26. Only Composition B's 2.70 mm/us could be checked against a second text
// (the University of Utah Uintah code's "1-D Gurney cylinder test" input, which cites Cooper eq.
// 27.1 with sqrt(2E) = 2.70 km/s for Comp B); the rest are unverified.
constexpr std::string_view kCooper =
    "Cooper 1996, Explosives Engineering, Table 27.2 (as quoted in issue 26)";
constexpr std::string_view kCooperChecked =
    "Cooper 1996, Explosives Engineering, Table 27.2; 2.70 km/s also in Uintah's Gurney "
    "cylinder test input citing Cooper eq. 27.1";
// Mott constants: values recalled from TM 5-1300 (1990) / UFC 3-340-02 (2008), the table of
// "explosive constants" for primary fragments, in oz^(1/2) in^(-7/6). The source text was not
// available here: unverified, illustrative.
constexpr std::string_view kMottRecalled =
    "TM 5-1300 / UFC 3-340-02 table of Mott constants, recalled, not checked against the text: "
    "illustrative";
constexpr std::string_view kNone = "";

constexpr Explosive kTable[] = {
    {"TNT", 2440.0, kCooper, false, 0.0638, kMottRecalled, false},
    {"Comp B", 2700.0, kCooperChecked, true, 0.0554, kMottRecalled, false},
    {"RDX", 2830.0, kCooper, false, 0.0, kNone, false},
    {"HMX", 2970.0, kCooper, false, 0.0, kNone, false},
    {"PETN", 2930.0, kCooper, false, 0.0, kNone, false},
    {"Tetryl", 2500.0, kCooper, false, 0.0, kNone, false},
    {"Octol", 2800.0, kCooper, false, 0.0, kNone, false},
    {"H-6", 2580.0, kCooper, false, 0.0690, kMottRecalled, false},
};

bool same_name(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

}  // namespace

std::span<const Explosive> explosives() {
  return kTable;
}

const Explosive* find_explosive(std::string_view name) {
  for (const Explosive& e : kTable)
    if (same_name(e.name, name)) return &e;
  return nullptr;
}

Json explosives_json() {
  Json list = Json::array();
  for (const Explosive& e : kTable) {
    Json j = {{"name", e.name},
              {"gurney_velocity_mps", e.gurney_velocity_mps},
              {"gurney_source", e.gurney_source},
              {"gurney_verified", e.gurney_verified}};
    if (e.mott_constant_us > 0.0) {
      j["mott_constant_us"] = e.mott_constant_us;
      j["mott_constant_si"] = fragments::mott_constant_si_from_us(e.mott_constant_us);
      j["mott_source"] = e.mott_source;
      j["mott_verified"] = e.mott_verified;
    }
    list.push_back(std::move(j));
  }
  return {{"units",
           {{"gurney_velocity_mps", "m/s, sqrt(2E)"},
            {"mott_constant_us", "oz^(1/2) in^(-7/6)"},
            {"mott_constant_si", "kg^(1/2) m^(-7/6) (= mott_constant_us x 12.226445)"}}},
          {"explosives", std::move(list)}};
}

}  // namespace fragsim::api
