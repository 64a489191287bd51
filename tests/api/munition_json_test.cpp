// Munition description to fragment groups (api/munition_json.h): the example's groups follow the
// core formulas, the zones' frames point the nose where the munition's frame does, every problem
// names its field, and the built-in explosives table equals examples/munitions/explosives.json.
#include "api/munition_json.h"

#include <gtest/gtest.h>

#include <cmath>

#include "api/explosives.h"
#include "api/group_json.h"
#include "api/test_support.h"
#include "core/fragments/distribution.h"
#include "core/fragments/munition.h"
#include "core/fragments/sampling.h"

namespace fragsim::api {
namespace {

using testing::FieldMessage;
using testing::read_text;
using testing::source_path;

Json example() {
  return Json::parse(read_text(source_path("examples/munitions/munition.json")));
}

FieldMessage error_of(const Json& j) {
  try {
    groups_from_munition(j);
  } catch (const InputError& e) {
    return {e.field(), e.message()};
  }
  return {"<no error>", ""};
}

TEST(MunitionJson, ExampleGroupsFollowTheFormulas) {
  const MunitionGroups g = groups_from_munition(example());
  ASSERT_EQ(g.groups.size(), 3u);
  // Case: pi t (d + t) L rho; C/M; Gurney cylinder; Mott from Comp B's (unverified) constant.
  const double m = fragments::cylinder_wall_mass_kg(7850, 0.11, 0.02, 0.5);
  const double v = fragments::gurney_velocity(2700, 6.6 / m, fragments::CaseGeometry::kCylinder);
  const double mu =
      fragments::mott_scale_kg(fragments::mott_constant_si_from_us(0.0554), 0.02, 0.11);
  const double in_range = fragments::mott_survival(1e-4, mu) - fragments::mott_survival(1e5, mu);
  double total = 0.0;
  for (const Json& grp : g.groups) {
    EXPECT_NEAR(grp["speed_mps"].get<double>(), v, 1e-9 * v);
    EXPECT_EQ(grp["mass_kg"]["dist"], "mott");
    EXPECT_NEAR(grp["mass_kg"]["mu"].get<double>(), mu, 1e-12 * mu);
    total += grp["count"].get<double>();
    const fragments::FragmentGroupSpec spec = detail::parse_fragment_group(grp, "g");
    EXPECT_EQ(spec.mass_kg.kind, fragments::Distribution::Kind::kMott);
  }
  EXPECT_NEAR(total, m / (2 * mu) * in_range, 1e-9 * total);
  EXPECT_NEAR(g.groups[1]["count"].get<double>(), 0.8 * total, 1e-9 * total);
  // Side zone, polar 60..120 deg: elevation -30..30 about the nose axis.
  EXPECT_EQ(g.groups[1]["direction"]["elevation_deg"], Json::array({-30.0, 30.0}));
  // The unverified Mott constant is reported.
  ASSERT_EQ(g.notes.size(), 1u);
  EXPECT_NE(g.notes[0].find("unverified"), std::string::npos);
}

TEST(MunitionJson, ZoneFrameAxisIsTheNose) {
  // The group frame's +z must be the munition frame's +x (the nose) for any yaw and pitch.
  for (double yaw : {0.0, 35.0, -120.0}) {
    for (double pitch : {0.0, 20.0, 90.0, -45.0}) {
      Json j = example();
      j["frame"]["yaw_deg"] = yaw;
      j["frame"]["pitch_deg"] = pitch;
      const Json grp = groups_from_munition(j).groups[0];
      const auto spec = detail::parse_fragment_group(grp, "g");
      fragments::FrameSpec nose;
      nose.yaw_deg = yaw;
      nose.pitch_deg = pitch;
      const Vec3 want = fragments::frame_rotation(nose) * Vec3::UnitX();
      const Vec3 got = fragments::frame_rotation(spec.frame) * Vec3::UnitZ();
      EXPECT_LT((want - got).norm(), 1e-12) << yaw << " " << pitch;
    }
  }
}

TEST(MunitionJson, ExplicitValuesOverrideTheTable) {
  Json j = example();
  j["explosive"] = {{"gurney_velocity_mps", 2000.0}, {"mott_constant_si", 0.5}};
  j["charge"] = {{"charge_to_metal_ratio", 1.0}};
  j["geometry"] = "cylinder";
  const MunitionGroups g = groups_from_munition(j);
  EXPECT_NEAR(g.groups[0]["speed_mps"].get<double>(), 2000.0 / std::sqrt(1.5), 1e-9);
  EXPECT_NEAR(g.groups[0]["mass_kg"]["mu"].get<double>(), fragments::mott_scale_kg(0.5, 0.02, 0.11),
              1e-15);
  EXPECT_TRUE(g.notes.empty());
  j["explosive"] = {{"gurney_velocity_mps", 2000.0}, {"mott_constant_us", 0.05}};
  EXPECT_NEAR(groups_from_munition(j).groups[0]["mass_kg"]["mu"].get<double>(),
              fragments::mott_scale_kg(0.05 * 12.226445310107716, 0.02, 0.11), 1e-15);
  j["fragments"]["mu_kg"] = 0.002;
  j["geometry"] = "sphere";
  j["zones"] = {{{"polar_deg", {0, 180}}, {"fraction", 1}}};
  const MunitionGroups s = groups_from_munition(j);
  EXPECT_EQ(s.groups[0]["mass_kg"]["mu"], 0.002);
  EXPECT_NEAR(s.groups[0]["speed_mps"].get<double>(), 2000.0 / std::sqrt(1.6), 1e-9);
}

TEST(MunitionJson, ErrorsNameTheField) {
  const auto with = [](const char* pointer, const Json& v) {
    Json j = example();
    j[Json::json_pointer(pointer)] = v;
    return j;
  };
  const auto without = [](const char* parent, const char* key) {
    Json j = example();
    j[Json::json_pointer(parent)].erase(key);
    return j;
  };
  EXPECT_EQ(error_of(with("/case/wall_thickness_m", -0.02)),
            (FieldMessage{"case.wall_thickness_m", "must be > 0 (got -0.02)"}));
  EXPECT_EQ(error_of(without("/case", "wall_thickness_m")),
            (FieldMessage{"case.wall_thickness_m", "is required"}));
  EXPECT_EQ(error_of(without("/fragments", "cd")), (FieldMessage{"fragments.cd", "is required"}));
  EXPECT_EQ(error_of(with("/explosive/name", "semtex")).first, "explosive.name");
  EXPECT_EQ(error_of(with("/zones/1/fraction", 0.7)),
            (FieldMessage{"zones", "the fractions must sum to 1 (got 0.9)"}));
  EXPECT_EQ(error_of(with("/zones/0/polar_deg", Json::array({60, 0}))),
            (FieldMessage{"zones[0].polar_deg", "min must be < max (got [60, 0])"}));
  EXPECT_EQ(error_of(with("/geometry", "cone")).first, "geometry");
  EXPECT_EQ(error_of(with("/case/wall_thicknes_m", 1)).first, "case.wall_thicknes_m");
  EXPECT_EQ(error_of(with("/geometry", "sandwich")),
            (FieldMessage{"case.mass_kg", "is required for geometry sandwich"}));
  EXPECT_EQ(error_of(with("/geometry", "sphere")).first, "fragments.mu_kg");
  EXPECT_EQ(error_of(with("/charge/charge_to_metal_ratio", 0.5)),
            (FieldMessage{"charge", "give exactly one of mass_kg and charge_to_metal_ratio"}));
  EXPECT_EQ(error_of(with("/fragments/max_kg", 0.00005)),
            (FieldMessage{"fragments.max_kg", "must be > min"}));
  EXPECT_EQ(error_of(with("/fragments/shape", {{"type", "blob"}})).first, "fragments.shape.type");
  EXPECT_EQ(error_of(with("/explosive/name", "RDX")).first, "fragments.mu_kg");  // no B for RDX
  EXPECT_EQ(error_of(with("/explosive", {{"mott_constant_si", 0.5}})),
            (FieldMessage{"explosive.gurney_velocity_mps", "is required without a name"}));
  EXPECT_EQ(error_of(with("/explosive/mott_constant_si", 0.5) /* and the table's name */).first,
            "<no error>");
  Json both = with("/explosive/mott_constant_si", 0.5);
  both["explosive"]["mott_constant_us"] = 0.05;
  EXPECT_EQ(
      error_of(both),
      (FieldMessage{"explosive", "give at most one of mott_constant_si and mott_constant_us"}));
}

TEST(Explosives, TableEqualsTheDataFile) {
  const Json file = Json::parse(read_text(source_path("examples/munitions/explosives.json")));
  EXPECT_EQ(file, explosives_json());
  EXPECT_NE(find_explosive("comp b"), nullptr);
  EXPECT_EQ(find_explosive("semtex"), nullptr);
}

}  // namespace
}  // namespace fragsim::api
