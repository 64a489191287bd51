// `fragsim run --shard I/N` and `fragsim merge` as subprocesses (docs/cluster.md): shards run
// with any thread counts and merged in any order give the outputs of one `fragsim run` (every
// figure bit for bit); every bad piece is refused with exit 2 and a message naming the problem
// and the file, leaving no output behind; --progress-file; Ctrl-C during a shard.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "api/scenario_json.h"
#include "api/test_support.h"
#include "cli/cli_process.h"
#include "core/run/partial.h"
#include "formats/partial_file.h"
#include "formats/results_h5.h"

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using fragsim::cli::testing::CliResult;

const std::string kDemo = FRAGSIM_SOURCE_DIR "/examples/demo/scenario.json";
const std::string kMinimal = FRAGSIM_SOURCE_DIR "/examples/minimal/scenario.json";
const std::string kScale = "0.05";  // the demo's 80,000 samples scaled to 4,000

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

class ShardMerge : public fragsim::cli::testing::CliDirTest {
 protected:
  ShardMerge() : CliDirTest("fragsim_shard_test_") {}

  // One `fragsim run` of the scenario into dir/`name`.
  fs::path run_whole(const std::string& scenario, const std::string& scale,
                     const std::string& name) {
    const fs::path out = dir_ / name;
    const CliResult r = run({"run", scenario, "--out", out.string(), "--samples-scale", scale,
                             "--threads", "2", "--quiet"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return out;
  }

  // Shards 0..n-1 into dir/`tag`-i/partial.fsp, shard i with 1 + (i + n) % 3 threads.
  std::vector<fs::path> run_shards(const std::string& scenario, const std::string& scale,
                                   std::int64_t n, const std::string& tag) {
    std::vector<fs::path> parts;
    for (std::int64_t i = 0; i < n; ++i) {
      const fs::path out = dir_ / (tag + "-" + std::to_string(i));
      const CliResult r = run({"run", scenario, "--out", out.string(), "--samples-scale", scale,
                               "--shard", std::to_string(i) + "/" + std::to_string(n), "--threads",
                               std::to_string(1 + (i + n) % 3), "--quiet"});
      EXPECT_EQ(r.exit_code, 0) << "shard " << i << "/" << n << ": " << r.err;
      EXPECT_EQ(r.out, "");
      parts.push_back(out / "partial.fsp");
      EXPECT_TRUE(fs::is_regular_file(parts.back()));
    }
    return parts;
  }

  CliResult merge(const std::string& scenario, const std::vector<fs::path>& parts,
                  const fs::path& out, const std::string& scale = kScale) {
    std::vector<std::string> args = {"merge", scenario};
    for (const fs::path& p : parts) args.push_back(p.string());
    args.insert(args.end(), {"--out", out.string(), "--quiet"});
    if (!scale.empty()) args.insert(args.end(), {"--samples-scale", scale});
    return run(args);
  }

  // The demo's three shards at kScale, run once per test.
  const std::vector<fs::path>& three_shards() {
    if (three_.empty()) three_ = run_shards(kDemo, kScale, 3, "three");
    return three_;
  }

  // `fragsim merge` refused the pieces: exit 2, one error line with every part of `expected`,
  // and nothing in --out (it is not created; an existing one gains no file).
  void expect_merge_refused(const std::string& scenario, const std::vector<fs::path>& parts,
                            const std::vector<std::string>& expected,
                            const std::string& scale = kScale) {
    // Directories of their own: a merge that wrongly succeeded leaves no trace for the next.
    const std::string n = std::to_string(++refusals_);
    const fs::path out = dir_ / ("merged-refused-" + n);
    const fs::path existing = dir_ / ("existing-" + n);
    const CliResult r = merge(scenario, parts, out, scale);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    for (const std::string& e : expected)
      EXPECT_TRUE(contains(r.err, e)) << "\"" << e << "\" missing in " << r.err;
    EXPECT_FALSE(fs::exists(out)) << "merge created " << out;
    // Into an existing directory: it is left as it was.
    fs::create_directories(existing);
    write_text(existing / "keep.txt", "kept");
    const CliResult again = merge(scenario, parts, existing, scale);
    EXPECT_EQ(again.exit_code, 2) << again.err;
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(existing))
      names.push_back(e.path().filename().string());
    EXPECT_EQ(names, std::vector<std::string>{"keep.txt"});
  }

  std::vector<fs::path> three_;
  int refusals_ = 0;
};

// summary.json equal but for "timing" and "provenance" (every number bit for bit: the texts of
// the parsed documents are compared, and nlohmann/json prints the shortest text that reads back
// to the same double), and every dataset of results.h5 byte for byte.
void expect_same_outputs(const fs::path& reference, const fs::path& candidate) {
  ASSERT_TRUE(fs::exists(candidate / "summary.json")) << candidate;
  Json a = Json::parse(read_text(reference / "summary.json"));
  Json b = Json::parse(read_text(candidate / "summary.json"));
  EXPECT_EQ(a["provenance"]["scenario_sha256"], b["provenance"]["scenario_sha256"]);
  for (Json* j : {&a, &b}) {
    j->erase("timing");
    j->erase("provenance");
  }
  EXPECT_EQ(a.dump(), b.dump()) << "summary.json differs";
  for (auto it = a.begin(); it != a.end(); ++it)
    EXPECT_EQ(it.value().dump(), b[it.key()].dump()) << "summary.json: \"" << it.key() << "\"";
  EXPECT_GT(a["histories_done"].get<std::int64_t>(), 0);

  namespace api = fragsim::api;
  const fs::path ra = reference / "results.h5", rb = candidate / "results.h5";
  const auto names = fragsim::formats::list_datasets(ra);
  ASSERT_EQ(fragsim::formats::list_datasets(rb), names);
  EXPECT_NE(std::find(names.begin(), names.end(), "/ptn/density_per_m2"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "/fragments/end_position_m"), names.end());
  for (const auto& name : names)
    EXPECT_EQ(fragsim::formats::read_dataset_raw(ra, name),
              fragsim::formats::read_dataset_raw(rb, name))
        << name;
  for (const char* attr : {"samples", "histories_done", "seed"})
    EXPECT_EQ(fragsim::formats::read_attribute_int64(ra, "/", attr),
              fragsim::formats::read_attribute_int64(rb, "/", attr))
        << attr;
}

// ---- Shards merged = one run ----

TEST_F(ShardMerge, ShardsWithAnyThreadsMergedInAnyOrderGiveTheOutputsOfOneRun) {
  const fs::path reference = run_whole(kDemo, kScale, "one");
  {  // the demo records trajectories: compared too
    const auto names = fragsim::formats::list_datasets(reference / "results.h5");
    EXPECT_NE(std::find(names.begin(), names.end(), "/trajectories/t_s"), names.end());
  }
  std::mt19937 gen(2024);
  for (const std::int64_t n : {1, 2, 3, 5}) {
    SCOPED_TRACE("N = " + std::to_string(n));
    std::string tag = "n";  // (not "literal" + string: GCC 12's false -Wrestrict)
    tag += std::to_string(n);
    std::vector<fs::path> parts = run_shards(kDemo, kScale, n, tag);
    for (int order = 0; order < 2; ++order) {
      std::shuffle(parts.begin(), parts.end(), gen);
      std::string name = "merged-";
      name += std::to_string(n * 10 + order);
      const fs::path out = dir_ / name;
      const CliResult r = merge(kDemo, parts, out);
      ASSERT_EQ(r.exit_code, 0) << r.err;
      expect_same_outputs(reference, out);
      // Only the outputs of `run`: no temporaries, no partial.
      std::vector<std::string> names;
      for (const auto& e : fs::directory_iterator(out)) names.push_back(e.path().filename());
      std::sort(names.begin(), names.end());
      EXPECT_EQ(names, (std::vector<std::string>{"results.h5", "summary.json"}));
    }
  }
}

// More shards than a group's samples: some shards hold no history of it (of the minimal example
// at 2 samples, shards 0, 1 and 3 of 5 hold none at all).
TEST_F(ShardMerge, MoreShardsThanSamplesSomeEmptyStillMergeToOneRun) {
  const fs::path minimal_one = run_whole(kMinimal, "0.001", "minimal-one");
  std::vector<fs::path> parts = run_shards(kMinimal, "0.001", 5, "minimal");
  std::reverse(parts.begin(), parts.end());
  const fs::path out = dir_ / "minimal-merged";
  const CliResult r = merge(kMinimal, parts, out, "0.001");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_same_outputs(minimal_one, out);
  EXPECT_EQ(Json::parse(read_text(out / "summary.json"))["samples"], 2);

  // The demo at 20, 8 and 4 samples in 7 shards.
  const fs::path demo_one = run_whole(kDemo, "0.0004", "demo-one");
  std::vector<fs::path> demo_parts = run_shards(kDemo, "0.0004", 7, "demo");
  std::rotate(demo_parts.begin(), demo_parts.begin() + 3, demo_parts.end());
  const fs::path demo_out = dir_ / "demo-merged";
  const CliResult d = merge(kDemo, demo_parts, demo_out, "0.0004");
  ASSERT_EQ(d.exit_code, 0) << d.err;
  expect_same_outputs(demo_one, demo_out);
  EXPECT_EQ(Json::parse(read_text(demo_out / "summary.json"))["samples"], 32);
}

// ---- Pieces merge refuses ----

TEST_F(ShardMerge, AMissingShardIsRefused) {
  const auto& p = three_shards();
  expect_merge_refused(kDemo, {p[2], p[0]}, {"shard 1 of 3 missing"});
  expect_merge_refused(kDemo, {p[1]}, {"shards 0, 2 (2 of 3) missing"});
}

TEST_F(ShardMerge, AShardGivenTwiceIsRefusedNamingTheFile) {
  const auto& p = three_shards();
  // The same file twice, and a copy of it under another name.
  expect_merge_refused(kDemo, {p[0], p[1], p[1], p[2]},
                       {p[1].string() + ": ", "shard 1 is there twice"});
  const fs::path copy = dir_ / "copy.fsp";
  fs::copy_file(p[2], copy);
  expect_merge_refused(kDemo, {p[0], p[1], p[2], copy},
                       {copy.string() + ": ", "shard 2 is there twice"});
}

TEST_F(ShardMerge, ShardsOfDifferentSplitsAreRefused) {
  const auto& p = three_shards();
  const std::vector<fs::path> halves = run_shards(kDemo, kScale, 2, "halves");
  expect_merge_refused(kDemo, {p[0], halves[1], p[1], p[2]},
                       {halves[1].string() + ": ", "different splits (3 and 2 shards)"});
}

// A byte of the scenario file changed (a letter of the description: the same run otherwise).
TEST_F(ShardMerge, AShardOfAnotherScenarioFileIsRefused) {
  const auto& p = three_shards();
  std::string text = read_text(kDemo);
  const auto at = text.find("\"description\": \"");
  ASSERT_NE(at, std::string::npos);
  ASSERT_EQ(text[at + 16], 'f');
  text[at + 16] = 'F';
  const fs::path changed = dir_ / "changed.json";
  write_text(changed, text);
  ASSERT_EQ(run({"validate", changed.string()}).exit_code, 0);
  expect_merge_refused(changed.string(), {p[0], p[1], p[2]},
                       {p[0].string() + ": ", "a shard of another scenario file"});
}

TEST_F(ShardMerge, AShardOfAnotherSamplesScaleIsRefused) {
  const auto& p = three_shards();
  expect_merge_refused(kDemo, {p[0], p[1], p[2]}, {p[0].string() + ": ", "another --samples-scale"},
                       "0.1");
  expect_merge_refused(kDemo, {p[0], p[1], p[2]}, {p[0].string() + ": ", "another --samples-scale"},
                       "");  // none: 1
  // One shard of another scale among the others.
  const std::vector<fs::path> other = run_shards(kDemo, "0.04", 3, "scale04");
  expect_merge_refused(kDemo, {p[0], other[1], p[2]},
                       {other[1].string() + ": ", "another --samples-scale"});
}

TEST_F(ShardMerge, ATruncatedOrDamagedPartialIsRefusedNamingTheFile) {
  const auto& p = three_shards();
  const std::string bytes = read_text(p[1]);
  ASSERT_GT(bytes.size(), 1000u);
  const fs::path cut = dir_ / "cut.fsp";
  for (const std::size_t n :
       {std::size_t{0}, std::size_t{12}, std::size_t{40}, bytes.size() / 2, bytes.size() - 1}) {
    SCOPED_TRACE(n);
    write_text(cut, bytes.substr(0, n));
    expect_merge_refused(
        kDemo, {p[0], cut, p[2]},
        {cut.string() + ": ", n < 16 ? "not a partial file" : "checksum"});  // magic + CRC-32
  }
  std::string flipped = bytes;
  flipped[bytes.size() / 3] = static_cast<char>(flipped[bytes.size() / 3] ^ 0x10);
  write_text(cut, flipped);
  expect_merge_refused(kDemo, {p[0], cut, p[2]},
                       {cut.string() + ": ", "not an intact partial file"});
  // Not a partial at all: the scenario given as a part.
  expect_merge_refused(kDemo, {p[0], kDemo, p[2]}, {kDemo + ": ", "not a partial file"});
}

TEST_F(ShardMerge, AMissingFileOrADirectoryIsRefusedNamingIt) {
  const auto& p = three_shards();
  const fs::path missing = dir_ / "missing.fsp";
  expect_merge_refused(kDemo, {p[0], missing, p[2]}, {missing.string() + ": ", "cannot read"});
  expect_merge_refused(kDemo, {p[0], p[1].parent_path(), p[2]},
                       {p[1].parent_path().string() + ": ", "a directory, not a partial file"});
}

// A partial of a scenario whose site has another shape.
TEST_F(ShardMerge, APartialOfAnotherSiteIsRefused) {
  const auto& p = three_shards();
  expect_merge_refused(kMinimal, {p[0], p[1], p[2]},
                       {p[0].string() + ": ", "a partial of another site"});
}

// Partials forged with a valid checksum (decoded, altered, encoded again): values no shard can
// have are bad input, refused with exit 2 naming the file -- not an internal error (exit 1) and
// not a summary with wrapped counts (exit 0).
TEST_F(ShardMerge, ForgedPartialsWithAValidChecksumAreRefused) {
  namespace api = fragsim::api;
  namespace run = fragsim::run;
  const auto& p = three_shards();
  const auto doc = api::parse_scenario_document_text(read_text(kDemo));
  const std::size_t bins =
      run::tally_bins(doc.scenario, *api::validate_scenario(doc.scenario)).total;
  auto forge = [&](std::size_t k, const std::string& name, auto&& alter) {
    fragsim::formats::PartialIdentity id;
    run::PartialRun part = fragsim::formats::read_partial_file(p[k], bins, id);
    alter(part);
    const fs::path out = dir_ / name;
    fragsim::formats::write_partial_file(out, part, id);
    return out;
  };
  {  // histories_done near 2^63 in two shards: their sum overflows
    auto huge = [](run::PartialRun& q) { q.histories_done = (std::int64_t{1} << 62) + 7; };
    const fs::path a = forge(1, "huge-1.fsp", huge), b = forge(2, "huge-2.fsp", huge);
    expect_merge_refused(kDemo, {p[0], a, b}, {".fsp: "});
  }
  {  // a cancelled shard (`fragsim run --shard` writes nothing when cancelled): its figures
     // were never computed, so a merge would have written empty maps as a result
    const fs::path a = forge(1, "cancelled.fsp", [](run::PartialRun& q) {
      q.cancelled = true;
      q.stop_reason = run::StopReason::kCancelled;
    });
    expect_merge_refused(kDemo, {p[0], a, p[2]}, {a.string() + ": ", "cancelled shard"});
  }
  {  // a negative outcome count
    const fs::path a =
        forge(1, "negative.fsp", [](run::PartialRun& q) { q.outcome_histories[0] = -1000; });
    expect_merge_refused(kDemo, {p[0], a, p[2]}, {a.string() + ": "});
  }
  // Open strata whose sums are set: the first stratum shard 1 has (shard 0 has it too), one entry.
  auto set_sum = [](std::uint32_t& bin_out, std::uint64_t top) {
    return [&bin_out, top](run::PartialRun& q) {
      auto open = q.tally.open_strata();
      auto& st = open.begin()->second;
      if (bin_out == 0xffffffffu) bin_out = st.entries[0].bin;
      st.entries = {{bin_out, fragsim::tally::ExactSum::from_limbs({0, 0, 0, 0, top}), {}}};
      std::vector<fragsim::tally::ExactBins> var;
      for (std::size_t k = 0; k < q.tally.partitions(); ++k)
        var.push_back(q.tally.variance_sums(k));
      q.tally.restore(q.tally.mean_sums(), var, open);
    };
  };
  {  // a sum beyond the range of exact sums (2^158)
    std::uint32_t bin = 0xffffffffu;
    const fs::path a = forge(1, "out-of-range.fsp", set_sum(bin, std::uint64_t{1} << 62));
    expect_merge_refused(kDemo, {p[0], a, p[2]}, {a.string() + ": "});
  }
  {  // two pieces of a stratum with sums in range (1.5 * 2^157) whose total is not
    std::uint32_t bin = 0xffffffffu;
    const fs::path b = forge(1, "large-1.fsp", set_sum(bin, std::uint64_t{3} << 60));
    const fs::path a = forge(0, "large-0.fsp", set_sum(bin, std::uint64_t{3} << 60));
    expect_merge_refused(kDemo, {a, b, p[2]}, {".fsp: "});
  }
}

// ---- Command lines refused ----

TEST_F(ShardMerge, BadShardArgumentsAreUsageErrors) {
  const fs::path out = dir_ / "out";
  for (const std::string shard :
       {"3/3", "-1/2", "1/0", "x", "", "1", "1/", "/2", "1/2/3", "+1/2", "0/-1", "0x1/2",
        "0/1000001", "99999999999999999999/2", " 1/2", "1/ 2", "\t0/2"}) {
    SCOPED_TRACE("--shard \"" + shard + "\"");
    const CliResult r = run({"run", kDemo, "--out", out.string(), "--shard", shard});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("error: --shard: expected I/N", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, "\"" + shard + "\"")) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
  // The = form, and a missing value.
  EXPECT_EQ(run({"run", kDemo, "--out", out.string(), "--shard=2/2"}).exit_code, 2);
  const CliResult none = run({"run", kDemo, "--out", out.string(), "--shard"});
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_TRUE(contains(none.err, "--shard: needs a value")) << none.err;
  EXPECT_FALSE(fs::exists(out));
}

// A settings.precision run cannot be split (its batch-boundary decisions need every history of a
// batch), but runs whole as the one shard of 0/1, its precision report carried in the partial.
TEST_F(ShardMerge, APrecisionRunIsRefusedAsShardsButRunsWholeAsOne) {
  Json j = Json::parse(read_text(kMinimal));
  j["settings"]["record_fragments"] = false;
  j["settings"]["precision"] = {{"building_abs_error", 1e3}};
  const fs::path scenario = dir_ / "precision.json";
  write_text(scenario, j.dump());
  const fs::path out = dir_ / "out", progress = dir_ / "progress.json";
  for (const char* shard : {"0/2", "1/2"}) {
    SCOPED_TRACE(shard);
    const CliResult r = run({"run", scenario.string(), "--out", out.string(), "--shard", shard,
                             "--progress-file", progress.string()});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("error: settings.precision: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, "--shard")) << r.err;
    EXPECT_FALSE(fs::exists(out));
    ASSERT_TRUE(fs::exists(progress));
    EXPECT_EQ(Json::parse(read_text(progress))["state"], "failed");
    fs::remove(progress);
  }
  const fs::path whole = dir_ / "whole", part = dir_ / "part", merged = dir_ / "merged";
  const CliResult one = run({"run", scenario.string(), "--out", whole.string()});
  ASSERT_EQ(one.exit_code, 0) << one.err;
  const CliResult shard = run({"run", scenario.string(), "--out", part.string(), "--shard", "0/1"});
  ASSERT_EQ(shard.exit_code, 0) << shard.err;
  const CliResult m =
      run({"merge", scenario.string(), (part / "partial.fsp").string(), "--out", merged.string()});
  ASSERT_EQ(m.exit_code, 0) << m.err;
  Json a = Json::parse(read_text(whole / "summary.json"));
  Json b = Json::parse(read_text(merged / "summary.json"));
  ASSERT_TRUE(a.contains("precision")) << a.dump().substr(0, 400);
  for (Json* x : {&a, &b}) {
    x->erase("timing");
    x->erase("provenance");
  }
  EXPECT_EQ(a, b);
}

TEST_F(ShardMerge, MergeWithoutPartsOrOutIsAUsageError) {
  const fs::path out = dir_ / "out";
  const CliResult none = run({"merge", kDemo, "--out", out.string()});
  EXPECT_EQ(none.exit_code, 2) << none.err;
  EXPECT_TRUE(contains(none.err, "merge: no partial files")) << none.err;
  const CliResult no_out = run({"merge", kDemo, (dir_ / "a.fsp").string()});
  EXPECT_EQ(no_out.exit_code, 2) << no_out.err;
  EXPECT_TRUE(contains(no_out.err, "merge needs --out DIR")) << no_out.err;
  const CliResult nothing = run({"merge"});
  EXPECT_EQ(nothing.exit_code, 2) << nothing.err;
  EXPECT_TRUE(contains(nothing.err, "missing SCENARIO.json")) << nothing.err;
  const CliResult threads = run({"merge", kDemo, "a.fsp", "--out", out.string(), "--threads", "2"});
  EXPECT_EQ(threads.exit_code, 2) << threads.err;
  EXPECT_TRUE(contains(threads.err, "--threads: unknown option")) << threads.err;
  EXPECT_FALSE(fs::exists(out));
}

// ---- --progress-file ----

Json read_progress(const fs::path& p) {
  return Json::parse(read_text(p));
}

TEST_F(ShardMerge, ProgressFileSaysDoneWithEveryHistoryOfTheShard) {
  const fs::path progress = dir_ / "progress.json";
  const fs::path out = dir_ / "shard";
  const CliResult r = run({"run", kDemo, "--out", out.string(), "--samples-scale", kScale,
                           "--shard", "1/3", "--progress-file", progress.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json p = read_progress(progress);
  EXPECT_EQ(p["state"], "done");
  // Shard 1 of 3 of 2500, 1000 and 500 samples: [833, 1666), [333, 666), [166, 333).
  EXPECT_EQ(p["histories_total"], 833 + 333 + 167);
  EXPECT_EQ(p["histories_done"], p["histories_total"]);
  EXPECT_GE(p["elapsed_s"].get<double>(), 0.0);
  EXPECT_FALSE(fs::exists(dir_ / "progress.json.tmp"));

  // A whole run, and an empty shard (no history at all): done, done == total.
  const CliResult w = run({"run", kMinimal, "--out", (dir_ / "whole").string(), "--samples-scale",
                           "0.01", "--progress-file", progress.string(), "--quiet"});
  ASSERT_EQ(w.exit_code, 0) << w.err;
  EXPECT_EQ(read_progress(progress)["state"], "done");
  EXPECT_EQ(read_progress(progress)["histories_done"], 20);
  EXPECT_EQ(read_progress(progress)["histories_total"], 20);
  const CliResult e = run({"run", kMinimal, "--out", (dir_ / "empty").string(), "--samples-scale",
                           "0.001", "--shard", "0/5", "--progress-file", progress.string()});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_TRUE(contains(e.out, "Shard 0 of 5: 0 histories")) << e.out;
  EXPECT_EQ(read_progress(progress)["state"], "done");
  EXPECT_EQ(read_progress(progress)["histories_done"], 0);
  EXPECT_EQ(read_progress(progress)["histories_total"], 0);
}

// Bad input after the file was named: it says "failed" (written even if no progress came
// before). A command line refused before the run starts writes nothing.
TEST_F(ShardMerge, ProgressFileSaysFailedOnBadInput) {
  const fs::path progress = dir_ / "progress.json";
  const fs::path bad = dir_ / "bad.json";
  write_text(bad, "{\"schema\": \"fragsim.scenario/1\"");
  const CliResult r = run({"run", bad.string(), "--out", (dir_ / "out").string(), "--shard", "0/2",
                           "--progress-file", progress.string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  ASSERT_TRUE(fs::exists(progress));
  const Json p = read_progress(progress);
  EXPECT_EQ(p["state"], "failed");
  EXPECT_EQ(p["histories_done"], 0);
  const CliResult missing = run({"run", (dir_ / "nope.json").string(), "--out",
                                 (dir_ / "out").string(), "--progress-file", progress.string()});
  EXPECT_EQ(missing.exit_code, 2) << missing.err;
  EXPECT_EQ(read_progress(progress)["state"], "failed");
  fs::remove(progress);
  const CliResult usage = run({"run", kDemo, "--out", (dir_ / "out").string(), "--shard", "2/2",
                               "--progress-file", progress.string()});
  EXPECT_EQ(usage.exit_code, 2) << usage.err;
  EXPECT_FALSE(fs::exists(progress));
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// ---- Ctrl-C ----

TEST_F(ShardMerge, InterruptDuringAShardLeavesNoPartial) {
  const fs::path out = dir_ / "shard", progress = dir_ / "progress.json";
  // The demo scaled up: half of it takes seconds, long enough to be interrupted.
  const pid_t pid = spawn({"run", kDemo, "--out", out.string(), "--samples-scale", "5", "--shard",
                           "0/2", "--threads", "2", "--progress-file", progress.string()});
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  std::string state;
  while (std::chrono::steady_clock::now() < deadline) {
    if (fs::exists(progress)) {
      state = read_progress(progress)["state"];
      if (state == "running") break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (state != "running") {
    ::kill(pid, SIGKILL);
    wait(pid);
    FAIL() << "the shard did not report running progress in time (state \"" << state << "\")";
  }
  ::kill(pid, SIGINT);
  const CliResult r = wait(pid);
  EXPECT_EQ(r.exit_code, 130) << r.err;
  EXPECT_TRUE(contains(r.err, "cancelled: no output written")) << r.err;
  EXPECT_FALSE(fs::exists(out / "partial.fsp"));
  EXPECT_FALSE(fs::exists(out)) << "output directory left behind";
  const Json p = read_progress(progress);
  EXPECT_EQ(p["state"], "cancelled");
  EXPECT_LT(p["histories_done"].get<std::int64_t>(), p["histories_total"].get<std::int64_t>());
}

}  // namespace
