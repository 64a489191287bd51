// Printing a report page to PDF with headless chromium (report_pdf.h).
#include "report/report_pdf.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

namespace fragsim::report {

namespace {

namespace fs = std::filesystem;

// The flags: headless, no GPU, a throw-away profile, nothing fetched from any network (no
// host resolves, no proxy), time for the page's script to draw the figures.
std::vector<std::string> chromium_args(const std::string& chromium, const fs::path& html,
                                       const fs::path& pdf, const fs::path& profile) {
  return {chromium,
          "--headless",
          "--no-sandbox",  // run as root in containers; the page is fragsim's own
          "--disable-gpu",
          "--no-first-run",
          "--disable-extensions",
          "--disable-background-networking",
          "--disable-component-update",
          "--disable-sync",
          "--host-resolver-rules=MAP * ~NOTFOUND",
          "--proxy-server=127.0.0.1:9",
          "--user-data-dir=" + profile.string(),
          "--no-pdf-header-footer",
          "--virtual-time-budget=30000",
          "--print-to-pdf=" + pdf.string(),
          "file://" + fs::absolute(html).string()};
}

// The child's side of fork(): only async-signal-safe calls (the daemon forks from one of many
// threads; another may hold malloc's lock), so argv and the log path are prepared before.
[[noreturn]] void exec_child(char* const* argv, const char* log) {
  setpgid(0, 0);
  const int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0600);
  if (fd >= 0) {
    dup2(fd, STDOUT_FILENO);
    dup2(fd, STDERR_FILENO);
    close(fd);
  }
  execv(argv[0], argv);
  _exit(127);
}

// The last lines of the browser's output, for an error message.
std::string tail_of(const fs::path& log) {
  std::ifstream in(log);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lines.push_back(line);
  std::string out;
  for (std::size_t k = lines.size() > 3 ? lines.size() - 3 : 0; k < lines.size(); ++k)
    out += (out.empty() ? "" : " | ") + lines[k];
  return out.empty() ? "no output" : out;
}

// Ends what is left of the browser's process group (helpers it started) and reaps those that
// are our children: orphans become fragsimd's when it is PID 1 of a container. Waits up to 2 s.
void end_group(pid_t pgid) {
  kill(-pgid, SIGKILL);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  int status = 0;
  for (pid_t r; (r = waitpid(-pgid, &status, WNOHANG)) >= 0;) {
    if (r == 0 && std::chrono::steady_clock::now() > end) break;
    if (r == 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

int wait_for(pid_t pid, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > end) {
      end_group(pid);
      throw std::runtime_error("chromium did not finish the PDF within " +
                               std::to_string(timeout.count()) + " s");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return status;
}

bool is_pdf(const fs::path& pdf) {
  std::ifstream in(pdf, std::ios::binary);
  char head[5] = {};
  return in.read(head, 5) && std::string(head, 5) == "%PDF-";
}

}  // namespace

std::string chromium_path(const std::string& configured) {
  if (!configured.empty()) return configured;
  const char* env = std::getenv("CHROMIUM");
  return env != nullptr && *env != '\0' ? env : "/usr/bin/chromium";
}

void print_pdf(const fs::path& html, const fs::path& pdf, const std::string& chromium,
               std::chrono::seconds timeout) {
  if (access(chromium.c_str(), X_OK) != 0)
    throw std::runtime_error("no browser to print the PDF with at " + chromium +
                             " (apt-get install chromium, or set CHROMIUM)");
  char tmpl[] = "/tmp/fragsim-chromium-XXXXXX";
  if (mkdtemp(tmpl) == nullptr) throw std::runtime_error("cannot create a browser profile folder");
  const fs::path profile(tmpl);
  const fs::path log = profile / "chromium.log";
  const auto args = chromium_args(chromium, html, pdf, profile / "profile");
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const std::string log_path = log.string();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("cannot start chromium (fork failed)");
  if (pid == 0) exec_child(argv.data(), log_path.c_str());
  int status = 0;
  try {
    status = wait_for(pid, timeout);
  } catch (...) {
    std::error_code ec;
    fs::remove_all(profile, ec);
    throw;
  }
  end_group(pid);
  const std::string output = tail_of(log);
  std::error_code ec;
  fs::remove_all(profile, ec);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !is_pdf(pdf))
    throw std::runtime_error("chromium could not print the PDF (" +
                             (WIFEXITED(status) ? "exit " + std::to_string(WEXITSTATUS(status))
                                                : std::string("killed")) +
                             "): " + output);
}

}  // namespace fragsim::report
