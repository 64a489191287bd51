#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "core/common/error.h"
#include "server/backend.h"
#include "server/backend_templates.h"
#include "server/child_process.h"

// The configuration half of server/backend.h: a BackendConfig resolved into a ResolvedBackend
// (presets applied, defaults filled, templates checked), and where the programs are found.
namespace fragsim::server {

namespace fs = std::filesystem;

namespace {

// Slurm states in which a job is still queued or at work (squeue --states).
constexpr const char* kSlurmActiveStates =
    "--states=PENDING,RUNNING,CONFIGURING,COMPLETING,SUSPENDED,STOPPED,REQUEUED,REQUEUE_HOLD,"
    "REQUEUE_FED,RESIZING,SIGNALING,STAGE_OUT";

}  // namespace

std::string default_fragsim_program() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    for (const fs::path& candidate :
         {self.parent_path() / "fragsim", self.parent_path().parent_path() / "cli" / "fragsim"})
      if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  const std::string found = find_program("fragsim");
  return found.empty() ? "fragsim" : found;
}

std::string find_fragsim_mpi(const fs::path& fragsim, const fs::path& self) {
  std::vector<fs::path> candidates;
  for (const fs::path& program : {fragsim, self}) {
    if (!program.has_parent_path()) continue;  // a bare name, found on PATH
    candidates.push_back(program.parent_path() / "fragsim-mpi");
    candidates.push_back(program.parent_path().parent_path() / "mpi" / "fragsim-mpi");
  }
  for (const auto& c : candidates)
    if (::access(c.c_str(), X_OK) == 0) return c.string();
  return find_program("fragsim-mpi");
}

ResolvedBackend precision_backend(const ResolvedBackend& b) {
  ResolvedBackend p = b;
  p.shards = 1;
  if (b.precision_run.empty()) return p;
  p.run = b.precision_run;
  p.submit = {"{shard_script}", "0"};
  p.submit_per_shard = false;
  p.track = BackendTrack::kProcess;
  return p;
}

namespace {

// The mpi, slurm and command presets: shard count, default submit/status/cancel templates and
// how a job is followed (`track`, when the config leaves it empty).
void apply_preset(const BackendConfig& c, ResolvedBackend& r, std::string& track) {
  if (c.kind == "mpi") {
    r.shards = c.shards > 0 ? c.shards : 2;
    if (c.mpirun.empty()) throw InputError("backend.mpirun", "must name the launcher");
    if (r.submit.empty()) {
      r.submit = c.mpirun;
      for (const char* a : {"-np", "{shards}", "{shard_script}"}) r.submit.emplace_back(a);
    }
    if (track.empty()) track = "process";
  } else if (c.kind == "slurm") {
    r.shards = c.shards > 0 ? c.shards : 4;
    if (c.sbatch.empty()) throw InputError("backend.sbatch", "must name sbatch");
    if (r.submit.empty()) {
      r.submit = c.sbatch;
      if (c.threads > 0) r.submit.push_back("--cpus-per-task=" + std::to_string(c.threads));
      for (const char* a : {"--parsable", "--array=0-{last_shard}", "--job-name=fragsim-{job_id}",
                            "--output={workdir}/slurm-%a.out", "{shard_script}"})
        r.submit.emplace_back(a);
    }
    if (r.status.empty())
      r.status = {"squeue", "--noheader", "--jobs={ids}", kSlurmActiveStates, "--format=%i"};
    if (r.cancel.empty()) r.cancel = {"scancel", "{ids}"};
    if (track.empty()) track = "queue";
  } else if (c.kind == "command") {
    if (c.shards <= 0) throw InputError("backend.shards", "is required for a command backend");
    r.shards = c.shards;
    if (r.submit.empty())
      throw InputError("backend.submit", "is required for a command backend (an argv template)");
    if (track.empty()) track = "process";
  } else {
    throw InputError("backend.kind",
                     "must be local, mpi, slurm or command (got \"" + c.kind + "\")");
  }
}

void resolve_track(const std::string& track, ResolvedBackend& r) {
  if (track == "process") {
    r.track = BackendTrack::kProcess;
  } else if (track == "queue") {
    r.track = BackendTrack::kQueue;
    if (r.status.empty())
      throw InputError("backend.status", "is required with \"track\": \"queue\"");
    if (r.cancel.empty())
      throw InputError("backend.cancel", "is required with \"track\": \"queue\"");
  } else {
    throw InputError("backend.track", "must be process or queue (got \"" + track + "\")");
  }
}

// Every template names only the placeholders known where it is expanded.
void check_templates(ResolvedBackend& r) {
  const std::set<std::string> common = {"fragsim",    "scenario", "workdir", "shards",
                                        "last_shard", "threads",  "job_id"};
  std::set<std::string> run_names = common;
  run_names.insert({"shard", "shard_dir", "progress"});
  check_placeholders(r.run, "backend.run", run_names);
  std::set<std::string> submit_names = run_names;
  submit_names.insert("shard_script");
  check_placeholders(r.submit, "backend.submit", submit_names);
  r.submit_per_shard = mentions(r.submit, "shard");
  if (!r.submit_per_shard && (mentions(r.submit, "shard_dir") || mentions(r.submit, "progress")))
    throw InputError("backend.submit",
                     "{shard_dir} and {progress} need {shard} (a submission per shard)");
  const std::set<std::string> follow_names = {"ids", "workdir", "job_id", "shards"};
  check_placeholders(r.status, "backend.status", follow_names);
  check_placeholders(r.cancel, "backend.cancel", follow_names);
}

// mpi: how a settings.precision job runs (ResolvedBackend::precision_run), once `run`, `submit`
// and `fragsim` are resolved.
void resolve_precision(const BackendConfig& c, ResolvedBackend& r) {
  if (c.kind != "mpi") return;
  if (!c.divide_precision) {
    r.precision_note = "backend.divide_precision is false";
    return;
  }
  if (!c.run.empty() || !c.submit.empty()) {
    r.precision_note = "backend.run or backend.submit is set (the preset's own commands divide)";
    return;
  }
  std::error_code ec;
  const std::string program =
      !c.fragsim_mpi.empty() ? c.fragsim_mpi
                             : find_fragsim_mpi(r.fragsim, fs::read_symlink("/proc/self/exe", ec));
  if (program.empty()) {
    r.precision_note = "no fragsim-mpi beside " + r.fragsim +
                       ", beside fragsimd or on PATH (it is built only where CMake finds an MPI)";
    return;
  }
  r.precision_run = c.mpirun;
  for (const std::string& a : {std::string("-np"), std::to_string(r.shards), program})
    r.precision_run.push_back(a);
  for (const char* a : {"run", "{scenario}", "--out", "{shard_dir}", "--shard", "0/1", "--threads",
                        "{threads}", "--progress-file", "{progress}", "--quiet"})
    r.precision_run.emplace_back(a);
}

}  // namespace

void check_backend_config(const BackendConfig& config) {
  try {
    (void)resolve_backend(config);
  } catch (const InputError& e) {
    throw ConfigError(e.what());
  }
}

ResolvedBackend resolve_backend(const BackendConfig& c) {
  ResolvedBackend r;
  r.kind = c.kind;
  r.max_jobs = c.max_jobs;
  r.threads = c.threads;
  r.env = c.env;
  r.poll_interval_s = c.poll_interval_s;
  r.status_interval_s = c.status_interval_s;
  r.lost_after_s = c.lost_after_s;
  r.submit_timeout_s = c.submit_timeout_s;
  r.keep_workdir = c.keep_workdir;
  r.local = c.kind == "local";
  if (r.local) return r;
  r.submit = c.submit;
  r.status = c.status;
  r.cancel = c.cancel;
  std::string track = c.track;
  apply_preset(c, r, track);
  resolve_track(track, r);
  r.fragsim = c.fragsim.empty() ? default_fragsim_program() : c.fragsim;
  r.run = c.run;
  if (r.run.empty())
    r.run = {
        "{fragsim}",        "run",       "{scenario}", "--out",           "{shard_dir}", "--shard",
        "{shard}/{shards}", "--threads", "{threads}",  "--progress-file", "{progress}",  "--quiet"};
  check_templates(r);
  resolve_precision(c, r);
  return r;
}

}  // namespace fragsim::server
