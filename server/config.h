#pragma once
// fragsimd configuration: a JSON file (--config FILE) and command-line flags; flags override the
// file. Every key, flag and default is listed in docs/http-api.md ("Starting the daemon").
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "api/command_line.h"

namespace fragsim::server {

// Where jobs run (docs/http-api.md, "fragsimd backends"): "local" (the daemon's own thread pool,
// the default) or an external backend that runs each job as `shards` pieces through commands:
// "mpi" (mpirun, detached), "slurm" (an sbatch array) or "command" (argv templates given here).
// The presets fill submit/status/cancel; server/backend.h resolves and checks them.
struct BackendConfig {
  std::string kind = "local";       // local | command | mpi | slurm
  int shards = 0;                   // 0: the preset's default (mpi: 2, slurm: 4); command: required
  int max_jobs = 1;                 // backend jobs submitted at once
  int threads = 0;                  // --threads of each shard (0: all cores where it runs)
  std::string fragsim;              // the fragsim program the shards run (default: beside fragsimd)
  std::vector<std::string> run;     // one shard's command (default: fragsim run --shard I/N ...)
  std::vector<std::string> submit;  // argv template; once per shard if it holds {shard}
  std::string track;                // "process" (the submit's process group) | "queue" (ids)
  std::vector<std::string> status;  // queue: prints something while the job is queued/running
  std::vector<std::string> cancel;  // queue: required; process: optional (the group is killed)
  std::vector<std::string> mpirun = {"mpirun"};          // mpi: the launcher and its options
  std::vector<std::string> sbatch = {"sbatch"};          // slurm: sbatch and its options
  std::vector<std::pair<std::string, std::string>> env;  // exported to every shard
  double poll_interval_s = 0.5;                          // shard files read this often
  double status_interval_s = 30.0;                       // queue: the status command run this often
  double lost_after_s = 600.0;      // queue: status unknown this long -> treated as gone
  double submit_timeout_s = 120.0;  // queue: the submit command must return within this
  bool keep_workdir = false;        // keep jobs/<id>/backend-<n>/ after the job is done
  // mpi: settings.precision jobs run as `mpirun -np {shards} fragsim-mpi ... --shard 0/1` (ranks
  // exchanging every batch, one partial): fragsim_mpi is that program (default: beside fragsim
  // or fragsimd, else on PATH; none found: such jobs run as one process, as with
  // divide_precision false).
  std::string fragsim_mpi;
  bool divide_precision = true;
};

struct Config {
  std::string listen_host = "127.0.0.1";
  int listen_port = 8080;  // 0: any free port (see port_file)
  std::string data_dir = "fragsimd-data";
  int threads = 0;             // Monte Carlo threads per job; 0 = all cores
  int job_nice = 10;           // nice value of the job's threads (0: the daemon's own priority)
  int http_threads = 64;       // requests handled at once (idle connections hold no thread)
  double keep_alive_s = 15.0;  // an idle connection is closed after this
  std::int64_t max_connections = 4096;  // open connections; beyond, a new one gets a 503
  std::string token_file;
  bool auth = true;
  std::int64_t max_body_bytes = 256LL << 20;
  std::int64_t max_samples_per_job = 100'000'000;
  std::int64_t max_sites = 100;
  // Terrain triangles of one site (uploaded or inline), refused before it is built: about
  // 190 bytes each resident (docs/benchmarks.md section 7), so the default 2^24 is ~3.2 GB.
  std::int64_t max_terrain_triangles = 1LL << 24;
  std::int64_t max_queued_jobs = 1000;
  double request_timeout_s = 30.0;
  std::string port_file;
  std::string log_level = "info";
  int max_crashes = 3;  // a job running when the daemon died this many times is marked failed
  // Retention (server/purge.h, docs/operations.md): finished jobs older than retain_days, or the
  // earliest finished while the jobs directory holds more than retain_bytes, are purged at start
  // and every retain_interval_s. 0: no such limit (the default: nothing is purged unasked).
  double retain_days = 0.0;
  std::int64_t retain_bytes = 0;
  double retain_interval_s = 600.0;
  // The free-space guard (server/disk_guard.h): below this many bytes available on the data
  // directory's file system, new jobs and sites get 507 and queued jobs wait. 0: off.
  std::int64_t min_free_bytes = 512LL << 20;
  // The web viewer at /ui/ (docs/viewer.md): served from the files compiled in, or from ui_dir
  // when set (development); ui = false serves no page (404).
  bool ui = true;
  std::string ui_dir;
  // Origins ("https://hazx.example.org") whose pages may call the API from a browser: their
  // requests get Access-Control-Allow-Origin and their preflights an answer. None by default
  // (the page fragsimd serves is same-origin and needs none).
  std::vector<std::string> cors_origins;
  BackendConfig backend;
};

// What the command line asked for besides running.
struct Invocation {
  Config config;
  bool help = false;
  bool version = false;
  // `fragsimd backup TARGET [flags]`: back the data directory up to TARGET (server/backup.h).
  std::optional<std::string> backup_target;
};

// Thrown (exit 2) naming the flag or key and the problem; the flags are read by
// api/command_line.h, as fragsim's are.
using ConfigError = api::InvocationError;

Invocation parse_command_line(const std::vector<std::string>& args);  // without argv[0]
// Reads a config file into `config` (keys as in docs/http-api.md).
void apply_config_file(const std::string& path, Config& config);
// Checks the combination (auth off only on loopback, a token file when auth is on, ...).
void check_config(const Config& config);

bool is_loopback_host(const std::string& host);
// What a token may do (docs/operations.md, "Roles"), each role everything the one before may:
// read (list and read sites, jobs, results, metrics), submit (also submit jobs and sites, cancel
// and retry its own jobs), admin (also others' jobs, purge, delete sites).
enum class Role { kRead = 0, kSubmit = 1, kAdmin = 2 };
const char* role_name(Role r);
std::optional<Role> parse_role(std::string_view name);

struct Token {
  std::string secret;
  Role role = Role::kAdmin;
  bool operator==(const Token&) const = default;
};

// Tokens from a token file: one per line, "<token>" or "<token> <role>" (role read, submit or
// admin; a line without one is admin, as every token was before roles); blank lines and lines
// starting with '#' ignored. A line whose last word is not a role is all token.
std::vector<Token> read_tokens(const std::string& path);

const char* usage_text();

}  // namespace fragsim::server
