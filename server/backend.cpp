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

#include "core/common/error.h"
#include "formats/output_dir.h"
#include "server/backend_templates.h"
#include "server/child_process.h"
#include "server/log.h"

namespace fragsim::server {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

constexpr const char* kManifest = "manifest.json";
constexpr const char* kScenario = "scenario.json";
constexpr const char* kShardScript = "shard.sh";
constexpr const char* kManifestFormat = "fragsimd.backend/1";

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
  // Appended piece by piece: GCC 12 warns of an overlap (-Wrestrict, a false positive) in
  // "." + name + ".tmp" once inlined here.
  std::string name = ".";
  name += p.filename().string();
  name += ".tmp";
  const fs::path tmp = p.parent_path() / name;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
  }
  ::chmod(tmp.c_str(), mode);
  formats::fsync_path(tmp);
  fs::rename(tmp, p);
  formats::fsync_path(p.parent_path());
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

// ---- Commands ----

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
