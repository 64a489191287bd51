// fragsim-mpi under a real mpirun (Open MPI): any number of ranks writes the figures of one
// `fragsim run`, bit for bit; bad input is one clear message and exit 2 (mpi/mpi_run.h).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/sanitizer_build.h"

namespace fs = std::filesystem;

namespace {

struct Result {
  int exit_code = -1;
  std::string err;
};

std::string read_text(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// Starts argv (argv[0] a path) with stdout/stderr to files in `dir`; Open MPI is allowed to run
// as root (CI containers) and to place more ranks than cores (2-core machines).
pid_t start(const fs::path& dir, std::vector<std::string> args) {
  const std::string err = (dir / "stderr.txt").string(), out = (dir / "stdout.txt").string();
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
    ::setenv("OMPI_MCA_rmaps_base_oversubscribe", "1", 1);
    // Under ASan (deploy/sanitize.sh): Open MPI's plugins, dlclose()d by MPI_Finalize, leave
    // allocations LeakSanitizer can only attribute to "<unknown module>", so no suppression
    // matches them. Leaks are not checked in these MPI processes; their code but mpi_run.cpp is
    // the CLI's, leak-checked under ASan by test_cli.
    if (const char* asan = std::getenv("ASAN_OPTIONS"))
      ::setenv("ASAN_OPTIONS", (std::string(asan) + ":detect_leaks=0").c_str(), 1);
    const int fo = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int fe = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fo, STDOUT_FILENO);
    ::dup2(fe, STDERR_FILENO);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

Result finish(const fs::path& dir, pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  Result r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.err = read_text(dir / "stderr.txt");
  return r;
}

Result run(const fs::path& dir, std::vector<std::string> args) {
  return finish(dir, start(dir, std::move(args)));
}

nlohmann::json figures(const fs::path& summary) {
  nlohmann::json j = nlohmann::json::parse(read_text(summary));
  j.erase("timing");
  j.erase("provenance");
  return j;
}

class MpiRun : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("fragsim_mpi_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

 public:
  std::vector<std::string> mpirun(int np) const {
    return {MPIEXEC, "-np", std::to_string(np), FRAGSIM_MPI};
  }

 protected:
  fs::path dir_;
  const std::string scenario_ = std::string(FRAGSIM_SOURCE_DIR) + "/examples/demo/scenario.json";
};

TEST_F(MpiRun, AnyNumberOfRanksWritesTheFiguresOfOneProcess) {
  const Result one = run(dir_, {FRAGSIM_CLI, "run", scenario_, "--out", (dir_ / "one").string(),
                                "--samples-scale", "0.1", "--threads", "1", "--quiet"});
  ASSERT_EQ(one.exit_code, 0) << one.err;
  const nlohmann::json expected = figures(dir_ / "one" / "summary.json");
  ASSERT_GT(expected["hazardous_fragment_distance_m"].get<double>(), 0.0);
  for (const int np : {1, 2, 3}) {
    SCOPED_TRACE(np);
    const fs::path out = dir_ / ("np" + std::to_string(np));
    auto args = mpirun(np);
    for (const char* a : {"run", scenario_.c_str(), "--out", out.c_str(), "--samples-scale", "0.1",
                          "--threads", "1", "--quiet", "--progress-file"})
      args.emplace_back(a);
    args.push_back((dir_ / "progress.json").string());
    const Result r = run(dir_, args);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(figures(out / "summary.json"), expected);
    // The whole run's progress, in the one file rank 0 writes.
    const auto progress = nlohmann::json::parse(read_text(dir_ / "progress.json"));
    EXPECT_EQ(progress["state"], "done");
    EXPECT_EQ(progress["histories_done"], expected["histories_done"]);
    EXPECT_EQ(progress["histories_total"], expected["histories_done"]);
    EXPECT_FALSE(fs::exists(dir_ / "progress.json.0"));
    EXPECT_FALSE(fs::exists(dir_ / "progress.json.1"));
  }
}

// While the ranks run, --progress-file counts every rank's histories against the whole run's;
// SIGINT to mpirun (forwarded to the ranks) stops them all: no output, --out removed again.
TEST_F(MpiRun, ProgressIsTheWholeRunsAndAnInterruptLeavesNoOutput) {
  const fs::path out = dir_ / "out", progress_file = dir_ / "progress.json";
  auto args = mpirun(2);
  for (const char* a : {"run", scenario_.c_str(), "--out", out.c_str(), "--samples-scale", "40",
                        "--threads", "1", "--quiet", "--progress-file", progress_file.c_str()})
    args.emplace_back(a);
  const pid_t pid = start(dir_, args);
  nlohmann::json seen;
  for (int i = 0; i < 1200; ++i) {  // up to 120 s (ASan, a loaded machine)
    ::usleep(100000);
    const std::string text = read_text(progress_file);
    if (text.empty()) continue;
    seen = nlohmann::json::parse(text);
    if (seen["histories_done"].get<std::int64_t>() > 0) break;
  }
  ASSERT_EQ(seen.value("state", ""), "running") << seen.dump();
  EXPECT_TRUE(fs::is_directory(out)) << "--out is made before the run";
  // The demo's groups hold 80,000 samples (examples/demo/scenario.json), times 40.
  EXPECT_EQ(seen["histories_total"], 3200000) << seen.dump();
  ::kill(pid, SIGINT);
  const Result r = finish(dir_, pid);
  EXPECT_NE(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("cancelled: no output written"), std::string::npos) << r.err;
  const auto last = nlohmann::json::parse(read_text(progress_file));
  EXPECT_EQ(last["state"], "cancelled") << last.dump();
  EXPECT_LT(last["histories_done"].get<std::int64_t>(), 3200000);
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(MpiRun, OutThatCannotBeMadeFailsBeforeTheRun) {
  const fs::path file = dir_ / "a-file";
  std::ofstream(file) << "kept";
  auto args = mpirun(2);
  const std::string out = (file / "out").string();
  for (const char* a : {"run", scenario_.c_str(), "--out", out.c_str(), "--quiet"})
    args.emplace_back(a);
  const Result r = run(dir_, args);
  EXPECT_EQ(r.exit_code, 2);
  const auto first = r.err.find("error: --out: cannot create directory");
  ASSERT_NE(first, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("error: --out", first + 1), std::string::npos) << "said twice:\n" << r.err;
  EXPECT_EQ(read_text(file), "kept");
}

TEST_F(MpiRun, BadInputIsOneMessageAndExitTwo) {
  auto missing = mpirun(2);
  for (const char* a : {"run", "/nonexistent/scenario.json", "--out", "/tmp/unused"})
    missing.emplace_back(a);
  const Result r = run(dir_, missing);
  EXPECT_EQ(r.exit_code, 2);
  const std::string msg = "cannot read /nonexistent/scenario.json";
  const auto first = r.err.find(msg);
  ASSERT_NE(first, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(msg, first + 1), std::string::npos) << "said more than once:\n" << r.err;

  auto shard = mpirun(2);
  for (const char* a : {"run", scenario_.c_str(), "--out", "/tmp/unused", "--shard", "0/2"})
    shard.emplace_back(a);
  const Result s = run(dir_, shard);
  EXPECT_EQ(s.exit_code, 2);
  EXPECT_NE(s.err.find("--shard"), std::string::npos) << s.err;
  EXPECT_FALSE(fs::exists("/tmp/unused"));
}

// A settings.precision run divided among ranks (docs/precision.md, "Divided runs"): the ranks
// exchange every batch, so -np 2 and 3 stop at the batch of `fragsim run`, for the same reason,
// with the same figures and precision report to the bit (its ETA aside: a wall-clock rate).
nlohmann::json precision_figures(const fs::path& summary) {
  nlohmann::json j = figures(summary);
  if (j["precision"].is_object()) j["precision"].erase("eta_s");
  return j;
}

fs::path precision_scenario(const fs::path& dir, const std::string& demo, bool importance,
                            bool targets) {
  nlohmann::json sc = nlohmann::json::parse(read_text(demo));
  nlohmann::json p = {{"min_batches", 2}, {"max_batches", 3}};
  if (targets) {  // met after 18 batches (8 with importance) at --samples-scale 0.05
    p["hfd_half_band_m"] = 8;
    p["max_batches"] = 30;
  }
  if (importance) p["direction_importance"] = {{"elevation_cells", 6}, {"azimuth_cells", 24}};
  sc["settings"]["precision"] = p;
  const fs::path file =
      dir / (std::string(importance ? "is" : "plain") + (targets ? "_targets" : "_max") + ".json");
  std::ofstream(file) << sc.dump();
  return file;
}

void expect_divided_equals_one_process(const MpiRun& t, const fs::path& dir,
                                       const fs::path& scenario, const std::string& reason) {
  const std::vector<std::string> common = {"--samples-scale", "0.05", "--threads", "1", "--quiet"};
  auto one_args = std::vector<std::string>{FRAGSIM_CLI, "run", scenario.string(), "--out",
                                           (dir / "one").string()};
  one_args.insert(one_args.end(), common.begin(), common.end());
  const Result one = run(dir, one_args);
  ASSERT_EQ(one.exit_code, 0) << one.err;
  const nlohmann::json expected = precision_figures(dir / "one" / "summary.json");
  ASSERT_EQ(expected["stop_reason"], reason);
  // Under a sanitizer (about 3 minutes a test with both) 3 ranks only: the uneven split.
  const std::vector<int> ranks =
      fragsim::testing::kSanitized ? std::vector<int>{3} : std::vector<int>{2, 3};
  for (const int np : ranks) {
    SCOPED_TRACE(np);
    const fs::path out = dir / ("np" + std::to_string(np));
    auto args = t.mpirun(np);
    for (const std::string& a :
         {std::string("run"), scenario.string(), std::string("--out"), out.string()})
      args.push_back(a);
    args.insert(args.end(), common.begin(), common.end());
    const Result r = run(dir, args);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json got = precision_figures(out / "summary.json");
    EXPECT_EQ(got["batches"], expected["batches"]);
    EXPECT_EQ(got["stop_reason"], expected["stop_reason"]);
    EXPECT_EQ(got, expected);
  }
  fs::remove_all(dir / "one");
  fs::remove_all(dir / "np2");
  fs::remove_all(dir / "np3");
}

TEST_F(MpiRun, APrecisionRunDividedAmongRanksStopsAndEndsAsOneProcess) {
  expect_divided_equals_one_process(*this, dir_, precision_scenario(dir_, scenario_, false, true),
                                    "targets_met");
  expect_divided_equals_one_process(*this, dir_, precision_scenario(dir_, scenario_, false, false),
                                    "max_batches");
}

TEST_F(MpiRun, ImportanceSamplingDividedAmongRanksLearnsAsOneProcess) {
  expect_divided_equals_one_process(*this, dir_, precision_scenario(dir_, scenario_, true, true),
                                    "targets_met");
  expect_divided_equals_one_process(*this, dir_, precision_scenario(dir_, scenario_, true, false),
                                    "max_batches");
}

// --shard 0/1 (what fragsimd's mpi backend runs for a precision job): the ranks divide the run
// as without it, and rank 0 writes the whole run's partial.fsp, committed (temporary and
// rename), instead of the outputs; `fragsim merge` of that one file gives `fragsim run`'s
// figures and stop batch to the bit. Other --shard values stay refused.
TEST_F(MpiRun, ShardZeroOfOneWritesTheWholeRunsPartial) {
  const fs::path scenario = precision_scenario(dir_, scenario_, false, false);
  const std::vector<std::string> common = {"--samples-scale", "0.05", "--threads", "1", "--quiet"};
  auto one_args = std::vector<std::string>{FRAGSIM_CLI, "run", scenario.string(), "--out",
                                           (dir_ / "one").string()};
  one_args.insert(one_args.end(), common.begin(), common.end());
  const Result one = run(dir_, one_args);
  ASSERT_EQ(one.exit_code, 0) << one.err;

  const fs::path out = dir_ / "part", progress_file = dir_ / "progress.json";
  auto args = mpirun(2);
  for (const std::string& a : {std::string("run"), scenario.string(), std::string("--out"),
                               out.string(), std::string("--shard"), std::string("0/1"),
                               std::string("--progress-file"), progress_file.string()})
    args.push_back(a);
  args.insert(args.end(), common.begin(), common.end());
  const Result r = run(dir_, args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(out)) files.push_back(e.path().filename().string());
  EXPECT_EQ(files, std::vector<std::string>{"partial.fsp"}) << "no outputs, no temporaries";
  const auto progress = nlohmann::json::parse(read_text(progress_file));
  EXPECT_EQ(progress["state"], "done");

  const fs::path merged = dir_ / "merged";
  const Result m =
      run(dir_, {FRAGSIM_CLI, "merge", scenario.string(), (out / "partial.fsp").string(), "--out",
                 merged.string(), "--samples-scale", "0.05", "--quiet"});
  ASSERT_EQ(m.exit_code, 0) << m.err;
  const nlohmann::json expected = precision_figures(dir_ / "one" / "summary.json");
  const nlohmann::json got = precision_figures(merged / "summary.json");
  EXPECT_EQ(got["batches"], expected["batches"]);
  EXPECT_EQ(got["stop_reason"], expected["stop_reason"]);
  EXPECT_EQ(got, expected);
  EXPECT_EQ(progress["histories_done"], expected["histories_done"]);

  auto refused = mpirun(2);
  const fs::path no = dir_ / "no";
  for (const char* a : {"run", scenario.c_str(), "--out", no.c_str(), "--shard", "1/2"})
    refused.emplace_back(a);
  const Result s = run(dir_, refused);
  EXPECT_EQ(s.exit_code, 2);
  EXPECT_NE(s.err.find("only --shard 0/1"), std::string::npos) << s.err;
  EXPECT_FALSE(fs::exists(no));
}

// SIGINT during a divided precision run stops every rank (at one batch boundary): no output.
TEST_F(MpiRun, AnInterruptStopsADividedPrecisionRun) {
  nlohmann::json sc = nlohmann::json::parse(read_text(scenario_));
  sc["settings"]["precision"] = {{"max_batches", 1000}};
  sc["settings"]["record_fragments"] = false;  // 1000 batches of records exceed the limit
  const fs::path file = dir_ / "precision.json", out = dir_ / "out";
  const fs::path progress_file = dir_ / "progress.json";
  std::ofstream(file) << sc.dump();
  auto args = mpirun(2);
  for (const char* a : {"run", file.c_str(), "--out", out.c_str(), "--samples-scale", "0.05",
                        "--threads", "1", "--quiet", "--progress-file", progress_file.c_str()})
    args.emplace_back(a);
  const pid_t pid = start(dir_, args);
  nlohmann::json seen;
  for (int i = 0; i < 1200; ++i) {  // up to 120 s: past the first boundaries
    ::usleep(100000);
    const std::string text = read_text(progress_file);
    if (text.empty()) continue;
    seen = nlohmann::json::parse(text);
    if (seen["histories_done"].get<std::int64_t>() > 3 * 4000) break;  // batch 3 begun
  }
  ASSERT_TRUE(seen.is_object()) << "no progress file";
  ASSERT_EQ(seen.value("state", ""), "running") << seen.dump();
  // Every batch the run may take: 1000 of 4,000 histories.
  EXPECT_EQ(seen["histories_total"], 4000000) << seen.dump();
  ::kill(pid, SIGINT);
  const Result r = finish(dir_, pid);
  EXPECT_NE(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("cancelled: no output written"), std::string::npos) << r.err;
  EXPECT_EQ(nlohmann::json::parse(read_text(progress_file))["state"], "cancelled");
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
