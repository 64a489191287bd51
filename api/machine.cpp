// The machine description (machine.h).
#include "api/machine.h"

#include <sys/utsname.h>

#include <ctime>
#include <fstream>
#include <string>
#include <thread>

namespace fragsim::api {

namespace {

// The first "model name" of /proc/cpuinfo (Linux on x86; other systems name it otherwise).
std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) break;
    const auto start = line.find_first_not_of(" \t", colon + 1);
    return start == std::string::npos ? "" : line.substr(start);
  }
  return "";
}

}  // namespace

std::string utc_now_iso8601() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string machine_description() {
  struct utsname u {};
  const bool have_uname = uname(&u) == 0;
  std::string out = have_uname ? std::string(u.nodename) : std::string("unknown host");
  std::string sep = ": ";
  if (const std::string cpu = cpu_model(); !cpu.empty()) {
    out += sep + cpu;
    sep = ", ";
  }
  if (const unsigned n = std::thread::hardware_concurrency(); n > 0) {
    out += sep + std::to_string(n) + " CPUs";
    sep = ", ";
  }
  if (have_uname)
    out +=
        sep + std::string(u.sysname) + " " + std::string(u.release) + " " + std::string(u.machine);
  return out;
}

}  // namespace fragsim::api
