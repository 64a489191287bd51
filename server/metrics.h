#pragma once
// Request counters and latency histograms for GET /metrics (Prometheus text format 0.0.4).
// The job and site gauges are read from the store and scheduler when the page is rendered.
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <tuple>

namespace fragsim::server {

class Metrics {
 public:
  // Upper bounds (seconds) of the latency histogram's buckets; +Inf is implied.
  static constexpr std::array<double, 8> kBuckets = {0.001, 0.005, 0.01, 0.05, 0.1, 0.5, 1.0, 5.0};

  // `route` is the pattern ("/v1/jobs/{id}"), or "unmatched".
  void record_request(const std::string& method, const std::string& route, int status,
                      double duration_s);

  struct Gauges {
    std::array<std::int64_t, 5> jobs_by_state{};  // JobState order
    std::int64_t queue_length = 0;
    std::int64_t histories_total = 0;
    double histories_per_s = 0.0;
    std::int64_t sites = 0;
    double uptime_s = 0.0;
    // Jobs purged since start and the bytes their directories held, by reason (request, age,
    // bytes: server/purge.h, PurgeReason order).
    std::array<std::uint64_t, 3> purged_jobs{};
    std::array<std::uint64_t, 3> purged_bytes{};
    // The data directory's file system (server/disk_guard.h); -1: it could not be asked.
    std::int64_t data_free_bytes = -1;
    std::int64_t data_min_free_bytes = 0;
    // From the connection layer (zeros without one, e.g. in tests without sockets).
    std::int64_t connections_open = 0;
    std::int64_t requests_queued = 0;       // headers in, waiting for a worker
    std::int64_t requests_in_progress = 0;  // with a worker
    std::int64_t http_workers = 0;
  };
  // Fills the connection gauges; set by the HTTP server.
  using ConnectionSource = std::function<void(Gauges&)>;
  void set_connection_source(ConnectionSource source);
  void fill_connection_gauges(Gauges& g) const;
  std::string render(const Gauges& g) const;

 private:
  struct Histogram {
    std::array<std::uint64_t, kBuckets.size()> counts{};  // non-cumulative
    std::uint64_t count = 0;
    double sum = 0.0;
  };
  mutable std::mutex mutex_;
  ConnectionSource connections_;
  std::map<std::tuple<std::string, std::string, int>, std::uint64_t> requests_;
  std::map<std::string, Histogram> latency_;
};

}  // namespace fragsim::server
