// `fragsim compare` as a user runs it: the files, the figures read back against each run's own
// summary.json, and bad input (exit 2 naming the variant's file and field, nothing written).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_process.h"

namespace fragsim::cli {
namespace {

namespace fs = std::filesystem;
using testing::CliDirTest;

class CompareCli : public CliDirTest {
 protected:
  CompareCli() : CliDirTest("compare_cli") {}
  // examples/minimal with `edit` applied, written to dir_/name.
  std::string scenario(const std::string& name,
                       const std::function<void(nlohmann::json&)>& edit = {}) {
    std::ifstream in(fs::path(FRAGSIM_SOURCE_DIR) / "examples/minimal/scenario.json");
    nlohmann::json j = nlohmann::json::parse(in);
    if (edit) edit(j);
    const fs::path p = dir_ / name;
    std::ofstream(p) << j.dump(1);
    return p.string();
  }
  static nlohmann::json read_json(const fs::path& p) {
    std::ifstream in(p);
    return nlohmann::json::parse(in);
  }
};

// The minimal site's building B1 moved 20 m further out: it gets fewer hits, and the same
// histories elsewhere give exactly the same figures.
void move_building(nlohmann::json& j) {
  j["site"]["buildings"][0]["footprint_m"] = {{80, -10}, {100, -10}, {100, 10}, {80, 10}};
}

TEST_F(CompareCli, WritesBothRunsAndTheirPairedDifference) {
  const std::string base = scenario("base.json"), variant = scenario("variant.json", move_building);
  const auto r = run({"compare", base, variant, "--out", (dir_ / "out").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("changed: site.buildings"), std::string::npos) << r.out;
  for (const char* f : {"compare.json", "compare.h5", "density_difference.tif", "base/summary.json",
                        "base/results.h5", "variant/summary.json", "variant/results.h5"})
    EXPECT_TRUE(fs::exists(dir_ / "out" / f)) << f;
  const nlohmann::json c = read_json(dir_ / "out/compare.json");
  const nlohmann::json sb = read_json(dir_ / "out/base/summary.json");
  const nlohmann::json sv = read_json(dir_ / "out/variant/summary.json");
  // (JSON values compared as text: gtest cannot print a JSON value)
  EXPECT_EQ(c["format_version"].dump(), "1");
  EXPECT_EQ(c["changed"].dump(), R"(["site.buildings"])");
  const nlohmann::json& b1 = c["buildings"][0]["impacts"];
  EXPECT_EQ(b1["base"].dump(), sb["buildings"][0]["expected_impacts"].dump());
  EXPECT_EQ(b1["variant"].dump(), sv["buildings"][0]["expected_impacts"].dump());
  EXPECT_NEAR(b1["difference"].get<double>(),
              b1["variant"].get<double>() - b1["base"].get<double>(), 1e-12);
  EXPECT_LT(b1["difference"].get<double>(), 0.0);
  EXPECT_GT(b1["paired_std_error"].get<double>(), 0.0);
  EXPECT_LE(b1["paired_std_error"].get<double>(), b1["unpaired_std_error"].get<double>());
  EXPECT_EQ(c["hfd"]["base_m"].dump(), sb["hazardous_fragment_distance_m"].dump());
  EXPECT_TRUE(c["density"]["same_terrain"].get<bool>());
  // --units us: the printed HFD in feet (the files stay SI).
  const auto us = run({"compare", base, variant, "--out", (dir_ / "us").string(), "--units", "us"});
  ASSERT_EQ(us.exit_code, 0) << us.err;
  EXPECT_NE(us.out.find(" ft, variant "), std::string::npos) << us.out;
}

// The same file twice: every difference is 0 with se 0 (the runs are bit-identical).
TEST_F(CompareCli, SameScenarioTwiceGivesZero) {
  const std::string base = scenario("base.json");
  const auto r = run({"compare", base, base, "--out", (dir_ / "out").string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "");
  const nlohmann::json c = read_json(dir_ / "out/compare.json");
  EXPECT_EQ(c["changed"].dump(), "[]");
  EXPECT_EQ(c["hfd"]["difference_m"].get<double>(), 0.0);
  EXPECT_EQ(c["hfd"]["paired_std_error_m"].get<double>(), 0.0);
  EXPECT_EQ(c["buildings"][0]["impacts"]["paired_std_error"].get<double>(), 0.0);
  EXPECT_EQ(c["density"]["triangles_beyond_2_std_errors"].get<int>(), 0);
}

// What cannot be paired is refused before anything is run or written, naming the variant's
// file and the field.
TEST_F(CompareCli, RefusesAVariantThatChangesTheHistories) {
  const std::string base = scenario("base.json");
  struct Case {
    std::function<void(nlohmann::json&)> edit;
    std::string field;
  };
  const Case cases[] = {
      {[](nlohmann::json& j) { j["settings"]["seed"] = 99; }, "settings.seed"},
      {[](nlohmann::json& j) { j["fragment_groups"][0]["samples"] = 2001; },
       "fragment_groups[0].samples"},
      {[](nlohmann::json& j) { j["settings"]["bounce"] = true; }, "settings.bounce"},
      {[](nlohmann::json& j) {
         j["settings"]["precision"] = {{"max_batches", 2}};
       },
       "settings"},
  };
  for (const Case& c : cases) {
    const std::string variant = scenario("variant.json", c.edit);
    const auto r = run({"compare", base, variant, "--out", (dir_ / "out").string()});
    EXPECT_EQ(r.exit_code, 2) << c.field;
    EXPECT_NE(r.err.find(variant + ": " + c.field), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out")) << c.field;
  }
  const auto missing = run({"compare", base, "--out", (dir_ / "out").string()});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("missing VARIANT.json"), std::string::npos) << missing.err;
  const auto broken = run({"compare", base, (dir_ / "nope.json").string(), "--out", "x"});
  EXPECT_EQ(broken.exit_code, 2);
  EXPECT_NE(broken.err.find("nope.json"), std::string::npos) << broken.err;
}

}  // namespace
}  // namespace fragsim::cli
