// The scenario's limits (docs/scenario.md, "Limits"; issue 10, found by fuzzing the parsers):
// coordinates, the terrain's extent, element counts and physical upper bounds are checked while
// parsing, before anything is sized from them, and each violation names its field.
#include <gtest/gtest.h>

#include "api/site_document.h"
#include "api/test_support.h"

namespace fragsim::api {
namespace {

using testing::FieldMessage;
using testing::minimal_example;
using testing::parse_error;
using testing::validation_error;
using Json = nlohmann::json;

Json with(Json j, const std::string& pointer, Json value) {
  j[Json::json_pointer(pointer)] = std::move(value);
  return j;
}

Json with_mesh_terrain(Json j, Json vertices, Json triangles) {
  j["site"]["terrain"] = {
      {"mesh", {{"vertices_m", std::move(vertices)}, {"triangles", std::move(triangles)}}},
      {"material", "soil"}};
  return j;
}

FieldMessage site_document_error(const Json& site) {
  try {
    parse_site_document(site);
  } catch (const InputError& e) {
    return {e.field(), e.message()};
  }
  return {"<no error>", ""};
}

TEST(Limits, ATerrainMeshAtTheLargestDoublesIsRefusedWhileParsing) {
  // A 3-vertex mesh at +-1e308 made the site build spin at 100 % CPU (its bucket grid).
  const Json j = with_mesh_terrain(
      minimal_example(), {{-1e308, -1e308, 0}, {1e308, -1e308, 0}, {0, 1e308, 0}}, {{0, 1, 2}});
  const FieldMessage expected{"site.terrain.mesh.vertices_m[0][0]",
                              "must be in [-1e+08, 1e+08] (got -1e+308)"};
  EXPECT_EQ(parse_error(j), expected);
  EXPECT_EQ(validation_error(j), expected);
  EXPECT_EQ(site_document_error(j["site"]),
            (FieldMessage{"terrain.mesh.vertices_m[0][0]", expected.second}));
}

TEST(Limits, ATriangleIndexOf2To63IsAnInputError) {
  const Json j =
      with_mesh_terrain(minimal_example(), {{-200, -200, 0}, {200, -200, 0}, {0, 200, 0}},
                        Json::parse("[[0, 1, 9223372036854775808.0]]"));
  EXPECT_EQ(parse_error(j).first, "site.terrain.mesh.triangles[0][2]");
  EXPECT_EQ(validation_error(with_mesh_terrain(minimal_example(),
                                               {{-200, -200, 0}, {200, -200, 0}, {0, 200, 0}},
                                               Json::parse("[[0, 1, 1e19]]")))
                .first,
            "site.terrain.mesh.triangles[0][2]");
}

TEST(Limits, SiteLimitsNameTheField) {
  struct Case {
    std::string pointer;
    Json value;
    FieldMessage expected;
  };
  const std::vector<Case> cases = {
      {"/site/terrain/plane/extent_m",
       {-1.5e5, -200, 1.5e5, 200},
       {"site.terrain.plane.extent_m", "spans 3e+05 m in x; a terrain may span at most 2e+05 m"}},
      {"/site/terrain/plane/elevation_m",
       1e6,
       {"site.terrain.plane.elevation_m", "must be in [-1e+05, 1e+05] (got 1e+06)"}},
      {"/site/buildings/0/footprint_m/1",
       {1e307, -10},
       {"site.buildings[0].footprint_m[1][0]", "must be in [-1e+08, 1e+08] (got 1e+307)"}},
      {"/site/buildings/0/height_m",
       2e4,
       {"site.buildings[0].height_m", "must be <= 10000 (got 20000)"}},
      {"/site/buildings/0/base_elevation_m",
       -1e307,
       {"site.buildings[0].base_elevation_m", "must be in [-1e+05, 1e+05] (got -1e+307)"}},
      {"/site/origin/easting_m",
       1e9,
       {"site.origin.easting_m", "must be in [-1e+08, 1e+08] (got 1e+09)"}},
      {"/fragment_groups/0/frame/origin_m",
       {0, 0, 1e300},
       {"fragment_groups[0].frame.origin_m[2]", "must be in [-1e+05, 1e+05] (got 1e+300)"}},
      {"/settings/hfd_origin_m",
       {-1e307, 0, 0},
       {"settings.hfd_origin_m[0]", "must be in [-1e+08, 1e+08] (got -1e+307)"}},
  };
  for (const auto& c : cases)
    EXPECT_EQ(parse_error(with(minimal_example(), c.pointer, c.value)), c.expected) << c.pointer;
  Json grid = minimal_example();
  grid["site"]["terrain"] = {{"grid",
                              {{"origin_m", {0, 0}},
                               {"spacing_m", 1e5},
                               {"nx", 4},
                               {"ny", 2},
                               {"elevation_m", std::vector<double>(8, 0.0)}}},
                             {"material", "soil"}};
  EXPECT_EQ(parse_error(grid), (FieldMessage{"site.terrain.grid.spacing_m",
                                             "spans 3e+05 m in x; a terrain may span at most "
                                             "2e+05 m ((nx - 1) * spacing_m)"}));
}

TEST(Limits, UtmCoordinatesStayAccepted) {
  // The minimal example moved to UTM zone 11N (as the demo's origin) and to a southern
  // northing near 1e7 m: absolute projected coordinates are inputs like any other.
  for (const double northing : {3839800.0, 9990000.0}) {
    Json j = minimal_example();
    const double e = 452300.0;
    j["site"]["terrain"]["plane"]["extent_m"] = {e - 200, northing - 200, e + 200, northing + 200};
    j["site"]["terrain"]["plane"]["elevation_m"] = 400;
    j["site"]["buildings"][0]["footprint_m"] = {{e + 60, northing - 10},
                                                {e + 80, northing - 10},
                                                {e + 80, northing + 10},
                                                {e + 60, northing + 10}};
    j["fragment_groups"][0]["frame"]["origin_m"] = {e, northing, 401};
    EXPECT_EQ(validation_error(j).first, "<no error>") << validation_error(j).second;
  }
}

TEST(Limits, AbsurdPhysicalValuesAreRefused) {
  // Values the fuzzer found accepted (each cost seconds per history): cd 1.8e19, a density of
  // 1.8e19 kg/m^3, gravity 2.1e9 m/s^2; and the other upper bounds.
  struct Case {
    std::string pointer;
    Json value;
    FieldMessage expected;
  };
  const std::vector<Case> cases = {
      {"/fragment_groups/0/cd", 1.8e19, {"fragment_groups[0].cd", "must be <= 10 (got 1.8e+19)"}},
      {"/fragment_groups/0/shape/density_kg_m3",
       1.8e19,
       {"fragment_groups[0].shape.density_kg_m3", "must be <= 1e+05 (got 1.8e+19)"}},
      {"/fragment_groups/0/shape/density_kg_m3",
       0.5,
       {"fragment_groups[0].shape.density_kg_m3", "must be >= 1 (got 0.5)"}},
      {"/gravity_mps2", 2.1e9, {"gravity_mps2", "must be <= 100 (got 2.1e+09)"}},
      {"/atmosphere",
       {{"model", "constant"}, {"density_kg_m3", 1e4}},
       {"atmosphere.density_kg_m3", "must be <= 100 (got 10000)"}},
      {"/atmosphere/wind_mps",
       {0, 300, 0},
       {"atmosphere.wind_mps[1]", "must be in [-200, 200] (got 300)"}},
      {"/fragment_groups/0/mass_kg", 1e6, {"fragment_groups[0].mass_kg", "must be <= 1e+05"}},
      {"/fragment_groups/0/speed_mps",
       {{"dist", "normal"}, {"mean", 1e9}, {"sigma", 1}},
       {"fragment_groups[0].speed_mps.mean",
        "truncation range [0, 20000] has no probability mass"}},
      {"/fragment_groups/0/spin_radps",
       {{"dist", "uniform"}, {"min", 0}, {"max", 1e9}},
       {"fragment_groups[0].spin_radps.max", "must be <= 1e+05"}},
      {"/fragment_groups/0/frame/velocity_mps",
       {0, 0, -3e4},
       {"fragment_groups[0].frame.velocity_mps[2]", "must be in [-20000, 20000] (got -30000)"}},
      {"/fragment_groups/0/count",
       1e300,
       {"fragment_groups[0].count", "must be <= 1e+12 (got 1e+300)"}},
      {"/fragment_groups/0/area_m2",
       1e6,
       {"fragment_groups[0].area_m2", "must be <= 1000 (got 1e+06)"}},
      {"/fragment_groups/0/shape",
       {{"type", "sphere"}, {"dims_m", {1e3}}},
       {"fragment_groups[0].shape.dims_m[0]", "must be <= 100 (got 1000)"}},
      {"/fragment_groups/0/cd",
       {{"mach", {0, 1e3}}, {"cd", {1, 1}}},
       {"fragment_groups[0].cd.mach[1]", "must be <= 100 (got 1000)"}},
      {"/site/materials/soil/friction",
       1e3,
       {"site.materials.soil.friction", "must be <= 10 (got 1000)"}},
      {"/site/materials/soil/embedment",
       {{"model", "johnson_reid_1975"}, {"bulk_density_kg_m3", 1e9}},
       {"site.materials.soil.embedment.bulk_density_kg_m3", "must be <= 1e+05 (got 1e+09)"}},
      {"/settings/max_flight_time_s",
       1e9,
       {"settings.max_flight_time_s", "must be <= 3600 (got 1e+09)"}},
      {"/settings/person_height_m", 1e3, {"settings.person_height_m", "must be <= 100 (got 1000)"}},
      {"/settings/bounce_limits",
       {{"max_ground_steps", 10000000}},
       {"settings.bounce_limits.max_ground_steps", "must be <= 1000000 (got 10000000)"}},
  };
  for (const auto& c : cases)
    EXPECT_EQ(parse_error(with(minimal_example(), c.pointer, c.value)), c.expected) << c.pointer;
}

}  // namespace
}  // namespace fragsim::api
