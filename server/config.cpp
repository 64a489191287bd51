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
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "api/command_line.h"
#include "api/json_fields.h"
#include "api/scenario_json.h"

namespace fragsim::server {

namespace {

using Json = nlohmann::json;

constexpr std::int64_t kInt64Max = std::numeric_limits<std::int64_t>::max();

std::int64_t parse_integer(const std::string& text, const std::string& what, std::int64_t lo,
                           std::int64_t hi) {
  return api::integer_option(what, text, lo, hi);
}

double parse_seconds(const std::string& text, const std::string& what) {
  return api::number_option(what, text, "seconds", {0.0, true, 86400.0});
}

// Retention's age limit: days in [0, 36500] (0: none).
constexpr double kMaxRetainDays = 36500.0;

double parse_days(const std::string& text, const std::string& what) {
  return api::number_option(what, text, "days", {0.0, false, kMaxRetainDays}, " (0: no age limit)");
}

void set_listen(const std::string& text, const std::string& what, Config& c) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0)
    throw ConfigError(what + ": expected HOST:PORT, got \"" + text + "\"");
  std::string host = text.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);  // [::1]:8080
  const auto port = api::to_integer(std::string_view(text).substr(colon + 1));
  if (!port || *port < 0 || *port > 65535)
    throw ConfigError(what + ": expected HOST:PORT with a port in [0, 65535], got \"" + text +
                      "\"");
  c.listen_host = host;
  c.listen_port = static_cast<int>(*port);
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

// One setting of fragsimd: its config-file key, its flag ("--" and the key with '-' for '_',
// unless named otherwise; "" for a key without one) and how each form sets the Config. The range
// of a number is written once here, for both forms.
struct Setting {
  using FromText = std::function<void(const std::string& text, const std::string& flag, Config&)>;
  using FromJson = std::function<void(const Json& v, const std::string& key, Config&)>;
  std::string key;
  std::string flag;
  FromText from_text;  // null: no flag
  FromJson from_json;  // null: no key
};

std::string flag_of(const std::string& key) {
  std::string flag = "--" + key;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

template <class T>
Setting integer_setting(const std::string& key, T Config::*field, std::int64_t lo,
                        std::int64_t hi) {
  return {key, flag_of(key),
          [=](const std::string& text, const std::string& flag, Config& c) {
            c.*field = static_cast<T>(parse_integer(text, flag, lo, hi));
          },
          [=](const Json& v, const std::string& k, Config& c) {
            c.*field = static_cast<T>(api::read_integer(v, k, lo, hi));
          }};
}

Setting seconds_setting(const std::string& key, double Config::*field) {
  return {key, flag_of(key),
          [=](const std::string& text, const std::string& flag, Config& c) {
            c.*field = parse_seconds(text, flag);
          },
          [=](const Json& v, const std::string& k, Config& c) { c.*field = read_seconds(v, k); }};
}

Setting text_setting(const std::string& key, std::string Config::*field) {
  return {
      key, flag_of(key),
      [=](const std::string& text, const std::string&, Config& c) { c.*field = text; },
      [=](const Json& v, const std::string& k, Config& c) { c.*field = api::read_string(v, k); }};
}

// A key whose flag is a switch (--no-auth, --no-ui: see take_switch).
Setting boolean_key(const std::string& key, bool Config::*field) {
  return {key, "", nullptr,
          [=](const Json& v, const std::string& k, Config& c) { c.*field = api::read_bool(v, k); }};
}

// The settings whose value is more than a number or a name.
std::vector<Setting> checked_settings() {
  return {
      {"listen", "--listen", set_listen,
       [](const Json& v, const std::string& k, Config& c) {
         set_listen(api::read_string(v, k), k, c);
       }},
      {"log_level", "--log-level",
       [](const std::string& text, const std::string& flag, Config& c) {
         check_log_level(text, flag);
         c.log_level = text;
       },
       [](const Json& v, const std::string& k, Config& c) {
         c.log_level = api::read_string(v, k);
         check_log_level(c.log_level, k);
       }},
      {"retain_days", "--retain-days",
       [](const std::string& text, const std::string& flag, Config& c) {
         c.retain_days = parse_days(text, flag);
       },
       [](const Json& v, const std::string& k, Config& c) {
         c.retain_days = api::read_number(v, k);
         api::check_ge_le(c.retain_days, 0.0, kMaxRetainDays, k);
       }},
      {"cors_origins", "--cors-origin",  // the flag adds one origin; repeatable
       [](const std::string& text, const std::string& flag, Config& c) {
         c.cors_origins.push_back(checked_origin(text, flag));
       },
       [](const Json& v, const std::string& k, Config& c) {
         if (!v.is_array()) throw InputError(k, "expected array of origins");
         c.cors_origins.clear();
         for (std::size_t i = 0; i < v.size(); ++i) {
           const std::string at = api::index_path(k, i);
           c.cors_origins.push_back(checked_origin(api::read_string(v[i], at), at));
         }
       }},
  };
}

// The backend: the key takes a preset name or an object; the flags its kind and two numbers.
std::vector<Setting> backend_settings() {
  return {
      {"backend", "--backend",
       [](const std::string& text, const std::string&, Config& c) { c.backend.kind = text; },
       [](const Json& v, const std::string&, Config& c) { apply_backend(v, c.backend); }},
      {"", "--backend-shards",
       [](const std::string& text, const std::string& flag, Config& c) {
         c.backend.shards = static_cast<int>(parse_integer(text, flag, 1, 4096));
       },
       nullptr},
      {"", "--backend-max-jobs",
       [](const std::string& text, const std::string& flag, Config& c) {
         c.backend.max_jobs = static_cast<int>(parse_integer(text, flag, 1, 10000));
       },
       nullptr},
  };
}

// Every setting (docs/http-api.md, "Starting the daemon").
const std::vector<Setting>& settings() {
  static const std::vector<Setting> all = [] {
    std::vector<Setting> s = {
        text_setting("data_dir", &Config::data_dir),
        text_setting("token_file", &Config::token_file),
        text_setting("port_file", &Config::port_file),
        text_setting("ui_dir", &Config::ui_dir),
        integer_setting("threads", &Config::threads, 0, api::kMaxThreads),
        integer_setting("http_threads", &Config::http_threads, 1, 1024),
        integer_setting("job_nice", &Config::job_nice, 0, 19),
        integer_setting("max_connections", &Config::max_connections, 1, 1'000'000),
        integer_setting("max_body_bytes", &Config::max_body_bytes, 1024, kInt64Max),
        integer_setting("max_samples_per_job", &Config::max_samples_per_job, 1, kInt64Max),
        integer_setting("max_terrain_triangles", &Config::max_terrain_triangles, 2, kInt64Max),
        integer_setting("max_sites", &Config::max_sites, 1, kInt64Max),
        integer_setting("max_queued_jobs", &Config::max_queued_jobs, 1, kInt64Max),
        integer_setting("max_crashes", &Config::max_crashes, 1, 1000),
        integer_setting("retain_bytes", &Config::retain_bytes, 0, kInt64Max),
        integer_setting("min_free_bytes", &Config::min_free_bytes, 0, kInt64Max),
        seconds_setting("request_timeout_s", &Config::request_timeout_s),
        seconds_setting("keep_alive_s", &Config::keep_alive_s),
        seconds_setting("retain_interval_s", &Config::retain_interval_s),
        boolean_key("auth", &Config::auth),
        boolean_key("ui", &Config::ui),
    };
    for (auto* more : {checked_settings, backend_settings})
      for (Setting& x : more()) s.push_back(std::move(x));
    return s;
  }();
  return all;
}

// The settings' keys or flags (for "did you mean").
std::vector<std::string> names_of(std::string Setting::*name) {
  std::vector<std::string> names;
  for (const Setting& x : settings())
    if (!(x.*name).empty()) names.push_back(x.*name);
  return names;
}

// The flags without a value.
bool take_switch(api::ArgReader& r, Invocation& inv) {
  if (r.take_flag("--help", "-h")) {
    inv.help = true;
  } else if (r.take_flag("--version")) {
    inv.version = true;
  } else if (r.take_flag("--no-auth")) {
    inv.config.auth = false;
  } else if (r.take_flag("--no-ui")) {
    inv.config.ui = false;
  } else {
    return false;
  }
  return true;
}

// One pass over the flags into `inv`; the config files they name are collected, not read.
void read_flags(const std::vector<std::string>& args, Invocation& inv,
                std::vector<std::string>& config_files) {
  api::ArgReader r(args);
  while (!r.done()) {
    if (take_switch(r, inv)) continue;
    if (auto path = r.take_value("--config")) {
      config_files.push_back(std::move(*path));
      continue;
    }
    const std::string name = r.word().substr(0, r.word().find('='));
    const auto& all = settings();
    const auto it = std::find_if(all.begin(), all.end(),
                                 [&](const Setting& x) { return x.from_text && x.flag == name; });
    if (it == all.end()) {
      std::vector<std::string> flags = names_of(&Setting::flag);
      for (const char* f : {"--config", "--help", "--version", "--no-auth", "--no-ui"})
        flags.push_back(f);
      r.unknown_option(flags);
    }
    it->from_text(*r.take_value(name), name, inv.config);
  }
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
  const auto& all = settings();
  try {
    for (const auto& item : j.items()) {
      const std::string& k = item.key();
      const auto it = std::find_if(all.begin(), all.end(),
                                   [&](const Setting& x) { return x.from_json && x.key == k; });
      if (it == all.end()) {
        const std::string guess = api::suggest_key(k, names_of(&Setting::key));
        throw InputError(
            k, guess.empty() ? "unknown key" : "unknown key (did you mean \"" + guess + "\"?)");
      }
      it->from_json(item.value(), k, c);
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
  // The config files first, so that flags override them wherever they stand: a first pass finds
  // them (and checks every flag), the second sets the flags over what the files set.
  Invocation first_pass;
  std::vector<std::string> config_files;
  read_flags(args, first_pass, config_files);
  for (const std::string& path : config_files) apply_config_file(path, inv.config);
  std::vector<std::string> again;
  read_flags(args, inv, again);
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
         "  (a value follows its option, --threads 4, or joins it: --threads=4)\n"
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
