// fragsimd under load, as an operator would try it (docs/benchmarks.md §6):
//  1. wrk (Debian package `wrk`) against a loopback daemon while a long demo job runs: each
//     connection count flat out on the running job's status, then paced (every connection one
//     request per --pace-ms); requests/s, p50/p99/max latency, errors, and the job's own
//     throughput meanwhile;
//  2. the demo job's PTN GeoJSON requested --geojson times in a row: time, size, daemon memory;
//  3. soak: --soak small jobs one after the other (each: submit, poll until done, summary,
//     buildings), daemon memory every 50 jobs.
//
//   build/bench/bench_daemon_load [--connections 200,1000] [--duration-s 15] [--pace-ms 100]
//                                 [--geojson 10] [--soak 500] [--skip-wrk]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tests/server/daemon_process.h"

namespace {

using namespace fragsim::server::testing;
using Json = nlohmann::json;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// VmRSS and VmHWM (peak) of a process, MiB.
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

Json get_json(httplib::Client& c, const std::string& path) {
  auto r = c.Get(path);
  if (!r || r->status != 200) throw std::runtime_error("GET " + path + " failed");
  return Json::parse(r->body);
}

std::string submit(httplib::Client& c, const Json& job) {
  auto r = c.Post("/v1/jobs", job.dump(), "application/json");
  if (!r || r->status != 202)
    throw std::runtime_error("POST /v1/jobs failed: " +
                             (r ? r->body : httplib::to_string(r.error())));
  return Json::parse(r->body).at("job_id").get<std::string>();
}

void wait_done(httplib::Client& c, const std::string& id) {
  while (true) {
    const std::string state = get_json(c, "/v1/jobs/" + id).at("state").get<std::string>();
    if (state == "done") return;
    if (state == "failed" || state == "cancelled") throw std::runtime_error("job " + state);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

Json with_samples_scaled(Json job, double factor) {
  for (auto& g : job["fragment_groups"])
    g["samples"] =
        std::max<std::int64_t>(1, static_cast<std::int64_t>(g["samples"].get<double>() * factor));
  return job;
}

std::string run_command(const std::string& command) {
  std::string out;
  if (FILE* p = ::popen(command.c_str(), "r")) {
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
    ::pclose(p);
  }
  return out;
}

// The figures of wrk --latency output we report.
struct WrkFigures {
  double requests_per_s = 0, p50_ms = 0, p99_ms = 0, max_ms = 0;
  long requests = 0, errors = 0;
};

double wrk_ms(const std::string& text) {  // "12.3ms", "1.2s", "850us"
  const double v = std::atof(text.c_str());
  if (text.find("us") != std::string::npos) return v / 1e3;
  if (text.find("ms") != std::string::npos) return v;
  if (text.find('m') != std::string::npos) return v * 60e3;
  return v * 1e3;
}

WrkFigures parse_wrk(const std::string& out) {
  WrkFigures f;
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream w(line);
    std::string a, b, c, d;
    w >> a >> b >> c >> d;
    if (a == "Latency" && !d.empty()) f.max_ms = wrk_ms(d);
    if (a == "50%") f.p50_ms = wrk_ms(b);
    if (a == "99%") f.p99_ms = wrk_ms(b);
    if (a == "Requests/sec:") f.requests_per_s = std::atof(b.c_str());
    if (b == "requests" && c == "in") f.requests = std::atol(a.c_str());
    if (a == "Socket" && b == "errors:") {  // connect N, read N, write N, timeout N
      for (std::size_t p = line.find_first_of("0123456789"); p != std::string::npos;
           p = line.find_first_of("0123456789", line.find_first_not_of("0123456789", p)))
        f.errors += std::atol(line.c_str() + p);
    }
    if (a == "Non-2xx") f.errors += std::atol(line.c_str() + line.rfind(' ') + 1);
  }
  return f;
}

void wrk_runs(Daemon& d, const Json& job, const std::vector<int>& connections, int duration_s,
              int pace_ms, const fs::path& dir) {
  auto c = d.client();
  Json long_job = with_samples_scaled(job, 100.0);  // 8 M histories: minutes, cancelled after
  long_job["settings"]["record_fragments"] = false;
  const std::string id = submit(*c, long_job);
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const fs::path pace = dir / "pace.lua";
  write_text(pace, "function delay()\n  return " + std::to_string(pace_ms) + "\nend\n");
  std::printf("\nwrk, GET /v1/jobs/{id} of a running demo job, %d s each\n", duration_s);
  std::printf("  %-6s %-14s %10s %9s %9s %9s %9s %8s %14s\n", "conns", "mode", "requests", "req/s",
              "p50 ms", "p99 ms", "max ms", "errors", "job hist/s");
  for (const int n : connections) {
    for (const bool paced : {false, true}) {
      const auto h0 = get_json(*c, "/v1/jobs/" + id).at("histories_done").get<double>();
      const auto t0 = Clock::now();
      const std::string out = run_command(
          "wrk -t2 -c" + std::to_string(n) + " -d" + std::to_string(duration_s) +
          "s --timeout 10s --latency " + (paced ? "-s " + pace.string() + " " : "") +
          "-H 'Authorization: Bearer " + kToken + "' http://127.0.0.1:" + std::to_string(d.port()) +
          "/v1/jobs/" + id + " 2>&1");
      const double wall = seconds_since(t0);
      const auto h1 = get_json(*c, "/v1/jobs/" + id).at("histories_done").get<double>();
      const WrkFigures f = parse_wrk(out);
      if (f.requests == 0) std::cerr << out;
      const std::string mode = paced ? "every " + std::to_string(pace_ms) + " ms" : "flat out";
      std::printf("  %-6d %-14s %10ld %9.0f %9.2f %9.2f %9.2f %8ld %14.0f\n", n, mode.c_str(),
                  f.requests, f.requests_per_s, f.p50_ms, f.p99_ms, f.max_ms, f.errors,
                  (h1 - h0) / wall);
    }
  }
  c->Delete("/v1/jobs/" + id);
}

void geojson_runs(Daemon& d, const Json& job, int count) {
  auto c = d.client();
  const std::string id = submit(*c, job);
  wait_done(*c, id);
  const auto [rss0, hwm0] = memory_mib(d.pid());
  std::printf("\nPTN GeoJSON of the demo job, %d requests in a row\n", count);
  std::printf("  before: RSS %.1f MiB (peak so far %.1f MiB)\n", rss0, hwm0);
  std::printf("  %-8s %10s %12s %12s\n", "request", "seconds", "bytes", "RSS MiB");
  for (int k = 1; k <= count; ++k) {
    const auto t0 = Clock::now();
    auto r = c->Get("/v1/jobs/" + id + "/ptn?format=geojson");
    const double s = seconds_since(t0);
    if (!r || r->status != 200) throw std::runtime_error("GeoJSON request failed");
    const auto [rss, hwm] = memory_mib(d.pid());
    std::printf("  %-8d %10.3f %12zu %12.1f\n", k, s, r->body.size(), rss);
    (void)hwm;
  }
  std::printf("  peak RSS since start: %.1f MiB\n", memory_mib(d.pid()).second);
}

void soak(Daemon& d, const Json& job, int count) {
  auto c = d.client();
  const Json small = with_samples_scaled(job, 0.02);
  std::printf("\nsoak: %d jobs of %s histories one after the other\n", count, "1,600");
  std::printf("  %-6s %10s %10s %12s\n", "jobs", "RSS MiB", "peak MiB", "s per job");
  auto t0 = Clock::now();
  for (int k = 1; k <= count; ++k) {
    const std::string id = submit(*c, small);
    wait_done(*c, id);
    get_json(*c, "/v1/jobs/" + id + "/summary");
    get_json(*c, "/v1/jobs/" + id + "/buildings");
    if (k == 1 || k % 50 == 0) {
      const auto [rss, hwm] = memory_mib(d.pid());
      std::printf("  %-6d %10.1f %10.1f %12.3f\n", k, rss, hwm,
                  seconds_since(t0) / (k == 1 ? 1 : 50));
      std::fflush(stdout);
      t0 = Clock::now();
    }
  }
}

std::vector<int> parse_list(const std::string& s) {
  std::vector<int> v;
  std::istringstream in(s);
  for (std::string item; std::getline(in, item, ',');) v.push_back(std::atoi(item.c_str()));
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> connections = {200, 1000};
  int duration_s = 15, pace_ms = 100, geojson = 10, soak_jobs = 500;
  bool skip_wrk = false;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    const bool has = k + 1 < argc;
    if (a == "--connections" && has) {
      connections = parse_list(argv[++k]);
    } else if (a == "--duration-s" && has) {
      duration_s = std::atoi(argv[++k]);
    } else if (a == "--pace-ms" && has) {
      pace_ms = std::atoi(argv[++k]);
    } else if (a == "--geojson" && has) {
      geojson = std::atoi(argv[++k]);
    } else if (a == "--soak" && has) {
      soak_jobs = std::atoi(argv[++k]);
    } else if (a == "--skip-wrk") {
      skip_wrk = true;
    } else {
      std::cerr << "usage: bench_daemon_load [--connections 200,1000] [--duration-s S] "
                   "[--pace-ms MS] [--geojson N] [--soak N] [--skip-wrk]\n";
      return 2;
    }
  }
  if (!skip_wrk && std::system("command -v wrk > /dev/null 2>&1") != 0) {
    std::cerr << "bench_daemon_load: wrk not found (apt-get install wrk), or pass --skip-wrk\n";
    return 2;
  }
  const fs::path dir = fs::temp_directory_path() / ("bench_load_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  try {
    Daemon d(dir, {"--log-level", "warn", "--threads", "0"});
    d.start();
    auto c = d.client();
    const Json demo = Json::parse(read_text(source_path("examples/demo/scenario.json")));
    auto site = c->Post("/v1/sites", demo["site"].dump(), "application/json");
    if (!site || site->status >= 300) throw std::runtime_error("POST /v1/sites failed");
    Json job = demo;
    job.erase("site");
    job["site_id"] = Json::parse(site->body)["site_id"];
    std::printf("fragsimd pid %d, RSS %.1f MiB with the demo site loaded\n", d.pid(),
                memory_mib(d.pid()).first);
    if (!skip_wrk) wrk_runs(d, job, connections, duration_s, pace_ms, dir);
    if (geojson > 0) geojson_runs(d, job, geojson);
    if (soak_jobs > 0) soak(d, job, soak_jobs);
    d.kill(SIGTERM);
  } catch (const std::exception& e) {
    std::cerr << "bench_daemon_load: " << e.what() << "\n";
    return 1;
  }
  fs::remove_all(dir);
  return 0;
}
