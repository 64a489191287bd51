#include "server/child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace fragsim::server {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

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

}  // namespace

// Field 22 of /proc/<pid>/stat: when the process started (clock ticks since boot); 0 if none.
std::uint64_t process_start_time(pid_t pid) {
  std::ifstream file("/proc/" + std::to_string(pid) + "/stat");
  const std::string stat((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
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

}  // namespace fragsim::server
