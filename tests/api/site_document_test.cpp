// Site documents (fragsimd POST /v1/sites): site-relative error paths, the content-hash id (same
// site, same id, however it is spelt), geometry errors from build_site, site id form.
#include "api/site_document.h"

#include <gtest/gtest.h>

#include "api/sha256.h"
#include "test_support.h"

namespace fragsim::api {
namespace {

using testing::FieldMessage;
using testing::Json;
using testing::minimal_example;

Json minimal_site() {
  return minimal_example()["site"];
}

// A 3 x 3 grid terrain site (100 m spacing).
Json grid_site() {
  Json site = minimal_site();
  site["terrain"] = {{"grid",
                      {{"origin_m", {-100, -100}},
                       {"spacing_m", 100},
                       {"nx", 3},
                       {"ny", 3},
                       {"elevation_m", {0, 1, 2, 3, 4, 5, 6, 7, 8}}}},
                     {"material", "soil"}};
  site["buildings"] = Json::array();
  return site;
}

FieldMessage site_error(const Json& j) {
  try {
    parse_site_document(j);
  } catch (const InputError& e) {
    return {e.field(), e.message()};
  }
  return {"<no error>", ""};
}

FieldMessage build_error(const Json& j) {
  try {
    build_site(parse_site_document(j));
  } catch (const InputError& e) {
    return {e.field(), e.message()};
  }
  return {"<no error>", ""};
}

std::string id_of_text(const std::string& text) {
  return parse_site_document(parse_json_text(text)).site_id;
}

// ---- The id ----

TEST(SiteDocument, IdIsTheHashOfTheNormalisedJson) {
  const SiteDocument doc = parse_site_document(minimal_site());
  EXPECT_TRUE(is_site_id(doc.site_id)) << doc.site_id;
  EXPECT_EQ(doc.site_id, "s_" + sha256_hex(doc.normalised.dump()).substr(0, 16));
}

TEST(SiteDocument, NormalisedIsWhatAScenarioSiteHolds) {
  const SiteDocument doc = parse_site_document(minimal_site());
  const Json scenario = scenario_to_json(parse_scenario_document(minimal_example()));
  EXPECT_EQ(doc.normalised, scenario["site"]);
  // And it reads back to the same site and the same id.
  const SiteDocument again = parse_site_document(doc.normalised);
  EXPECT_EQ(again.site_id, doc.site_id);
  EXPECT_EQ(again.normalised, doc.normalised);
}

TEST(SiteDocument, SameSiteWithKeysInAnotherOrderAndOtherWhitespaceHasTheSameId) {
  const std::string a =
      R"({"terrain": {"plane": {"elevation_m": 0, "extent_m": [-100, -100, 100, 100],
      "cell_m": 10}, "material": "soil"}, "materials": {"soil": {"friction": 0.9,
      "restitution": 0.2}}})";
  const std::string b =
      "{\n\t\"materials\" : { \"soil\" : { \"restitution\" : 0.2 , \"friction\" : 0.9 } } ,\n"
      "  \"terrain\" : { \"material\" : \"soil\" ,\n \"plane\" : { \"cell_m\" : 10 , "
      "\"extent_m\" : [ -100 , -100 , 100 , 100 ] , \"elevation_m\" : 0 } }\n}\n";
  EXPECT_EQ(id_of_text(a), id_of_text(b));
}

TEST(SiteDocument, NumbersSpeltDifferentlyGiveTheSameId) {
  const auto text = [](const std::string& one, const std::string& ten) {
    return R"({"terrain": {"plane": {"elevation_m": )" + one +
           R"(, "extent_m": [-100, -100, 100, 100], "cell_m": )" + ten +
           R"(}, "material": "soil"}, "materials": {"soil": {"friction": )" + one + "}}}";
  };
  const std::string id = id_of_text(text("1", "10"));
  EXPECT_EQ(id_of_text(text("1.0", "10.0")), id);
  EXPECT_EQ(id_of_text(text("1e0", "1e1")), id);
  EXPECT_EQ(id_of_text(text("1.000", "1.0E+1")), id);
  EXPECT_EQ(id_of_text(text("10e-1", "100e-1")), id);
}

TEST(SiteDocument, DefaultsGivenExplicitlyGiveTheSameId) {
  Json plain = minimal_site();
  Json explicit_defaults = plain;
  const scene::MaterialSpec defaults;
  explicit_defaults["materials"]["soil"]["rolling_resistance"] = defaults.rolling_resistance;
  ASSERT_NE(plain, explicit_defaults);
  EXPECT_EQ(parse_site_document(explicit_defaults).site_id, parse_site_document(plain).site_id);
}

TEST(SiteDocument, ADifferentSiteHasAnotherId) {
  const std::string id = parse_site_document(grid_site()).site_id;
  Json changed = grid_site();
  changed["terrain"]["grid"]["elevation_m"][4] = 4.5;
  EXPECT_NE(parse_site_document(changed).site_id, id);

  Json plane = minimal_site();
  const std::string plane_id = parse_site_document(plane).site_id;
  plane["terrain"]["plane"]["elevation_m"] = 1;
  EXPECT_NE(parse_site_document(plane).site_id, plane_id);
  plane = minimal_site();
  plane["buildings"][0]["height_m"] = 6.5;
  EXPECT_NE(parse_site_document(plane).site_id, plane_id);
  plane = minimal_site();
  plane.erase("origin");
  EXPECT_NE(parse_site_document(plane).site_id, plane_id);
  plane = minimal_site();
  plane["materials"]["soil"]["illustrative"] = false;  // provenance is part of the site
  EXPECT_NE(parse_site_document(plane).site_id, plane_id);
}

TEST(SiteDocument, IsSiteId) {
  EXPECT_TRUE(is_site_id("s_0123456789abcdef"));
  EXPECT_FALSE(is_site_id("s_0123456789ABCDEF"));
  EXPECT_FALSE(is_site_id("s_0123456789abcde"));
  EXPECT_FALSE(is_site_id("s_0123456789abcdef0"));
  EXPECT_FALSE(is_site_id("s_0123456789abcdeg"));
  EXPECT_FALSE(is_site_id("j_0123456789abcdef"));
  EXPECT_FALSE(is_site_id("s_../../../etc/pas"));
  EXPECT_FALSE(is_site_id(""));
}

// ---- Parse errors: site-relative paths ----

TEST(SiteDocument, TopLevelMustBeAnObject) {
  EXPECT_EQ(site_error(Json::array()).first, "");
  EXPECT_EQ(site_error(Json(3)).first, "");
}

TEST(SiteDocument, ErrorPathsAreSiteRelative) {
  Json site = grid_site();
  site["terrain"]["grid"]["nx"] = "3";
  EXPECT_EQ(site_error(site), FieldMessage("terrain.grid.nx", "expected integer, got string"));

  site = minimal_site();
  site["terrain"]["plane"]["cell_m"] = -1;
  EXPECT_EQ(site_error(site), FieldMessage("terrain.plane.cell_m", "must be > 0 (got -1)"));

  site = minimal_site();
  site["materials"]["soil"]["friction"] = "high";
  EXPECT_EQ(site_error(site).first, "materials.soil.friction");

  site = minimal_site();
  site["buildings"][0]["height_m"] = 0;
  EXPECT_EQ(site_error(site), FieldMessage("buildings[0].height_m", "must be > 0 (got 0)"));

  site = minimal_site();
  site["terrain"]["material"] = "rock";
  EXPECT_EQ(site_error(site), FieldMessage("terrain.material", "unknown material \"rock\""));
}

TEST(SiteDocument, UnknownAndMissingKeys) {
  Json site = minimal_site();
  site["terain"] = site["terrain"];
  EXPECT_EQ(site_error(site), FieldMessage("terain", "unknown key (did you mean \"terrain\"?)"));

  site = minimal_site();
  site.erase("terrain");
  EXPECT_EQ(site_error(site), FieldMessage("terrain", "is required"));

  // A site is not a scenario: a whole scenario posted as a site is refused at its first
  // scenario-only key.
  EXPECT_EQ(site_error(minimal_example()).second.rfind("unknown key", 0), 0u);
}

// ---- Geometry errors: build_site ----

TEST(SiteDocument, BuildSiteAcceptsTheExample) {
  const auto site = build_site(parse_site_document(minimal_site()));
  ASSERT_NE(site, nullptr);
  EXPECT_EQ(site->terrain_triangle_count(), 20000u);  // 100 x 100 cells of 30 m
  ASSERT_EQ(site->buildings().size(), 1u);
  EXPECT_EQ(site->buildings()[0].id, "B1");
}

TEST(SiteDocument, BuildingFootprintErrorIsSiteRelative) {
  Json site = minimal_site();
  site["buildings"][0]["footprint_m"] = {{60, -10}, {80, 10}, {80, -10}, {60, 10}};  // bow tie
  const FieldMessage e = build_error(site);
  EXPECT_EQ(e.first, "buildings[0].footprint_m");
  EXPECT_EQ(e.second, "self-crossing polygon (edges 0 and 2 cross)");

  // The same site inline in a scenario reports the scenario path.
  Json scenario = minimal_example();
  scenario["site"] = site;
  EXPECT_EQ(testing::validation_error(scenario).first, "site.buildings[0].footprint_m");
}

TEST(SiteDocument, BuildingOutsideTheTerrainIsSiteRelative) {
  Json site = minimal_site();
  site["buildings"][0]["footprint_m"] = {{1900, 1900}, {1910, 1900}, {1910, 1910}, {1900, 1910}};
  EXPECT_EQ(build_error(site), FieldMessage("buildings[0].footprint_m",
                                            "footprint lies outside the terrain; give "
                                            "base_elevation_m"));
}

TEST(SiteDocument, TerrainMeshErrorIsSiteRelative) {
  Json site = minimal_site();
  site["buildings"] = Json::array();
  site["terrain"] = {
      {"mesh",
       {{"vertices_m", {{0, 0, 0}, {100, 0, 0}, {100, 100, 0}}}, {"triangles", {{0, 1, 7}}}}},
      {"material", "soil"}};
  const FieldMessage e = build_error(site);
  EXPECT_EQ(e.first.rfind("terrain.mesh.triangles[0]", 0), 0u) << e.first << ": " << e.second;

  site["terrain"]["mesh"]["triangles"] = {{0, 1, 1}};
  EXPECT_EQ(build_error(site), FieldMessage("terrain.mesh.triangles[0]", "zero-area triangle"));
}

TEST(SiteDocument, GridTerrainElevationCountIsSiteRelative) {
  Json site = grid_site();
  site["terrain"]["grid"]["elevation_m"].erase(0);
  const FieldMessage e = build_error(site);
  EXPECT_EQ(e.first, "terrain.grid.elevation_m") << e.second;
}

// ---- Footprints with holes (courtyards) ----

// The example's building (60..80 x -10..10) with two courtyards, in either orientation.
Json courtyard_site() {
  Json site = minimal_site();
  site["buildings"][0]["holes_m"] = {{{63, -7}, {70, -7}, {70, 0}, {63, 0}},
                                     {{78, 8}, {78, -5}, {73, 2}}};
  return site;
}

TEST(SiteDocument, HolesRoundTripThroughTheNormalisedSite) {
  const SiteDocument doc = parse_site_document(courtyard_site());
  ASSERT_EQ(doc.spec.buildings[0].holes_m.size(), 2u);
  EXPECT_EQ(doc.spec.buildings[0].holes_m[1][2], (std::array<double, 2>{73, 2}));
  EXPECT_EQ(doc.normalised["buildings"][0]["holes_m"], courtyard_site()["buildings"][0]["holes_m"]);
  const SiteDocument again = parse_site_document(doc.normalised);
  EXPECT_EQ(again.normalised, doc.normalised);
  EXPECT_EQ(again.site_id, doc.site_id);
  EXPECT_NE(doc.site_id, parse_site_document(minimal_site()).site_id);
  // A site without holes writes no holes_m: its normalised form, and so its id, are as before.
  EXPECT_FALSE(parse_site_document(minimal_site()).normalised["buildings"][0].contains("holes_m"));
  // Built: 4 + 4 + 3 vertices and 2 holes, 4 * 11 + 4 * 2 - 4 triangles.
  const auto site = build_site(again);
  EXPECT_EQ(site->buildings()[0].triangle_count, 48u);
  // The same in a scenario.
  Json scenario = minimal_example();
  scenario["site"] = courtyard_site();
  EXPECT_EQ(scenario_to_json(parse_scenario_document(scenario))["site"], doc.normalised);
}

TEST(SiteDocument, HolesErrors) {
  Json site = courtyard_site();
  site["buildings"][0]["holes_m"] = {{63, -7}, {70, -7}, {70, 0}};  // a ring, not rings
  EXPECT_EQ(site_error(site),
            FieldMessage("buildings[0].holes_m[0][0]", "expected array of 2 numbers, got integer"));
  site["buildings"][0]["holes_m"] = {{{63, -7}, {70, -7, 1}, {70, 0}}};
  EXPECT_EQ(site_error(site).first, "buildings[0].holes_m[0][1]");
  site["buildings"][0]["holes_m"] = "courtyard";
  EXPECT_EQ(site_error(site), FieldMessage("buildings[0].holes_m", "expected array, got string"));
  // Site limits, at parse time.
  site["buildings"][0]["holes_m"] = {{{63, -7}, {2e8, -7}, {70, 0}}};
  EXPECT_EQ(site_error(site).first, "buildings[0].holes_m[0][1][0]");
  // A mesh building has none.
  site = courtyard_site();
  site["buildings"][0].erase("footprint_m");
  site["buildings"][0].erase("height_m");
  site["buildings"][0]["mesh"] = {{"vertices_m", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}},
                                  {"triangles", {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}},
                                  {"surface", {"wall", "wall", "wall", "roof"}}};
  EXPECT_EQ(site_error(site),
            FieldMessage("buildings[0].holes_m",
                         "only the footprint form has holes; a mesh gives its courtyards as "
                         "geometry"));
}

TEST(SiteDocument, HoleGeometryErrorsAreSiteRelative) {
  Json site = courtyard_site();
  site["buildings"][0]["holes_m"][1] = {{75, 5}, {85, 5}, {85, 8}};  // through the east wall
  EXPECT_EQ(build_error(site),
            FieldMessage("buildings[0].holes_m[1]",
                         "not inside the footprint (its edge 0 meets footprint_m edge 1)"));
  site["buildings"][0]["holes_m"][1] = {{64, -6}, {66, -6}, {66, -4}};  // in holes_m[0]
  EXPECT_EQ(build_error(site), FieldMessage("buildings[0].holes_m[1]", "lies inside holes_m[0]"));
  Json scenario = minimal_example();
  scenario["site"] = site;
  EXPECT_EQ(testing::validation_error(scenario),
            FieldMessage("site.buildings[0].holes_m[1]", "lies inside holes_m[0]"));
}

}  // namespace
}  // namespace fragsim::api
