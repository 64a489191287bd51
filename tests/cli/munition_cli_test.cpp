// `fragsim groups from-munition`: its output is a fragment_groups array that a scenario runs
// with, and bad input exits 2 naming the field and writes nothing.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "api/test_support.h"
#include "cli/cli_process.h"

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using fragsim::api::testing::read_text;
using fragsim::api::testing::source_path;

class MunitionCli : public fragsim::cli::testing::CliDirTest {
 protected:
  MunitionCli() : CliDirTest("fragsim_cli_munition_") {}

  Json munition() const {
    return Json::parse(read_text(source_path("examples/munitions/munition.json")));
  }
  fragsim::cli::testing::CliResult from_munition(const Json& m) {
    std::ofstream(dir_ / "munition.json") << m.dump();
    return run({"groups", "from-munition", (dir_ / "munition.json").string(), "--out",
                (dir_ / "groups.json").string()});
  }
};

TEST_F(MunitionCli, GroupsRunInAScenario) {
  const auto r = from_munition(munition());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("Gurney speed V"), std::string::npos) << r.err;  // the derivation
  EXPECT_NE(r.err.find("note: the Mott constant of Comp B is unverified"), std::string::npos);
  // The committed derivation of the example is what the command prints today.
  EXPECT_NE(r.err.find(read_text(source_path("examples/munitions/derivation.txt"))),
            std::string::npos)
      << r.err;
  const Json groups = Json::parse(read_text(dir_ / "groups.json"));
  ASSERT_EQ(groups.size(), 3u);
  // The committed example output is what the command writes today.
  EXPECT_EQ(groups, Json::parse(read_text(source_path("examples/munitions/groups.json"))));
  Json scenario = fragsim::api::testing::minimal_example();
  scenario["fragment_groups"] = groups;
  std::ofstream(dir_ / "scenario.json") << scenario.dump();
  const auto v = run({"validate", (dir_ / "scenario.json").string()});
  EXPECT_EQ(v.exit_code, 0) << v.err;
  const auto run_r = run({"run", (dir_ / "scenario.json").string(), "--out",
                          (dir_ / "out").string(), "--samples-scale", "0.05", "--quiet"});
  ASSERT_EQ(run_r.exit_code, 0) << run_r.err;
  const Json summary = Json::parse(read_text(dir_ / "out" / "summary.json"));
  double count = 0.0;
  for (const Json& g : groups) count += g["count"].get<double>();
  EXPECT_NEAR(summary["real_fragments"].get<double>(), count, 1e-6 * count);
}

TEST_F(MunitionCli, WithoutOutPrintsTheGroups) {
  std::ofstream(dir_ / "munition.json") << munition().dump();
  const auto r = run({"groups", "from-munition", (dir_ / "munition.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json::parse(r.out).size(), 3u);
}

TEST_F(MunitionCli, BadInputExits2NamingTheFieldAndWritesNothing) {
  struct Case {
    const char* pointer;
    Json value;
    const char* expected;
  };
  const Case cases[] = {
      {"/case/wall_thickness_m", -0.02, "error: case.wall_thickness_m: must be > 0 (got -0.02)"},
      {"/explosive/name", "semtex", "error: explosive.name: unknown explosive \"semtex\""},
      {"/zones/0/fraction", 0.3, "error: zones: the fractions must sum to 1 (got 1.2)"},
      {"/fragments/samples", 0, "error: fragments.samples: must be >= 1"},
  };
  for (const Case& c : cases) {
    Json m = munition();
    m[Json::json_pointer(c.pointer)] = c.value;
    const auto r = from_munition(m);
    EXPECT_EQ(r.exit_code, 2) << c.pointer;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "groups.json")) << c.pointer;
  }
  Json missing = munition();
  missing["case"].erase("length_m");
  const auto r = from_munition(missing);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("error: case.length_m: is required"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "groups.json"));
  const auto usage = run({"groups", "from-munition"});
  EXPECT_EQ(usage.exit_code, 2);
  EXPECT_NE(usage.err.find("missing MUNITION.json"), std::string::npos) << usage.err;
}

}  // namespace
