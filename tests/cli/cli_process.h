#pragma once
// The `fragsim` executable (FRAGSIM_CLI) as a subprocess for the cli tests: stdout and stderr go
// to files in the test's directory and are read back with the exit code.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "api/test_support.h"

namespace fragsim::cli::testing {

struct CliResult {
  int exit_code = -1;  // -1 when killed by a signal
  std::string out;
  std::string err;
};

// Starts the CLI with `args`; its output goes to dir/stdout.txt and dir/stderr.txt.
inline pid_t spawn_cli(const std::filesystem::path& dir, const std::vector<std::string>& args) {
  const std::string out = (dir / "stdout.txt").string(), err = (dir / "stderr.txt").string();
  std::vector<std::string> argv_s = {FRAGSIM_CLI};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fo = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int fe = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fo, STDOUT_FILENO);
    ::dup2(fe, STDERR_FILENO);
    ::execv(FRAGSIM_CLI, argv.data());
    ::_exit(127);
  }
  return pid;
}

// Waits for a process spawn_cli started in `dir` and reads its output.
inline CliResult wait_cli(const std::filesystem::path& dir, pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = api::testing::read_text(dir / "stdout.txt");
  r.err = api::testing::read_text(dir / "stderr.txt");
  return r;
}

// A test with a fresh directory of its own (named by `prefix`, removed afterwards) in which the
// CLI runs as a subprocess.
class CliDirTest : public ::testing::Test {
 protected:
  explicit CliDirTest(std::string prefix) : prefix_(std::move(prefix)) {}
  void SetUp() override { dir_ = api::testing::fresh_test_dir(prefix_); }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  pid_t spawn(const std::vector<std::string>& args) { return spawn_cli(dir_, args); }
  CliResult wait(pid_t pid) { return wait_cli(dir_, pid); }
  CliResult run(const std::vector<std::string>& args) { return wait(spawn(args)); }

  std::filesystem::path dir_;

 private:
  std::string prefix_;
};

}  // namespace fragsim::cli::testing
