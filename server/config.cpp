#include "server/config.h"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "api/json_fields.h"
#include "api/scenario_json.h"

namespace fragsim::server {

namespace {

using Json = nlohmann::json;

constexpr std::int64_t kInt64Max = std::numeric_limits<std::int64_t>::max();

std::int64_t parse_integer(const std::string& text, const std::string& what, std::int64_t lo,
                           std::int64_t hi) {
  std::size_t used = 0;
  long long v = 0;
  try {
    v = std::stoll(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty())
    throw ConfigError(what + ": expected an integer, got \"" + text + "\"");
  if (v < lo || v > hi)
    throw ConfigError(what + ": must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                      "] (got " + text + ")");
  return v;
}

double parse_seconds(const std::string& text, const std::string& what) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || !(v > 0.0) || v > 86400.0)
    throw ConfigError(what + ": expected seconds in (0, 86400], got \"" + text + "\"");
  return v;
}

// Retention's age limit: days in [0, 36500] (0: none).
constexpr double kMaxRetainDays = 36500.0;

double parse_days(const std::string& text, const std::string& what) {
  std::size_t used = 0;
  double v = -1.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || !(v >= 0.0) || v > kMaxRetainDays)
    throw ConfigError(what + ": expected days in [0, 36500] (0: no age limit), got \"" + text +
                      "\"");
  return v;
}

void set_listen(const std::string& text, const std::string& what, Config& c) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0)
    throw ConfigError(what + ": expected HOST:PORT, got \"" + text + "\"");
  std::string host = text.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);  // [::1]:8080
  c.listen_host = host;
  c.listen_port = static_cast<int>(parse_integer(text.substr(colon + 1), what, 0, 65535));
}

void check_log_level(const std::string& level, const std::string& what) {
  if (level != "debug" && level != "info" && level != "warn" && level != "error")
    throw ConfigError(what + ": must be debug, info, warn or error (got \"" + level + "\")");
}

// An origin as browsers send it: scheme "http" or "https", "://", a host (and port), no path.
std::string checked_origin(const std::string& origin, const std::string& what) {
  const auto fail = [&]() {
    return ConfigError(what +
                       ": expected an origin such as https://hazx.example.org:8443 (no "
                       "path, no trailing slash), got \"" +
                       origin + "\"");
  };
  const std::size_t sep = origin.find("://");
  if (sep == std::string::npos) throw fail();
  const std::string scheme = origin.substr(0, sep), rest = origin.substr(sep + 3);
  if ((scheme != "http" && scheme != "https") || rest.empty()) throw fail();
  for (const char c : rest)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == ':' ||
          c == '[' || c == ']'))
      throw fail();
  return origin;
}

std::string read_text_file(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(what + ": cannot read " + path + ": " + std::strerror(errno));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> read_argv(const Json& v, const std::string& path) {
  if (!v.is_array())
    throw InputError(path, "expected an array of strings (a command and its arguments)");
  std::vector<std::string> out;
  for (std::size_t i = 0; i < v.size(); ++i)
    out.push_back(api::read_string(v[i], api::index_path(path, i)));
  return out;
}

double read_seconds(const Json& v, const std::string& path) {
  const double s = api::read_number(v, path);
  api::check_gt(s, 0.0, path);
  api::check_le(s, 86400.0, path);
  return s;
}

// "backend": a preset name ("local", "mpi", "slurm") or an object (docs/http-api.md).
void apply_backend(const Json& j, BackendConfig& b) {
  if (j.is_string()) {
    b.kind = j.get<std::string>();
    return;
  }
  if (!j.is_object()) throw InputError("backend", "expected a backend name or an object");
  static const std::vector<std::string> kKeys = {
      "kind",         "shards",           "max_jobs",     "threads",         "fragsim",
      "run",          "submit",           "track",        "status",          "cancel",
      "mpirun",       "sbatch",           "env",          "poll_interval_s", "status_interval_s",
      "lost_after_s", "submit_timeout_s", "keep_workdir", "fragsim_mpi",     "divide_precision"};
  for (const auto& item : j.items()) {
    const std::string& k = item.key();
    const std::string at = "backend." + k;
    const Json& v = item.value();
    if (k == "kind") {
      b.kind = api::read_string(v, at);
    } else if (k == "shards") {
      b.shards = static_cast<int>(api::read_integer(v, at, 1, 4096));
    } else if (k == "max_jobs") {
      b.max_jobs = static_cast<int>(api::read_integer(v, at, 1, 10000));
    } else if (k == "threads") {
      b.threads = static_cast<int>(api::read_integer(v, at, 0, api::kMaxThreads));
    } else if (k == "fragsim") {
      b.fragsim = api::read_string(v, at);
    } else if (k == "run") {
      b.run = read_argv(v, at);
    } else if (k == "submit") {
      b.submit = read_argv(v, at);
    } else if (k == "track") {
      b.track = api::read_string(v, at);
    } else if (k == "status") {
      b.status = read_argv(v, at);
    } else if (k == "cancel") {
      b.cancel = read_argv(v, at);
    } else if (k == "mpirun") {
      b.mpirun = read_argv(v, at);
    } else if (k == "sbatch") {
      b.sbatch = read_argv(v, at);
    } else if (k == "env") {
      if (!v.is_object()) throw InputError(at, "expected an object of NAME: value");
      b.env.clear();
      for (const auto& e : v.items()) {
        const std::string name = e.key();
        const bool ok = !name.empty() && !std::isdigit(static_cast<unsigned char>(name[0])) &&
                        std::all_of(name.begin(), name.end(),
                                    [](unsigned char c) { return std::isalnum(c) || c == '_'; });
        if (!ok) throw InputError(at, "\"" + name + "\" is not an environment variable name");
        b.env.emplace_back(name, api::read_string(e.value(), api::child_path(at, name)));
      }
    } else if (k == "poll_interval_s") {
      b.poll_interval_s = read_seconds(v, at);
    } else if (k == "status_interval_s") {
      b.status_interval_s = read_seconds(v, at);
    } else if (k == "lost_after_s") {
      b.lost_after_s = read_seconds(v, at);
    } else if (k == "submit_timeout_s") {
      b.submit_timeout_s = read_seconds(v, at);
    } else if (k == "keep_workdir") {
      b.keep_workdir = api::read_bool(v, at);
    } else if (k == "fragsim_mpi") {
      b.fragsim_mpi = api::read_string(v, at);
    } else if (k == "divide_precision") {
      b.divide_precision = api::read_bool(v, at);
    } else {
      const std::string guess = api::suggest_key(k, kKeys);
      throw InputError(
          at, guess.empty() ? "unknown key" : "unknown key (did you mean \"" + guess + "\"?)");
    }
  }
}

}  // namespace

// Loopback: "localhost", "::1" or an IPv4 address literal in 127.0.0.0/8. A host *name* that
// merely starts with "127." could resolve to anything.
bool is_loopback_host(const std::string& host) {
  if (host == "localhost" || host == "::1") return true;
  in_addr addr{};
  if (::inet_pton(AF_INET, host.c_str(), &addr) != 1) return false;
  return (ntohl(addr.s_addr) >> 24) == 127;
}

const char* role_name(Role r) {
  switch (r) {
    case Role::kRead: return "read";
    case Role::kSubmit: return "submit";
    case Role::kAdmin: break;
  }
  return "admin";
}

std::optional<Role> parse_role(std::string_view name) {
  for (const Role r : {Role::kRead, Role::kSubmit, Role::kAdmin})
    if (name == role_name(r)) return r;
  return std::nullopt;
}

std::vector<Token> read_tokens(const std::string& path) {
  std::istringstream in(read_text_file(path, "token file"));
  std::vector<Token> tokens;
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
      line.pop_back();
    std::size_t start = line.find_first_not_of(" \t");
    if (start == std::string::npos || line[start] == '#') continue;
    Token t{line.substr(start), Role::kAdmin};
    if (const std::size_t gap = t.secret.find_last_of(" \t"); gap != std::string::npos) {
      if (const auto role = parse_role(std::string_view(t.secret).substr(gap + 1))) {
        t.role = *role;
        t.secret.erase(t.secret.find_last_not_of(" \t", gap) + 1);
      }
    }
    tokens.push_back(std::move(t));
  }
  return tokens;
}

namespace {

// Each key of the config file and how it sets the Config (`k` names the key in errors).
using ConfigSetter = std::function<void(const Json& v, const std::string& k, Config& c)>;

const std::map<std::string, ConfigSetter>& config_setters() {
  auto positive_seconds = [](const Json& v, const std::string& k) {
    const double s = api::read_number(v, k);
    api::check_gt(s, 0.0, k);
    api::check_le(s, 86400.0, k);
    return s;
  };
  static const std::map<std::string, ConfigSetter> setters = {
      {"listen", [](const Json& v, const std::string& k,
                    Config& c) { set_listen(api::read_string(v, k), k, c); }},
      {"data_dir",
       [](const Json& v, const std::string& k, Config& c) { c.data_dir = api::read_string(v, k); }},
      {"threads",
       [](const Json& v, const std::string& k, Config& c) {
         c.threads = static_cast<int>(api::read_integer(v, k, 0, api::kMaxThreads));
       }},
      {"http_threads",
       [](const Json& v, const std::string& k, Config& c) {
         c.http_threads = static_cast<int>(api::read_integer(v, k, 1, 1024));
       }},
      {"token_file", [](const Json& v, const std::string& k,
                        Config& c) { c.token_file = api::read_string(v, k); }},
      {"auth",
       [](const Json& v, const std::string& k, Config& c) { c.auth = api::read_bool(v, k); }},
      {"max_body_bytes",
       [](const Json& v, const std::string& k, Config& c) {
         c.max_body_bytes = api::read_integer(v, k, 1024, kInt64Max);
       }},
      {"max_samples_per_job",
       [](const Json& v, const std::string& k, Config& c) {
         c.max_samples_per_job = api::read_integer(v, k, 1, kInt64Max);
       }},
      {"max_terrain_triangles",
       [](const Json& v, const std::string& k, Config& c) {
         c.max_terrain_triangles = api::read_integer(v, k, 2, kInt64Max);
       }},
      {"max_sites", [](const Json& v, const std::string& k,
                       Config& c) { c.max_sites = api::read_integer(v, k, 1, kInt64Max); }},
      {"max_queued_jobs",
       [](const Json& v, const std::string& k, Config& c) {
         c.max_queued_jobs = api::read_integer(v, k, 1, kInt64Max);
       }},
      {"request_timeout_s",
       [positive_seconds](const Json& v, const std::string& k, Config& c) {
         c.request_timeout_s = positive_seconds(v, k);
       }},
      {"job_nice",
       [](const Json& v, const std::string& k, Config& c) {
         c.job_nice = static_cast<int>(api::read_integer(v, k, 0, 19));
       }},
      {"keep_alive_s", [positive_seconds](const Json& v, const std::string& k,
                                          Config& c) { c.keep_alive_s = positive_seconds(v, k); }},
      {"max_connections",
       [](const Json& v, const std::string& k, Config& c) {
         c.max_connections = api::read_integer(v, k, 1, 1'000'000);
       }},
      {"log_level",
       [](const Json& v, const std::string& k, Config& c) {
         c.log_level = api::read_string(v, k);
         check_log_level(c.log_level, k);
       }},
      {"max_crashes",
       [](const Json& v, const std::string& k, Config& c) {
         c.max_crashes = static_cast<int>(api::read_integer(v, k, 1, 1000));
       }},
      {"retain_days",
       [](const Json& v, const std::string& k, Config& c) {
         c.retain_days = api::read_number(v, k);
         api::check_ge_le(c.retain_days, 0.0, kMaxRetainDays, k);
       }},
      {"retain_bytes", [](const Json& v, const std::string& k,
                          Config& c) { c.retain_bytes = api::read_integer(v, k, 0, kInt64Max); }},
      {"min_free_bytes",
       [](const Json& v, const std::string& k, Config& c) {
         c.min_free_bytes = api::read_integer(v, k, 0, kInt64Max);
       }},
      {"retain_interval_s",
       [positive_seconds](const Json& v, const std::string& k, Config& c) {
         c.retain_interval_s = positive_seconds(v, k);
       }},
      {"port_file", [](const Json& v, const std::string& k,
                       Config& c) { c.port_file = api::read_string(v, k); }},
      {"ui", [](const Json& v, const std::string& k, Config& c) { c.ui = api::read_bool(v, k); }},
      {"ui_dir",
       [](const Json& v, const std::string& k, Config& c) { c.ui_dir = api::read_string(v, k); }},
      {"backend",
       [](const Json& v, const std::string&, Config& c) { apply_backend(v, c.backend); }},
      {"cors_origins",
       [](const Json& v, const std::string& k, Config& c) {
         if (!v.is_array()) throw InputError(k, "expected array of origins");
         c.cors_origins.clear();
         for (std::size_t i = 0; i < v.size(); ++i) {
           const std::string at = k + "[" + std::to_string(i) + "]";
           c.cors_origins.push_back(checked_origin(api::read_string(v[i], at), at));
         }
       }},
  };
  return setters;
}

}  // namespace

void apply_config_file(const std::string& path, Config& c) {
  const std::string text = read_text_file(path, "--config");
  Json j;
  try {
    j = api::parse_json_text(text);
  } catch (const InputError& e) {
    throw ConfigError(path + ": " + e.what());
  }
  if (!j.is_object()) throw ConfigError(path + ": expected a JSON object");
  const auto& setters = config_setters();
  try {
    for (const auto& item : j.items()) {
      const std::string& k = item.key();
      const auto it = setters.find(k);
      if (it == setters.end()) {
        std::vector<std::string> keys;
        for (const auto& [name, set] : setters) keys.push_back(name);
        const std::string guess = api::suggest_key(k, keys);
        throw InputError(
            k, guess.empty() ? "unknown key" : "unknown key (did you mean \"" + guess + "\"?)");
      }
      it->second(item.value(), k, c);
    }
  } catch (const InputError& e) {
    throw ConfigError(path + ": " + e.what());
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
}

Invocation parse_command_line(const std::vector<std::string>& command_line) {
  Invocation inv;
  std::vector<std::string> args = command_line;
  if (!args.empty() && args[0] == "backup") {
    if (args.size() < 2 || args[1].rfind("--", 0) == 0)
      throw ConfigError("backup: needs a target directory (fragsimd backup DIR [--data-dir D])");
    inv.backup_target = args[1];
    args.erase(args.begin(), args.begin() + 2);
  }
  // The config file first, so that flags override it wherever they stand.
  for (std::size_t k = 0; k < args.size(); ++k) {
    if (args[k] == "--config") {
      if (k + 1 >= args.size()) throw ConfigError("--config: needs a file name");
      apply_config_file(args[k + 1], inv.config);
    }
  }
  Config& c = inv.config;
  for (std::size_t k = 0; k < args.size(); ++k) {
    const std::string& a = args[k];
    auto value = [&]() -> const std::string& {
      if (k + 1 >= args.size()) throw ConfigError(a + ": needs a value");
      return args[++k];
    };
    if (a == "--help" || a == "-h") {
      inv.help = true;
    } else if (a == "--version") {
      inv.version = true;
    } else if (a == "--config") {
      ++k;
    } else if (a == "--listen") {
      set_listen(value(), a, c);
    } else if (a == "--data-dir") {
      c.data_dir = value();
    } else if (a == "--threads") {
      c.threads = static_cast<int>(parse_integer(value(), a, 0, api::kMaxThreads));
    } else if (a == "--http-threads") {
      c.http_threads = static_cast<int>(parse_integer(value(), a, 1, 1024));
    } else if (a == "--token-file") {
      c.token_file = value();
    } else if (a == "--no-auth") {
      c.auth = false;
    } else if (a == "--max-body-bytes") {
      c.max_body_bytes = parse_integer(value(), a, 1024, kInt64Max);
    } else if (a == "--max-samples-per-job") {
      c.max_samples_per_job = parse_integer(value(), a, 1, kInt64Max);
    } else if (a == "--max-terrain-triangles") {
      c.max_terrain_triangles = parse_integer(value(), a, 2, kInt64Max);
    } else if (a == "--max-sites") {
      c.max_sites = parse_integer(value(), a, 1, kInt64Max);
    } else if (a == "--max-queued-jobs") {
      c.max_queued_jobs = parse_integer(value(), a, 1, kInt64Max);
    } else if (a == "--request-timeout-s") {
      c.request_timeout_s = parse_seconds(value(), a);
    } else if (a == "--job-nice") {
      c.job_nice = static_cast<int>(parse_integer(value(), a, 0, 19));
    } else if (a == "--keep-alive-s") {
      c.keep_alive_s = parse_seconds(value(), a);
    } else if (a == "--max-connections") {
      c.max_connections = parse_integer(value(), a, 1, 1'000'000);
    } else if (a == "--port-file") {
      c.port_file = value();
    } else if (a == "--log-level") {
      c.log_level = value();
      check_log_level(c.log_level, a);
    } else if (a == "--ui-dir") {
      c.ui_dir = value();
    } else if (a == "--no-ui") {
      c.ui = false;
    } else if (a == "--cors-origin") {
      c.cors_origins.push_back(checked_origin(value(), a));
    } else if (a == "--backend") {
      c.backend.kind = value();
    } else if (a == "--backend-shards") {
      c.backend.shards = static_cast<int>(parse_integer(value(), a, 1, 4096));
    } else if (a == "--backend-max-jobs") {
      c.backend.max_jobs = static_cast<int>(parse_integer(value(), a, 1, 10000));
    } else if (a == "--max-crashes") {
      c.max_crashes = static_cast<int>(parse_integer(value(), a, 1, 1000));
    } else if (a == "--retain-days") {
      c.retain_days = parse_days(value(), a);
    } else if (a == "--retain-bytes") {
      c.retain_bytes = parse_integer(value(), a, 0, kInt64Max);
    } else if (a == "--min-free-bytes") {
      c.min_free_bytes = parse_integer(value(), a, 0, kInt64Max);
    } else if (a == "--retain-interval-s") {
      c.retain_interval_s = parse_seconds(value(), a);
    } else {
      throw ConfigError(a + ": unknown option");
    }
  }
  return inv;
}

void check_config(const Config& c) {
  if (c.data_dir.empty()) throw ConfigError("--data-dir: must not be empty");
  if (!c.auth && !is_loopback_host(c.listen_host))
    throw ConfigError("--no-auth: refused while listening on " + c.listen_host +
                      " (authentication may only be off on a loopback address)");
  if (!c.ui_dir.empty() && !std::filesystem::is_regular_file(c.ui_dir + "/index.html"))
    throw ConfigError("--ui-dir: " + c.ui_dir + " holds no index.html (give the viewer/ folder)");
  if (c.auth) {
    if (c.token_file.empty())
      throw ConfigError("--token-file: required (or --no-auth on a loopback address)");
    if (read_tokens(c.token_file).empty())
      throw ConfigError("--token-file: " + c.token_file + " holds no token");
  }
}

const char* usage_text() {
  return "usage: fragsimd [options]\n"
         "       fragsimd backup DIR [--data-dir D | --config FILE]\n"
         "                           copy the data directory to DIR while the daemon runs\n"
         "                           (docs/operations.md)\n"
         "  --config FILE            JSON config file (keys: docs/http-api.md); flags override it\n"
         "  --listen HOST:PORT       address (default 127.0.0.1:8080; port 0 = any free port)\n"
         "  --data-dir DIR           queue, sites and results (default ./fragsimd-data)\n"
         "  --threads N              Monte Carlo threads per job (default: all cores)\n"
         "  --job-nice N             nice value of a job's threads, 0-19 (default 10)\n"
         "  --http-threads N         requests handled at once (default 64)\n"
         "  --max-connections N      open connections (default 4096; more get a 503)\n"
         "  --keep-alive-s S         close a connection idle this long (default 15)\n"
         "  --token-file FILE        bearer tokens, one per line (required unless --no-auth)\n"
         "  --no-auth                no authentication (only on a loopback address)\n"
         "  --max-body-bytes N       largest request body (default 268435456)\n"
         "  --max-samples-per-job N  (default 100000000)\n"
         "  --max-sites N            (default 100)\n"
         "  --max-terrain-triangles N  terrain triangles of one site (default 16777216)\n"
         "  --max-queued-jobs N      (default 1000)\n"
         "  --request-timeout-s S    a request must arrive within S of its first byte (default "
         "30)\n"
         "  --port-file FILE         write the bound port here once listening\n"
         "  --max-crashes N          fail a job after N daemon crashes while it ran (default 3)\n"
         "  --retain-days D          purge finished jobs D days after they finished (default 0: "
         "never)\n"
         "  --retain-bytes N         purge the earliest finished jobs while jobs/ holds more "
         "(default 0: no limit)\n"
         "  --retain-interval-s S    apply the two above at start and every S (default 600)\n"
         "  --min-free-bytes N       below N bytes free on the data directory's file system, "
         "refuse new jobs (507) and hold queued ones (default 536870912; 0: off)\n"
         "  --ui-dir DIR             serve the web viewer (/ui/) from DIR, not the copy built in\n"
         "  --no-ui                  serve no web viewer\n"
         "  --cors-origin ORIGIN     let pages of ORIGIN call the API (repeatable; none by "
         "default)\n"
         "  --backend KIND           where jobs run: local (default), mpi, slurm; a command "
         "backend\n"
         "                           and the options of each: config key \"backend\"\n"
         "  --backend-shards N       shards of each backend job (mpi default 2, slurm 4)\n"
         "  --backend-max-jobs N     backend jobs submitted at once (default 1)\n"
         "  --log-level LEVEL        debug | info | warn | error (default info)\n"
         "  --version, --help\n";
}

}  // namespace fragsim::server
