// summary.json fields from a synthetic RunResult, and the text report.
#include "api/summary_json.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <memory>

#include "api/ground_bracket_json.h"
#include "core/run/run.h"
#include "fragsim/version.h"
#include "test_support.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::api {
namespace {

using Json = nlohmann::ordered_json;

run::RunResult synthetic_result() {
  run::RunResult r;
  r.samples = 2000;
  r.histories_done = 2000;
  r.real_fragments = 1000.0;
  r.seed = 42;
  r.ptn_density_per_m2 = {0.1, 0.02, 0.0};
  r.ptn_std_error_per_m2 = {0.01, 0.005, 0.0};
  r.max_ptn_density_per_m2 = 0.1;
  r.max_ptn_triangle = 0;
  r.max_ptn_location_m = Vec3(3.5, -2.0, 0.25);
  r.hfd_origin_m = Vec3(0, 0, 1);
  r.hazardous_fragment_distance_m = 266.5;
  r.hfd_lower_m = 248.0;
  r.hfd_upper_m = 273.25;
  for (std::size_t k = 0; k < r.hfd_by_sector_m.size(); ++k)
    r.hfd_by_sector_m[k] = 10.0 * static_cast<double>(k);
  r.buildings.push_back(testing::example_building());
  run::BuildingResult far;
  far.id = "far_store";
  r.buildings.push_back(far);
  r.outcome_histories[0] = 48;
  r.outcome_fragments[0] = {24.0, 3.5};
  r.outcome_histories[3] = 1952;
  r.outcome_fragments[3] = {976.0, 3.75};
  r.timing.wall_s = 2.0;
  r.timing.parse_s = 0.0625;
  r.timing.build_s = 0.125;
  r.timing.threads = 4;
  r.timing.fragments_per_s = 1000.0;
  r.timing.fragments_per_s_per_thread = 250.0;
  r.timing.integration_s = 5.0;
  r.timing.geometry_s = 2.0;
  r.timing.tally_s = 0.5;
  r.stats.rhs_evaluations = 117814;
  r.stats.integrator_steps = 18969;
  r.stats.chords = 6538;
  r.stats.scene_queries = 74;
  r.stats.chords_skipped = 9;
  r.stats.ptn_triangle_tests = 16486;
  return r;
}

TEST(SummaryJson, HeadlineFields) {
  run::Scenario sc;
  Provenance p = build_provenance();
  p.scenario_sha256 = "abc123";
  const Json s = summary_to_json(synthetic_result(), sc, p);
  EXPECT_EQ(s.begin().key(), "schema");  // first, for anyone reading the file
  EXPECT_EQ(s["schema"], "fragsim.result/1");
  EXPECT_EQ(s["samples"], 2000);
  EXPECT_EQ(s["histories_done"], 2000);
  EXPECT_EQ(s["real_fragments"], 1000.0);
  EXPECT_EQ(s["seed"], 42);
  EXPECT_EQ(s["cancelled"], false);
  EXPECT_EQ(s["hazardous_fragment_distance_m"], 266.5);
  EXPECT_EQ(s["hazardous_fragment_distance_band_m"], Json::array({248.0, 273.25}));
  EXPECT_EQ(s["hfd_origin_m"], Json::array({0.0, 0.0, 1.0}));
  EXPECT_EQ(s["hfd_threshold_per_m2"], sc.settings.hfd_threshold_per_m2);
  EXPECT_EQ(s["hazardous_ke_j"], sc.settings.hazardous_ke_j);
  EXPECT_EQ(s["person_height_m"], sc.settings.person_height_m);
  ASSERT_EQ(s["hfd_by_sector_m"].size(), 36u);
  EXPECT_EQ(s["hfd_by_sector_m"][35], 350.0);
  EXPECT_EQ(s["max_ptn_density_per_m2"], 0.1);
  EXPECT_EQ(s["max_ptn_triangle"], 0);
  EXPECT_EQ(s["max_ptn_location_m"], Json::array({3.5, -2.0, 0.25}));
  EXPECT_EQ(s["provenance"]["version"], kVersion);
  EXPECT_EQ(s["provenance"]["git_sha"], kGitSha);
  EXPECT_EQ(s["provenance"]["scenario_sha256"], "abc123");
}

// Issue 22: an HFD cut by the site boundary is a lower bound in summary.json (hfd_bound, the band's
// ends, every sector) and says so first thing in the text, with the fragments that left.
run::RunResult cut_result() {
  run::RunResult r = synthetic_result();
  run::SiteBoundary& b = r.site_boundary;
  b.hfd_cut = true;
  b.band_upper_cut = true;
  b.hfd_sectors_cut = 2;
  b.hfd_sector_cut[0] = b.hfd_sector_cut[35] = true;
  b.max_boundary_density_per_m2 = 0.05;
  b.left_hazardous = {963.0, 4.25};
  b.left_hazardous_by_sector[0] = {500.0, 3.0};
  b.left_hazardous_by_sector[35] = {463.0, 3.0};
  b.left_hazardous_histories = 1926;
  return r;
}

TEST(SummaryJson, AnHfdCutByTheSiteBoundaryIsALowerBound) {
  const Json s = summary_to_json(cut_result(), run::Scenario{}, build_provenance());
  EXPECT_EQ(s["hfd_bound"], "lower");
  EXPECT_EQ(s["hfd_band_bound"], Json::array({"none", "lower"}));
  ASSERT_EQ(s["hfd_by_sector_bound"].size(), 36u);
  EXPECT_EQ(s["hfd_by_sector_bound"][0], "lower");
  EXPECT_EQ(s["hfd_by_sector_bound"][1], "none");
  EXPECT_EQ(s["hfd_by_sector_bound"][35], "lower");
  // The flag follows the figure it qualifies.
  std::vector<std::string> keys;
  for (const auto& item : s.items()) keys.push_back(item.key());
  const auto at = [&](const char* k) {
    return std::find(keys.begin(), keys.end(), k) - keys.begin();
  };
  EXPECT_EQ(at("hfd_bound"), at("hazardous_fragment_distance_m") + 1);
  EXPECT_EQ(at("hfd_band_bound"), at("hazardous_fragment_distance_band_m") + 1);
  EXPECT_EQ(at("hfd_by_sector_bound"), at("hfd_by_sector_m") + 1);
  const Json& sb = s["site_boundary"];
  EXPECT_EQ(sb["hfd_sectors_cut"], 2);
  EXPECT_EQ(sb["max_boundary_density_per_m2"], 0.05);
  EXPECT_EQ(sb["left_site_hazardous"]["histories"], 1926);
  EXPECT_EQ(sb["left_site_hazardous"]["fragments"], 963.0);
  EXPECT_EQ(sb["left_site_hazardous"]["fragments_std_error"], 4.25);
  EXPECT_EQ(sb["left_site_hazardous"]["by_sector_fragments"][35], 463.0);
  EXPECT_EQ(sb["left_site_hazardous"]["by_sector_std_error"][0], 3.0);
  EXPECT_EQ(sb["note"],
            "HFD ≥ 266.5 m: hazardous density reaches the site boundary in 2 of 36 sectors; "
            "extend the terrain");

  const std::string text = render_summary_text(s);
  EXPECT_EQ(text.rfind("WARNING: HFD ≥ 266.5 m: hazardous density reaches the site boundary in 2 "
                       "of 36 sectors; extend the terrain\n",
                       0),
            0u)
      << text;
  for (const char* part :
       {"Hazardous fragment distance   ≥ 266.5 m, a lower bound  (±1 se band 248.0 .. ≥ 273.2 m)",
        "  site boundary               hazardous in 2 of 36 sectors (density there up to 0.05 per "
        "m², 2.8 × the threshold)",
        "  left site while hazardous   963 ± 4.25 real fragments (1926 histories): where they land "
        "is not modelled"})
    EXPECT_NE(text.find(part), std::string::npos) << "missing \"" << part << "\" in\n" << text;
}

TEST(SummaryJson, AnHfdInsideTheSiteIsNoBound) {
  const Json s = summary_to_json(synthetic_result(), run::Scenario{}, build_provenance());
  EXPECT_EQ(s["hfd_bound"], "none");
  EXPECT_EQ(s["hfd_band_bound"], Json::array({"none", "none"}));
  for (const auto& b : s["hfd_by_sector_bound"]) EXPECT_EQ(b, "none");
  EXPECT_TRUE(s["site_boundary"]["note"].is_null());
  EXPECT_EQ(s["site_boundary"]["hfd_sectors_cut"], 0);
  const std::string text = render_summary_text(s);
  EXPECT_EQ(text.find("WARNING"), std::string::npos) << text;
  EXPECT_EQ(text.find("≥"), std::string::npos) << text;
  EXPECT_NE(text.find("  site boundary               not reached"), std::string::npos) << text;
}

TEST(SummaryJson, Buildings) {
  const Json s = summary_to_json(synthetic_result(), run::Scenario{}, build_provenance());
  ASSERT_EQ(s["buildings"].size(), 2u);
  const Json& b = s["buildings"][0];
  EXPECT_EQ(b["id"], "B1");
  EXPECT_EQ(b["expected_impacts"], 12.5);
  EXPECT_EQ(b["impacts_std_error"], 0.25);
  EXPECT_EQ(b["expected_penetrations"], 3.0);
  EXPECT_EQ(b["penetrations_std_error"], 0.5);
  EXPECT_EQ(b["residual_ke_j"], 4000.0);
  EXPECT_EQ(b["residual_ke_std_error_j"], 300.0);
  EXPECT_EQ(b["by_surface"].size(), 3u);  // wall, roof, window: a building has no terrain surface
  EXPECT_EQ(b["by_surface"]["wall"]["expected_impacts"], 10.0);
  EXPECT_EQ(b["by_surface"]["wall"]["impacts_std_error"], 0.2);
  EXPECT_EQ(b["by_surface"]["roof"]["expected_impacts"], 2.5);
  EXPECT_EQ(b["by_surface"]["roof"]["expected_penetrations"], 3.0);
  EXPECT_EQ(b["by_surface"]["roof"]["penetrations_std_error"], 0.5);
  EXPECT_EQ(b["by_surface"]["window"]["expected_impacts"], 0.0);
  EXPECT_EQ(s["buildings"][1]["id"], "far_store");
}

TEST(SummaryJson, OutcomesInEnumOrder) {
  const Json s = summary_to_json(synthetic_result(), run::Scenario{}, build_provenance());
  ASSERT_EQ(s["outcomes"].size(), static_cast<std::size_t>(run::kOutcomeCount));
  int k = 0;
  for (const auto& [name, o] : s["outcomes"].items())
    EXPECT_EQ(name, run::outcome_name(static_cast<run::Outcome>(k++)));
  EXPECT_EQ(s["outcomes"]["ground"]["histories"], 48);
  EXPECT_EQ(s["outcomes"]["ground"]["fragments"], 24.0);
  EXPECT_EQ(s["outcomes"]["ground"]["fragments_std_error"], 3.5);
  EXPECT_EQ(s["outcomes"]["left_site"]["histories"], 1952);
  EXPECT_EQ(s["outcomes"]["integration_failed"]["histories"], 0);
  EXPECT_EQ(s["outcomes"]["work_limit"]["histories"], 0);
  EXPECT_EQ(s["outcomes"]["ground_step_cap"]["histories"], 0);
}

// A real run whose histories all stop at the ground step cap: summary.json counts them under
// their own outcome (not `ground`) and in stats.ground_step_caps. With bounce and no restitution
// a sphere thrown low lands, then rolls on the plane for many steps; the cap is 2 of them.
TEST(SummaryJson, GroundStepCappedHistoriesAreCountedUnderTheirOwnOutcome) {
  run::Scenario sc = validation::rolling_sphere_scenario(3);
  sc.settings.max_ground_steps = 2;
  const Json s = summary_to_json(run::run(sc), sc, build_provenance());
  EXPECT_EQ(s["outcomes"]["ground_step_cap"]["histories"], 3);
  EXPECT_DOUBLE_EQ(s["outcomes"]["ground_step_cap"]["fragments"].get<double>(), 1.0);
  EXPECT_EQ(s["outcomes"]["ground"]["histories"], 0);
  EXPECT_EQ(s["stats"]["ground_step_caps"], 3);
  EXPECT_EQ(s["stats"]["energy_rises"], 0);
  EXPECT_NE(render_summary_text(s).find("ground_step_cap"), std::string::npos);
}

// settings.ground_bracket: the tornado table (rows widest HFD swing first, each end's figures),
// the HFD's range over every run, and the text summary's lines; null without the setting.
TEST(SummaryJson, GroundBracketIsATornadoTable) {
  run::Scenario sc = validation::flat_site_scenario(1000.0, 20.0);
  auto g = validation::sphere_group(Vec3(0, 0, 1.0), 0.2, 300.0, 2000.0, 40);
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = -4.0;
  g.direction.elevation_max_deg = 4.0;
  sc.groups = {g};
  sc.settings.bounce = true;
  sc.site.materials.at("soil").fast_contact = scene::FastContactSpec{};
  const Json without = summary_to_json(run::run(sc), sc, build_provenance());
  EXPECT_TRUE(without["ground_bracket"].is_null());
  sc.settings.ground_bracket = run::GroundBracketSettings{0.5};
  const Json s = summary_to_json(run::run(sc), sc, build_provenance());
  const Json& b = s["ground_bracket"];
  ASSERT_TRUE(b.is_object());
  EXPECT_EQ(b["material"], "soil");
  EXPECT_EQ(b["histories_per_run"], 20);
  ASSERT_EQ(b["rows"].size(), 5u);  // fast_contact's five constants
  double previous = std::numeric_limits<double>::infinity();
  double lo = b["nominal"]["hfd_m"].get<double>(), hi = lo;
  for (const Json& row : b["rows"]) {
    EXPECT_LE(row["hfd_swing_m"].get<double>(), previous);
    previous = row["hfd_swing_m"].get<double>();
    for (const char* end : {"low", "high"}) {
      EXPECT_TRUE(row[end].contains("value"));
      EXPECT_EQ(row[end]["hfd_band_m"].size(), 2u);
      lo = std::min(lo, row[end]["hfd_m"].get<double>());
      hi = std::max(hi, row[end]["hfd_m"].get<double>());
    }
  }
  EXPECT_EQ(b["hfd_range_m"][0].get<double>(), lo);
  EXPECT_EQ(b["hfd_range_m"][1].get<double>(), hi);
  const std::string text = render_summary_text(s);
  EXPECT_NE(text.find("ground-model bracket"), std::string::npos);
  EXPECT_NE(text.find("at the same 20 histories per run"), std::string::npos);  // its nominal
  EXPECT_NE(text.find("roughness_deg"), std::string::npos);
}

TEST(SummaryJson, TimingStatsAndProfile) {
  run::Scenario sc;
  Json s = summary_to_json(synthetic_result(), sc, build_provenance());
  EXPECT_EQ(s["timing"]["wall_s"], 2.0);
  EXPECT_EQ(s["timing"]["parse_s"], 0.0625);
  EXPECT_EQ(s["timing"]["build_s"], 0.125);
  EXPECT_EQ(s["timing"]["threads"], 4);
  EXPECT_EQ(s["timing"]["fragments_per_s"], 1000.0);
  EXPECT_EQ(s["timing"]["fragments_per_s_per_thread"], 250.0);
  EXPECT_FALSE(s["timing"].contains("integration_s"));  // not measured without profile
  EXPECT_FALSE(s["provenance"].contains("scenario_sha256"));
  EXPECT_EQ(s["stats"]["rhs_evaluations"], 117814);
  EXPECT_EQ(s["stats"]["integrator_steps"], 18969);
  EXPECT_EQ(s["stats"]["chords"], 6538);
  EXPECT_EQ(s["stats"]["scene_queries"], 74);
  EXPECT_EQ(s["stats"]["chords_skipped"], 9);
  EXPECT_EQ(s["stats"]["ptn_triangle_tests"], 16486);
  sc.settings.profile = true;
  s = summary_to_json(synthetic_result(), sc, build_provenance());
  EXPECT_EQ(s["timing"]["integration_s"], 5.0);
  EXPECT_EQ(s["timing"]["geometry_s"], 2.0);
  EXPECT_EQ(s["timing"]["tally_s"], 0.5);
}

TEST(SummaryJson, NoHazardousTriangleGivesNullLocation) {
  run::RunResult r = synthetic_result();
  r.max_ptn_triangle = -1;
  r.max_ptn_density_per_m2 = 0.0;
  const Json s = summary_to_json(r, run::Scenario{}, build_provenance());
  EXPECT_TRUE(s["max_ptn_triangle"].is_null());
  EXPECT_TRUE(s["max_ptn_location_m"].is_null());
  EXPECT_NE(render_summary_text(s).find("Max PTN density"), std::string::npos);
}

TEST(SummaryText, ReportsHeadlinesAndTheBuildingTable) {
  const Json s = summary_to_json(synthetic_result(), run::Scenario{}, build_provenance());
  const std::string text = render_summary_text(s);
  const auto has = [&](const std::string& part) {
    EXPECT_NE(text.find(part), std::string::npos) << "missing \"" << part << "\" in\n" << text;
  };
  has("Samples (histories)           2000");
  has("Real fragments                1000");
  has("Hazardous fragment distance   266.5 m  (±1 se band 248.0 .. 273.2 m)");
  has("Max PTN density               0.1 per m² at (3.5, -2.0, 0.2) (terrain triangle 0)");
  // Building rows: id (column as wide as the longest id + 2), impacts +/- se, penetrations
  // +/- se, each right-aligned in 24 columns ("±" is one column).
  const auto sp = [](std::size_t n) { return std::string(n, ' '); };
  has("  B1" + sp(9) + sp(13) + "12.5 ± 0.25" + sp(17) + "3 ± 0.5\n");
  has("  far_store" + sp(2) + sp(19) + "0 ± 0" + sp(19) + "0 ± 0\n");
  has("  ground" + sp(16) + sp(10) + "48" + sp(16) + "24 ± 3.5\n");
  has("Run time 2.00 s (before it: parse 0.06 s, site build 0.12 s) on 4 threads: 1000 "
      "fragments/s (250 per thread)");
  EXPECT_EQ(text.find("CANCELLED"), std::string::npos);
  EXPECT_EQ(text.find("profile:"), std::string::npos);
}

TEST(SummaryText, MarksCancelledResults) {
  run::RunResult r = synthetic_result();
  r.cancelled = true;
  r.histories_done = 700;
  const std::string text =
      render_summary_text(summary_to_json(r, run::Scenario{}, build_provenance()));
  EXPECT_EQ(text.rfind("CANCELLED: partial result of 700 histories", 0), 0u) << text;
}

TEST(SummaryText, NoBuildings) {
  run::RunResult r = synthetic_result();
  r.buildings.clear();
  const std::string text =
      render_summary_text(summary_to_json(r, run::Scenario{}, build_provenance()));
  EXPECT_NE(text.find("Buildings: none"), std::string::npos) << text;
}

TEST(SummaryJson, PrecisionStopAndTargets) {
  run::RunResult r = synthetic_result();
  EXPECT_EQ(summary_to_json(r, run::Scenario{}, build_provenance())["stop_reason"], "samples");
  EXPECT_FALSE(summary_to_json(r, run::Scenario{}, build_provenance()).contains("precision"));
  r.batches = 7;
  r.stop_reason = run::StopReason::kMaxBatches;
  auto report = std::make_shared<run::PrecisionReport>();
  report->batches = 7;
  report->histories = 14000;
  report->histories_needed = std::numeric_limits<double>::infinity();
  report->eta_s = std::numeric_limits<double>::infinity();
  run::TargetStatus hfd{"hfd_half_band_m", "", "half_band_m", 4.5, 3.0, false, 31500.0, false, ""};
  run::TargetStatus b{"building_penetrations",
                      "far_store",
                      "zero_count_bound",
                      0.02,
                      -std::numeric_limits<double>::infinity(),
                      false,
                      std::numeric_limits<double>::infinity(),
                      false,
                      ""};
  report->targets = {hfd, b};
  r.precision = report;
  const Json j = summary_to_json(r, run::Scenario{}, build_provenance());
  EXPECT_EQ(j["batches"], 7);
  EXPECT_EQ(j["stop_reason"], "max_batches");
  const Json& p = j["precision"];
  EXPECT_EQ(p["batches"], 7);
  EXPECT_FALSE(p["all_met"].get<bool>());
  EXPECT_TRUE(p["eta_s"].is_null()) << "an unreachable target has no ETA";
  ASSERT_EQ(p["targets"].size(), 2u);
  EXPECT_EQ(p["targets"][0]["figure"], "hfd_half_band_m");
  EXPECT_FALSE(p["targets"][0].contains("building"));
  EXPECT_EQ(p["targets"][0]["histories_needed"], 31500.0);
  EXPECT_EQ(p["targets"][1]["building"], "far_store");
  EXPECT_TRUE(p["targets"][1]["allowed"].is_null());
  // Text: the stop, the HFD target line, the building figures' worst one.
  const std::string text = render_summary_text(j);
  EXPECT_NE(text.find("(7 batches, stopped: max_batches)"), std::string::npos) << text;
  EXPECT_NE(text.find("hfd_half_band_m"), std::string::npos) << text;
  EXPECT_NE(text.find("NOT MET"), std::string::npos) << text;
  EXPECT_NE(text.find("0 of 1 met; worst far_store building_penetrations"), std::string::npos)
      << text;

  // An HFD target the site boundary makes unmeetable: in JSON, and said with its reason.
  report->targets[0].unmeetable = true;
  report->targets[0].note = "the HFD is a lower bound; extend the terrain";
  report->any_unmeetable = true;
  r.stop_reason = run::StopReason::kTargetsUnmeetable;
  const Json u = summary_to_json(r, run::Scenario{}, build_provenance());
  EXPECT_EQ(u["stop_reason"], "targets_unmeetable");
  EXPECT_TRUE(u["precision"]["any_unmeetable"].get<bool>());
  EXPECT_TRUE(u["precision"]["targets"][0]["unmeetable"].get<bool>());
  EXPECT_EQ(u["precision"]["targets"][0]["note"], "the HFD is a lower bound; extend the terrain");
  EXPECT_TRUE(u["precision"]["targets"][1]["note"].is_null());
  const std::string ut = render_summary_text(u);
  EXPECT_NE(ut.find("Precision targets (not all can be met)"), std::string::npos) << ut;
  EXPECT_NE(ut.find("UNMEETABLE: the HFD is a lower bound; extend the terrain"), std::string::npos)
      << ut;
  EXPECT_NE(ut.find("stopped: targets_unmeetable"), std::string::npos) << ut;
}

}  // namespace
}  // namespace fragsim::api

namespace fragsim::api {
namespace {

// What sets the HFD (issue 23): two groups, the HFD's triangle mostly the ground phase's.
run::RunResult attributed_result(run::Scenario& sc) {
  run::RunResult r = synthetic_result();
  sc.groups.resize(2);
  sc.groups[0].name = "case";
  sc.groups[1].name = "rear closure";
  run::HfdAttribution& a = r.hfd_attribution;
  a.by_mechanism[0].hfd_m = 120.0;
  a.by_mechanism[1].hfd_m = 80.5;
  a.by_mechanism[2].hfd_m = 266.5;
  a.by_mechanism[2].cut.sectors[3] = true;
  a.by_mechanism[2].cut.sector_count = 1;
  a.by_group.resize(2);
  a.by_group[0].hfd_m = 150.0;
  a.by_group[1].hfd_m = 266.5;
  a.at_hfd.triangle = 17;
  a.at_hfd.distance_m = 266.5;
  a.at_hfd.density_per_m2 = 0.02;
  a.at_hfd.by_mechanism = {0.0, 0.08, 0.92};
  a.at_hfd.by_group = {0.05, 0.95};
  a.at_sector_hfd[7] = a.at_hfd;
  return r;
}

TEST(SummaryJson, HfdAttributionByMechanismGroupAndAtTheHfd) {
  run::Scenario sc;
  const Json s = summary_to_json(attributed_result(sc), sc, build_provenance());
  const Json& a = s["hfd_attribution"];
  EXPECT_EQ(a["mechanisms"], Json({"direct_flight", "after_ricochet", "ground"}));
  EXPECT_EQ(a["groups"], Json({"case", "rear closure"}));
  EXPECT_EQ(a["by_mechanism"]["ground"]["hfd_m"], 266.5);
  EXPECT_EQ(a["by_mechanism"]["ground"]["hfd_bound"], "lower");
  EXPECT_EQ(a["by_mechanism"]["ground"]["hfd_by_sector_bound"][3], "lower");
  EXPECT_EQ(a["by_mechanism"]["direct_flight"]["hfd_bound"], "none");
  EXPECT_EQ(a["by_mechanism"]["after_ricochet"]["hfd_by_sector_m"].size(), 36u);
  EXPECT_EQ(a["by_mechanism"]["after_ricochet"]["hfd_band_m"].size(), 2u);
  ASSERT_EQ(a["by_group"].size(), 2u);
  EXPECT_EQ(a["by_group"][1]["group"], "rear closure");
  EXPECT_EQ(a["by_group"][1]["hfd_m"], 266.5);
  EXPECT_TRUE(a["by_group_omitted_reason"].is_null());
  EXPECT_EQ(a["at_hfd"]["triangle"], 17);
  EXPECT_EQ(a["at_hfd"]["distance_m"], 266.5);
  EXPECT_EQ(a["at_hfd"]["share_by_mechanism"]["ground"], 0.92);
  EXPECT_EQ(a["at_hfd"]["share_by_group"], Json({0.05, 0.95}));
  ASSERT_EQ(a["at_sector_hfd"].size(), 36u);
  EXPECT_TRUE(a["at_sector_hfd"][0].is_null());  // no HFD in that sector
  EXPECT_EQ(a["at_sector_hfd"][7]["triangle"], 17);
}

TEST(SummaryJson, OmittedGroupFiguresSayWhy) {
  run::Scenario sc;
  run::RunResult r = attributed_result(sc);
  r.hfd_attribution.by_group.clear();
  r.hfd_attribution.at_hfd.by_group.clear();
  r.hfd_attribution.by_group_omitted_reason =
      "70 fragment groups: per-group fields are kept for at most 64 groups";
  const Json s = summary_to_json(r, sc, build_provenance());
  const Json& a = s["hfd_attribution"];
  EXPECT_EQ(a["by_group"], Json::array());
  EXPECT_TRUE(a["at_hfd"]["share_by_group"].is_null());
  EXPECT_EQ(a["by_group_omitted_reason"], r.hfd_attribution.by_group_omitted_reason);
  const std::string text = render_summary_text(s);
  EXPECT_NE(text.find("HFD by group alone          omitted: 70 fragment groups"), std::string::npos)
      << text;
}

TEST(SummaryText, SaysWhatSetsTheHfd) {
  run::Scenario sc;
  const std::string text =
      render_summary_text(summary_to_json(attributed_result(sc), sc, build_provenance()));
  const auto has = [&](const std::string& part) {
    EXPECT_NE(text.find(part), std::string::npos) << "missing \"" << part << "\" in\n" << text;
  };
  has("  set by (at its triangle)    ground 92 %, after_ricochet 8 %; group \"rear closure\" 95 %, "
      "\"case\" 5 %\n");
  has("  HFD by mechanism alone      ground ≥ 266.5 m, direct_flight 120.0 m, after_ricochet "
      "80.5 m\n");
  has("  HFD by group alone          \"rear closure\" 266.5 m, \"case\" 150.0 m\n");
}

TEST(SummaryText, NoHfdNoSetByLine) {
  const Json s = summary_to_json(run::RunResult{}, run::Scenario{}, build_provenance());
  EXPECT_TRUE(s["hfd_attribution"]["at_hfd"].is_null());
  const std::string text = render_summary_text(s);
  EXPECT_EQ(text.find("set by"), std::string::npos) << text;
}

// US customary units (docs/units.md): distances in ft (m / 0.3048), densities per 600 ft²
// (× 55.741824 m²), the cut sectors by bearing; site coordinates stay in metres and say so.
TEST(SummaryText, UsUnits) {
  const Json s = summary_to_json(synthetic_result(), run::Scenario{}, build_provenance());
  EXPECT_EQ(render_summary_text(s, UnitSystem::kSi), render_summary_text(s));
  const std::string text = render_summary_text(s, UnitSystem::kUs);
  const auto has = [&](const std::string& part) {
    EXPECT_NE(text.find(part), std::string::npos) << "missing \"" << part << "\" in\n" << text;
  };
  // 266.5 m = 874.34 ft; 248.0 m = 813.65 ft; 273.25 m = 896.49 ft.
  has("Hazardous fragment distance   874.3 ft  (±1 se band 813.6 .. 896.5 ft)\n");
  // The default threshold, 1/55.74 per m², is 1.00003 per 600 ft²; 55.74 m² = 599.98 ft².
  has("  threshold                   1 per 600 ft² (1 per 600.0 ft²), from (0.0, 0.0, 1.0) m\n");
  has("Max PTN density               5.574 per 600 ft² at (3.5, -2.0, 0.2) m (terrain triangle "
      "0)\n");
  has("  site boundary               not reached (density there up to 0 per 600 ft², 0 × the "
      "threshold)\n");
  has("  B1" + std::string(22, ' ') + "12.5 ± 0.25");  // counts are counts
  EXPECT_EQ(text.find(" m²"), std::string::npos) << text;
  EXPECT_EQ(text.find(" m)"), std::string::npos) << text;
}

TEST(SummaryText, UsUnitsOfAnHfdCutByTheSiteBoundary) {
  const Json s = summary_to_json(cut_result(), run::Scenario{}, build_provenance());
  const std::string text = render_summary_text(s, UnitSystem::kUs);
  EXPECT_EQ(text.rfind("WARNING: HFD ≥ 874.3 ft: hazardous density reaches the site boundary in 2 "
                       "of 36 sectors; extend the terrain\n",
                       0),
            0u)
      << text;
  // Sectors 0 (azimuth 0–10°, bearing 080°–090°) and 35 (bearing 090°–100°): one arc.
  for (const char* part :
       {"Hazardous fragment distance   ≥ 874.3 ft, a lower bound  (±1 se band 813.6 .. ≥ 896.5 "
        "ft)",
        "  site boundary               hazardous in 2 of 36 sectors, bearings 080°–100° (density "
        "there up to 2.787 per 600 ft², 2.8 × the threshold)"})
    EXPECT_NE(text.find(part), std::string::npos) << "missing \"" << part << "\" in\n" << text;
}

TEST(SummaryText, UsUnitsOfAttributionAndPrecisionTargets) {
  run::Scenario sc;
  run::RunResult r = attributed_result(sc);
  auto report = std::make_shared<run::PrecisionReport>();
  report->targets = {
      run::TargetStatus{"hfd_half_band_m", "", "half_band_m", 4.5, 3.0, false, 31500.0, false, ""}};
  r.precision = report;
  const Json s = summary_to_json(r, sc, build_provenance());
  const std::string text = render_summary_text(s, UnitSystem::kUs);
  const auto has = [&](const std::string& part) {
    EXPECT_NE(text.find(part), std::string::npos) << "missing \"" << part << "\" in\n" << text;
  };
  // 120 m = 393.70 ft, 80.5 m = 264.11 ft, 150 m = 492.13 ft.
  has("  HFD by mechanism alone      ground ≥ 874.3 ft, direct_flight 393.7 ft, after_ricochet "
      "264.1 ft\n");
  has("  HFD by group alone          \"rear closure\" 874.3 ft, \"case\" 492.1 ft\n");
  // 4.5 m = 14.76 ft, 3 m = 9.843 ft; the figure's "_m" goes with its metres.
  has("  hfd_half_band" + std::string(15, ' ') + "14.76 ft (allowed 9.843 ft)  NOT MET\n");
  EXPECT_NE(render_summary_text(s).find("hfd_half_band_m             4.5 (allowed 3)  NOT MET"),
            std::string::npos);
}

// The ground-model bracket's lines in ft (139.24 m = 456.82 ft, 421.83 m = 1383.96 ft,
// 156.91 m = 514.80 ft); the constants' values stay as the scenario gives them.
TEST(SummaryText, UsUnitsOfTheGroundBracket) {
  const Json s = Json::parse(R"({"ground_bracket": {
      "material": "soil", "histories_per_run": 20, "cancelled": false,
      "nominal": {"hfd_m": 156.91}, "hfd_range_m": [139.24, 421.83], "hfd_range_bound": "none",
      "rows": [{"constant": "roughness_deg",
                "low": {"value": 0, "hfd_m": 421.83, "hfd_bound": "none"},
                "high": {"value": 5, "hfd_m": 139.24, "hfd_bound": "lower"}}]}})");
  const auto us = ground_bracket_text(s, UnitSystem::kUs);
  ASSERT_EQ(us.size(), 2u);
  EXPECT_EQ(us[0].second,
            "HFD 456.8 … 1384.0 ft over the ranges of soil's constants; nominal 514.8 ft at the "
            "same 20 histories per run");
  EXPECT_EQ(us[1].second, "1384.0 ft at 0, ≥ 456.8 ft at 5");
  const auto si = ground_bracket_text(s);
  EXPECT_EQ(si[0].second,
            "HFD 139.2 … 421.8 m over the ranges of soil's constants; nominal 156.9 m at the same "
            "20 histories per run");
  EXPECT_EQ(si[1].second, "421.8 m at 0, ≥ 139.2 m at 5");
}

}  // namespace
}  // namespace fragsim::api
