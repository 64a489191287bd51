// The command line of `fragsim` (app/args.h): each command's operands and options, and the
// usage errors that name what is wrong (exit code 2 in main).
#include "app/args.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace fragsim::app {
namespace {

using Args = std::vector<std::string>;

// The UsageError's message, or "" when the command line parses.
std::string usage_error(const Args& args) {
  try {
    parse_args(args);
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(Args, AnUnknownOptionNamesTheNearestItsCommandTakes) {
  EXPECT_EQ(usage_error({"run", "s.json", "--out", "d", "--thread", "2"}),
            "--thread: unknown option (did you mean --threads?)");
  EXPECT_EQ(usage_error({"export", "r.h5", "--out", "d", "--pixel-n=3"}),
            "--pixel-n: unknown option (did you mean --pixel-m?)");
  // --threads is close to nothing submit takes.
  EXPECT_EQ(usage_error({"submit", "s.json", "--threads", "2"}), "--threads: unknown option");
}

TEST(Args, RunTakesItsOptionsInBothSpellings) {
  const Options o = parse_args({"run", "s.json", "--out", "d", "--threads=3", "--samples-scale",
                                "0.5", "--shard", "2/5", "--progress-file=p.json", "-q"});
  EXPECT_EQ(o.command, Command::kRun);
  EXPECT_EQ(o.scenario, "s.json");
  EXPECT_EQ(o.out, "d");
  EXPECT_EQ(o.threads, 3);
  EXPECT_EQ(o.samples_scale, 0.5);
  ASSERT_TRUE(o.shard);
  EXPECT_EQ(o.shard->index, 2);
  EXPECT_EQ(o.shard->count, 5);
  EXPECT_EQ(o.progress_file, "p.json");
  EXPECT_TRUE(o.quiet);
}

TEST(Args, MergeTakesTheScenarioThenItsPartialFiles) {
  const Options o = parse_args({"merge", "s.json", "a.fsp", "--out", "d", "b.fsp", "c.fsp"});
  EXPECT_EQ(o.command, Command::kMerge);
  EXPECT_EQ(o.scenario, "s.json");
  EXPECT_EQ(o.parts, (Args{"a.fsp", "b.fsp", "c.fsp"}));
  EXPECT_EQ(o.out, "d");
  EXPECT_EQ(usage_error({"merge", "s.json", "a.fsp", "--out", "d", "--threads", "2"}),
            "--threads: unknown option");
  EXPECT_EQ(usage_error({"merge", "s.json", "--out", "d"}),
            "merge: no partial files (PART.fsp ...)");
  EXPECT_EQ(usage_error({"merge", "s.json", "a.fsp"}), "merge needs --out DIR");
}

TEST(Args, SubmitTakesItsOptions) {
  const Options o =
      parse_args({"submit", "s.json", "--server", "https://h:1", "--token-file", "t",
                  "--priority=-5", "--idempotency-key", "k", "--no-wait", "--maps", "--out", "d"});
  EXPECT_EQ(o.command, Command::kSubmit);
  EXPECT_EQ(o.server, "https://h:1");
  EXPECT_EQ(o.token_file, "t");
  EXPECT_EQ(o.priority, -5);
  EXPECT_EQ(o.idempotency_key, "k");
  EXPECT_FALSE(o.wait);
  EXPECT_TRUE(o.maps);
  EXPECT_EQ(o.out, "d");
  EXPECT_EQ(parse_args({"submit", "s.json"}).server, "http://127.0.0.1:8080");
  EXPECT_EQ(parse_args({"submit", "s.json", "--compare-with", "j_0123456789abcdef"}).compare_with,
            "j_0123456789abcdef");
  EXPECT_EQ(usage_error({"submit", "s.json", "--compare-with", "nope"}),
            "--compare-with: expected a job id (j_ and 16 hex digits), got \"nope\"");
  EXPECT_EQ(usage_error({"submit", "s.json", "--maps"}),
            "--maps needs --out DIR (the maps go to DIR/maps)");
  EXPECT_EQ(usage_error({"submit", "s.json", "--server", "h:1"}),
            "--server: expected http://HOST:PORT, got \"h:1\"");
  EXPECT_EQ(usage_error({"submit", "s.json", "--priority", "1001"}),
            "--priority: expected an integer in [-1000, 1000], got \"1001\"");
  EXPECT_EQ(usage_error({"submit", "s.json", "--threads", "2"}), "--threads: unknown option");
}

TEST(Args, FileCommandsNeedTheirInputAndOut) {
  Options o = parse_args({"export", "r.h5", "--out", "d", "--pixel-m", "2.5"});
  EXPECT_EQ(o.command, Command::kExport);
  EXPECT_EQ(o.scenario, "r.h5");
  EXPECT_EQ(o.pixel_m, 2.5);
  EXPECT_EQ(o.smoothing_m, std::nullopt);
  EXPECT_EQ(parse_args({"export", "r.h5", "--out", "d", "--smoothing-m=12.5"}).smoothing_m, 12.5);
  o = parse_args({"site", "import", "i.json", "--out", "s.json"});
  EXPECT_EQ(o.command, Command::kSiteImport);
  EXPECT_EQ(o.scenario, "i.json");
  o = parse_args({"site", "export-gis", "s.json", "--out=d"});
  EXPECT_EQ(o.command, Command::kSiteExportGis);
  EXPECT_EQ(o.out, "d");
  EXPECT_EQ(usage_error({"export", "--out", "d"}), "export: missing RESULTS.h5");
  EXPECT_EQ(usage_error({"export", "r.h5"}), "export needs --out DIR");
  EXPECT_EQ(usage_error({"export", "r.h5", "--out", "d", "--pixel-m", "0"}),
            "--pixel-m: expected a number > 0, got \"0\"");
  EXPECT_EQ(usage_error({"export", "r.h5", "--out", "d", "--smoothing-m", "-1"}),
            "--smoothing-m: expected a number > 0, got \"-1\"");
  EXPECT_EQ(usage_error({"export", "r.h5", "--out", "d", "--smoothing-m", "inf"}),
            "--smoothing-m: expected a number > 0, got \"inf\"");
  EXPECT_EQ(usage_error({"run", "s.json", "--out", "d", "--smoothing-m", "1"}),
            "--smoothing-m: unknown option");
  EXPECT_EQ(usage_error({"site", "import", "i.json", "--pixel-m", "1"}),
            "--pixel-m: unknown option");
  EXPECT_EQ(usage_error({"site", "import", "i.json"}), "site import needs --out SITE.json");
  EXPECT_EQ(usage_error({"site", "export-gis"}), "site export-gis: missing SITE.json");
  EXPECT_NE(usage_error({"site", "frobnicate"}).find("site: expected"), std::string::npos);
  EXPECT_EQ(usage_error({"site", "import", "i.json", "--out", ""}), "--out: empty file name");
  o = parse_args({"shape", "import", "rock.stl", "--axes", "y_up"});
  EXPECT_EQ(o.command, Command::kShapeImport);
  EXPECT_EQ(o.scenario, "rock.stl");
  EXPECT_EQ(o.axes, "y_up");
  EXPECT_EQ(parse_args({"shape", "import", "rock.ply"}).axes, "z_up");
  EXPECT_EQ(usage_error({"shape", "import"}), "shape import: missing FILE (.stl, .obj, .ply)");
  EXPECT_EQ(usage_error({"shape", "import", "r.stl", "--out", "x"}), "--out: unknown option");
  EXPECT_NE(usage_error({"shape", "export"}).find("shape: expected"), std::string::npos);
  o = parse_args({"groups", "from-munition", "m.json", "--out", "g.json"});
  EXPECT_EQ(o.command, Command::kGroupsFromMunition);
  EXPECT_EQ(o.scenario, "m.json");
  EXPECT_EQ(o.out, "g.json");
  EXPECT_EQ(parse_args({"groups", "from-munition", "m.json"}).out, "");  // stdout
  EXPECT_EQ(usage_error({"groups", "from-munition"}),
            "groups from-munition: missing MUNITION.json");
  EXPECT_NE(usage_error({"groups", "import"}).find("groups: expected"), std::string::npos);
  EXPECT_EQ(usage_error({"groups", "from-munition", "m.json", "--axes", "y_up"}),
            "--axes: unknown option");
}

// --units si|us (docs/units.md): the printed summary of run, merge and submit; export's US
// fields. SI by default; anything else names what it expected.
TEST(Args, UnitsOnTheCommandsThatPresentFigures) {
  EXPECT_EQ(parse_args({"run", "s.json", "--out", "d"}).units, api::UnitSystem::kSi);
  EXPECT_EQ(parse_args({"run", "s.json", "--out", "d", "--units", "us"}).units,
            api::UnitSystem::kUs);
  EXPECT_EQ(parse_args({"run", "s.json", "--units=si", "--out", "d"}).units, api::UnitSystem::kSi);
  EXPECT_EQ(parse_args({"merge", "s.json", "a.fsp", "--out", "d", "--units", "us"}).units,
            api::UnitSystem::kUs);
  EXPECT_EQ(parse_args({"submit", "s.json", "--units=us"}).units, api::UnitSystem::kUs);
  EXPECT_EQ(parse_args({"export", "r.h5", "--out", "d", "--units", "us"}).units,
            api::UnitSystem::kUs);
  EXPECT_EQ(usage_error({"run", "s.json", "--out", "d", "--units", "imperial"}),
            "--units: expected si or us, got \"imperial\"");
  EXPECT_EQ(usage_error({"submit", "s.json", "--units", "US"}),
            "--units: expected si or us, got \"US\"");
  EXPECT_EQ(usage_error({"export", "r.h5", "--out", "d", "--units="}),
            "--units: expected si or us, got \"\"");
  EXPECT_EQ(usage_error({"run", "s.json", "--out", "d", "--units"}), "--units: needs a value");
  EXPECT_EQ(usage_error({"validate", "s.json", "--units", "us"}), "--units: unknown option");
  EXPECT_EQ(usage_error({"site", "import", "i.json", "--out", "s.json", "--units", "us"}),
            "--units: unknown option");
}

TEST(Args, HelpAndVersionWinAndEveryMistakeIsNamed) {
  for (const Args& a : {Args{"help"}, Args{"-h"}, Args{"--help"}, Args{"run", "s.json", "-h"}})
    EXPECT_EQ(parse_args(a).command, Command::kHelp);
  EXPECT_EQ(parse_args({"version"}).command, Command::kVersion);
  EXPECT_EQ(parse_args({"validate", "s.json"}).command, Command::kValidate);
  EXPECT_EQ(usage_error({}), "missing command");
  EXPECT_EQ(usage_error({"fly"}), "unknown command \"fly\"");
  EXPECT_EQ(usage_error({"run", "s.json"}), "run needs --out DIR");
  EXPECT_EQ(usage_error({"run", "--out", "d"}), "missing SCENARIO.json");
  EXPECT_EQ(usage_error({"run", "a.json", "b.json", "--out", "d"}),
            "more than one scenario file (\"b.json\")");
  EXPECT_EQ(usage_error({"run", "s.json", "--out"}), "--out: needs a value");
  EXPECT_EQ(usage_error({"run", "s.json", "--out", ""}), "--out: empty directory name");
  EXPECT_EQ(usage_error({"validate", "s.json", "--out", "d"}), "--out: unknown option");
  EXPECT_NE(usage_error({"run", "s.json", "--out", "d", "--threads", "x"}).find("--threads:"),
            std::string::npos);
  EXPECT_NE(usage_error({"run", "s.json", "--out", "d", "--shard", "3/3"}).find("--shard:"),
            std::string::npos);
  EXPECT_NE(usage_error({"run", "s.json", "--out", "d", "--samples-scale", "-1"})
                .find("--samples-scale:"),
            std::string::npos);
  EXPECT_EQ(usage_error({"run", "s.json", "--out", "d", "--progress-file="}),
            "--progress-file: empty file name");
  // A lone "-" is an operand, not an option.
  EXPECT_EQ(parse_args({"run", "-", "--out", "d"}).scenario, "-");
}

}  // namespace
}  // namespace fragsim::app
