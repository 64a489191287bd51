#pragma once
// Loopback test support: fragsimd as a separate process (fork + exec of the built binary) on a
// free port, an HTTP client with the test's token, and the CLI for reference runs.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

// After Eigen-using headers: httplib.h pulls in <resolv.h> (macro `_res`).
#include <httplib.h>

namespace fragsim::server::testing {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

inline constexpr const char* kToken = "test-token-0123456789";

inline std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

inline fs::path source_path(const std::string& relative) {
  return fs::path(FRAGSIM_SOURCE_DIR) / relative;
}

// An empty directory of the test's own (process id and test name in its name).
inline fs::path fresh_dir(const std::string& prefix) {
  const fs::path dir = fs::temp_directory_path() /
                       (prefix + std::to_string(::getpid()) + "_" +
                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Runs a program to completion; returns its exit status (-1 when it did not exit normally).
inline int run_process(const std::vector<std::string>& argv, const fs::path& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::FILE* f = std::freopen(log.c_str(), "a", stderr);
    (void)f;
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class Daemon {
 public:
  // `dir` holds the data directory, the token file, the port file and the log.
  explicit Daemon(fs::path dir, std::vector<std::string> extra = {})
      : dir_(std::move(dir)), extra_(std::move(extra)) {
    write_text(dir_ / "tokens", std::string("# test tokens\n") + kToken + "\n");
  }
  ~Daemon() { kill(SIGKILL); }
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  void start() {
    fs::remove(dir_ / "port");
    pid_ = ::fork();
    if (pid_ == 0) {
      std::FILE* f = std::freopen((dir_ / "fragsimd.log").c_str(), "a", stderr);
      (void)f;
      std::vector<std::string> argv = {FRAGSIMD,
                                       "--listen",
                                       "127.0.0.1:0",
                                       "--data-dir",
                                       (dir_ / "data").string(),
                                       "--token-file",
                                       (dir_ / "tokens").string(),
                                       "--port-file",
                                       (dir_ / "port").string(),
                                       "--threads",
                                       "2",
                                       "--log-level",
                                       "debug"};
      argv.insert(argv.end(), extra_.begin(), extra_.end());
      std::vector<char*> args;
      for (auto& a : argv) args.push_back(a.data());
      args.push_back(nullptr);
      ::execv(args[0], args.data());
      ::_exit(127);
    }
    const auto deadline = Clock::now() + std::chrono::seconds(60);
    while (Clock::now() < deadline) {
      if (fs::exists(dir_ / "port")) {
        port_ = std::stoi(read_text(dir_ / "port"));
        return;
      }
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        FAIL() << "fragsimd exited at start; log:\n" << read_text(dir_ / "fragsimd.log");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    FAIL() << "fragsimd did not write its port file";
  }

  // Sends `sig` and waits for the process; returns its exit status (-1: killed by a signal).
  int kill(int sig) {
    if (pid_ <= 0) return -1;
    ::kill(pid_, sig);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  bool alive() const { return pid_ > 0 && ::kill(pid_, 0) == 0; }

  int port() const { return port_; }
  const fs::path& dir() const { return dir_; }
  fs::path data() const { return dir_ / "data"; }
  std::string log() const { return read_text(dir_ / "fragsimd.log"); }

  // A client with the test token (or `token`, "" for none).
  std::unique_ptr<httplib::Client> client(const std::string& token = kToken) const {
    auto c = std::make_unique<httplib::Client>("127.0.0.1", port_);
    if (!token.empty()) c->set_bearer_token_auth(token);
    c->set_read_timeout(std::chrono::seconds(120));
    c->set_connection_timeout(std::chrono::seconds(10));
    return c;
  }

 private:
  fs::path dir_;
  std::vector<std::string> extra_;
  pid_t pid_ = -1;
  int port_ = 0;
};

inline Json demo_scenario() {
  return Json::parse(read_text(source_path("examples/demo/scenario.json")));
}
inline Json minimal_scenario() {
  return Json::parse(read_text(source_path("examples/minimal/scenario.json")));
}

// POST /v1/sites with the scenario's inline site; returns the site id.
inline std::string upload_site(httplib::Client& c, const Json& scenario) {
  auto r = c.Post("/v1/sites", scenario.at("site").dump(), "application/json");
  EXPECT_TRUE(r);
  if (!r) return "";
  EXPECT_TRUE(r->status == 201 || r->status == 200) << r->status << " " << r->body;
  return Json::parse(r->body).at("site_id").get<std::string>();
}

// The scenario with its site replaced by site_id.
inline Json by_site_id(Json scenario, const std::string& site_id) {
  scenario.erase("site");
  scenario["site_id"] = site_id;
  return scenario;
}

inline std::string submit(httplib::Client& c, const Json& job) {
  auto r = c.Post("/v1/jobs", job.dump(), "application/json");
  EXPECT_TRUE(r);
  if (!r) return "";
  EXPECT_EQ(r->status, 202) << r->body;
  return Json::parse(r->body).at("job_id").get<std::string>();
}

inline Json job_status(httplib::Client& c, const std::string& id) {
  auto r = c.Get("/v1/jobs/" + id);
  if (!r || r->status != 200) return Json();
  return Json::parse(r->body);
}

// Polls until the job is in a final state (or the generous deadline passes: then it fails).
inline Json wait_final(httplib::Client& c, const std::string& id, int seconds = 600) {
  const auto deadline = Clock::now() + std::chrono::seconds(seconds);
  Json s;
  while (Clock::now() < deadline) {
    s = job_status(c, id);
    const std::string state = s.value("state", "");
    if (state == "done" || state == "failed" || state == "cancelled") return s;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ADD_FAILURE() << "job " << id << " did not finish; last status " << s.dump();
  return s;
}

}  // namespace fragsim::server::testing
