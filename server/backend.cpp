#include "server/backend.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "api/output_dir.h"
#include "core/common/error.h"
#include "server/log.h"

extern char** environ;

namespace fragsim::server {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

constexpr const char* kManifest = "manifest.json";
constexpr const char* kScenario = "scenario.json";
constexpr const char* kShardScript = "shard.sh";
constexpr const char* kManifestFormat = "fragsimd.backend/1";

// Slurm states in which a job is still queued or at work (squeue --states).
constexpr const char* kSlurmActiveStates =
    "--states=PENDING,RUNNING,CONFIGURING,COMPLETING,SUSPENDED,STOPPED,REQUEUED,REQUEUE_HOLD,"
    "REQUEUE_FED,RESIZING,SIGNALING,STAGE_OUT";

// ---- Templates ----

// Placeholders are {name} with name in [a-z_]; other braces (${i}, %{x}, {X}) are plain text.
struct Piece {
  bool placeholder = false;
  std::string text;  // literal text, or the placeholder's name
};

std::vector<Piece> split_template(const std::string& s) {
  std::vector<Piece> out;
  std::string literal;
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s[k] == '{' && (k == 0 || (s[k - 1] != '$' && s[k - 1] != '%'))) {
      const std::size_t close = s.find('}', k + 1);
      if (close != std::string::npos && close > k + 1) {
        const std::string name = s.substr(k + 1, close - k - 1);
        if (std::all_of(name.begin(), name.end(),
                        [](char c) { return (c >= 'a' && c <= 'z') || c == '_'; })) {
          if (!literal.empty()) out.push_back({false, std::move(literal)});
          literal.clear();
          out.push_back({true, name});
          k = close;
          continue;
        }
      }
    }
    literal += s[k];
  }
  if (!literal.empty()) out.push_back({false, std::move(literal)});
  return out;
}

void check_placeholders(const std::vector<std::string>& argv, const std::string& key,
                        const std::set<std::string>& known) {
  for (std::size_t i = 0; i < argv.size(); ++i)
    for (const auto& p : split_template(argv[i]))
      if (p.placeholder && known.count(p.text) == 0) {
        std::string list;
        for (const auto& n : known) list += (list.empty() ? "{" : ", {") + n + "}";
        throw InputError(key + "[" + std::to_string(i) + "]",
                         "unknown placeholder {" + p.text + "} (known here: " + list + ")");
      }
}

bool mentions(const std::vector<std::string>& argv, const std::string& name) {
  for (const auto& a : argv)
    for (const auto& p : split_template(a))
      if (p.placeholder && p.text == name) return true;
  return false;
}

// Replaces the placeholders found in `vars`; others are left as they are ({ids}, expanded later).
std::string expand(const std::string& s, const std::map<std::string, std::string>& vars) {
  std::string out;
  for (const auto& p : split_template(s)) {
    if (!p.placeholder) {
      out += p.text;
      continue;
    }
    const auto it = vars.find(p.text);
    if (it == vars.end()) {
      out += '{';
      out += p.text;
      out += '}';
    } else {
      out += it->second;
    }
  }
  return out;
}

std::vector<std::string> expand_all(const std::vector<std::string>& argv,
                                    const std::map<std::string, std::string>& vars) {
  std::vector<std::string> out;
  for (const auto& a : argv) out.push_back(expand(a, vars));
  return out;
}

// A word for /bin/sh: single-quoted.
std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (const char c : s) {
    if (c == '\'')
      out += "'\\''";
    else
      out += c;
  }
  out += '\'';
  return out;
}

// ---- Files ----

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return {};
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Written under a temporary name, fsynced and renamed: a reader sees the old or the new file.
void write_file_atomic(const fs::path& p, const std::string& text, mode_t mode = 0644) {
  const fs::path tmp = p.parent_path() / ("." + p.filename().string() + ".tmp");
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
  }
  ::chmod(tmp.c_str(), mode);
  api::fsync_path(tmp);
  fs::rename(tmp, p);
  api::fsync_path(p.parent_path());
}

// The last non-empty line of a text file, at most 300 characters ("" when none).
std::string last_line(const fs::path& p) {
  std::string text = read_file(p);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' '))
    text.pop_back();
  const auto nl = text.rfind('\n');
  std::string line = nl == std::string::npos ? text : text.substr(nl + 1);
  if (line.size() > 300) line = "..." + line.substr(line.size() - 300);
  return line;
}

std::string log_reference(const fs::path& log) {
  std::error_code ec;
  if (!fs::exists(log, ec)) return "log: " + log.string() + " (not written)";
  const std::string tail = last_line(log);
  return "log: " + log.string() + (tail.empty() ? std::string(" (empty)") : ": " + tail);
}

// ---- Processes ----

// Field 22 of /proc/<pid>/stat: when the process started (clock ticks since boot); 0 if none.
std::uint64_t process_start_time(pid_t pid) {
  const std::string stat = read_file("/proc/" + std::to_string(pid) + "/stat");
  const auto close = stat.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream in(stat.substr(close + 2));
  std::string field;
  // Fields after the command: 3 (state) ... 22 (starttime): 20 of them.
  for (int k = 3; k <= 22; ++k)
    if (!(in >> field)) return 0;
  try {
    return std::stoull(field);
  } catch (const std::exception&) {
    return 0;
  }
}

std::string find_program(const std::string& name) {
  if (name.find('/') != std::string::npos) return name;
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "/usr/local/bin:/usr/bin:/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const fs::path candidate = fs::path(dir.empty() ? "." : dir) / name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return {};
}

int open_output(const fs::path& p) {
  const int fd = p.empty() ? ::open("/dev/null", O_WRONLY | O_CLOEXEC)
                           : ::open(p.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0)
    throw std::runtime_error("cannot open " + (p.empty() ? std::string("/dev/null") : p.string()) +
                             ": " + std::strerror(errno));
  return fd;
}

// The daemon's environment with `env`'s variables set (replacing any of the same name).
std::vector<std::string> child_environment(
    const std::vector<std::pair<std::string, std::string>>& env) {
  std::vector<std::string> envs;
  for (char** e = environ; e && *e; ++e) {
    const std::string s = *e;
    const std::string name = s.substr(0, s.find('='));
    if (std::none_of(env.begin(), env.end(), [&](const auto& kv) { return kv.first == name; }))
      envs.push_back(s);
  }
  for (const auto& [k, v] : env) envs.push_back(k + "=" + v);
  return envs;
}

// What the forked child needs, prepared before the fork (the child may only make
// async-signal-safe calls).
struct ChildSetup {
  std::string program;
  std::vector<char*> argv, envp;  // null-terminated, pointing into the parent's strings
  const char* cwd = nullptr;
  int in_fd = -1, out_fd = -1, err_fd = -1;
  int report_fd = -1;  // exec's errno goes here when exec fails (closed by a successful exec)
  int max_fd = 0;
};

// In the forked child: a session of its own, stdio from the setup, every other descriptor
// closed, signals at their defaults and unblocked, then exec. Async-signal-safe calls only.
[[noreturn]] void exec_child(const ChildSetup& c) {
  ::setsid();
  ::dup2(c.in_fd, 0);
  ::dup2(c.out_fd, 1);
  ::dup2(c.err_fd, 2);
  const int report = c.report_fd > 2 ? c.report_fd : -1;
  bool closed = false;  // every descriptor but 0-2 and the report pipe
#ifdef SYS_close_range
  closed = report < 0
               ? ::syscall(SYS_close_range, 3U, ~0U, 0U) == 0
               : (report == 3 ||
                  ::syscall(SYS_close_range, 3U, static_cast<unsigned>(report - 1), 0U) == 0) &&
                     ::syscall(SYS_close_range, static_cast<unsigned>(report + 1), ~0U, 0U) == 0;
#endif
  if (!closed)
    for (int fd = 3; fd < c.max_fd; ++fd)
      if (fd != report) ::close(fd);
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  for (int sig = 1; sig < NSIG; ++sig) ::sigaction(sig, &dfl, nullptr);
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  if (::chdir(c.cwd) == 0) ::execve(c.program.c_str(), c.argv.data(), c.envp.data());
  const int e = errno;
  if (report >= 0) {
    const ssize_t w = ::write(report, &e, sizeof e);
    (void)w;
  }
  ::_exit(127);
}

// Waits until the child has exec'd (the pipe closes) or reports why it could not (then reaps
// it and throws).
void await_exec(int pipe_read, pid_t pid, const std::string& program) {
  int child_errno = 0;
  ssize_t got = 0;
  do {
    got = ::read(pipe_read, &child_errno, sizeof child_errno);
  } while (got < 0 && errno == EINTR);
  ::close(pipe_read);
  if (got == static_cast<ssize_t>(sizeof child_errno)) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    throw std::runtime_error("cannot execute " + program + ": " + std::strerror(child_errno));
  }
}

// Starts `argv` in a session of its own (its process group id = its pid), stdin from /dev/null,
// stdout and stderr to the files given, in `cwd`, with every signal unblocked and at its default
// (the daemon blocks SIGINT/SIGTERM in its threads and ignores SIGPIPE, which exec would pass on)
// and no descriptor of the daemon's open (a listening socket held by a detached mpirun would keep
// a restarted daemon from binding its port). Returns once the child is in its own session, so
// the group is there to be watched at once. Throws when the program cannot be found or run.
pid_t spawn(const std::vector<std::string>& argv, const fs::path& out, const fs::path& err,
            const fs::path& cwd, const std::vector<std::pair<std::string, std::string>>& env) {
  if (argv.empty() || argv[0].empty()) throw std::runtime_error("empty command");
  ChildSetup c;
  c.program = find_program(argv[0]);
  if (c.program.empty())
    throw std::runtime_error("cannot find program \"" + argv[0] + "\" in PATH");
  std::vector<std::string> envs = child_environment(env);
  for (const auto& a : argv) c.argv.push_back(const_cast<char*>(a.c_str()));
  c.argv.push_back(nullptr);
  for (auto& e : envs) c.envp.push_back(e.data());
  c.envp.push_back(nullptr);
  c.cwd = cwd.c_str();
  auto close_stdio = [&c] {
    for (const int fd : {c.in_fd, c.out_fd, c.err_fd})
      if (fd >= 0) ::close(fd);
  };
  c.in_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  try {
    c.out_fd = open_output(out);
    c.err_fd = open_output(err);
  } catch (...) {
    close_stdio();
    throw;
  }
  int exec_pipe[2] = {-1, -1};  // closed by a successful exec (O_CLOEXEC), or carries its errno
  if (::pipe2(exec_pipe, O_CLOEXEC) != 0) {
    const int e = errno;
    close_stdio();
    throw std::runtime_error(std::string("pipe: ") + std::strerror(e));
  }
  c.report_fd = exec_pipe[1];
  rlimit lim{};
  ::getrlimit(RLIMIT_NOFILE, &lim);
  c.max_fd = static_cast<int>(std::min<rlim_t>(lim.rlim_cur, 1 << 16));

  const pid_t pid = ::fork();
  if (pid == 0) exec_child(c);
  const int fork_errno = errno;
  close_stdio();
  ::close(exec_pipe[1]);
  if (pid < 0) {
    ::close(exec_pipe[0]);
    throw std::runtime_error(std::string("fork: ") + std::strerror(fork_errno));
  }
  await_exec(exec_pipe[0], pid, c.program);
  return pid;
}

// Reaps the group's members that are this process's children (the submit command itself, and
// orphans when fragsimd is PID 1 of a container), so that a finished group does not linger as
// zombies.
void reap_group(pid_t pgid) {
  int status = 0;
  while (::waitpid(-pgid, &status, WNOHANG) > 0) {
  }
}

std::string join(const std::vector<std::string>& v, const char* sep) {
  std::string out;
  for (const auto& s : v) {
    if (!out.empty()) out += sep;
    out += s;
  }
  return out;
}

std::string track_name(BackendTrack t) {
  return t == BackendTrack::kQueue ? "queue" : "process";
}

// The ids a queue's submit command printed: the first word of each line, up to a ';'
// (sbatch --parsable prints "1234" or "1234;cluster").
std::vector<std::string> parse_ids(const std::string& text) {
  std::vector<std::string> ids;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    std::istringstream words(line);
    std::string id;
    if (!(words >> id)) continue;
    id = id.substr(0, id.find(';'));
    if (!id.empty()) ids.push_back(id);
  }
  return ids;
}

}  // namespace

// ---- Configuration ----

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

// ---- Commands ----

namespace {

// Waits for `pid` at most `timeout_s`: its exit status, 128 + signal, -1 (error) or -2 (timed
// out: its process group is then killed).
int wait_for(pid_t pid, double timeout_s) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (true) {
    const pid_t got = ::waitpid(pid, &status, WNOHANG);
    if (got == pid) break;
    if (got < 0 && errno != EINTR) return -1;
    if (Clock::now() > deadline) {
      ::kill(-pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return -2;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

}  // namespace

int run_command(const std::vector<std::string>& argv, const fs::path& out, const fs::path& err,
                double timeout_s) {
  pid_t pid = -1;
  try {
    pid = spawn(argv, out, err, fs::current_path(), {});
  } catch (const std::exception& e) {
    log(LogLevel::kWarn, "backend command not started",
        {{"command", join(argv, " ")}, {"error", e.what()}});
    return -1;
  }
  const int rc = wait_for(pid, timeout_s);
  if (rc == -2) log(LogLevel::kWarn, "backend command timed out", {{"command", join(argv, " ")}});
  return rc < 0 ? -1 : rc;
}

// ---- Work directory ----

ShardFiles ShardFiles::of(const fs::path& w, int shard) {
  const std::string s = "shard-" + std::to_string(shard);
  return {w / s, w / (s + ".progress.json"), w / (s + ".exit"), w / (s + ".log")};
}

fs::path BackendJob::scenario_file() const {
  return workdir_ / kScenario;
}

fs::path BackendJob::partial_file(int shard) const {
  return ShardFiles::of(workdir_, shard).dir / "partial.fsp";
}

std::string BackendJob::describe() const {
  if (track_ == BackendTrack::kQueue)
    return "queue id" + std::string(ids_.size() == 1 ? " " : "s ") + join(ids_, ", ");
  std::vector<std::string> g;
  for (const auto& x : groups_) g.push_back(std::to_string(x.pgid));
  return "process group" + std::string(g.size() == 1 ? " " : "s ") + join(g, ", ");
}

void BackendJob::write_manifest(const std::string& state) const {
  Json groups = Json::array();
  for (const auto& g : groups_) groups.push_back({{"pgid", g.pgid}, {"start_time", g.start_time}});
  const Json m = {{"format", kManifestFormat},
                  {"job_id", job_id_},
                  {"attempt", attempt_},
                  {"state", state},
                  {"shards", shards_},
                  {"track", track_name(track_)},
                  {"groups", groups},
                  {"ids", ids_},
                  {"status", status_},
                  {"cancel", cancel_},
                  {"status_interval_s", status_interval_s_},
                  {"lost_after_s", lost_after_s_},
                  {"submitted_utc", submitted_utc_}};
  write_file_atomic(workdir_ / kManifest, m.dump(2) + "\n");
}

std::optional<BackendJob> BackendJob::read_manifest(const fs::path& workdir, std::string* state) {
  const Json m = Json::parse(read_file(workdir / kManifest), nullptr, false);
  if (!m.is_object() || m.value("format", "") != kManifestFormat) return std::nullopt;
  try {
    BackendJob j;
    j.workdir_ = workdir;
    j.job_id_ = m.at("job_id").get<std::string>();
    j.attempt_ = m.at("attempt").get<int>();
    j.shards_ = m.at("shards").get<int>();
    j.track_ =
        m.at("track").get<std::string>() == "queue" ? BackendTrack::kQueue : BackendTrack::kProcess;
    for (const auto& g : m.at("groups"))
      j.groups_.push_back({g.at("pgid").get<pid_t>(), g.at("start_time").get<std::uint64_t>()});
    j.ids_ = m.at("ids").get<std::vector<std::string>>();
    j.status_ = m.at("status").get<std::vector<std::string>>();
    j.cancel_ = m.at("cancel").get<std::vector<std::string>>();
    j.status_interval_s_ = m.at("status_interval_s").get<double>();
    j.lost_after_s_ = m.at("lost_after_s").get<double>();
    j.submitted_utc_ = m.at("submitted_utc").get<std::string>();
    if (state) *state = m.at("state").get<std::string>();
    return j;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

namespace {

// shard.sh: the one script every engine starts, once per shard.
std::string shard_script(const ResolvedBackend& b, const std::string& job_id, int attempt,
                         const fs::path& w, const std::map<std::string, std::string>& vars) {
  // A word of the shard's command: static text single-quoted, the shard's own parts from the
  // shell's variables.
  const auto word = [&](const std::string& arg) {
    std::string out;
    for (const auto& p : split_template(arg)) {
      if (!p.placeholder) {
        out += shell_quote(p.text);
      } else if (p.text == "shard") {
        out += "\"$i\"";
      } else if (p.text == "shard_dir") {
        out += "\"$W/shard-$i\"";
      } else if (p.text == "progress") {
        out += "\"$W/shard-$i.progress.json\"";
      } else {
        out += shell_quote(vars.at(p.text));
      }
    }
    return out.empty() ? std::string("''") : out;
  };
  std::string command;
  for (const auto& a : b.run) {
    if (!command.empty()) command += ' ';
    command += word(a);
  }
  const std::string n = std::to_string(b.shards);
  std::string s;
  s += "#!/bin/sh\n";
  s += "# Written by fragsimd for job " + job_id + ", attempt " + std::to_string(attempt) +
       ": runs one shard of its " + n +
       " and records how it ended.\n"
       "# The shard: the first argument, or the rank a launcher gives (Slurm array, Open MPI, "
       "PMI).\n";
  s += "W=" + shell_quote(w.string()) + "\n";
  s += "i=${1:-${SLURM_ARRAY_TASK_ID:-${OMPI_COMM_WORLD_RANK:-${PMI_RANK:-${PMIX_RANK:-}}}}}\n";
  s += "case \"$i\" in\n"
       "  ''|*[!0-9]*) echo \"shard.sh: no shard index (argument or launcher rank)\" >&2; exit 2 "
       ";;\n"
       "esac\n";
  s += "if [ \"$i\" -ge " + n + " ]; then echo \"shard.sh: shard $i out of range (" + n +
       " shards)\" >&2; exit 2; fi\n";
  for (const auto& [k, v] : b.env) s += "export " + k + "=" + shell_quote(v) + "\n";
  s += "cd \"$W\" || exit 2\n";
  s += command + " >\"$W/shard-$i.log\" 2>&1 </dev/null\n";
  s += "rc=$?\n";
  s += "printf '%s\\n' \"$rc\" >\"$W/shard-$i.exit.tmp\" && mv -f \"$W/shard-$i.exit.tmp\" "
       "\"$W/shard-$i.exit\"\n";
  s += "exit \"$rc\"\n";
  return s;
}

}  // namespace

BackendJob BackendJob::submit(const ResolvedBackend& backend, const std::string& job_id,
                              int attempt, const fs::path& w, const std::string& scenario_text,
                              int shards) {
  ResolvedBackend b = backend;
  if (shards > 0) b.shards = shards;
  std::error_code ec;
  fs::remove_all(w, ec);
  fs::create_directories(w);
  const fs::path workdir = fs::absolute(w);
  write_file_atomic(workdir / kScenario, scenario_text);
  const std::map<std::string, std::string> vars = {
      {"fragsim", b.fragsim},
      {"scenario", (workdir / kScenario).string()},
      {"workdir", workdir.string()},
      {"shards", std::to_string(b.shards)},
      {"last_shard", std::to_string(b.shards - 1)},
      {"threads", std::to_string(b.threads)},
      {"job_id", job_id},
      {"shard_script", (workdir / kShardScript).string()}};
  write_file_atomic(workdir / kShardScript, shard_script(b, job_id, attempt, workdir, vars), 0755);

  BackendJob j;
  j.workdir_ = workdir;
  j.job_id_ = job_id;
  j.attempt_ = attempt;
  j.shards_ = b.shards;
  j.track_ = b.track;
  const std::map<std::string, std::string> follow_vars = {
      {"workdir", workdir.string()}, {"job_id", job_id}, {"shards", std::to_string(b.shards)}};
  j.status_ = expand_all(b.status, follow_vars);
  j.cancel_ = expand_all(b.cancel, follow_vars);
  j.status_interval_s_ = b.status_interval_s;
  j.lost_after_s_ = b.lost_after_s;
  j.submitted_utc_ = utc_now();
  j.write_manifest("submitting");

  const int commands = b.submit_per_shard ? b.shards : 1;
  try {
    for (int k = 0; k < commands; ++k) {
      std::map<std::string, std::string> v = vars;
      if (b.submit_per_shard) {
        const ShardFiles f = ShardFiles::of(workdir, k);
        v["shard"] = std::to_string(k);
        v["shard_dir"] = f.dir.string();
        v["progress"] = f.progress.string();
      }
      j.run_submission(b, k, expand_all(b.submit, v));
    }
  } catch (...) {
    j.cancel(false);
    j.cancel(true);
    throw;
  }
  j.write_manifest("submitted");
  return j;
}

void BackendJob::run_submission(const ResolvedBackend& b, int k,
                                const std::vector<std::string>& argv) {
  const std::string stem = "submit-" + std::to_string(k);
  const fs::path out = workdir_ / (stem + ".out"), err = workdir_ / (stem + ".log");
  if (b.track == BackendTrack::kProcess) {
    const pid_t pid = spawn(argv, out, err, workdir_, b.env);
    const Group g{pid, process_start_time(pid)};
    write_file_atomic(workdir_ / (stem + ".pid"),
                      std::to_string(g.pgid) + " " + std::to_string(g.start_time) + "\n");
    groups_.push_back(g);
    return;
  }
  // Queue submissions are quick (sbatch returns once the job is queued): waited for.
  const int rc = wait_for(spawn(argv, out, err, workdir_, b.env), b.submit_timeout_s);
  if (rc != 0)
    throw std::runtime_error("submit command " + shell_quote(argv[0]) +
                             (rc == -2 ? " timed out (backend.submit_timeout_s)"
                                       : " failed (exit status " + std::to_string(rc) + ")") +
                             "; " + log_reference(err));
  const auto ids = parse_ids(read_file(out));
  if (ids.empty())
    throw std::runtime_error("submit command " + shell_quote(argv[0]) + " printed no job id (" +
                             out.string() + " is empty); " + log_reference(err));
  ids_.insert(ids_.end(), ids.begin(), ids.end());
}

std::optional<BackendJob> BackendJob::attach(const fs::path& workdir) {
  std::string state;
  auto j = read_manifest(workdir, &state);
  if (!j || state != "submitted") return std::nullopt;
  return j;
}

void BackendJob::abandon(const fs::path& workdir) {
  std::string state;
  auto j = read_manifest(workdir, &state);
  if (!j) return;
  // What the dead daemon started before it could record it: the submit-K.pid and .out files.
  if (j->track_ == BackendTrack::kProcess) {
    j->groups_.clear();
    std::error_code ec;
    for (fs::directory_iterator it(workdir, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (name.rfind("submit-", 0) != 0 || it->path().extension() != ".pid") continue;
      std::istringstream in(read_file(it->path()));
      Group g;
      if (in >> g.pgid >> g.start_time) j->groups_.push_back(g);
    }
  } else {
    j->ids_.clear();
    for (int k = 0; k < j->shards_; ++k) {
      const auto ids = parse_ids(read_file(workdir / ("submit-" + std::to_string(k) + ".out")));
      j->ids_.insert(j->ids_.end(), ids.begin(), ids.end());
    }
    if (j->ids_.empty()) return;
  }
  j->cancel(false);
  j->cancel(true);
}

// ---- Following ----

std::vector<std::string> BackendJob::expand_ids(const std::vector<std::string>& tmpl) const {
  std::vector<std::string> out;
  for (const auto& a : tmpl) {
    if (a == "{ids}") {
      out.insert(out.end(), ids_.begin(), ids_.end());
    } else {
      out.push_back(expand(a, {{"ids", join(ids_, ",")}}));
    }
  }
  return out;
}

bool BackendJob::groups_alive() {
  bool alive = false;
  for (const auto& g : groups_) {
    reap_group(g.pgid);
    const std::uint64_t leader = process_start_time(g.pgid);
    if (leader != 0 && leader == g.start_time) {
      alive = true;  // the submit command itself
      continue;
    }
    if (::kill(-g.pgid, 0) != 0 && errno == ESRCH) continue;
    // The number is someone's group: ours, unless its leader is a newer process (the group
    // ended and the id was given again; a group id is not reused while the group exists).
    if (leader != 0) continue;
    alive = true;
  }
  return alive;
}

bool BackendJob::queue_gone() {
  const auto now = Clock::now();
  if (watch_.status_checked &&
      now - watch_.last_status < std::chrono::duration<double>(status_interval_s_))
    return watch_.gone_count >= 2;
  watch_.status_checked = true;
  watch_.last_status = now;
  const fs::path out = workdir_ / "status.out";
  const int rc = run_command(expand_ids(status_), out, workdir_ / "status.log", 60.0);
  std::string text = read_file(out);
  const bool empty = text.find_first_not_of(" \t\r\n") == std::string::npos;
  if (rc == 0) {
    watch_.unknown_since.reset();
    watch_.gone_count = empty ? watch_.gone_count + 1 : 0;
  } else {
    // The queue could not say (controller down, or a job it no longer remembers).
    if (!watch_.unknown_since) watch_.unknown_since = now;
    if (now - *watch_.unknown_since > std::chrono::duration<double>(lost_after_s_)) return true;
  }
  // Twice in a row: a shard's last file written on a shared file system shows up here late.
  return watch_.gone_count >= 2;
}

bool BackendJob::processes_gone() {
  return track_ == BackendTrack::kQueue || !groups_alive();
}

BackendJob::Poll BackendJob::poll() {
  const auto read_shards = [&] {
    std::vector<ShardProgress> shards(static_cast<std::size_t>(shards_));
    for (int k = 0; k < shards_; ++k) {
      const ShardFiles f = ShardFiles::of(workdir_, k);
      ShardProgress& p = shards[static_cast<std::size_t>(k)];
      const Json j = Json::parse(read_file(f.progress), nullptr, false);
      if (j.is_object()) {
        p.histories_done = j.value("histories_done", std::int64_t{0});
        p.histories_total = j.value("histories_total", std::int64_t{0});
        p.elapsed_s = j.value("elapsed_s", 0.0);
        p.state = j.value("state", "");
      }
      const std::string exit = read_file(f.exit);
      if (!exit.empty()) {
        try {
          p.exit_status = std::stoi(exit);
        } catch (const std::exception&) {
          p.exit_status = -1;
        }
      }
    }
    return shards;
  };
  const std::string of = " of " + std::to_string(shards_);
  // Done, failed, or nullopt while some shard has not ended.
  const auto judge = [&](Poll& p) -> bool {
    for (int k = 0; k < shards_; ++k) {
      const auto& s = p.shards[static_cast<std::size_t>(k)];
      if (s.exit_status && *s.exit_status != 0) {
        p.state = Poll::State::kFailed;
        p.error = "shard " + std::to_string(k) + of + " failed (exit status " +
                  std::to_string(*s.exit_status) + "); " +
                  log_reference(ShardFiles::of(workdir_, k).log);
        return true;
      }
    }
    for (const auto& s : p.shards)
      if (!s.exit_status) return false;
    for (int k = 0; k < shards_; ++k) {
      std::error_code ec;
      if (!fs::is_regular_file(partial_file(k), ec)) {
        p.state = Poll::State::kFailed;
        p.error = "shard " + std::to_string(k) + of + " exited 0 but wrote no " +
                  partial_file(k).string() + "; " + log_reference(ShardFiles::of(workdir_, k).log);
        return true;
      }
    }
    p.state = Poll::State::kDone;
    return true;
  };

  Poll p;
  p.shards = read_shards();
  if (judge(p)) return p;
  const bool gone = track_ == BackendTrack::kQueue ? queue_gone() : !groups_alive();
  if (!gone) return p;
  // Gone: a shard may have written its exit file between the first read and the check.
  p.shards = read_shards();
  if (judge(p)) return p;
  for (int k = 0; k < shards_; ++k) {
    if (p.shards[static_cast<std::size_t>(k)].exit_status) continue;
    const ShardFiles f = ShardFiles::of(workdir_, k);
    std::error_code ec;
    std::string where = log_reference(f.log);
    if (!fs::exists(f.log, ec)) {
      // Never started: what the submission said.
      where += "; submit " + log_reference(workdir_ / "submit-0.log");
    }
    p.state = Poll::State::kFailed;
    p.error = "shard " + std::to_string(k) + of + " stopped without recording its end (" +
              (track_ == BackendTrack::kQueue ? "the queue no longer holds " : "") + describe() +
              (track_ == BackendTrack::kQueue ? "" : " gone") + "); " + where;
    return p;
  }
  return p;
}

void BackendJob::cancel(bool force) {
  if (track_ == BackendTrack::kProcess) {
    for (const auto& g : groups_) {
      reap_group(g.pgid);
      const std::uint64_t leader = process_start_time(g.pgid);
      if (leader != 0 && leader != g.start_time) continue;  // the id belongs to another now
      ::kill(-g.pgid, force ? SIGKILL : SIGTERM);
    }
    if (!force && !cancel_.empty())
      run_command(expand_ids(cancel_), workdir_ / "cancel.out", workdir_ / "cancel.log", 60.0);
    return;
  }
  if (force || ids_.empty()) return;
  const int rc =
      run_command(expand_ids(cancel_), workdir_ / "cancel.out", workdir_ / "cancel.log", 60.0);
  if (rc != 0)
    log(LogLevel::kWarn, "backend cancel command failed",
        {{"job_id", job_id_},
         {"exit_status", std::to_string(rc)},
         {"log", (workdir_ / "cancel.log").string()}});
}

}  // namespace fragsim::server
