// server/backend: presets and templates (resolve_backend), and one backend job followed through
// its files (BackendJob) with stand-in shards that write what `fragsim run --shard` writes.
#include "server/backend.h"

#include <gtest/gtest.h>
#include <signal.h>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <thread>

#include "api/test_support.h"
#include "core/common/error.h"

namespace fragsim::server {
namespace {

namespace fs = std::filesystem;

std::string resolve_error(const BackendConfig& c) {
  try {
    resolve_backend(c);
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no error>";
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

TEST(BackendConfig, LocalIsTheDefault) {
  const ResolvedBackend r = resolve_backend(BackendConfig{});
  EXPECT_TRUE(r.local);
}

TEST(BackendConfig, MpiPresetStartsTheShardScriptUnderMpirun) {
  BackendConfig c;
  c.kind = "mpi";
  c.mpirun = {"mpirun", "--oversubscribe"};
  c.fragsim = "/opt/fragsim/bin/fragsim";
  const ResolvedBackend r = resolve_backend(c);
  EXPECT_FALSE(r.local);
  EXPECT_EQ(r.shards, 2);
  EXPECT_EQ(r.track, BackendTrack::kProcess);
  EXPECT_FALSE(r.submit_per_shard);
  EXPECT_EQ(r.submit, (std::vector<std::string>{"mpirun", "--oversubscribe", "-np", "{shards}",
                                                "{shard_script}"}));
  EXPECT_EQ(r.fragsim, "/opt/fragsim/bin/fragsim");
  EXPECT_TRUE(contains(r.run, "--shard"));
  EXPECT_TRUE(contains(r.run, "{shard}/{shards}"));
  EXPECT_TRUE(contains(r.run, "--progress-file"));
}

// A settings.precision job on the mpi preset: one shard, shard.sh started once, running
// fragsim-mpi on `shards` ranks under the preset's mpirun, its rank 0 writing the whole run's
// partial as shard 0/1 (docs/http-api.md, "fragsimd backends").
TEST(BackendConfig, MpiPresetDividesPrecisionJobsAmongFragsimMpiRanks) {
  BackendConfig c;
  c.kind = "mpi";
  c.shards = 3;
  c.mpirun = {"mpirun", "--oversubscribe"};
  c.fragsim = "/opt/fragsim/bin/fragsim";
  c.fragsim_mpi = "/opt/fragsim/bin/fragsim-mpi";
  const ResolvedBackend r = resolve_backend(c);
  EXPECT_EQ(r.precision_run,
            (std::vector<std::string>{"mpirun", "--oversubscribe", "-np", "3",
                                      "/opt/fragsim/bin/fragsim-mpi", "run", "{scenario}", "--out",
                                      "{shard_dir}", "--shard", "0/1", "--threads", "{threads}",
                                      "--progress-file", "{progress}", "--quiet"}));
  const ResolvedBackend p = precision_backend(r);
  EXPECT_EQ(p.shards, 1);
  EXPECT_EQ(p.run, r.precision_run);
  EXPECT_EQ(p.submit, (std::vector<std::string>{"{shard_script}", "0"}));
  EXPECT_FALSE(p.submit_per_shard);
  EXPECT_EQ(p.track, BackendTrack::kProcess);
  EXPECT_EQ(precision_backend(r).shards, 1);
  EXPECT_EQ(r.shards, 3) << "other jobs keep their shards";

  // Not divided: one process (`run` as shard 0/1 under `mpirun -np 1`), and the note says why.
  for (const auto& [change, why] :
       std::vector<std::pair<std::function<void(BackendConfig&)>, std::string>>{
           {[](BackendConfig& x) { x.divide_precision = false; }, "divide_precision is false"},
           {[](BackendConfig& x) {
              x.run = {"{fragsim}", "run", "{scenario}"};
            },
            "backend.run or backend.submit is set"}}) {
    BackendConfig d = c;
    change(d);
    const ResolvedBackend u = resolve_backend(d);
    EXPECT_TRUE(u.precision_run.empty());
    EXPECT_NE(u.precision_note.find(why), std::string::npos) << u.precision_note;
    const ResolvedBackend q = precision_backend(u);
    EXPECT_EQ(q.shards, 1);
    EXPECT_EQ(q.run, u.run);
    EXPECT_EQ(q.submit, u.submit);
  }
  c.kind = "slurm";
  EXPECT_TRUE(resolve_backend(c).precision_run.empty()) << "only the mpi preset divides";
}

// fragsim-mpi is looked for beside fragsim and fragsimd, in their build tree, then on PATH; none:
// "" (the mpi preset then runs precision jobs as one process).
TEST(BackendConfig, FragsimMpiIsFoundBesideFragsimOrNotAtAll) {
  const fs::path dir = api::testing::fresh_test_dir("fragsim_backend_find_mpi_");
  const char* old_path = std::getenv("PATH");
  const std::string saved = old_path ? old_path : "";
  ::setenv("PATH", (dir / "empty").c_str(), 1);
  const fs::path fragsim = dir / "bin" / "fragsim", self = dir / "sbin" / "fragsimd";
  EXPECT_EQ(find_fragsim_mpi(fragsim, self), "");
  EXPECT_EQ(find_fragsim_mpi("fragsim", self), "");
  fs::create_directories(dir / "mpi");
  std::ofstream(dir / "mpi" / "fragsim-mpi") << "#!/bin/sh\n";
  fs::permissions(dir / "mpi" / "fragsim-mpi", fs::perms::owner_all);
  EXPECT_EQ(find_fragsim_mpi(fragsim, self), (dir / "mpi" / "fragsim-mpi").string())
      << "the build tree: build/cli/fragsim -> build/mpi/fragsim-mpi";
  fs::create_directories(dir / "bin");
  std::ofstream(dir / "bin" / "fragsim-mpi") << "#!/bin/sh\n";
  fs::permissions(dir / "bin" / "fragsim-mpi", fs::perms::owner_all);
  EXPECT_EQ(find_fragsim_mpi(fragsim, self), (dir / "bin" / "fragsim-mpi").string());
  ::setenv("PATH", saved.c_str(), 1);
  fs::remove_all(dir);
}

TEST(BackendConfig, SlurmPresetIsAnArrayFollowedThroughTheQueue) {
  BackendConfig c;
  c.kind = "slurm";
  c.shards = 8;
  c.threads = 4;
  c.sbatch = {"sbatch", "--partition=hazard", "--time=2:00:00"};
  const ResolvedBackend r = resolve_backend(c);
  EXPECT_EQ(r.shards, 8);
  EXPECT_EQ(r.track, BackendTrack::kQueue);
  EXPECT_EQ(r.submit[0], "sbatch");
  EXPECT_TRUE(contains(r.submit, "--partition=hazard"));
  EXPECT_TRUE(contains(r.submit, "--parsable"));
  EXPECT_TRUE(contains(r.submit, "--array=0-{last_shard}"));
  EXPECT_TRUE(contains(r.submit, "--cpus-per-task=4"));
  EXPECT_EQ(r.submit.back(), "{shard_script}");
  EXPECT_EQ(r.status[0], "squeue");
  EXPECT_EQ(r.cancel, (std::vector<std::string>{"scancel", "{ids}"}));
}

TEST(BackendConfig, CommandBackendsAreChecked) {
  BackendConfig c;
  c.kind = "command";
  EXPECT_EQ(resolve_error(c), "backend.shards: is required for a command backend");
  c.shards = 2;
  EXPECT_NE(resolve_error(c).find("backend.submit: is required"), std::string::npos);
  c.submit = {"/bin/sh", "submit.sh", "{shard_scrip}"};
  EXPECT_NE(resolve_error(c).find("backend.submit[2]: unknown placeholder {shard_scrip}"),
            std::string::npos)
      << resolve_error(c);
  c.submit = {"/bin/sh", "submit.sh", "{shard_script}", "${HOME}", "%{x}"};
  EXPECT_EQ(resolve_error(c), "<no error>") << "other braces are plain text";
  c.track = "queue";
  EXPECT_NE(resolve_error(c).find("backend.status: is required"), std::string::npos);
  c.status = {"qstat", "{ids}"};
  EXPECT_NE(resolve_error(c).find("backend.cancel: is required"), std::string::npos);
  c.cancel = {"qdel", "{ids}"};
  EXPECT_EQ(resolve_error(c), "<no error>");
  c.track = "sometimes";
  EXPECT_NE(resolve_error(c).find("backend.track: must be process or queue"), std::string::npos);
  c.track = "";
  c.submit = {"bsub", "{shard_dir}"};
  EXPECT_NE(resolve_error(c).find("need {shard}"), std::string::npos);
  c.submit = {"bsub", "-J", "shard{shard}", "{shard_script}", "{shard}"};
  EXPECT_TRUE(resolve_backend(c).submit_per_shard);
  c.kind = "kubernetes";
  EXPECT_NE(resolve_error(c).find("backend.kind: must be local, mpi, slurm or command"),
            std::string::npos);
}

class BackendJobFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = api::testing::fresh_test_dir("fragsim_backend_test_");
    // A stand-in shard: writes the progress and partial files as `fragsim run --shard` does
    // (exiting with the status in $STANDIN_EXIT_<shard>, after $STANDIN_SLEEP seconds).
    standin_ = dir_ / "standin.sh";
    std::ofstream(standin_) << "#!/bin/sh\n"
                               "# standin.sh SHARD SHARD_DIR PROGRESS\n"
                               "sleep \"${STANDIN_SLEEP:-0}\"\n"
                               "mkdir -p \"$2\" && echo partial >\"$2/partial.fsp\"\n"
                               "printf '{\"histories_done\":10,\"histories_total\":10,"
                               "\"elapsed_s\":0.5,\"state\":\"done\"}' >\"$3\"\n"
                               "eval \"rc=\\${STANDIN_EXIT_$1:-0}\"\n"
                               "[ \"$rc\" = 0 ] || echo \"standin $1 failing\" >&2\n"
                               "exit \"$rc\"\n";
    fs::permissions(standin_, fs::perms::owner_all);
    std::ofstream(dir_ / "submit.sh") << "#!/bin/sh\n"
                                         "n=$2; i=0\n"
                                         "while [ $i -lt $n ]; do \"$1\" $i & i=$((i + 1)); done\n"
                                         "wait\n";
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  ResolvedBackend backend(int shards) const {
    BackendConfig c;
    c.kind = "command";
    c.shards = shards;
    c.submit = {"/bin/sh", (dir_ / "submit.sh").string(), "{shard_script}", "{shards}"};
    c.run = {standin_.string(), "{shard}", "{shard_dir}", "{progress}"};
    return resolve_backend(c);
  }
  BackendJob::Poll poll_until_ended(BackendJob& job) const {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    BackendJob::Poll p;
    while (std::chrono::steady_clock::now() < deadline) {
      p = job.poll();
      if (p.state != BackendJob::Poll::State::kRunning) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return p;
  }

  fs::path dir_;
  fs::path standin_;
};

TEST_F(BackendJobFiles, EveryShardEndedWithItsPartialIsDone) {
  ResolvedBackend b = backend(3);
  b.env = {{"STANDIN_SLEEP", "0.2"}};
  BackendJob job = BackendJob::submit(b, "j_0000000000000001", 1, dir_ / "w", "{}");
  EXPECT_EQ(job.poll().state, BackendJob::Poll::State::kRunning);
  const auto p = poll_until_ended(job);
  ASSERT_EQ(p.state, BackendJob::Poll::State::kDone) << p.error;
  ASSERT_EQ(p.shards.size(), 3u);
  for (const auto& s : p.shards) {
    EXPECT_EQ(s.histories_done, 10);
    EXPECT_EQ(s.state, "done");
    EXPECT_EQ(s.exit_status, 0);
  }
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(fs::exists(job.partial_file(k)));
  EXPECT_EQ(job.scenario_file(), fs::absolute(dir_ / "w" / "scenario.json"));
  // A later daemon finds it again from the manifest alone.
  auto again = BackendJob::attach(dir_ / "w");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->shards(), 3);
  EXPECT_EQ(again->describe(), job.describe());
  EXPECT_EQ(again->poll().state, BackendJob::Poll::State::kDone);
}

TEST_F(BackendJobFiles, ANonZeroExitFailsNamingTheShardAndItsLog) {
  ResolvedBackend b = backend(2);
  b.env = {{"STANDIN_EXIT_1", "4"}};
  BackendJob job = BackendJob::submit(b, "j_0000000000000002", 1, dir_ / "w", "{}");
  const auto p = poll_until_ended(job);
  ASSERT_EQ(p.state, BackendJob::Poll::State::kFailed);
  EXPECT_NE(p.error.find("shard 1 of 2 failed (exit status 4)"), std::string::npos) << p.error;
  EXPECT_NE(
      p.error.find((fs::absolute(dir_ / "w") / "shard-1.log").string() + ": standin 1 failing"),
      std::string::npos)
      << p.error;
}

TEST_F(BackendJobFiles, ASubmitCommandThatCannotStartFailsTheSubmission) {
  ResolvedBackend b = backend(2);
  b.submit = {"no-such-launcher-here", "{shard_script}"};
  try {
    BackendJob::submit(b, "j_0000000000000003", 1, dir_ / "w", "{}");
    FAIL() << "submitted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-launcher-here"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(BackendJob::attach(dir_ / "w")) << "never marked submitted";
}

TEST_F(BackendJobFiles, AQueueSubmissionRecordsTheIdsItPrinted) {
  BackendConfig c;
  c.kind = "command";
  c.shards = 2;
  c.track = "queue";
  // "Queue": echoes an id and starts the shards itself.
  std::ofstream(dir_ / "qsub.sh") << "#!/bin/sh\n"
                                     "\"$1\" 0 & \"$1\" 1 &\n"
                                     "echo '4242;cluster'\n";
  c.submit = {"/bin/sh", (dir_ / "qsub.sh").string(), "{shard_script}"};
  // The queue holds the job until both shards have recorded their end: a queue that forgot it
  // while the shards still ran (as this stand-in once did) fails the job, and rightly so.
  const std::string w = (dir_ / "w").string();
  c.status = {"/bin/sh", "-c",
              "echo {ids} >>" + (dir_ / "status.calls").string() + "; [ -e " + w +
                  "/shard-0.exit ] && [ -e " + w + "/shard-1.exit ] || echo {ids}"};
  c.cancel = {"/bin/sh", "-c", "echo \"$0\" >" + (dir_ / "cancelled").string(), "{ids}"};
  c.run = {standin_.string(), "{shard}", "{shard_dir}", "{progress}"};
  c.status_interval_s = 0.05;
  BackendJob job =
      BackendJob::submit(resolve_backend(c), "j_0000000000000004", 1, dir_ / "w", "{}");
  EXPECT_EQ(job.describe(), "queue id 4242");
  EXPECT_EQ(poll_until_ended(job).state, BackendJob::Poll::State::kDone);
  job.cancel(false);
  std::ifstream in(dir_ / "cancelled");
  std::string id;
  in >> id;
  EXPECT_EQ(id, "4242");
}

}  // namespace
}  // namespace fragsim::server
