// fragsimd: the fragment-throw hazard analysis service. Holds sites in memory, queues jobs in
// SQLite, runs them on a thread pool, serves results over HTTP (docs/http-api.md).
//
// Exit codes: 0 after a clean shutdown (SIGINT/SIGTERM), 2 for a bad command line or config,
// 1 when the daemon cannot start (data directory, database, address in use).
#include <pthread.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>

#include "fragsim/version.h"
#include "server/backend.h"
#include "server/backup.h"
#include "server/config.h"
#include "server/http_server.h"
#include "server/log.h"
#include "server/service.h"

namespace {

using namespace fragsim::server;

// Written under a temporary name and renamed: a reader never sees a half-written port.
void write_port_file(const std::string& path, int port) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp);
    out << port << "\n";
    if (!out) throw std::runtime_error("cannot write --port-file " + path);
  }
  std::filesystem::rename(tmp, path);
}

// Every connection is a file descriptor; so are the database, the result files being written
// and the job's threads' files. A soft limit below --max-connections plus a margin is raised
// towards the hard limit (systemd and Docker default the soft limit to 1024).
void raise_open_file_limit(std::int64_t max_connections) {
  constexpr std::int64_t kMargin = 256;
  rlimit lim{};
  if (::getrlimit(RLIMIT_NOFILE, &lim) != 0) return;
  const auto wanted = static_cast<rlim_t>(max_connections + kMargin);
  if (lim.rlim_cur >= wanted) return;
  lim.rlim_cur = std::min(wanted, lim.rlim_max);
  ::setrlimit(RLIMIT_NOFILE, &lim);
  if (lim.rlim_cur < wanted)
    log(LogLevel::kWarn, "open-file limit below --max-connections",
        {{"limit", std::to_string(lim.rlim_cur)},
         {"max_connections", std::to_string(max_connections)}});
}

// `fragsimd backup DIR`: 0 when the backup is whole, 1 otherwise (nothing is left at DIR).
int backup(const std::string& data_dir, const std::string& target) {
  try {
    const BackupReport r = backup_data_dir(data_dir, target);
    std::cout << "fragsimd: backed up " << data_dir << " to " << target << ": " << r.sites
              << " sites, " << r.jobs << " jobs (" << r.done_jobs << " done, with their files), "
              << r.bytes << " bytes, store schema " << r.schema_version << "\n";
    for (const std::string& id : r.gone)
      std::cout << "fragsimd: job " << id << " was purged while the backup ran: left out\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "fragsimd: backup failed: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  Invocation inv;
  try {
    inv = parse_command_line(std::vector<std::string>(argv + 1, argv + argc));
    if (inv.help) {
      std::cout << usage_text();
      return 0;
    }
    if (inv.version) {
      std::cout << "fragsimd " << fragsim::kVersion << " (git " << fragsim::kGitSha << ")\n";
      return 0;
    }
    if (inv.backup_target) return backup(inv.config.data_dir, *inv.backup_target);
    check_config(inv.config);
    check_backend_config(inv.config.backend);
  } catch (const ConfigError& e) {
    std::cerr << "fragsimd: error: " << e.what() << "\n(see fragsimd --help)\n";
    return 2;
  }
  const Config& config = inv.config;
  set_log_level(parse_log_level(config.log_level));
  raise_open_file_limit(config.max_connections);

  // SIGINT/SIGTERM are taken by one thread with sigwait; every other thread (the scheduler, the
  // Monte Carlo workers, the HTTP pool) inherits the blocked mask.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  ::signal(SIGPIPE, SIG_IGN);  // a client that hangs up must not kill the daemon

  try {
    Service service(config);
    HttpServer http(service);
    const int port = http.bind();
    if (!config.port_file.empty()) write_port_file(config.port_file, port);
    log(LogLevel::kInfo, "listening",
        {{"address", config.listen_host + ":" + std::to_string(port)},
         {"data_dir", std::filesystem::absolute(config.data_dir).string()},
         {"auth", config.auth ? "bearer" : "off"},
         {"version", fragsim::kVersion}});

    if (!is_loopback_host(config.listen_host))
      log(LogLevel::kWarn, "plain HTTP beyond loopback: bearer tokens cross the network in clear",
          {{"advice", "put a TLS proxy in front (deploy/nginx/fragsimd.conf, docs/http-api.md)"}});

    std::thread signal_thread([&] {
      int sig = 0;
      sigwait(&stop_signals, &sig);
      log(LogLevel::kInfo, "stopping", {{"signal", sig == SIGINT ? "SIGINT" : "SIGTERM"}});
      http.stop();
    });
    const bool ok = http.run();
    if (!ok) {
      // The listener failed (not a signal): wake the signal thread so it can be joined.
      log(LogLevel::kError, "listener failed");
      ::kill(::getpid(), SIGTERM);
    }
    signal_thread.join();
    service.shutdown();  // the running job goes back to the queue
    log(LogLevel::kInfo, "stopped");
    return ok ? 0 : 1;
  } catch (const std::exception& e) {
    log(LogLevel::kError, "cannot start", {{"error", e.what()}});
    return 1;
  }
}
