// fragsimd configuration: command-line flags, the JSON config file (flags override it), the
// combination checks, token files.
#include "server/config.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "api/test_support.h"
#include "server/backend.h"

namespace fragsim::server {
namespace {

namespace fs = std::filesystem;
using Args = std::vector<std::string>;

// The ConfigError message of parsing `args`; "<no error>" when it parses.
std::string command_line_error(const Args& args) {
  try {
    parse_command_line(args);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "<no error>";
}

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.rfind(prefix, 0) == 0;
}

class ConfigFile : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_config_test_"); }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }
  std::string file_error(const std::string& text) {
    const std::string path = write("config.json", text);
    Config c;
    try {
      apply_config_file(path, c);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "<no error>";
  }

  fs::path dir_;
};

using ConfigCheck = ConfigFile;
using ConfigTokens = ConfigFile;

// ---- Command line ----

TEST(ConfigCommandLine, Defaults) {
  const Invocation inv = parse_command_line({});
  const Config& c = inv.config;
  EXPECT_FALSE(inv.help);
  EXPECT_FALSE(inv.version);
  EXPECT_EQ(c.listen_host, "127.0.0.1");
  EXPECT_EQ(c.listen_port, 8080);
  EXPECT_EQ(c.data_dir, "fragsimd-data");
  EXPECT_EQ(c.threads, 0);
  EXPECT_EQ(c.http_threads, 64);
  EXPECT_EQ(c.token_file, "");
  EXPECT_TRUE(c.auth);
  EXPECT_EQ(c.max_body_bytes, 268435456);
  EXPECT_EQ(c.max_samples_per_job, 100000000);
  EXPECT_EQ(c.max_sites, 100);
  EXPECT_EQ(c.max_queued_jobs, 1000);
  EXPECT_EQ(c.request_timeout_s, 30.0);
  EXPECT_EQ(c.port_file, "");
  EXPECT_EQ(c.log_level, "info");
  EXPECT_EQ(c.max_crashes, 3);
}

TEST(ConfigCommandLine, EveryFlag) {
  const Invocation inv = parse_command_line({"--listen",
                                             "0.0.0.0:9090",
                                             "--data-dir",
                                             "/var/lib/fragsimd",
                                             "--threads",
                                             "4",
                                             "--http-threads",
                                             "8",
                                             "--token-file",
                                             "/etc/fragsimd/tokens",
                                             "--max-body-bytes",
                                             "2048",
                                             "--max-samples-per-job",
                                             "5000",
                                             "--max-sites",
                                             "7",
                                             "--max-terrain-triangles",
                                             "5000",
                                             "--max-queued-jobs",
                                             "9",
                                             "--request-timeout-s",
                                             "2.5",
                                             "--port-file",
                                             "/tmp/port",
                                             "--log-level",
                                             "debug",
                                             "--max-crashes",
                                             "5"});
  const Config& c = inv.config;
  EXPECT_EQ(c.listen_host, "0.0.0.0");
  EXPECT_EQ(c.listen_port, 9090);
  EXPECT_EQ(c.data_dir, "/var/lib/fragsimd");
  EXPECT_EQ(c.threads, 4);
  EXPECT_EQ(c.http_threads, 8);
  EXPECT_EQ(c.token_file, "/etc/fragsimd/tokens");
  EXPECT_TRUE(c.auth);
  EXPECT_EQ(c.max_body_bytes, 2048);
  EXPECT_EQ(c.max_samples_per_job, 5000);
  EXPECT_EQ(c.max_sites, 7);
  EXPECT_EQ(c.max_terrain_triangles, 5000);
  EXPECT_EQ(c.max_queued_jobs, 9);
  EXPECT_EQ(c.request_timeout_s, 2.5);
  EXPECT_EQ(c.port_file, "/tmp/port");
  EXPECT_EQ(c.log_level, "debug");
  EXPECT_EQ(c.max_crashes, 5);
  EXPECT_FALSE(inv.help);
  EXPECT_FALSE(inv.version);
}

TEST(ConfigCommandLine, SwitchFlags) {
  EXPECT_FALSE(parse_command_line({"--no-auth"}).config.auth);
  EXPECT_TRUE(parse_command_line({"--help"}).help);
  EXPECT_TRUE(parse_command_line({"-h"}).help);
  EXPECT_TRUE(parse_command_line({"--version"}).version);
}

TEST(ConfigCommandLine, LaterFlagWins) {
  EXPECT_EQ(parse_command_line({"--threads", "2", "--threads", "6"}).config.threads, 6);
}

TEST(ConfigCommandLine, ListenForms) {
  Config c = parse_command_line({"--listen", "[::1]:8080"}).config;
  EXPECT_EQ(c.listen_host, "::1");
  EXPECT_EQ(c.listen_port, 8080);
  c = parse_command_line({"--listen", "127.0.0.1:0"}).config;
  EXPECT_EQ(c.listen_host, "127.0.0.1");
  EXPECT_EQ(c.listen_port, 0);
  c = parse_command_line({"--listen", "localhost:65535"}).config;
  EXPECT_EQ(c.listen_host, "localhost");
  EXPECT_EQ(c.listen_port, 65535);
  c = parse_command_line({"--listen", "[::]:1"}).config;
  EXPECT_EQ(c.listen_host, "::");
  EXPECT_EQ(c.listen_port, 1);
}

TEST(ConfigCommandLine, BadListenNamesTheFlag) {
  for (const char* bad : {"localhost", ":8080", "127.0.0.1:", "127.0.0.1:65536", "127.0.0.1:-1",
                          "127.0.0.1:http", "127.0.0.1:80x", "[::1]"}) {
    const std::string e = command_line_error({"--listen", bad});
    EXPECT_TRUE(starts_with(e, "--listen: ")) << bad << " -> " << e;
  }
}

TEST(ConfigCommandLine, BadValuesNameTheFlag) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--threads", "-1"},
      {"--threads", "1025"},
      {"--threads", "four"},
      {"--threads", "1.5"},
      {"--threads", ""},
      {"--http-threads", "0"},
      {"--http-threads", "1025"},
      {"--max-body-bytes", "1023"},
      {"--max-body-bytes", "99999999999999999999999"},
      {"--max-samples-per-job", "0"},
      {"--max-sites", "0"},
      {"--max-terrain-triangles", "1"},
      {"--max-queued-jobs", "-3"},
      {"--request-timeout-s", "0"},
      {"--request-timeout-s", "-1"},
      {"--request-timeout-s", "86401"},
      {"--request-timeout-s", "nan"},
      {"--request-timeout-s", "5s"},
      {"--log-level", "verbose"},
      {"--log-level", "INFO"},
      {"--max-crashes", "0"},
      {"--max-crashes", "1001"},
      {"--retain-days", "-1"},
      {"--retain-days", "36501"},
      {"--retain-days", "nan"},
      {"--retain-days", "7d"},
      {"--retain-bytes", "-1"},
      {"--retain-bytes", "1G"},
      {"--retain-interval-s", "0"},
  };
  for (const auto& [flag, value] : bad) {
    const std::string e = command_line_error({flag, value});
    EXPECT_TRUE(starts_with(e, flag + ": ")) << flag << " " << value << " -> " << e;
  }
}

TEST(ConfigCommandLine, RangeBoundsAreAccepted) {
  EXPECT_EQ(parse_command_line({"--threads", "1024"}).config.threads, 1024);
  EXPECT_EQ(parse_command_line({"--http-threads", "1"}).config.http_threads, 1);
  EXPECT_EQ(parse_command_line({"--max-body-bytes", "1024"}).config.max_body_bytes, 1024);
  EXPECT_EQ(parse_command_line({"--request-timeout-s", "86400"}).config.request_timeout_s, 86400.0);
  EXPECT_EQ(parse_command_line({"--max-crashes", "1"}).config.max_crashes, 1);
  EXPECT_EQ(parse_command_line({"--retain-days", "0"}).config.retain_days, 0.0);
  EXPECT_EQ(parse_command_line({"--retain-days", "36500"}).config.retain_days, 36500.0);
  EXPECT_EQ(parse_command_line({"--retain-days", "0.5"}).config.retain_days, 0.5);
  EXPECT_EQ(parse_command_line({"--retain-bytes", "0"}).config.retain_bytes, 0);
  EXPECT_EQ(parse_command_line({"--retain-bytes", "1000000000"}).config.retain_bytes, 1000000000);
  EXPECT_EQ(parse_command_line({"--retain-interval-s", "86400"}).config.retain_interval_s, 86400.0);
  for (const char* level : {"debug", "info", "warn", "error"})
    EXPECT_EQ(parse_command_line({"--log-level", level}).config.log_level, level);
}

TEST(ConfigCommandLine, MissingValueAndUnknownFlag) {
  EXPECT_EQ(command_line_error({"--threads"}), "--threads: needs a value");
  EXPECT_EQ(command_line_error({"--data-dir"}), "--data-dir: needs a value");
  EXPECT_EQ(command_line_error({"--config"}), "--config: needs a value");
  EXPECT_EQ(command_line_error({"--thread", "4"}),
            "--thread: unknown option (did you mean --threads?)");
  EXPECT_EQ(command_line_error({"--listen=", "x"}), "--listen: expected HOST:PORT, got \"\"");
  EXPECT_EQ(command_line_error({"serve"}), "serve: unknown option");
}

TEST(ConfigCommandLine, ValuesTakeBothSpellings) {
  const Config c = parse_command_line({"--threads=4", "--data-dir=/d", "--retain-days=0.5"}).config;
  EXPECT_EQ(c.threads, 4);
  EXPECT_EQ(c.data_dir, "/d");
  EXPECT_EQ(c.retain_days, 0.5);
  EXPECT_EQ(command_line_error({"--threads=x"}),
            "--threads: expected an integer in [0, 1024], got \"x\"");
  EXPECT_EQ(command_line_error({"--frobnicate=1"}), "--frobnicate: unknown option");
}

// A setting's range is written once for its flag and its config-file key: each bound is taken
// by both, one step beyond it refused by both.
TEST_F(ConfigFile, FlagAndKeyShareTheirRanges) {
  struct Edge {
    const char* key;
    const char* ok;
    const char* bad;
  };
  const Edge edges[] = {
      {"threads", "1024", "1025"},        {"http_threads", "1", "0"},
      {"job_nice", "19", "20"},           {"max_connections", "1000000", "1000001"},
      {"max_body_bytes", "1024", "1023"}, {"max_terrain_triangles", "2", "1"},
      {"max_crashes", "1000", "1001"},    {"retain_bytes", "0", "-1"},
      {"min_free_bytes", "0", "-1"},      {"request_timeout_s", "86400", "86401"},
      {"keep_alive_s", "86400", "0"},     {"retain_days", "36500", "36501"},
  };
  for (const Edge& e : edges) {
    std::string flag = std::string("--") + e.key;
    std::replace(flag.begin(), flag.end(), '_', '-');
    EXPECT_EQ(command_line_error({flag, e.ok}), "<no error>") << flag;
    EXPECT_TRUE(starts_with(command_line_error({flag, e.bad}), flag + ": ")) << flag;
    const std::string key = std::string("\"") + e.key + "\": ";
    EXPECT_EQ(file_error("{" + key + e.ok + "}"), "<no error>") << e.key;
    EXPECT_NE(file_error("{" + key + e.bad + "}").find(std::string(e.key) + ": "),
              std::string::npos)
        << e.key;
  }
}

TEST(ConfigCommandLine, UsageMentionsEveryFlag) {
  const std::string usage = usage_text();
  for (const char* flag : {"--config",
                           "--listen",
                           "--data-dir",
                           "--threads",
                           "--http-threads",
                           "--token-file",
                           "--no-auth",
                           "--max-body-bytes",
                           "--max-samples-per-job",
                           "--max-sites",
                           "--max-terrain-triangles",
                           "--max-queued-jobs",
                           "--request-timeout-s",
                           "--port-file",
                           "--max-crashes",
                           "--retain-days",
                           "--retain-bytes",
                           "--retain-interval-s",
                           "--log-level",
                           "--version",
                           "--help"})
    EXPECT_NE(usage.find(flag), std::string::npos) << flag;
}

// ---- Config file ----

TEST_F(ConfigFile, EveryKey) {
  const std::string path = write("fragsimd.json", R"({
    "listen": "[::1]:9000", "data_dir": "/srv/data", "threads": 3, "http_threads": 4,
    "token_file": "/etc/tokens", "auth": false, "max_body_bytes": 4096,
    "max_samples_per_job": 777, "max_sites": 5, "max_queued_jobs": 6,
    "request_timeout_s": 1.5, "log_level": "warn", "max_crashes": 2, "port_file": "/tmp/p",
    "retain_days": 30, "retain_bytes": 5000000000, "retain_interval_s": 60})");
  Config c;
  apply_config_file(path, c);
  EXPECT_EQ(c.listen_host, "::1");
  EXPECT_EQ(c.listen_port, 9000);
  EXPECT_EQ(c.data_dir, "/srv/data");
  EXPECT_EQ(c.threads, 3);
  EXPECT_EQ(c.http_threads, 4);
  EXPECT_EQ(c.token_file, "/etc/tokens");
  EXPECT_FALSE(c.auth);
  EXPECT_EQ(c.max_body_bytes, 4096);
  EXPECT_EQ(c.max_samples_per_job, 777);
  EXPECT_EQ(c.max_sites, 5);
  EXPECT_EQ(c.max_queued_jobs, 6);
  EXPECT_EQ(c.request_timeout_s, 1.5);
  EXPECT_EQ(c.log_level, "warn");
  EXPECT_EQ(c.max_crashes, 2);
  EXPECT_EQ(c.port_file, "/tmp/p");
  EXPECT_EQ(c.retain_days, 30.0);
  EXPECT_EQ(c.retain_bytes, 5000000000);
  EXPECT_EQ(c.retain_interval_s, 60.0);
}

TEST_F(ConfigFile, KeysNotGivenKeepTheirValues) {
  const std::string path = write("c.json", R"({"threads": 2})");
  Config c;
  c.data_dir = "kept";
  apply_config_file(path, c);
  EXPECT_EQ(c.threads, 2);
  EXPECT_EQ(c.data_dir, "kept");
  EXPECT_EQ(c.listen_port, 8080);
}

TEST_F(ConfigFile, DocumentedExampleIsAccepted) {
  const std::string path = write("example.json", R"({
  "listen": "0.0.0.0:8080",
  "data_dir": "/var/lib/fragsimd",
  "token_file": "/etc/fragsimd/tokens",
  "http_threads": 32,
  "max_body_bytes": 268435456,
  "log_level": "info"
})");
  Config c;
  apply_config_file(path, c);
  EXPECT_EQ(c.listen_host, "0.0.0.0");
  EXPECT_EQ(c.data_dir, "/var/lib/fragsimd");
}

TEST_F(ConfigFile, UnknownKeyWithSuggestion) {
  const std::string e = file_error(R"({"listn": "127.0.0.1:1"})");
  EXPECT_NE(e.find("listn: unknown key (did you mean \"listen\"?)"), std::string::npos) << e;
  EXPECT_NE(e.find("config.json"), std::string::npos) << e;  // names the file
  const std::string e2 = file_error(R"({"max_site": 3})");
  EXPECT_NE(e2.find("did you mean \"max_sites\"?"), std::string::npos) << e2;
  const std::string e3 = file_error(R"({"colour": "blue"})");
  EXPECT_NE(e3.find("colour: unknown key"), std::string::npos) << e3;
  EXPECT_EQ(e3.find("did you mean"), std::string::npos) << e3;
}

TEST_F(ConfigFile, BadValuesNameTheKey) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"threads", R"("4")"},
      {"threads", "-1"},
      {"http_threads", "0"},
      {"auth", R"("no")"},
      {"max_body_bytes", "10"},
      {"max_sites", "0"},
      {"request_timeout_s", "0"},
      {"log_level", R"("loud")"},
      {"max_crashes", "0"},
      {"listen", R"("nowhere")"},
      {"listen", "8080"},
      {"data_dir", "1"},
      {"max_samples_per_job", "1.5"},
      {"token_file", "null"},
      {"retain_days", "-0.5"},
      {"retain_days", R"("30")"},
      {"retain_bytes", "-1"},
      {"retain_bytes", "1.5"},
      {"retain_interval_s", "0"},
  };
  for (const auto& [key, value] : bad) {
    const std::string e = file_error("{\"" + key + "\": " + value + "}");
    EXPECT_NE(e, "<no error>") << key;
    EXPECT_NE(e.find(": " + key + ": "), std::string::npos) << key << " " << value << " -> " << e;
  }
}

TEST_F(ConfigFile, NotAnObjectOrNotJson) {
  EXPECT_NE(file_error("[1, 2]"), "<no error>");
  EXPECT_NE(file_error("{\"threads\": 2"), "<no error>");
  EXPECT_NE(file_error(R"({"threads": 2, "threads": 3})"), "<no error>");  // duplicate key
  Config c;
  EXPECT_THROW(apply_config_file((dir_ / "missing.json").string(), c), ConfigError);
}

TEST_F(ConfigFile, FlagsOverrideTheFileWhateverTheOrder) {
  const std::string path = write("c.json", R"({"threads": 7, "max_sites": 11, "listen":
      "10.0.0.1:1234", "auth": false, "log_level": "error"})");
  for (const Args& args : {Args{"--config", path, "--threads", "3", "--listen", "127.0.0.1:99"},
                           Args{"--threads", "3", "--listen", "127.0.0.1:99", "--config", path},
                           Args{"--threads", "3", "--config", path, "--listen", "127.0.0.1:99"}}) {
    const Config c = parse_command_line(args).config;
    EXPECT_EQ(c.threads, 3);
    EXPECT_EQ(c.listen_host, "127.0.0.1");
    EXPECT_EQ(c.listen_port, 99);
    EXPECT_EQ(c.max_sites, 11);  // from the file
    EXPECT_FALSE(c.auth);        // from the file
    EXPECT_EQ(c.log_level, "error");
  }
}

TEST_F(ConfigFile, ConfigFileErrorsComeThroughTheCommandLine) {
  const std::string path = write("c.json", R"({"threads": "many"})");
  EXPECT_THROW(parse_command_line({"--config", path}), ConfigError);
  EXPECT_THROW(parse_command_line({"--config", (dir_ / "absent.json").string()}), ConfigError);
}

// ---- The web viewer and CORS (docs/viewer.md) ----

TEST(ConfigCommandLine, ViewerAndCorsFlags) {
  const Config d = parse_command_line({}).config;
  EXPECT_TRUE(d.ui);
  EXPECT_TRUE(d.ui_dir.empty());
  EXPECT_TRUE(d.cors_origins.empty());  // CORS off by default
  const Config c =
      parse_command_line({"--ui-dir", "/src/viewer", "--cors-origin", "https://hazx.example.org",
                          "--cors-origin", "http://127.0.0.1:3000", "--no-ui"})
          .config;
  EXPECT_EQ(c.ui_dir, "/src/viewer");
  EXPECT_FALSE(c.ui);
  EXPECT_EQ(c.cors_origins,
            (std::vector<std::string>{"https://hazx.example.org", "http://127.0.0.1:3000"}));
  for (const char* bad : {"hazx.example.org", "https://hazx.example.org/", "ftp://x", "https://",
                          "https://a b", "*", "https://x/path"}) {
    const std::string e = command_line_error({"--cors-origin", bad});
    EXPECT_TRUE(starts_with(e, "--cors-origin: expected an origin")) << bad << ": " << e;
  }
}

TEST_F(ConfigFile, ViewerAndCorsKeys) {
  Config c;
  apply_config_file(write("c.json", R"({"ui": false, "ui_dir": "/v",
      "cors_origins": ["https://a.example", "http://[::1]:8000"]})"),
                    c);
  EXPECT_FALSE(c.ui);
  EXPECT_EQ(c.ui_dir, "/v");
  EXPECT_EQ(c.cors_origins, (std::vector<std::string>{"https://a.example", "http://[::1]:8000"}));
  const std::string e = file_error(R"({"cors_origins": ["https://a.example", "a.example"]})");
  EXPECT_NE(e.find("cors_origins[1]: expected an origin"), std::string::npos) << e;
  EXPECT_NE(
      file_error(R"({"cors_origins": "https://a.example"})").find("cors_origins: expected array"),
      std::string::npos);
}

TEST(ConfigCommandLine, BackendFlags) {
  EXPECT_EQ(parse_command_line({}).config.backend.kind, "local");
  const Config c =
      parse_command_line({"--backend", "mpi", "--backend-shards", "6", "--backend-max-jobs", "3"})
          .config;
  EXPECT_EQ(c.backend.kind, "mpi");
  EXPECT_EQ(c.backend.shards, 6);
  EXPECT_EQ(c.backend.max_jobs, 3);
  EXPECT_TRUE(starts_with(command_line_error({"--backend-shards", "0"}), "--backend-shards: "));
  const std::string usage = usage_text();
  for (const char* flag : {"--backend", "--backend-shards", "--backend-max-jobs"})
    EXPECT_NE(usage.find(flag), std::string::npos) << flag;
}

TEST_F(ConfigFile, BackendKey) {
  Config c;
  apply_config_file(write("c.json", R"({"backend": {"kind": "command", "shards": 3,
      "max_jobs": 2, "threads": 1, "fragsim": "/opt/fragsim",
      "submit": ["/bin/sh", "submit.sh", "{shard_script}", "{shards}"],
      "run": ["{fragsim}", "run", "{scenario}", "--out", "{shard_dir}", "--shard", "{shard}/{shards}"],
      "track": "queue", "status": ["qstat", "{ids}"], "cancel": ["qdel", "{ids}"],
      "mpirun": ["mpirun", "--oversubscribe"], "sbatch": ["sbatch", "-p", "x"],
      "env": {"OMP_NUM_THREADS": "1"}, "poll_interval_s": 0.25, "status_interval_s": 5,
      "lost_after_s": 60, "submit_timeout_s": 30, "keep_workdir": true,
      "fragsim_mpi": "/opt/fragsim/bin/fragsim-mpi", "divide_precision": false}})"),
                    c);
  const BackendConfig& b = c.backend;
  EXPECT_EQ(b.kind, "command");
  EXPECT_EQ(b.shards, 3);
  EXPECT_EQ(b.max_jobs, 2);
  EXPECT_EQ(b.threads, 1);
  EXPECT_EQ(b.fragsim, "/opt/fragsim");
  EXPECT_EQ(b.submit.size(), 4u);
  EXPECT_EQ(b.run.size(), 7u);
  EXPECT_EQ(b.track, "queue");
  EXPECT_EQ(b.status, (std::vector<std::string>{"qstat", "{ids}"}));
  EXPECT_EQ(b.cancel, (std::vector<std::string>{"qdel", "{ids}"}));
  EXPECT_EQ(b.mpirun, (std::vector<std::string>{"mpirun", "--oversubscribe"}));
  EXPECT_EQ(b.sbatch, (std::vector<std::string>{"sbatch", "-p", "x"}));
  EXPECT_EQ(b.env, (std::vector<std::pair<std::string, std::string>>{{"OMP_NUM_THREADS", "1"}}));
  EXPECT_EQ(b.poll_interval_s, 0.25);
  EXPECT_EQ(b.status_interval_s, 5.0);
  EXPECT_EQ(b.lost_after_s, 60.0);
  EXPECT_EQ(b.submit_timeout_s, 30.0);
  EXPECT_TRUE(b.keep_workdir);
  EXPECT_EQ(b.fragsim_mpi, "/opt/fragsim/bin/fragsim-mpi");
  EXPECT_FALSE(b.divide_precision);
  EXPECT_TRUE(BackendConfig{}.divide_precision);

  Config preset;
  apply_config_file(write("p.json", R"({"backend": "slurm"})"), preset);
  EXPECT_EQ(preset.backend.kind, "slurm");

  EXPECT_NE(file_error(R"({"backend": {"shard": 2}})")
                .find("backend.shard: unknown key (did you mean \"shards\"?)"),
            std::string::npos)
      << file_error(R"({"backend": {"shard": 2}})");
  EXPECT_NE(file_error(R"({"backend": {"submit": "sbatch x"}})")
                .find("backend.submit: expected an array"),
            std::string::npos);
  EXPECT_NE(file_error(R"({"backend": {"env": {"1X": "a"}}})").find("not an environment variable"),
            std::string::npos);
  EXPECT_NE(file_error(R"({"backend": 3})").find("backend: expected a backend name or an object"),
            std::string::npos);
}

TEST_F(ConfigCheck, BackendIsResolvedAtStart) {
  Config c;
  c.auth = false;
  c.backend.kind = "command";
  c.backend.shards = 2;
  EXPECT_NO_THROW(check_config(c)) << "the backend is resolved by check_backend_config";
  try {
    check_backend_config(c.backend);
    ADD_FAILURE() << "a command backend without submit was accepted";
  } catch (const ConfigError& e) {
    EXPECT_TRUE(starts_with(e.what(), "backend.submit: ")) << e.what();
  }
  c.backend.kind = "mpi";
  EXPECT_NO_THROW(check_backend_config(c.backend));
}

TEST_F(ConfigCheck, UiDirMustHoldTheViewer) {
  Config c;
  c.auth = false;
  c.ui_dir = (dir_ / "nothing").string();
  try {
    check_config(c);
    ADD_FAILURE() << "accepted a folder without index.html";
  } catch (const ConfigError& e) {
    EXPECT_TRUE(starts_with(e.what(), "--ui-dir: ")) << e.what();
  }
  write("index.html", "<!doctype html>");
  c.ui_dir = dir_.string();
  EXPECT_NO_THROW(check_config(c));
}

// ---- check_config ----

TEST_F(ConfigCheck, NoAuthOnlyOnLoopback) {
  Config c;
  c.auth = false;
  for (const char* host : {"127.0.0.1", "127.1.2.3", "localhost", "::1"}) {
    c.listen_host = host;
    EXPECT_NO_THROW(check_config(c)) << host;
  }
  for (const char* host : {"0.0.0.0", "::", "192.168.1.10", "10.0.0.1", "example.com"}) {
    c.listen_host = host;
    try {
      check_config(c);
      ADD_FAILURE() << host << ": accepted";
    } catch (const ConfigError& e) {
      EXPECT_TRUE(starts_with(e.what(), "--no-auth: ")) << e.what();
    }
  }
}

TEST_F(ConfigCheck, NoAuthOnTheCommandLineIsRefusedOnAnyAddress) {
  const Config c = parse_command_line({"--no-auth", "--listen", "0.0.0.0:8080"}).config;
  EXPECT_THROW(check_config(c), ConfigError);
  const Config ok = parse_command_line({"--no-auth", "--listen", "[::1]:8080"}).config;
  EXPECT_NO_THROW(check_config(ok));
}

TEST_F(ConfigCheck, AuthNeedsANonEmptyTokenFile) {
  Config c;  // auth on by default
  try {
    check_config(c);
    ADD_FAILURE() << "accepted without a token file";
  } catch (const ConfigError& e) {
    EXPECT_TRUE(starts_with(e.what(), "--token-file: ")) << e.what();
  }
  c.token_file = write("empty", "");
  EXPECT_THROW(check_config(c), ConfigError);
  c.token_file = write("comments", "# only a comment\n\n   \n  # another\n");
  EXPECT_THROW(check_config(c), ConfigError);
  c.token_file = (dir_ / "missing").string();
  EXPECT_THROW(check_config(c), ConfigError);
  c.token_file = write("tokens", "# ops\nsecret-token\n");
  EXPECT_NO_THROW(check_config(c));
  c.listen_host = "0.0.0.0";  // any address with auth on
  EXPECT_NO_THROW(check_config(c));
}

TEST_F(ConfigCheck, EmptyDataDirIsRefused) {
  Config c;
  c.auth = false;
  c.data_dir = "";
  EXPECT_THROW(check_config(c), ConfigError);
}

TEST(ConfigLoopback, Hosts) {
  EXPECT_TRUE(is_loopback_host("127.0.0.1"));
  EXPECT_TRUE(is_loopback_host("127.255.0.9"));
  EXPECT_TRUE(is_loopback_host("localhost"));
  EXPECT_TRUE(is_loopback_host("::1"));
  EXPECT_FALSE(is_loopback_host("0.0.0.0"));
  EXPECT_FALSE(is_loopback_host("::"));
  EXPECT_FALSE(is_loopback_host("128.0.0.1"));
  EXPECT_FALSE(is_loopback_host("1.127.0.0"));
  EXPECT_FALSE(is_loopback_host(""));
}

// A host name that merely starts with "127." is not a 127.x.x.x address: it resolves through DNS
// to anything, so --no-auth is refused on it.
TEST(ConfigLoopback, HostNameStartingWith127IsNotLoopback) {
  EXPECT_FALSE(is_loopback_host("127.attacker.example"));
  Config c;
  c.auth = false;
  c.listen_host = "127.attacker.example";
  EXPECT_THROW(check_config(c), ConfigError);
}

// ---- Tokens ----

TEST_F(ConfigTokens, CommentsBlankLinesAndWhitespace) {
  const std::string path = write("tokens",
                                 "# fragsimd tokens\n"
                                 "\n"
                                 "  alpha  \n"
                                 "\tbeta\t\r\n"
                                 "   # indented comment\n"
                                 "gamma delta\n"
                                 "   \n"
                                 "last-without-newline");
  EXPECT_EQ(read_tokens(path), (std::vector<Token>{{"alpha", Role::kAdmin},
                                                   {"beta", Role::kAdmin},
                                                   {"gamma delta", Role::kAdmin},
                                                   {"last-without-newline", Role::kAdmin}}));
}

TEST_F(ConfigTokens, CrlfFile) {
  const std::string path = write("tokens", "one\r\ntwo submit\r\n");
  EXPECT_EQ(read_tokens(path), (std::vector<Token>{{"one", Role::kAdmin}, {"two", Role::kSubmit}}));
}

// A role after the token (the last word: read, submit or admin); without one, admin, as every
// token was before roles; a last word that is not a role is part of the token.
TEST_F(ConfigTokens, RolesAfterTheToken) {
  const std::string path = write("tokens",
                                 "wall-screen read\n"
                                 "front-end\tsubmit\n"
                                 "  operator   admin  \n"
                                 "old-token\n"
                                 "two words\n"
                                 "a token read submit\n"
                                 "READ\n"
                                 "x Read\n");
  EXPECT_EQ(read_tokens(path), (std::vector<Token>{{"wall-screen", Role::kRead},
                                                   {"front-end", Role::kSubmit},
                                                   {"operator", Role::kAdmin},
                                                   {"old-token", Role::kAdmin},
                                                   {"two words", Role::kAdmin},
                                                   {"a token read", Role::kSubmit},
                                                   {"READ", Role::kAdmin},
                                                   {"x Read", Role::kAdmin}}));
  for (const Role r : {Role::kRead, Role::kSubmit, Role::kAdmin})
    EXPECT_EQ(parse_role(role_name(r)), r);
  EXPECT_FALSE(parse_role("Admin"));
  EXPECT_FALSE(parse_role(""));
}

TEST_F(ConfigTokens, EmptyAndMissing) {
  EXPECT_TRUE(read_tokens(write("empty", "")).empty());
  EXPECT_TRUE(read_tokens(write("blank", "\n\n#x\n")).empty());
  EXPECT_THROW(read_tokens((dir_ / "missing").string()), ConfigError);
}

}  // namespace
}  // namespace fragsim::server
