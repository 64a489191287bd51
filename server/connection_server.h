#pragma once
// fragsimd's connection layer: cpp-httplib parses and answers requests, but connections are
// handled here, event-driven (docs/architecture.md, "Connections").
//
// cpp-httplib 0.11 gives every connection a pool thread for its whole life: an idle keep-alive
// connection, or a client sending one header line per second, holds a thread, and clients beyond
// the pool wait. Here one watcher thread (epoll) holds every connection between requests and
// reads request headers as they trickle in; a worker thread is taken only once a request's
// headers are complete, and given back when its answer is sent. Deadlines are totals, not per
// read: a request's headers and body must arrive within request_timeout_s of its first byte, and
// an answer must leave at no less than min_send_bytes_per_s after a grace of request_timeout_s.
#include <httplib.h>

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>

namespace fragsim::server {

struct ConnectionLimits {
  int min_worker_threads = 4;       // workers kept (twice the cores serves quick requests best)
  int worker_threads = 64;          // at most this many requests handled at once
  double stall_s = 0.2;             // a request in hand this long makes room for another worker
  double request_timeout_s = 30.0;  // first byte of a request to its last byte
  double keep_alive_s = 15.0;       // an idle connection between requests is closed after this
  std::size_t max_header_bytes = 64 << 10;  // request line and headers together
  std::size_t max_requests_per_connection = 10'000;
  double min_send_bytes_per_s = 64 << 10;  // a client reading slower than this is dropped
  std::size_t max_connections = 4096;      // beyond this a new connection gets a 503
};

// Connection counts for /metrics.
struct ConnectionCounts {
  std::size_t open = 0;     // accepted and not yet closed
  std::size_t queued = 0;   // headers complete, waiting for a worker
  std::size_t busy = 0;     // a worker is reading, handling or answering its request
  std::size_t workers = 0;  // worker threads started
};

// A complete raw HTTP response (status line, headers, body) the connection layer sends on its
// own and then closes the connection: 408 (headers too slow), 431 (headers too large), 503 (too
// many connections).
using RawRefusal = std::function<std::string(int status)>;

class ConnectionServer : public httplib::Server {
 public:
  ConnectionServer(const ConnectionLimits& limits, RawRefusal refusal);
  ~ConnectionServer() override;
  ConnectionServer(const ConnectionServer&) = delete;
  ConnectionServer& operator=(const ConnectionServer&) = delete;

  // Serves until stop(); then closes idle connections and waits for the requests in hand.
  // Returns false if the listener failed.
  bool serve();
  // From any thread, also before serve() has started listening (cpp-httplib's own stop() does
  // nothing then: the accept loop checks this flag every 100 ms as well).
  void stop();
  ConnectionCounts counts() const;
  // In a handler or error handler: whether this request's body stopped arriving at its deadline
  // (cpp-httplib then reports a 400).
  static bool request_timed_out();

  class Impl;  // the watcher and the workers (connection_server.cpp)

 private:
  // Called by cpp-httplib's accept loop for each new connection: hands it to the watcher.
  bool process_and_close_socket(socket_t sock) override;

  std::unique_ptr<Impl> impl_;
  std::shared_ptr<std::atomic<bool>> stop_requested_;
};

}  // namespace fragsim::server
