// The `fragsim` executable as a subprocess: exit codes, error messages naming the field, no
// output directory after bad input, cancellation, and bit-identical results.h5 datasets for any
// thread count and chunk size.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "api/test_support.h"
#include "cli/cli_process.h"
#include "formats/results_h5.h"

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

Json minimal_example() {
  return Json::parse(read_text(fs::path(FRAGSIM_SOURCE_DIR) / "examples/minimal/scenario.json"));
}

using fragsim::cli::testing::CliResult;

// The CLI as a subprocess, its output in the test directory (cli_process.h).
class Cli : public fragsim::cli::testing::CliDirTest {
 protected:
  Cli() : CliDirTest("fragsim_cli_test_") {}

  fs::path scenario_file(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    write_text(p, text);
    return p;
  }

  // `run` on bad input: exit 2, exactly one error line naming the field, and no output
  // directory afterwards; `validate` agrees.
  void expect_rejected(const std::string& text, const std::string& expected_error_prefix) {
    const fs::path scenario = scenario_file("bad.json", text);
    const fs::path out = dir_ / "out" / "nested";
    const CliResult r = run({"run", scenario.string(), "--out", out.string(), "--threads", "1"});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("error: " + expected_error_prefix, 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out")) << "the output directory was created";
    const CliResult v = run({"validate", scenario.string()});
    EXPECT_EQ(v.exit_code, 2);
    EXPECT_EQ(v.err, r.err);
  }
};

// A square mesh terrain (4 vertices) for the geometry cases.
Json with_mesh_terrain(Json j) {
  j["site"]["terrain"] = {
      {"mesh",
       {{"vertices_m", {{-200, -200, 0}, {200, -200, 0}, {200, 200, 0}, {-200, 200, 0}}},
        {"triangles", {{0, 1, 2}, {0, 2, 3}}}}},
      {"material", "soil"}};
  return j;
}

TEST_F(Cli, VersionAndHelp) {
  const CliResult v = run({"--version"});
  EXPECT_EQ(v.exit_code, 0);
  EXPECT_EQ(v.out.rfind("fragsim ", 0), 0u) << v.out;
  EXPECT_NE(v.out.find("(git "), std::string::npos);
  const CliResult h = run({"--help"});
  EXPECT_EQ(h.exit_code, 0);
  EXPECT_NE(h.out.find("fragsim run SCENARIO.json --out DIR"), std::string::npos);
}

TEST_F(Cli, UsageErrorsExitTwo) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{},
        {"frobnicate"},
        {"run", "x.json"},
        {"validate"},
        {"run", "x.json", "--out", "o", "--threads", "many"},
        {"run", "x.json", "--out", "o", "--samples-scale", "0"},
        {"validate", "x.json", "--bogus"},
        {"submit", "x.json", "--maps"},
        {"export", "r.h5", "--out", "o", "--smoothing-m", "-1"}}) {
    const CliResult r = run(args);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << r.err;
  }
  EXPECT_FALSE(fs::exists("o"));
}

TEST_F(Cli, MissingScenarioFile) {
  const CliResult r = run({"validate", (dir_ / "nope.json").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("cannot read"), std::string::npos) << r.err;
}

TEST_F(Cli, ValidateMinimalExample) {
  const CliResult r = run({"validate", FRAGSIM_SOURCE_DIR "/examples/minimal/scenario.json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("ok: ", 0), 0u) << r.out;
  EXPECT_NE(r.out.find("1 building"), std::string::npos) << r.out;
}

// ---- One test per class of bad input ----

TEST_F(Cli, MalformedJson) {
  expect_rejected("{\"schema\": \"fragsim.scenario/1\",\n \"site\": }",
                  "malformed JSON at line 2, column 10: ");
}

TEST_F(Cli, WrongType) {
  Json j = minimal_example();
  j["fragment_groups"][0]["samples"] = "2000";
  expect_rejected(j.dump(2), "fragment_groups[0].samples: expected integer, got string\n");
}

TEST_F(Cli, OutOfRangeValue) {
  Json j = minimal_example();
  j["fragment_groups"][0]["speed_mps"]["sigma"] = -40;
  expect_rejected(j.dump(2), "fragment_groups[0].speed_mps.sigma: must be > 0\n");
}

TEST_F(Cli, BadMeshIndex) {
  Json j = with_mesh_terrain(minimal_example());
  j["site"]["terrain"]["mesh"]["triangles"][1][1] = 9;
  expect_rejected(j.dump(2),
                  "site.terrain.mesh.triangles[1][1]: vertex index 9 out of range (vertices: 4)\n");
}

TEST_F(Cli, InfiniteVertex) {
  std::string text = with_mesh_terrain(minimal_example()).dump();
  const std::string vertex = "[200,200,0]";
  ASSERT_NE(text.find(vertex), std::string::npos);
  text.replace(text.find(vertex), vertex.size(), "[200,200,1e999]");
  expect_rejected(text, "site.terrain.mesh.vertices_m[2][2]: not finite\n");
}

TEST_F(Cli, EmptyFragmentGroups) {
  Json j = minimal_example();
  j["fragment_groups"] = Json::array();
  expect_rejected(j.dump(2),
                  "fragment_groups: must not be empty (give at least one fragment group)\n");
}

TEST_F(Cli, BadInputLeavesAnExistingDirectoryUntouched) {
  Json j = minimal_example();
  j["settings"]["integrater"] = Json::object();
  const fs::path scenario = scenario_file("bad.json", j.dump());
  fs::create_directories(dir_ / "existing");
  write_text(dir_ / "existing" / "keep.txt", "x");
  const CliResult r = run({"run", scenario.string(), "--out", (dir_ / "existing").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "error: settings.integrater: unknown key (did you mean \"integrator\"?)\n");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir_ / "existing"))
    names.push_back(e.path().filename());
  EXPECT_EQ(names, std::vector<std::string>{"keep.txt"});
}

// An --out that cannot be made is the user's input too: exit 2 naming --out, before the run.
TEST_F(Cli, OutThatCannotBeMadeIsInvalidInput) {
  write_text(dir_ / "a-file", "kept");
  const std::string out = (dir_ / "a-file" / "out").string();
  const CliResult r =
      run({"run", FRAGSIM_SOURCE_DIR "/examples/minimal/scenario.json", "--out", out, "--quiet"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(r.err.rfind("error: --out: cannot create directory ", 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(read_text(dir_ / "a-file"), "kept");
}

// ---- Runs ----

TEST_F(Cli, RunWritesSummaryAndResults) {
  const fs::path out = dir_ / "run";
  const CliResult r = run({"run", FRAGSIM_SOURCE_DIR "/examples/minimal/scenario.json", "--out",
                           out.string(), "--threads", "2", "--samples-scale", "0.5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(out)) names.push_back(e.path().filename());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"results.h5", "summary.json"}));  // no temporaries
  const Json s = Json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(s["schema"], "fragsim.result/1");
  EXPECT_EQ(s["samples"], 1000);  // 2000 scaled by 0.5
  EXPECT_EQ(s["seed"], 42);
  EXPECT_EQ(s["cancelled"], false);
  EXPECT_EQ(s["timing"]["threads"], 2);
  // Parsing and the site build are timed where they happen, before the run (issue 11: build_s
  // read 0.00 s while they took most of a large site's time).
  EXPECT_GT(s["timing"]["parse_s"].get<double>(), 0.0);
  EXPECT_GT(s["timing"]["build_s"].get<double>(), 0.0);
  EXPECT_EQ(s["buildings"][0]["id"], "B1");
  EXPECT_EQ(s["provenance"]["scenario_sha256"].get<std::string>().size(), 64u);
  // The report on stdout.
  for (const char* part : {"Samples (histories)", "Real fragments", "Hazardous fragment distance",
                           "Max PTN density", "B1", "Outcomes", "fragments/s", "per thread"})
    EXPECT_NE(r.out.find(part), std::string::npos) << part << " missing in\n" << r.out;
  // The recorded scenario shows the overrides.
  const Json stored = Json::parse(
      fragsim::formats::read_attribute_string(out / "results.h5", "/", "scenario_json"));
  EXPECT_EQ(stored["fragment_groups"][0]["samples"], 1000);
  EXPECT_EQ(stored["settings"]["threads"], 2);
}

// Issue 22: a terrain too small for its fragments (the minimal example's group on a 400 m x
// 400 m plane) is valid input: `validate` exits 0 with its ok lines and warns on stderr, naming
// the group; `run` warns the same before the run (and not with --quiet); a terrain large enough
// gives no warning.
TEST_F(Cli, ATerrainTooSmallForAGroupIsWarnedOfNotRefused) {
  Json small = minimal_example();
  small["site"]["terrain"]["plane"]["extent_m"] = {-200, -200, 200, 200};
  const fs::path small_file = scenario_file("small.json", small.dump());
  const std::string warning = "warning: fragment_groups[0] (\"steel spheres\"): about ";
  const CliResult v = run({"validate", small_file.string()});
  EXPECT_EQ(v.exit_code, 0) << v.err;
  EXPECT_EQ(v.out.rfind("ok: " + small_file.string() + "\n", 0), 0u) << v.out;
  EXPECT_NE(v.err.find(warning), std::string::npos) << v.err;
  EXPECT_NE(v.err.find("extend the terrain"), std::string::npos) << v.err;
  EXPECT_EQ(v.err.find("warning: ", v.err.find(warning) + 1), std::string::npos) << "one group";

  const CliResult r = run({"run", small_file.string(), "--out", (dir_ / "r").string(),
                           "--samples-scale", "0.01", "--threads", "1"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find(warning), std::string::npos) << r.err;

  Json large = small;
  large["site"]["terrain"]["plane"]["extent_m"] = {-5000, -5000, 5000, 5000};
  large["site"]["terrain"]["plane"]["cell_m"] = 250;
  const CliResult l = run({"validate", scenario_file("large.json", large.dump()).string()});
  EXPECT_EQ(l.exit_code, 0) << l.err;
  EXPECT_EQ(l.err.find("warning:"), std::string::npos) << l.err;
}

// Issue 22: the printed summary of a run whose HFD the site boundary cuts starts with a warning
// and prints the HFD as a bound; summary.json says "lower". The example as shipped: neither.
TEST_F(Cli, AnHfdCutByTheSiteBoundaryIsPrintedAsALowerBound) {
  Json small = minimal_example();
  small["site"]["terrain"]["plane"]["extent_m"] = {-200, -200, 200, 200};
  small["site"]["terrain"]["plane"]["cell_m"] = 10;
  const CliResult r = run({"run", scenario_file("small.json", small.dump()).string(), "--out",
                           (dir_ / "small").string(), "--threads", "1"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("WARNING: HFD ≥ ", 0), 0u) << r.out;
  EXPECT_NE(r.out.find("reaches the site boundary in "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Hazardous fragment distance   ≥ "), std::string::npos) << r.out;
  const Json s = Json::parse(fragsim::api::testing::read_text(dir_ / "small/summary.json"));
  EXPECT_EQ(s["hfd_bound"], "lower");
  EXPECT_GT(s["site_boundary"]["left_site_hazardous"]["histories"].get<int>(), 0);

  const CliResult e = run({"run", FRAGSIM_SOURCE_DIR "/examples/minimal/scenario.json", "--out",
                           (dir_ / "example").string(), "--threads", "1"});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_EQ(e.out.find("WARNING"), std::string::npos) << e.out;
  EXPECT_EQ(e.out.find("≥"), std::string::npos) << e.out;
  EXPECT_NE(e.out.find("  site boundary               not reached"), std::string::npos) << e.out;
}

// --units us (docs/units.md): the printed summary in ft and per 600 ft², summary.json as SI as
// without it; a unit system other than si or us is a usage error (exit 2).
TEST_F(Cli, UnitsUsPrintsFeetAndWritesTheSameSiFiles) {
  const std::string minimal = FRAGSIM_SOURCE_DIR "/examples/minimal/scenario.json";
  const CliResult us = run({"run", minimal, "--out", (dir_ / "us").string(), "--threads", "1",
                            "--samples-scale", "0.25", "--units", "us"});
  ASSERT_EQ(us.exit_code, 0) << us.err;
  const CliResult si = run({"run", minimal, "--out", (dir_ / "si").string(), "--threads", "1",
                            "--samples-scale", "0.25"});
  ASSERT_EQ(si.exit_code, 0) << si.err;
  Json a = Json::parse(read_text(dir_ / "us/summary.json"));
  Json b = Json::parse(read_text(dir_ / "si/summary.json"));
  const double hfd_m = a["hazardous_fragment_distance_m"].get<double>();
  ASSERT_GT(hfd_m, 0.0);
  char ft[64];
  std::snprintf(ft, sizeof ft, "Hazardous fragment distance   %.1f ft  (±1 se band ",
                hfd_m / 0.3048);
  EXPECT_NE(us.out.find(ft), std::string::npos) << ft << " missing in\n" << us.out;
  EXPECT_NE(us.out.find("  threshold                   1 per 600 ft² (1 per 600.0 ft²), from "),
            std::string::npos)
      << us.out;
  EXPECT_EQ(us.out.find(" per m²"), std::string::npos) << us.out;
  EXPECT_NE(si.out.find(" per m²"), std::string::npos) << si.out;
  for (Json* j : {&a, &b}) (*j).erase("timing");
  EXPECT_EQ(a, b);  // the files do not depend on --units

  const CliResult bad = run({"run", minimal, "--out", (dir_ / "bad").string(), "--units", "ft"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.err.rfind("error: --units: expected si or us, got \"ft\"\n", 0), 0u) << bad.err;
  EXPECT_FALSE(fs::exists(dir_ / "bad"));
}

TEST_F(Cli, QuietRunPrintsNothing) {
  const CliResult r = run({"run", FRAGSIM_SOURCE_DIR "/examples/minimal/scenario.json", "--out",
                           (dir_ / "q").string(), "--quiet", "--samples-scale", "0.1"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "");
  EXPECT_TRUE(fs::exists(dir_ / "q" / "summary.json"));
}

TEST_F(Cli, DeterministicForThreadsAndChunkSize) {
  const std::string minimal = FRAGSIM_SOURCE_DIR "/examples/minimal/scenario.json";
  Json chunked = minimal_example();
  chunked["settings"]["chunk_histories"] = 37;
  const fs::path chunked_file = scenario_file("chunked.json", chunked.dump(2));
  const std::vector<std::pair<std::string, std::vector<std::string>>> runs = {
      {"t1", {"run", minimal, "--out", (dir_ / "t1").string(), "--threads", "1", "--quiet"}},
      {"t2", {"run", minimal, "--out", (dir_ / "t2").string(), "--threads", "2", "--quiet"}},
      {"c37",
       {"run", chunked_file.string(), "--out", (dir_ / "c37").string(), "--threads", "2",
        "--quiet"}},
  };
  for (const auto& [name, args] : runs) ASSERT_EQ(run(args).exit_code, 0) << name;

  const fs::path reference = dir_ / "t1" / "results.h5";
  const auto names = fragsim::formats::list_datasets(reference);
  EXPECT_NE(std::find(names.begin(), names.end(), "/ptn/density_per_m2"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "/fragments/end_position_m"), names.end());
  for (const char* other : {"t2", "c37"}) {
    const fs::path file = dir_ / other / "results.h5";
    ASSERT_EQ(fragsim::formats::list_datasets(file), names) << other;
    for (const auto& name : names)
      EXPECT_EQ(fragsim::formats::read_dataset_raw(reference, name),
                fragsim::formats::read_dataset_raw(file, name))
          << name << " differs between t1 and " << other;
  }
  // The run produced something to compare: fragments reached the ground near the origin.
  double max_density = 0;
  for (double d : fragsim::formats::read_dataset_double(reference, "/ptn/density_per_m2"))
    max_density = std::max(max_density, d);
  EXPECT_GT(max_density, 0.0);
  // summary.json agrees too, apart from timing.
  Json a = Json::parse(read_text(dir_ / "t1" / "summary.json"));
  Json b = Json::parse(read_text(dir_ / "c37" / "summary.json"));
  a.erase("timing");
  b.erase("timing");
  a["provenance"].erase("scenario_sha256");
  b["provenance"].erase("scenario_sha256");
  EXPECT_EQ(a, b);
}

// A polyhedron group (a rock: the hull of 9 points, sized by mass at 2700 kg/m^3) through the
// whole pipeline with bounce: no NaN anywhere in the fragments' records, no energy rise, and the
// same results.h5 datasets with 1 and 2 threads.
TEST_F(Cli, PolyhedronGroupRunsDeterministically) {
  Json j = minimal_example();
  Json& g = j["fragment_groups"][0];
  g["name"] = "rocks";
  g["samples"] = 300;
  g["shape"] = {{"type", "polyhedron"},
                {"density_kg_m3", 2700},
                {"vertices_m",
                 {{0.12, 0.01, -0.02},
                  {-0.1, 0.04, 0.0},
                  {0.02, 0.09, 0.03},
                  {0.0, -0.08, 0.05},
                  {0.03, -0.02, -0.06},
                  {-0.04, -0.05, -0.03},
                  {0.05, 0.05, 0.06},
                  {0, 0, 0},
                  {-0.06, 0.02, 0.05}}}};
  g["mass_kg"] = {{"dist", "lognormal"}, {"median", 1.0}, {"sigma_ln", 0.5}, {"max", 20}};
  g["speed_mps"] = {{"dist", "uniform"}, {"min", 20}, {"max", 60}};
  g["spin_radps"] = {{"dist", "uniform"}, {"min", 0}, {"max", 30}};
  g["cd"] = 1.0;
  j["settings"]["bounce"] = true;
  const fs::path file = scenario_file("rocks.json", j.dump(2));
  for (const char* t : {"1", "2"})
    ASSERT_EQ(run({"run", file.string(), "--out", (dir_ / t).string(), "--threads", t, "--quiet"})
                  .exit_code,
              0)
        << t;
  const fs::path reference = dir_ / "1" / "results.h5";
  const auto names = fragsim::formats::list_datasets(reference);
  ASSERT_EQ(fragsim::formats::list_datasets(dir_ / "2" / "results.h5"), names);
  for (const auto& name : names)
    EXPECT_EQ(fragsim::formats::read_dataset_raw(reference, name),
              fragsim::formats::read_dataset_raw(dir_ / "2" / "results.h5", name))
        << name;
  const auto ends = fragsim::formats::read_dataset_double(reference, "/fragments/end_position_m");
  ASSERT_EQ(ends.size(), 900u);
  for (const double v : ends) ASSERT_TRUE(std::isfinite(v));
  const Json s = Json::parse(read_text(dir_ / "1" / "summary.json"));
  EXPECT_EQ(s["stats"]["energy_rises"], 0);
  EXPECT_GT(s["stats"]["bounces"].get<long>(), 300);
}

TEST_F(Cli, InterruptCancelsWithoutLeavingOutput) {
  // The demo scaled up takes long enough (tens of seconds) to be interrupted mid-run.
  const fs::path out = dir_ / "cancelled";
  const pid_t pid = spawn({"run", FRAGSIM_SOURCE_DIR "/examples/demo/scenario.json", "--out",
                           out.string(), "--samples-scale", "5", "--threads", "2", "--quiet"});
  // The directory appears once validation passed and the run is about to start (the handler is
  // installed by then).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(out) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(fs::exists(out));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ::kill(pid, SIGINT);
  const CliResult r = wait(pid);
  EXPECT_EQ(r.exit_code, 130) << r.err;
  EXPECT_NE(r.err.find("cancelled"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out)) << "output left behind";
}

// settings.precision: a line per batch boundary on stderr (not a terminal here; at most one per
// progress interval, and the last), and the stop in the report.
TEST_F(Cli, PrecisionRunReportsEachBatchAndWhyItStopped) {
  Json j = minimal_example();
  j["settings"]["record_fragments"] = false;
  j["fragment_groups"][0]["samples"] = 200;
  j["settings"]["precision"] = {{"building_abs_error", 1e3}, {"min_batches", 3}};
  const fs::path scenario = scenario_file("precision.json", j.dump());
  const fs::path out = dir_ / "out";
  const CliResult r = run({"run", scenario.string(), "--out", out.string(), "--threads", "2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("batch 3: 2 of 2 targets met"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("600 (3 batches, stopped: targets_met)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Precision targets (all met)"), std::string::npos) << r.out;
  const Json summary = Json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(summary["stop_reason"], "targets_met");
  EXPECT_EQ(summary["samples"], 600);
}

}  // namespace
