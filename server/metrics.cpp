#include "server/metrics.h"

#include <sstream>

#include "server/log.h"
#include "server/store.h"

namespace fragsim::server {

namespace {

// Label values: backslash, double quote and newline escaped (exposition format 0.0.4).
std::string label(const std::string& v) {
  std::string out;
  for (const char c : v) {
    if (c == '\\' || c == '"') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace

void Metrics::record_request(const std::string& method, const std::string& route, int status,
                             double duration_s) {
  const std::lock_guard<std::mutex> lock(mutex_);
  ++requests_[{method, route, status}];
  Histogram& h = latency_[route];
  std::size_t k = 0;
  while (k < kBuckets.size() && duration_s > kBuckets[k]) ++k;
  if (k < kBuckets.size()) ++h.counts[k];
  ++h.count;
  h.sum += duration_s;
}

void Metrics::set_connection_source(ConnectionSource source) {
  const std::lock_guard<std::mutex> lock(mutex_);
  connections_ = std::move(source);
}

void Metrics::fill_connection_gauges(Gauges& g) const {
  ConnectionSource source;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    source = connections_;
  }
  if (source) source(g);
}

std::string Metrics::render(const Gauges& g) const {
  std::ostringstream o;
  o << "# HELP fragsimd_jobs Jobs by state.\n# TYPE fragsimd_jobs gauge\n";
  for (int s = 0; s < kJobStateCount; ++s)
    o << "fragsimd_jobs{state=\"" << job_state_name(static_cast<JobState>(s)) << "\"} "
      << g.jobs_by_state[static_cast<std::size_t>(s)] << "\n";
  o << "# HELP fragsimd_queue_length Jobs waiting to run.\n# TYPE fragsimd_queue_length gauge\n"
    << "fragsimd_queue_length " << g.queue_length << "\n";
  o << "# HELP fragsimd_histories_total Fragment histories completed since start.\n"
    << "# TYPE fragsimd_histories_total counter\nfragsimd_histories_total " << g.histories_total
    << "\n";
  o << "# HELP fragsimd_histories_per_second Throughput of the running job (0 when idle).\n"
    << "# TYPE fragsimd_histories_per_second gauge\nfragsimd_histories_per_second "
    << format_double(g.histories_per_s) << "\n";
  static constexpr std::array<const char*, 3> kReasons = {"request", "age", "bytes"};
  o << "# HELP fragsimd_jobs_purged_total Finished jobs purged since start, by reason.\n"
    << "# TYPE fragsimd_jobs_purged_total counter\n";
  for (std::size_t k = 0; k < kReasons.size(); ++k)
    o << "fragsimd_jobs_purged_total{reason=\"" << kReasons[k] << "\"} " << g.purged_jobs[k]
      << "\n";
  o << "# HELP fragsimd_purged_bytes_total Bytes of the purged jobs' files, by reason.\n"
    << "# TYPE fragsimd_purged_bytes_total counter\n";
  for (std::size_t k = 0; k < kReasons.size(); ++k)
    o << "fragsimd_purged_bytes_total{reason=\"" << kReasons[k] << "\"} " << g.purged_bytes[k]
      << "\n";
  if (g.data_free_bytes >= 0)
    o << "# HELP fragsimd_data_free_bytes Bytes available on the data directory's file system.\n"
      << "# TYPE fragsimd_data_free_bytes gauge\nfragsimd_data_free_bytes " << g.data_free_bytes
      << "\n";
  o << "# HELP fragsimd_data_min_free_bytes The free space below which new jobs are refused "
       "(--min-free-bytes; 0: no guard).\n"
    << "# TYPE fragsimd_data_min_free_bytes gauge\nfragsimd_data_min_free_bytes "
    << g.data_min_free_bytes << "\n";
  o << "# HELP fragsimd_sites Sites held in memory.\n# TYPE fragsimd_sites gauge\nfragsimd_sites "
    << g.sites << "\n";
  o << "# HELP fragsimd_uptime_seconds Seconds since the daemon started.\n"
    << "# TYPE fragsimd_uptime_seconds gauge\nfragsimd_uptime_seconds " << format_double(g.uptime_s)
    << "\n";
  o << "# HELP fragsimd_http_connections Open client connections.\n"
    << "# TYPE fragsimd_http_connections gauge\nfragsimd_http_connections " << g.connections_open
    << "\n";
  o << "# HELP fragsimd_http_requests_queued Requests whose headers are in, waiting for a "
       "worker.\n# TYPE fragsimd_http_requests_queued gauge\nfragsimd_http_requests_queued "
    << g.requests_queued << "\n";
  o << "# HELP fragsimd_http_requests_in_progress Requests being read, handled or answered.\n"
    << "# TYPE fragsimd_http_requests_in_progress gauge\nfragsimd_http_requests_in_progress "
    << g.requests_in_progress << "\n";
  o << "# HELP fragsimd_http_workers Request worker threads started.\n"
    << "# TYPE fragsimd_http_workers gauge\nfragsimd_http_workers " << g.http_workers << "\n";

  const std::lock_guard<std::mutex> lock(mutex_);
  o << "# HELP fragsimd_http_requests_total HTTP requests by method, route and status.\n"
    << "# TYPE fragsimd_http_requests_total counter\n";
  for (const auto& [key, n] : requests_) {
    const auto& [method, route, status] = key;
    o << "fragsimd_http_requests_total{method=\"" << label(method) << "\",route=\"" << label(route)
      << "\",status=\"" << status << "\"} " << n << "\n";
  }
  o << "# HELP fragsimd_http_request_duration_seconds Request latency by route.\n"
    << "# TYPE fragsimd_http_request_duration_seconds histogram\n";
  for (const auto& [route, h] : latency_) {
    std::uint64_t cumulative = 0;
    for (std::size_t k = 0; k < kBuckets.size(); ++k) {
      cumulative += h.counts[k];
      o << "fragsimd_http_request_duration_seconds_bucket{route=\"" << label(route) << "\",le=\""
        << format_double(kBuckets[k]) << "\"} " << cumulative << "\n";
    }
    o << "fragsimd_http_request_duration_seconds_bucket{route=\"" << label(route)
      << "\",le=\"+Inf\"} " << h.count << "\n"
      << "fragsimd_http_request_duration_seconds_sum{route=\"" << label(route) << "\"} "
      << format_double(h.sum) << "\n"
      << "fragsimd_http_request_duration_seconds_count{route=\"" << label(route) << "\"} "
      << h.count << "\n";
  }
  return o.str();
}

}  // namespace fragsim::server
