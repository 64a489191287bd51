#include "server/thread_nice.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "server/log.h"

namespace fragsim::server {

void lower_thread_priority(int nice) {
  if (nice <= 0) return;
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  if (::setpriority(PRIO_PROCESS, tid, nice) != 0)
    log(LogLevel::kWarn, "job priority not lowered", {{"error", std::strerror(errno)}});
}

}  // namespace fragsim::server
