// fragsimd under load (docs/benchmarks.md §5):
//  1. overhead of running the demo job through the daemon against `fragsim run` on the same
//     scenario: wall time from submission until the job is seen done (polling every 10 ms), and
//     the run's own wall time (summary timing.wall_s), best of N each;
//  2. latency of status and result requests (p50, p99, max) while the demo job runs and
//     --clients clients poll, each waiting --interval-ms between requests (0: flat out).
//
//   build/bench/bench_daemon [--repeat N] [--clients K] [--interval-ms MS] [--threads T]
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>

#include "tests/server/daemon_process.h"

namespace {

using namespace fragsim::server::testing;
using Json = nlohmann::json;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// VmRSS and VmHWM (peak) of a process, MiB, from /proc.
std::pair<double, double> memory_mib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  double rss = 0, hwm = 0;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) rss = std::atof(line.c_str() + 6) / 1024.0;
    if (line.rfind("VmHWM:", 0) == 0) hwm = std::atof(line.c_str() + 6) / 1024.0;
  }
  return {rss, hwm};
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(k, v.size() - 1)];
}

Json get_json(httplib::Client& c, const std::string& path) {
  auto r = c.Get(path);
  if (!r || r->status != 200) throw std::runtime_error("GET " + path + " failed");
  return Json::parse(r->body);
}

std::string submit(httplib::Client& c, const Json& job) {
  auto r = c.Post("/v1/jobs", job.dump(), "application/json");
  if (!r || r->status != 202) throw std::runtime_error("POST /v1/jobs failed");
  return Json::parse(r->body).at("job_id").get<std::string>();
}

Json wait_done(httplib::Client& c, const std::string& id) {
  while (true) {
    Json s = get_json(c, "/v1/jobs/" + id);
    const std::string state = s.at("state").get<std::string>();
    if (state == "done") return s;
    if (state == "failed" || state == "cancelled") throw std::runtime_error("job " + state);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  int clients = 50;
  int threads = 0;
  int interval_ms = 100;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--repeat" && k + 1 < argc) {
      repeat = std::atoi(argv[++k]);
    } else if (a == "--clients" && k + 1 < argc) {
      clients = std::atoi(argv[++k]);
    } else if (a == "--interval-ms" && k + 1 < argc) {
      interval_ms = std::atoi(argv[++k]);
    } else if (a == "--threads" && k + 1 < argc) {
      threads = std::atoi(argv[++k]);
    } else {
      std::cerr << "usage: bench_daemon [--repeat N] [--clients K] [--interval-ms MS] "
                   "[--threads T]\n";
      return 2;
    }
  }
  const unsigned hw = std::thread::hardware_concurrency();
  if (threads <= 0) threads = static_cast<int>(hw > 0 ? hw : 1);

  const fs::path dir = fs::temp_directory_path() / ("bench_daemon_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Json demo = Json::parse(read_text(source_path("examples/demo/scenario.json")));
  write_text(dir / "demo.json", demo.dump());

  // 1. CLI reference.
  double cli_best = 1e300, cli_run_best = 1e300;
  for (int k = 0; k < repeat; ++k) {
    const auto t0 = Clock::now();
    const int rc = run_process({FRAGSIM_CLI, "run", (dir / "demo.json").string(), "--out",
                                (dir / ("cli" + std::to_string(k))).string(), "--quiet",
                                "--threads", std::to_string(threads)},
                               dir / "cli.log");
    const double wall = seconds_since(t0);
    if (rc != 0) {
      std::cerr << "fragsim run failed; see " << (dir / "cli.log") << "\n";
      return 1;
    }
    const Json s = Json::parse(read_text(dir / ("cli" + std::to_string(k)) / "summary.json"));
    cli_best = std::min(cli_best, wall);
    cli_run_best = std::min(cli_run_best, s["timing"]["wall_s"].get<double>());
  }

  Daemon d(dir, {"--threads", std::to_string(threads), "--log-level", "warn"});
  d.start();
  const auto [idle_rss, idle_hwm] = memory_mib(d.pid());
  auto c = d.client();
  auto site = c->Post("/v1/sites", demo["site"].dump(), "application/json");
  if (!site || site->status >= 300) throw std::runtime_error("POST /v1/sites failed");
  Json job = demo;
  job.erase("site");
  job["site_id"] = Json::parse(site->body)["site_id"];
  const auto [site_rss, site_hwm] = memory_mib(d.pid());

  double daemon_best = 1e300, daemon_run_best = 1e300;
  std::string done_id;
  for (int k = 0; k < repeat; ++k) {
    const auto t0 = Clock::now();
    done_id = submit(*c, job);
    wait_done(*c, done_id);
    const double wall = seconds_since(t0);
    const Json s = get_json(*c, "/v1/jobs/" + done_id + "/summary");
    daemon_best = std::min(daemon_best, wall);
    daemon_run_best = std::min(daemon_run_best, s["timing"]["wall_s"].get<double>());
  }
  std::printf("demo job, %d threads, best of %d\n", threads, repeat);
  std::printf("  fragsim run (process: parse, build, run, write) %8.3f s   run %8.3f s\n", cli_best,
              cli_run_best);
  std::printf("  fragsimd (submit until seen done)               %8.3f s   run %8.3f s\n",
              daemon_best, daemon_run_best);
  std::printf("  overhead: end to end %+.1f %%, run alone %+.1f %%\n",
              100.0 * (daemon_best / cli_best - 1.0),
              100.0 * (daemon_run_best / cli_run_best - 1.0));
  const auto [jobs_rss, jobs_hwm] = memory_mib(d.pid());
  std::printf(
      "  daemon memory (MiB): started %.1f; demo site loaded %.1f (peak %.1f); after %d "
      "jobs %.1f (peak %.1f)\n",
      idle_rss, site_rss, site_hwm, repeat, jobs_rss, jobs_hwm);
  (void)idle_hwm;

  // 2. Latency under polling while the job runs.
  std::mutex m;
  std::vector<double> status_s, summary_s, buildings_s;
  std::atomic<bool> stop{false};
  std::atomic<int> errors{0};
  const auto t0 = Clock::now();
  const std::string running = submit(*c, job);
  std::vector<std::thread> pool;
  for (int k = 0; k < clients; ++k) {
    pool.emplace_back([&, k] {
      auto client = d.client();
      std::vector<double> a, b, e;
      for (int n = k; !stop.load(); ++n) {
        const int kind = n % 3;
        const std::string path = kind == 0   ? "/v1/jobs/" + running
                                 : kind == 1 ? "/v1/jobs/" + done_id + "/summary"
                                             : "/v1/jobs/" + done_id + "/buildings";
        const auto r0 = Clock::now();
        auto r = client->Get(path);
        const double dt = seconds_since(r0);
        if (!r || r->status != 200) ++errors;
        (kind == 0 ? a : kind == 1 ? b : e).push_back(dt);
        if (interval_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(interval_ms));
      }
      const std::lock_guard<std::mutex> lock(m);
      status_s.insert(status_s.end(), a.begin(), a.end());
      summary_s.insert(summary_s.end(), b.begin(), b.end());
      buildings_s.insert(buildings_s.end(), e.begin(), e.end());
    });
  }
  wait_done(*c, running);
  const double polled_wall = seconds_since(t0);
  stop = true;
  for (auto& t : pool) t.join();
  const Json s = get_json(*c, "/v1/jobs/" + running + "/summary");
  std::printf(
      "\n%d clients polling every %d ms while the demo job runs (job %.3f s end to end, run "
      "%.3f s)\n",
      clients, interval_ms, polled_wall, s["timing"]["wall_s"].get<double>());
  std::printf("  %-22s %9s %9s %9s %9s\n", "request", "count", "p50 ms", "p99 ms", "max ms");
  const std::vector<std::pair<const char*, std::vector<double>*>> rows = {
      {"GET /v1/jobs/{id}", &status_s},
      {"GET .../summary", &summary_s},
      {"GET .../buildings", &buildings_s}};
  for (const auto& [name, v] : rows)
    std::printf("  %-22s %9zu %9.2f %9.2f %9.2f\n", name, v->size(), 1e3 * percentile(*v, 0.5),
                1e3 * percentile(*v, 0.99), 1e3 * percentile(*v, 1.0));
  std::printf("  errors: %d\n", errors.load());
  d.kill(SIGTERM);
  fs::remove_all(dir);
  return errors.load() == 0 ? 0 : 1;
}
