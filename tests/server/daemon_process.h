#pragma once
// fragsimd as a separate process (fork + exec of the built binary, FRAGSIMD) on a free loopback
// port, with a token file, and an HTTP client carrying that token. No gtest here: the loopback
// tests (daemon_support.h) and bench/bench_daemon.cpp both use it.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

// After Eigen-using headers: httplib.h pulls in <resolv.h> (macro `_res`).
#include <httplib.h>

namespace fragsim::server::testing {

namespace fs = std::filesystem;
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

// Runs a program to completion, its output (stdout and stderr) appended to `log`; returns its
// exit status (-1 when it did not exit normally).
inline int run_process(const std::vector<std::string>& argv, const fs::path& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::FILE* f = std::freopen(log.c_str(), "a", stderr);
    std::FILE* g = std::freopen(log.c_str(), "a", stdout);
    (void)f;
    (void)g;
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
  // `extra`: more fragsimd flags. `dir` holds the data directory, the token file, the port file and
  // the log.
  explicit Daemon(fs::path dir, std::vector<std::string> extra = {})
      : dir_(std::move(dir)), extra_(std::move(extra)) {
    // A server that answers before reading a whole body (413, 411) closes the connection under
    // a client still sending: the write must fail, not kill the test with SIGPIPE.
    ::signal(SIGPIPE, SIG_IGN);
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
      std::vector<std::string> argv = wrapper_;
      const std::vector<std::string> daemon = {
          FRAGSIMD, "--listen", "127.0.0.1:0", "--data-dir", (dir_ / "data").string(),
          "--token-file", (dir_ / "tokens").string(), "--port-file", (dir_ / "port").string(),
          "--threads", "2", "--log-level", "debug",
          // The CI machine's disk runs close to full while
          // the sanitizer builds sit beside the tests.
          "--min-free-bytes", "16777216"};
      argv.insert(argv.end(), daemon.begin(), daemon.end());
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
        throw std::runtime_error("fragsimd exited at start; log:\n" +
                                 read_text(dir_ / "fragsimd.log"));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    throw std::runtime_error("fragsimd did not write its port file");
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

  // A command the daemon is started under (e.g. unshare, to run it as PID 1); pid() is then
  // the wrapper's.
  void set_wrapper(std::vector<std::string> wrapper) { wrapper_ = std::move(wrapper); }

  int port() const { return port_; }
  pid_t pid() const { return pid_; }
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
  std::vector<std::string> wrapper_;
  pid_t pid_ = -1;
  int port_ = 0;
};

}  // namespace fragsim::server::testing
