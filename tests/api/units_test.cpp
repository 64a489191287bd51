// Presentation units (api/units.h): the exact factors of NIST SP 811 Appendix B, the US
// explosives-safety figures they give (DESR 6055.09: 58 ft-lb, 1 hazardous fragment per
// 600 ft^2), compass bearings of the HFD sectors, and the names accepted on the command line.
#include "api/units.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace fragsim::api {
namespace {

// Exact by definition: 1 ft = 0.3048 m, 1 lb = 0.45359237 kg, 1 lbf = 1 lb × g_n (9.80665 m/s²).
TEST(Units, FactorsAreTheDefinedOnes) {
  EXPECT_EQ(kFootM, 0.3048);
  EXPECT_EQ(kPoundKg, 0.45359237);
  EXPECT_DOUBLE_EQ(kPoundKg * 9.80665, 4.4482216152605);    // lbf in N
  EXPECT_DOUBLE_EQ(kFootM * 4.4482216152605, kFootPoundJ);  // ft-lb in J
  EXPECT_DOUBLE_EQ(k600SqFtM2, 55.741824);
  EXPECT_DOUBLE_EQ(present_length(0.3048, UnitSystem::kUs).value, 1.0);
  EXPECT_DOUBLE_EQ(present_length(1609.344, UnitSystem::kUs).value, 5280.0);  // a mile
  EXPECT_DOUBLE_EQ(present_mass(0.45359237, UnitSystem::kUs).value, 1.0);
  EXPECT_DOUBLE_EQ(present_speed(0.3048, UnitSystem::kUs).value, 1.0);
  EXPECT_DOUBLE_EQ(present_area(0.09290304, UnitSystem::kUs).value, 1.0);
  EXPECT_STREQ(present_length(1, UnitSystem::kUs).unit, "ft");
  EXPECT_STREQ(present_energy(1, UnitSystem::kUs).unit, "ft-lb");
  EXPECT_STREQ(present_mass(1, UnitSystem::kUs).unit, "lb");
  EXPECT_STREQ(present_speed(1, UnitSystem::kUs).unit, "ft/s");
  EXPECT_STREQ(present_area(1, UnitSystem::kUs).unit, "ft²");
}

// DESR 6055.09's hazardous fragment: 58 ft-lb, i.e. 78.64 J; fragsim's default 79 J is 58.27 ft-lb.
TEST(Units, HazardousEnergy) {
  EXPECT_NEAR(58.0 * kFootPoundJ, 78.63744, 1e-5);
  EXPECT_NEAR(present_energy(79.0, UnitSystem::kUs).value, 58.26741, 1e-5);
  EXPECT_EQ(format_energy(79.0, UnitSystem::kUs), "58.3 ft-lb");
  EXPECT_EQ(format_energy(79.0, UnitSystem::kSi), "79 J");
}

// 1 hazardous fragment per 600 ft² is 1/55.741824 per m² exactly (600 × 0.09290304 m²; not the
// 55.74192 sometimes quoted); the default threshold 1/55.74
// per m² (core/run/scenario.h) reads as 1 per 600 ft² to 4 digits (1.00003).
TEST(Units, ThresholdPer600SquareFeet) {
  EXPECT_DOUBLE_EQ(present_areal_density(1.0 / 55.741824, UnitSystem::kUs).value, 1.0);
  EXPECT_EQ(format_areal_density(1.0 / 55.741824, UnitSystem::kUs), "1 per 600 ft²");
  EXPECT_NEAR(present_areal_density(1.0 / 55.74, UnitSystem::kUs).value, 1.0000327, 1e-7);
  EXPECT_EQ(format_areal_density(1.0 / 55.74, UnitSystem::kUs), "1 per 600 ft²");
  EXPECT_EQ(format_areal_density(1.0 / 55.74, UnitSystem::kSi), "0.01794 per m²");
  EXPECT_STREQ(present_areal_density(1, UnitSystem::kUs).unit, "per 600 ft²");
}

TEST(Units, SiIsUnchanged) {
  const Presented p = present_length(138.8, UnitSystem::kSi);
  EXPECT_EQ(p.value, 138.8);
  EXPECT_STREQ(p.unit, "m");
  EXPECT_EQ(present_energy(79, UnitSystem::kSi).value, 79.0);
  EXPECT_EQ(present_mass(2.5, UnitSystem::kSi).value, 2.5);
  EXPECT_EQ(present_areal_density(0.25, UnitSystem::kSi).value, 0.25);
  EXPECT_EQ(format_length(138.8, UnitSystem::kSi), "138.8 m");
  EXPECT_EQ(format_length(138.8, UnitSystem::kUs), "455.4 ft");  // 455.38
  EXPECT_EQ(format_length(138.8, UnitSystem::kUs, 0), "455 ft");
  EXPECT_EQ(format_length(0.3048, UnitSystem::kUs, 3), "1.000 ft");
}

// Bearings clockwise from grid north (+y) of azimuths counter-clockwise from +x.
TEST(Units, Bearings) {
  EXPECT_EQ(bearing_deg(90.0), 0.0);
  EXPECT_EQ(bearing_deg(0.0), 90.0);
  EXPECT_EQ(bearing_deg(180.0), 270.0);
  EXPECT_EQ(bearing_deg(270.0), 180.0);
  EXPECT_EQ(bearing_deg(45.0), 45.0);
  EXPECT_EQ(bearing_deg(-90.0), 180.0);
  EXPECT_EQ(bearing_deg(-450.0), 180.0);
  EXPECT_EQ(bearing_deg(360.0), 90.0);
  EXPECT_EQ(bearing_deg(450.0), 0.0);
  EXPECT_FALSE(std::signbit(bearing_deg(450.0)));  // never "-0"
  EXPECT_EQ(bearing_deg(810.0), 0.0);
  const double just_past_north = bearing_deg(90.0 + 1e-14);  // 360 - 1e-14 rounds to 360
  EXPECT_GE(just_past_north, 0.0);
  EXPECT_LT(just_past_north, 360.0);
}

TEST(Units, SectorBearingRanges) {
  EXPECT_EQ(sector_bearing_range(0), "080°–090°");  // azimuth [0, 10): just south of east
  EXPECT_EQ(sector_bearing_range(8), "000°–010°");
  EXPECT_EQ(sector_bearing_range(9), "350°–360°");  // azimuth [90, 100): just west of north
  EXPECT_EQ(sector_bearing_range(18), "260°–270°");
  EXPECT_EQ(sector_bearing_range(35), "090°–100°");
  EXPECT_EQ(sector_bearing_range(36), sector_bearing_range(0));  // over 360°
  EXPECT_EQ(sector_bearing_range(44), "000°–010°");
  EXPECT_EQ(sector_bearing_range(-1), sector_bearing_range(35));  // negative
}

TEST(Units, SectorBearingArcs) {
  std::vector<bool> s(36, false);
  EXPECT_EQ(sector_bearing_arcs(s), "");
  s[0] = s[35] = true;  // across azimuth 0: one arc
  EXPECT_EQ(sector_bearing_arcs(s), "080°–100°");
  s[8] = s[9] = true;  // across north
  EXPECT_EQ(sector_bearing_arcs(s), "080°–100°, 350°–010°");
  s[18] = true;
  EXPECT_EQ(sector_bearing_arcs(s), "080°–100°, 260°–270°, 350°–010°");
  EXPECT_EQ(sector_bearing_arcs(std::vector<bool>(36, true)), "000°–360°");
}

TEST(Units, ParsesOnlySiAndUs) {
  EXPECT_EQ(parse_unit_system("si"), UnitSystem::kSi);
  EXPECT_EQ(parse_unit_system("us"), UnitSystem::kUs);
  for (const char* bad : {"", "SI", "US", "us ", "imperial", "metric", "ft"})
    EXPECT_FALSE(parse_unit_system(bad).has_value()) << bad;
  EXPECT_STREQ(unit_system_name(UnitSystem::kSi), "si");
  EXPECT_STREQ(unit_system_name(UnitSystem::kUs), "us");
}

}  // namespace
}  // namespace fragsim::api
