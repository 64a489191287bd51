// fragsimd with an external backend (server/backend.h), end to end: the daemon as a process, jobs
// run as shards by real `fragsim run --shard` processes started by a plain shell script (the
// "command" backend, always), by mpirun (the "mpi" preset, when Open MPI runs here) and by a
// stand-in for sbatch/squeue/scancel (the "slurm" preset's queue tracking, always). Results must
// be those of `fragsim run` bit for bit; the daemon must survive kill -9 without losing or
// rerunning the job; failed shards and cancellation must end the job as the contract says.
#include <signal.h>
#include <sys/stat.h>

#include <cstdlib>
#include <optional>

#include "tests/server/daemon_support.h"

namespace fragsim::server::testing {
namespace {

void write_script(const fs::path& path, const std::string& text) {
  write_text(path, text);
  fs::permissions(path, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                            fs::perms::others_read | fs::perms::others_exec);
}

// Starts shard.sh for every shard in the background and waits for them: the submit command of a
// "command" backend, the simplest engine there is.
fs::path submit_script(const fs::path& dir) {
  const fs::path p = dir / "submit.sh";
  write_script(p,
               "#!/bin/sh\n"
               "# submit.sh SHARD_SCRIPT N: every shard in the background\n"
               "n=$2; i=0\n"
               "while [ $i -lt $n ]; do \"$1\" $i & i=$((i + 1)); done\n"
               "wait\n");
  return p;
}

Json command_backend(const fs::path& dir, int shards) {
  return {{"kind", "command"},
          {"shards", shards},
          {"threads", 1},
          {"fragsim", FRAGSIM_CLI},
          {"submit", {"/bin/sh", submit_script(dir).string(), "{shard_script}", "{shards}"}},
          {"poll_interval_s", 0.1}};
}

// A daemon whose config file holds `backend`.
std::unique_ptr<Daemon> backend_daemon(const fs::path& dir, const Json& backend) {
  write_text(dir / "config.json", Json{{"backend", backend}}.dump(2));
  return std::make_unique<Daemon>(
      dir, std::vector<std::string>{"--config", (dir / "config.json").string()});
}

Json small_demo() {
  return scaled_samples(demo_scenario(), 0.5);
}

bool wait_for(const std::function<bool()>& condition, int seconds = 120) {
  const auto deadline = Clock::now() + std::chrono::seconds(seconds);
  while (Clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

// Waits until the job runs and its shards have reported progress; returns that status.
Json wait_progress(httplib::Client& c, const std::string& id) {
  Json s;
  wait_for([&] {
    s = job_status(c, id);
    return s.value("state", "") != "running"
               ? s.value("state", "") != "queued"
               : s.value("histories_done", 0) > 0 && !s["histories_per_s"].is_null();
  });
  return s;
}

// The manifest of a job's first backend attempt (server/backend.h).
Json manifest(const Daemon& d, const std::string& id) {
  const fs::path p = d.data() / "jobs" / id / "backend-1" / "manifest.json";
  return fs::exists(p) ? Json::parse(read_text(p)) : Json();
}

bool group_alive(pid_t pgid) {
  return ::kill(-pgid, 0) == 0 || errno != ESRCH;
}

// Every route that serves a done job answers as for a local job.
void expect_served(httplib::Client& c, const std::string& id) {
  for (const std::string route : {"/summary", "/buildings", "/ptn", "/ptn?format=geojson",
                                  "/results.h5", "/scene", "/maps"}) {
    auto r = c.Get("/v1/jobs/" + id + route);
    ASSERT_TRUE(r) << route;
    EXPECT_EQ(r->status, 200) << route << " " << r->body.substr(0, 300);
  }
}

// A summary's figures; the precision report's ETA divides by a wall-clock rate.
Json precision_figures(const std::string& text) {
  Json s = comparable_summary(text);
  if (s.contains("precision") && s["precision"].is_object()) s["precision"].erase("eta_s");
  return s;
}

// The job through the daemon's backend equals `fragsim run` on the same scenario.
void expect_same_as_cli(httplib::Client& c, const fs::path& dir, const std::string& id,
                        const Json& scenario) {
  const fs::path served = download(c, dir, id);
  const fs::path cli = cli_run(dir, id, scenario);
  expect_same_datasets(served / "results.h5", cli / "results.h5");
  EXPECT_EQ(precision_figures(read_text(served / "summary.json")),
            precision_figures(read_text(cli / "summary.json")));
}

bool mpirun_works() {
  return std::system("mpirun --allow-run-as-root --oversubscribe -np 2 true >/dev/null 2>&1") == 0;
}

Json mpi_backend() {
  return {{"kind", "mpi"},
          {"shards", 2},
          {"threads", 1},
          {"fragsim", FRAGSIM_CLI},
          {"mpirun", {"mpirun", "--allow-run-as-root", "--oversubscribe"}},
          {"poll_interval_s", 0.1}};
}

TEST(BackendDaemon, CommandBackendJobIsBitIdenticalToTheCli) {
  const fs::path dir = fresh_dir("fragsimd_backend_same_");
  auto d = backend_daemon(dir, command_backend(dir, 3));
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  const Json demo = small_demo();
  const std::string site = upload_site(*c, demo);
  const std::string id = submit(*c, by_site_id(demo, site));
  const Json s = wait_final(*c, id);
  ASSERT_EQ(s.value("state", ""), "done") << s.dump() << "\n" << d->log();
  EXPECT_EQ(s["histories_done"], s["histories_total"]);
  EXPECT_EQ(s["attempts"], 1);
  EXPECT_TRUE(s["error"].is_null());
  expect_same_as_cli(*c, dir, id, demo);
  expect_served(*c, id);
  EXPECT_FALSE(fs::exists(d->data() / "jobs" / id / "backend-1")) << "work directory left";
  EXPECT_NE(d->log().find("job submitted to backend"), std::string::npos);
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// A settings.precision job cannot be split: the backend runs it as its one shard (--shard 0/1,
// the partial carrying the precision report) and it ends as the CLI's run does.
TEST(BackendDaemon, APrecisionJobRunsWholeAsOneShard) {
  const fs::path dir = fresh_dir("fragsimd_backend_precision_");
  auto d = backend_daemon(dir, command_backend(dir, 3));
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  Json demo = small_demo();
  demo["settings"]["precision"] = {{"max_batches", 3}, {"building_rel_error", 1e-9}};
  const std::string id = submit(*c, demo);
  const Json s = wait_final(*c, id);
  ASSERT_EQ(s.value("state", ""), "done") << s.dump() << "\n" << d->log();
  EXPECT_NE(d->log().find("backend=command shards=1 "), std::string::npos) << d->log();
  expect_same_as_cli(*c, dir, id, demo);
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// The job a kill -9 interrupts must still run when the daemon is killed: the demo x 8 (640,000
// histories) in Release, x 2 in a sanitizer build (the x 8 job made the two restart tests 4-5
// minutes each under ASan in CI, 2026-11-29).
const double kRestartScale = outlasting(8.0);

// kill -9 of the daemon while the shards run: they go on; the restarted daemon re-attaches (the
// job stays running, attempts 1: not rerun) and finishes it with the same figures.
void restart_recovery(const fs::path& dir, const Json& backend,
                      const Json& scenario = scaled_samples(demo_scenario(), kRestartScale)) {
  auto d = backend_daemon(dir, backend);
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  const std::string id = submit(*c, scenario);
  const Json running = wait_progress(*c, id);
  ASSERT_EQ(running.value("state", ""), "running") << running.dump() << "\n" << d->log();
  EXPECT_LT(running["histories_done"].get<std::int64_t>(),
            running["histories_total"].get<std::int64_t>());
  EXPECT_TRUE(running["eta_s"].is_number()) << running.dump();
  const Json m = manifest(*d, id);
  ASSERT_EQ(m.value("state", ""), "submitted") << m.dump();
  const pid_t pgid = m["groups"][0]["pgid"].get<pid_t>();

  d->kill(SIGKILL);
  EXPECT_TRUE(group_alive(pgid)) << "the shards run on without the daemon";
  ASSERT_NO_THROW(d->start()) << d->log();
  c = d->client();
  const Json after = job_status(*c, id);
  EXPECT_EQ(after.value("state", ""), "running") << after.dump();
  EXPECT_EQ(after["attempts"], 1) << "re-attached, not rerun";
  const Json s = wait_final(*c, id);
  ASSERT_EQ(s.value("state", ""), "done") << s.dump() << "\n" << d->log();
  EXPECT_EQ(s["attempts"], 1);
  EXPECT_NE(d->log().find("backend job re-attached"), std::string::npos);
  EXPECT_EQ(d->log().find("interrupted by a previous daemon"), std::string::npos);
  expect_same_as_cli(*c, dir, id, scenario);
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

TEST(BackendDaemon, CommandBackendJobSurvivesKillNineOfTheDaemon) {
  const fs::path dir = fresh_dir("fragsimd_backend_restart_");
  Json backend = command_backend(dir, 2);
  restart_recovery(dir, backend);
}

TEST(BackendDaemon, MpiBackendJobSurvivesKillNineOfTheDaemon) {
  if (!mpirun_works()) GTEST_SKIP() << "mpirun cannot start 2 processes here";
  restart_recovery(fresh_dir("fragsimd_backend_mpi_"), mpi_backend());
}

TEST(BackendDaemon, MpiBackendJobIsBitIdenticalToTheCli) {
  if (!mpirun_works()) GTEST_SKIP() << "mpirun cannot start 2 processes here";
  const fs::path dir = fresh_dir("fragsimd_backend_mpi_same_");
  auto d = backend_daemon(dir, mpi_backend());
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  const Json scenario = with_seed(small_demo(), 5);
  const std::string id = submit(*c, scenario);
  const Json s = wait_final(*c, id);
  ASSERT_EQ(s.value("state", ""), "done") << s.dump() << "\n" << d->log();
  expect_same_as_cli(*c, dir, id, scenario);
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// ---- settings.precision jobs on the mpi preset: fragsim-mpi's ranks, one partial ----

#ifdef FRAGSIM_MPI
constexpr const char* kFragsimMpi = FRAGSIM_MPI;
#else
constexpr const char* kFragsimMpi = nullptr;
#endif

// Under TSan (deploy/sanitize.sh builds fragsim-mpi instrumented too) fragsim-mpi's ranks did
// not finish until deploy/sanitizers/tsan.supp named Open MPI's own lock-order report (it aborted
// one rank and left the other waiting; diagnosed 2026-11-29).
//
// Under ASan fragsim-mpi's ranks end with LeakSanitizer reports it can only attribute to
// "<unknown module>" (Open MPI's plugins, dlclose()d by MPI_Finalize), and exit 134: CI's ASan
// run failed the first two tests below so (2026-11-29). The daemon passes its environment to
// mpirun, so while a test's daemon runs, leak checks are off, as tests/mpi/mpi_run_test.cpp turns
// them off for the ranks it starts; fragsimd's own leaks are checked by the other tests.
class MpiRanksWithoutLeakChecks {
 public:
  MpiRanksWithoutLeakChecks() {
    if (const char* asan = std::getenv("ASAN_OPTIONS")) {
      old_ = asan;
      ::setenv("ASAN_OPTIONS", (*old_ + ":detect_leaks=0").c_str(), 1);
    }
  }
  ~MpiRanksWithoutLeakChecks() {
    if (old_) ::setenv("ASAN_OPTIONS", old_->c_str(), 1);
  }
  MpiRanksWithoutLeakChecks(const MpiRanksWithoutLeakChecks&) = delete;
  MpiRanksWithoutLeakChecks& operator=(const MpiRanksWithoutLeakChecks&) = delete;

 private:
  std::optional<std::string> old_;
};

Json mpi_precision_backend() {
  Json b = mpi_backend();
  b["fragsim_mpi"] = kFragsimMpi;
  return b;
}

// The demo x 0.05 (4,000 histories a batch) to a precision its HFD meets after 18 batches
// (measured), before max_batches: the stop batch is the targets' decision.
Json precision_demo() {
  Json sc = scaled_samples(demo_scenario(), 0.05);
  sc["settings"]["precision"] = {{"min_batches", 2}, {"max_batches", 30}, {"hfd_half_band_m", 8}};
  return sc;
}

// A precision job through the mpi backend on 2 ranks: one shard (shard.sh started once, running
// mpirun -np 2 fragsim-mpi ... --shard 0/1), the ranks exchanging every batch, and the job's
// results those of `fragsim run` to the bit, stopped at the same batch for the same reason.
TEST(BackendDaemon, MpiBackendDividesAPrecisionJobAmongFragsimMpiRanks) {
  if (!kFragsimMpi) GTEST_SKIP() << "fragsim-mpi not built (no MPI found by CMake)";
  if (!mpirun_works()) GTEST_SKIP() << "mpirun cannot start 2 processes here";
  const MpiRanksWithoutLeakChecks ranks_unchecked;
  const fs::path dir = fresh_dir("fragsimd_backend_mpi_precision_");
  Json backend = mpi_precision_backend();
  backend["keep_workdir"] = true;
  auto d = backend_daemon(dir, backend);
  ASSERT_NO_THROW(d->start()) << d->log();
  EXPECT_NE(d->log().find("settings.precision jobs divided among fragsim-mpi ranks"),
            std::string::npos)
      << d->log();
  auto c = d->client();
  const Json scenario = precision_demo();
  const std::string id = submit(*c, scenario);
  const Json s = wait_final(*c, id);
  ASSERT_EQ(s.value("state", ""), "done") << s.dump() << "\n" << d->log();
  EXPECT_NE(d->log().find("backend=mpi shards=1 ranks=2 "), std::string::npos) << d->log();
  const fs::path w = d->data() / "jobs" / id / "backend-1";
  const std::string script = read_text(w / "shard.sh");
  EXPECT_NE(script.find("'-np' '2' '" + std::string(kFragsimMpi) + "'"), std::string::npos)
      << script;
  EXPECT_NE(script.find("'--shard' '0/1'"), std::string::npos) << script;
  EXPECT_FALSE(fs::exists(w / "shard-1.exit")) << "one shard";
  EXPECT_EQ(manifest(*d, id)["shards"], 1);

  const fs::path served = download(*c, dir, id);
  const fs::path cli = cli_run(dir, id, scenario);
  expect_same_datasets(served / "results.h5", cli / "results.h5");
  const Json got = precision_figures(read_text(served / "summary.json"));
  const Json expected = precision_figures(read_text(cli / "summary.json"));
  EXPECT_EQ(expected["stop_reason"], "targets_met") << expected.dump();
  EXPECT_GT(expected["batches"].get<int>(), 2) << "stopped past min_batches, by the targets";
  EXPECT_EQ(got["batches"], expected["batches"]);
  EXPECT_EQ(got["stop_reason"], expected["stop_reason"]);
  EXPECT_EQ(got, expected);
  // The two ranks' threads (1 each) are the job's.
  EXPECT_EQ(Json::parse(read_text(served / "summary.json"))["timing"]["threads"], 2);
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// kill -9 of the daemon while fragsim-mpi's ranks run a precision job: they go on, and the
// restarted daemon re-attaches to the one shard and collects its partial, as for other mpi jobs.
TEST(BackendDaemon, MpiBackendPrecisionJobSurvivesKillNineOfTheDaemon) {
  if (!kFragsimMpi) GTEST_SKIP() << "fragsim-mpi not built (no MPI found by CMake)";
  if (!mpirun_works()) GTEST_SKIP() << "mpirun cannot start 2 processes here";
  const MpiRanksWithoutLeakChecks ranks_unchecked;
  // 6 batches of 40,000 histories (10,000 in a sanitizer build), no target met: long enough to
  // kill the daemon in the middle.
  Json scenario = scaled_samples(demo_scenario(), outlasting(0.5));
  scenario["settings"]["precision"] = {{"max_batches", 6}, {"building_rel_error", 1e-9}};
  restart_recovery(fresh_dir("fragsimd_backend_mpi_precision_restart_"), mpi_precision_backend(),
                   scenario);
}

// Cancel stops mpirun and its ranks (SIGTERM to shard.sh's process group, which mpirun forwards);
// the work directory goes once nothing writes to it.
TEST(BackendDaemon, CancelStopsAnMpiPrecisionJob) {
  if (!kFragsimMpi) GTEST_SKIP() << "fragsim-mpi not built (no MPI found by CMake)";
  if (!mpirun_works()) GTEST_SKIP() << "mpirun cannot start 2 processes here";
  const MpiRanksWithoutLeakChecks ranks_unchecked;
  const fs::path dir = fresh_dir("fragsimd_backend_mpi_precision_cancel_");
  auto d = backend_daemon(dir, mpi_precision_backend());
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  Json scenario = scaled_samples(demo_scenario(), 0.5);
  scenario["settings"]["record_fragments"] = false;
  scenario["settings"]["precision"] = {{"max_batches", 100}, {"building_rel_error", 1e-9}};
  const std::string id = submit(*c, scenario);
  const Json running = wait_progress(*c, id);
  ASSERT_EQ(running.value("state", ""), "running") << running.dump() << "\n" << d->log();
  const pid_t pgid = manifest(*d, id)["groups"][0]["pgid"].get<pid_t>();
  ASSERT_TRUE(group_alive(pgid));
  auto r = c->Delete("/v1/jobs/" + id);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_TRUE(wait_for([&] { return !group_alive(pgid); }, 30)) << "mpirun and its ranks stopped";
  EXPECT_TRUE(wait_for([&] { return !fs::exists(d->data() / "jobs" / id / "backend-1"); }, 30))
      << "the work directory goes once nothing writes to it";
  EXPECT_EQ(job_status(*c, id)["state"], "cancelled");
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// Without fragsim-mpi (divide_precision false behaves as a build without it), the mpi preset runs
// a precision job as one process, `fragsim run --shard 0/1` under mpirun -np 1, as before.
TEST(BackendDaemon, MpiBackendWithoutFragsimMpiRunsAPrecisionJobAsOneProcess) {
  if (!mpirun_works()) GTEST_SKIP() << "mpirun cannot start 2 processes here";
  const fs::path dir = fresh_dir("fragsimd_backend_mpi_precision_whole_");
  Json backend = mpi_backend();
  backend["divide_precision"] = false;
  auto d = backend_daemon(dir, backend);
  ASSERT_NO_THROW(d->start()) << d->log();
  EXPECT_NE(d->log().find("settings.precision jobs run as one process"), std::string::npos)
      << d->log();
  auto c = d->client();
  Json scenario = precision_demo();
  scenario["settings"]["precision"] = {{"max_batches", 2}, {"building_rel_error", 1e-9}};
  const std::string id = submit(*c, scenario);
  const Json s = wait_final(*c, id);
  ASSERT_EQ(s.value("state", ""), "done") << s.dump() << "\n" << d->log();
  EXPECT_NE(d->log().find("backend=mpi shards=1 submitted"), std::string::npos) << d->log();
  const fs::path served = download(*c, dir, id);
  const fs::path cli = cli_run(dir, id, scenario);
  expect_same_datasets(served / "results.h5", cli / "results.h5");
  EXPECT_EQ(precision_figures(read_text(served / "summary.json")),
            precision_figures(read_text(cli / "summary.json")));
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// A shard's command, `{shard}` first, through a wrapper that makes shard 1 misbehave.
Json with_run_wrapper(Json backend, const fs::path& wrapper) {
  backend["run"] = {
      "/bin/sh",         wrapper.string(), "{shard}", "{fragsim}",        "run",       "{scenario}",
      "--out",           "{shard_dir}",    "--shard", "{shard}/{shards}", "--threads", "1",
      "--progress-file", "{progress}",     "--quiet"};
  return backend;
}

// The small demo on a command backend of `shards` shards, each run through `script` (its first
// argument: the shard index); the job must end `failed` with code `backend`.
struct FailedBackendJob {
  std::unique_ptr<Daemon> daemon;
  std::string id;
  std::string message;  // error.message
};
FailedBackendJob failed_backend_job(const fs::path& dir, const std::string& script, int shards) {
  const fs::path wrapper = dir / "wrapper.sh";
  write_script(wrapper, script);
  FailedBackendJob f;
  f.daemon = backend_daemon(dir, with_run_wrapper(command_backend(dir, shards), wrapper));
  EXPECT_NO_THROW(f.daemon->start()) << f.daemon->log();
  auto c = f.daemon->client();
  f.id = submit(*c, small_demo());
  const Json s = wait_final(*c, f.id);
  EXPECT_EQ(s.value("state", ""), "failed") << s.dump();
  EXPECT_EQ(s["error"]["code"], "backend") << s.dump();
  if (s["error"].is_object()) f.message = s["error"].value("message", "");
  return f;
}

TEST(BackendDaemon, AShardThatFailsFailsTheJobNamingItsLog) {
  const fs::path dir = fresh_dir("fragsimd_backend_fail_");
  auto f = failed_backend_job(dir,
                              "#!/bin/sh\n"
                              "if [ \"$1\" = 1 ]; then echo \"shard one refuses\" >&2; exit 3; fi\n"
                              "shift; exec \"$@\"\n",
                              3);
  const std::string& message = f.message;
  EXPECT_NE(message.find("shard 1 of 3 failed (exit status 3)"), std::string::npos) << message;
  const fs::path log = f.daemon->data() / "jobs" / f.id / "backend-1" / "shard-1.log";
  EXPECT_NE(message.find(log.string()), std::string::npos) << message;
  EXPECT_NE(message.find("shard one refuses"), std::string::npos) << message;
  EXPECT_TRUE(fs::exists(log)) << "a failed job keeps its logs";
  auto r = f.daemon->client()->Get("/v1/jobs/" + f.id + "/summary");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 409);
  EXPECT_EQ(f.daemon->kill(SIGTERM), 0);
}

TEST(BackendDaemon, AShardWhoseProcessVanishesFailsTheJob) {
  const fs::path dir = fresh_dir("fragsimd_backend_vanish_");
  // Shard 1 kills its shard.sh (its parent) with SIGKILL: no exit status is ever recorded.
  auto f = failed_backend_job(dir,
                              "#!/bin/sh\n"
                              "if [ \"$1\" = 1 ]; then kill -9 $PPID; exit 0; fi\n"
                              "shift; exec \"$@\"\n",
                              2);
  const std::string& message = f.message;
  EXPECT_NE(message.find("shard 1 of 2 stopped without recording its end"), std::string::npos)
      << message;
  EXPECT_NE(message.find("process group"), std::string::npos) << message;
  EXPECT_NE(message.find("shard-1.log"), std::string::npos) << message;
  EXPECT_EQ(f.daemon->kill(SIGTERM), 0);
}

TEST(BackendDaemon, CancelStopsTheShards) {
  const fs::path dir = fresh_dir("fragsimd_backend_cancel_");
  auto d = backend_daemon(dir, command_backend(dir, 2));
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  const std::string id = submit(*c, scaled_samples(demo_scenario(), outlasting(20.0)));
  const Json running = wait_progress(*c, id);
  ASSERT_EQ(running.value("state", ""), "running") << running.dump();
  const pid_t pgid = manifest(*d, id)["groups"][0]["pgid"].get<pid_t>();
  ASSERT_TRUE(group_alive(pgid));
  auto r = c->Delete("/v1/jobs/" + id);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(Json::parse(r->body)["state"], "cancelled");
  EXPECT_TRUE(wait_for([&] { return !group_alive(pgid); }, 30)) << "the shards were stopped";
  EXPECT_TRUE(wait_for([&] { return !fs::exists(d->data() / "jobs" / id / "backend-1"); }, 30))
      << "the work directory goes once nothing writes to it";
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(job_status(*c, id)["state"], "cancelled");
  r = c->Delete("/v1/jobs/" + id);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 409);
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// backend.max_jobs = 1: one job at a time on the backend; the queue's order (priority, then
// submission) decides which runs next, as for local jobs.
TEST(BackendDaemon, QueuePrioritiesAndTheBackendsJobLimitApply) {
  const fs::path dir = fresh_dir("fragsimd_backend_queue_");
  Json backend = command_backend(dir, 2);
  backend["max_jobs"] = 1;
  auto d = backend_daemon(dir, backend);
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  const std::string first = submit(*c, scaled_samples(demo_scenario(), outlasting(4.0)));
  ASSERT_EQ(wait_progress(*c, first).value("state", ""), "running");
  Json low = with_seed(minimal_scenario(), 1);
  Json high = with_seed(minimal_scenario(), 2);
  high["priority"] = 5;
  const std::string b = submit(*c, low);
  const std::string h = submit(*c, high);
  EXPECT_EQ(job_status(*c, b)["state"], "queued");
  EXPECT_EQ(job_status(*c, h)["state"], "queued");
  for (const auto& id : {first, b, h}) EXPECT_EQ(wait_final(*c, id)["state"], "done");
  const std::string started_b = job_status(*c, b)["started_utc"];
  const std::string started_h = job_status(*c, h)["started_utc"];
  const std::string finished_first = job_status(*c, first)["finished_utc"];
  EXPECT_LT(started_h, started_b) << "the higher priority went first";
  EXPECT_GE(started_h, finished_first) << "one job at a time";
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// The slurm preset's queue tracking, against stand-ins for sbatch, squeue and scancel (first on
// the daemon's PATH) that run the array's tasks as local processes.
void write_fake_slurm(const fs::path& bin) {
  fs::create_directories(bin);
  write_script(bin / "sbatch",
               "#!/bin/sh\n"
               "# sbatch --parsable --array=0-K ... SCRIPT: tasks 0..K in the background\n"
               "last=0; script=\n"
               "for a in \"$@\"; do\n"
               "  case \"$a\" in --array=0-*) last=${a#--array=0-} ;; -*) ;; *) script=$a ;; esac\n"
               "done\n"
               "id=$$\n"
               "state=\"$(dirname \"$0\")/jobs\"; mkdir -p \"$state\"\n"
               "i=0\n"
               "while [ $i -le $last ]; do\n"
               "  SLURM_ARRAY_TASK_ID=$i setsid /bin/sh \"$script\" >/dev/null 2>&1 </dev/null &\n"
               "  echo $! >>\"$state/$id\"\n"
               "  i=$((i + 1))\n"
               "done\n"
               "echo \"$id;fakecluster\"\n");
  write_script(bin / "squeue",
               "#!/bin/sh\n"
               "# squeue --noheader --jobs=ID ...: the id while one of its tasks lives\n"
               "state=\"$(dirname \"$0\")/jobs\"\n"
               "for a in \"$@\"; do case \"$a\" in --jobs=*) id=${a#--jobs=} ;; esac; done\n"
               "echo \"$*\" >>\"$state/squeue.calls\"\n"
               "[ -f \"$state/$id\" ] || { echo \"slurm_load_jobs error: Invalid job id "
               "specified\" >&2; exit 1; }\n"
               "for p in $(cat \"$state/$id\"); do\n"
               "  if kill -0 \"$p\" 2>/dev/null; then echo \"$id\"; exit 0; fi\n"
               "done\n");
  write_script(bin / "scancel",
               "#!/bin/sh\n"
               "state=\"$(dirname \"$0\")/jobs\"\n"
               "for id in \"$@\"; do\n"
               "  echo \"$id\" >>\"$state/scancel.calls\"\n"
               "  for p in $(cat \"$state/$id\"); do kill -TERM -\"$p\" 2>/dev/null; done\n"
               "done\n");
}

class FakeSlurm : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fresh_dir("fragsimd_backend_slurm_");
    write_fake_slurm(dir_ / "bin");
    const char* path = std::getenv("PATH");
    old_path_ = path ? path : "";
    ::setenv("PATH", ((dir_ / "bin").string() + ":" + old_path_).c_str(), 1);
  }
  void TearDown() override { ::setenv("PATH", old_path_.c_str(), 1); }
  Json slurm_backend() const {
    return {{"kind", "slurm"},        {"shards", 3},
            {"threads", 1},           {"fragsim", FRAGSIM_CLI},
            {"poll_interval_s", 0.1}, {"status_interval_s", 0.3}};
  }
  fs::path dir_;
  std::string old_path_;
};

TEST_F(FakeSlurm, SlurmPresetJobIsBitIdenticalAndRecoversAfterKillNine) {
  auto d = backend_daemon(dir_, slurm_backend());
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  const Json scenario = scaled_samples(demo_scenario(), outlasting(6.0));
  const std::string id = submit(*c, scenario);
  ASSERT_EQ(wait_progress(*c, id).value("state", ""), "running") << d->log();
  const Json m = manifest(*d, id);
  ASSERT_EQ(m["track"], "queue") << m.dump();
  ASSERT_EQ(m["ids"].size(), 1u);
  EXPECT_NE(m["ids"][0].get<std::string>().find(';'), 0u);
  d->kill(SIGKILL);
  ASSERT_NO_THROW(d->start()) << d->log();
  c = d->client();
  EXPECT_EQ(job_status(*c, id)["state"], "running");
  const Json s = wait_final(*c, id);
  ASSERT_EQ(s.value("state", ""), "done") << s.dump() << "\n" << d->log();
  EXPECT_EQ(s["attempts"], 1);
  expect_same_as_cli(*c, dir_, id, scenario);
  EXPECT_TRUE(fs::exists(dir_ / "bin" / "jobs" / "squeue.calls")) << "followed through squeue";
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

TEST_F(FakeSlurm, CancelRunsScancel) {
  auto d = backend_daemon(dir_, slurm_backend());
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  const std::string id = submit(*c, scaled_samples(demo_scenario(), outlasting(20.0)));
  ASSERT_EQ(wait_progress(*c, id).value("state", ""), "running") << d->log();
  const std::string queue_id = manifest(*d, id)["ids"][0];
  auto r = c->Delete("/v1/jobs/" + id);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(read_text(dir_ / "bin" / "jobs" / "scancel.calls"), queue_id + "\n");
  std::this_thread::sleep_for(std::chrono::seconds(1));
  EXPECT_EQ(job_status(*c, id)["state"], "cancelled");
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// The queue forgets the job (squeue: "Invalid job id") while shards have not ended: after
// lost_after_s the job fails, naming the shards' state.
TEST_F(FakeSlurm, AJobTheQueueLostFailsTheJob) {
  Json backend = slurm_backend();
  backend["lost_after_s"] = 1.0;
  // Shard 0's task dies without a word, and the queue no longer knows the job.
  const fs::path wrapper = dir_ / "lost.sh";
  write_script(wrapper,
               "#!/bin/sh\n"
               "if [ \"$1\" = 0 ]; then rm -f \"" +
                   (dir_ / "bin" / "jobs").string() +
                   "\"/[0-9]*; kill -9 $PPID; exit 0; fi\n"
                   "shift; exec \"$@\"\n");
  auto d = backend_daemon(dir_, with_run_wrapper(backend, wrapper));
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  const std::string id = submit(*c, small_demo());
  const Json s = wait_final(*c, id);
  ASSERT_EQ(s.value("state", ""), "failed") << s.dump();
  const std::string message = s["error"]["message"];
  EXPECT_NE(message.find("shard 0 of 3 stopped without recording its end"), std::string::npos)
      << message;
  EXPECT_NE(message.find("queue"), std::string::npos) << message;
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

// The slurm preset for real: a private single-node Slurm (deploy/cluster/slurm-local.sh) when one
// can start here (root, slurm-wlm and munge installed), else skipped.
class RealSlurm : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fresh_dir("fragsimd_backend_realslurm_");
    script_ = source_path("deploy/cluster/slurm-local.sh");
    if (!fs::exists(script_)) GTEST_SKIP() << "no deploy/cluster/slurm-local.sh";
    // A short path: munged's socket lives there (at most 108 bytes).
    slurm_ = fs::temp_directory_path() / ("fsd-slurm-" + std::to_string(::getpid()));
    const std::string start = script_.string() + " start " + slurm_.string() + " >" +
                              (dir_ / "slurm.env").string() + " 2>" + (dir_ / "slurm.err").string();
    if (std::system(start.c_str()) != 0)
      GTEST_SKIP() << "no private Slurm here: " << read_text(dir_ / "slurm.err");
    started_ = true;
    const char* conf = std::getenv("SLURM_CONF");
    old_conf_ = conf ? std::optional<std::string>(conf) : std::nullopt;
    ::setenv("SLURM_CONF", (slurm_ / "etc" / "slurm.conf").c_str(), 1);
  }
  void TearDown() override {
    if (!started_) return;
    if (old_conf_)
      ::setenv("SLURM_CONF", old_conf_->c_str(), 1);
    else
      ::unsetenv("SLURM_CONF");
    const std::string stop = script_.string() + " stop " + slurm_.string() + " >/dev/null 2>&1";
    EXPECT_EQ(std::system(stop.c_str()), 0);
  }
  fs::path dir_, script_, slurm_;
  bool started_ = false;
  std::optional<std::string> old_conf_;
};

TEST_F(RealSlurm, SlurmPresetJobIsBitIdenticalSurvivesKillNineAndCancels) {
  const Json backend = {{"kind", "slurm"},        {"shards", 2},
                        {"threads", 1},           {"fragsim", FRAGSIM_CLI},
                        {"poll_interval_s", 0.1}, {"status_interval_s", 0.5}};
  auto d = backend_daemon(dir_, backend);
  ASSERT_NO_THROW(d->start()) << d->log();
  auto c = d->client();
  const Json scenario = scaled_samples(demo_scenario(), outlasting(4.0));
  const std::string id = submit(*c, scenario);
  ASSERT_EQ(wait_progress(*c, id).value("state", ""), "running") << d->log();
  d->kill(SIGKILL);
  ASSERT_NO_THROW(d->start()) << d->log();
  c = d->client();
  const Json s = wait_final(*c, id);
  ASSERT_EQ(s.value("state", ""), "done") << s.dump() << "\n" << d->log();
  EXPECT_EQ(s["attempts"], 1);
  expect_same_as_cli(*c, dir_, id, scenario);

  const std::string long_job = submit(*c, scaled_samples(demo_scenario(), outlasting(20.0)));
  ASSERT_EQ(wait_progress(*c, long_job).value("state", ""), "running") << d->log();
  const std::string queue_id = manifest(*d, long_job)["ids"][0];
  auto r = c->Delete("/v1/jobs/" + long_job);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  // scancel: the array leaves the queue.
  EXPECT_TRUE(wait_for(
      [&] {
        const std::string q = "squeue --noheader --jobs=" + queue_id + " >" +
                              (dir_ / "squeue.out").string() + " 2>/dev/null";
        return std::system(q.c_str()) != 0 || read_text(dir_ / "squeue.out").empty();
      },
      60));
  EXPECT_EQ(job_status(*c, long_job)["state"], "cancelled");
  EXPECT_EQ(d->kill(SIGTERM), 0);
}

}  // namespace
}  // namespace fragsim::server::testing
