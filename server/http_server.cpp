#include "server/http_server.h"

// After Eigen (through http_server.h): httplib.h pulls in <resolv.h>, whose `_res` macro breaks
// Eigen's parameter names.
#include <httplib.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cstring>
#include <fstream>
#include <memory>
#include <optional>
#include <thread>

#include "server/compression.h"
#include "server/connection_server.h"
#include "server/log.h"

namespace fragsim::server {

namespace {

constexpr int kListenBacklog = 1024;

Request to_request(const httplib::Request& in) {
  Request r;
  r.method = in.method;
  r.path = in.path;
  // The URL's query only: cpp-httplib also merges a form-encoded body into `params`.
  if (const auto q = in.target.find('?'); q != std::string::npos) {
    httplib::Params params;
    httplib::detail::parse_query_text(in.target.substr(q + 1), params);
    for (const auto& [k, v] : params) r.query[k] = v;
  }
  for (const auto& [k, v] : in.headers) r.headers[ascii_lower(k)] = v;
  r.body = in.body;
  return r;
}

// Streams a file in 1 MiB pieces; a file that vanished or cannot be read is a 500.
bool send_file(const std::filesystem::path& path, const std::string& content_type,
               httplib::Response& res) {
  auto in = std::make_shared<std::ifstream>(path, std::ios::binary);
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (!*in || ec) return false;
  res.set_content_provider(static_cast<std::size_t>(size), content_type,
                           [in](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                             constexpr std::size_t kPiece = 1 << 20;
                             std::vector<char> buf(std::min(length, kPiece));
                             in->seekg(static_cast<std::streamoff>(offset));
                             in->read(buf.data(), static_cast<std::streamsize>(buf.size()));
                             const auto got = static_cast<std::size_t>(in->gcount());
                             if (got == 0) return false;
                             sink.write(buf.data(), got);
                             return true;
                           });
  return true;
}

// A body produced in pieces (Response::stream), sent chunked as it is produced.
void send_stream(const std::function<bool(std::string&)>& stream, const std::string& content_type,
                 httplib::Response& res) {
  res.set_chunked_content_provider(content_type, [stream](std::size_t, httplib::DataSink& sink) {
    std::string piece;
    bool more = false;
    try {
      more = stream(piece);
    } catch (const std::exception& e) {  // the status is sent: all we can do is cut it short
      log(LogLevel::kError, "streamed answer failed", {{"error", e.what()}});
      return false;
    }
    if (!piece.empty() && !sink.write(piece.data(), piece.size())) return false;
    if (!more) sink.done();
    return true;
  });
}

// An in-memory body, gzip-compressed when it is text the client accepts so and worth it, and
// handed to cpp-httplib with its length: cpp-httplib then sends it as it is, rather than
// compressing it with Brotli at its slowest quality (server/compression.h).
// Error answers keep cpp-httplib's set_content: they are small, and the error handler below
// recognises an answer of ours by its body.
void send_body(const httplib::Request& req, Response& r, httplib::Response& res) {
  if (r.status >= 400 || r.body.empty()) {
    res.set_content(r.body, r.content_type);
    return;
  }
  auto body = std::make_shared<std::string>(std::move(r.body));
  if (compressible(r.content_type)) {
    res.set_header("Vary", "Accept-Encoding");
    if (body->size() >= kCompressMinBytes && body->size() < (1ULL << 31) &&
        accepts_gzip(req.get_header_value("Accept-Encoding"))) {
      *body = gzip(*body);
      res.set_header("Content-Encoding", "gzip");
    }
  }
  res.set_content_provider(body->size(), r.content_type,
                           [body](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                             return sink.write(body->data() + offset, length);
                           });
}

void set_error_body(httplib::Response& res, const Response& r) {
  res.status = r.status;
  res.set_content(r.body, r.content_type);
}

// A refusal sent before the request's body is read: the unread body must not be parsed as a next
// request, so the connection is closed after the answer. The content provider writes the whole
// error body and then reports failure, which makes cpp-httplib drop the connection.
void refuse_unread(httplib::Response& res, const Response& r) {
  res.status = r.status;
  res.set_header("Connection", "close");
  auto body = std::make_shared<std::string>(r.body);
  res.set_content_provider(body->size(), r.content_type,
                           [body](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                             sink.write(body->data() + offset, length);
                             return false;  // all written: now close
                           });
}

const char* reason_phrase(int status) {
  switch (status) {
    case 408: return "Request Timeout";
    case 431: return "Request Header Fields Too Large";
    case 503: return "Service Unavailable";
    default: return "Error";
  }
}

// What the connection layer answers on its own before closing a connection.
Response connection_refusal(int status, const Config& c) {
  switch (status) {
    case 408:
      return error_response(408, "request_timeout",
                            "the request's headers did not arrive within " +
                                format_double(c.request_timeout_s) + " s of its first byte");
    case 431:
      return error_response(431, "headers_too_large",
                            "the request line and headers exceed " +
                                std::to_string(ConnectionLimits{}.max_header_bytes) + " bytes");
    default:
      return error_response(503, "too_many_connections",
                            "the daemon holds " + std::to_string(c.max_connections) +
                                " connections already; retry shortly");
  }
}

std::string raw_response(const Response& r) {
  std::string out = "HTTP/1.1 " + std::to_string(r.status) + " " + reason_phrase(r.status) +
                    "\r\nContent-Type: " + r.content_type +
                    "\r\nContent-Length: " + std::to_string(r.body.size()) +
                    "\r\nConnection: close\r\n";
  if (r.status == 503) out += "Retry-After: 1\r\n";
  return out + "\r\n" + r.body;
}

ConnectionLimits connection_limits(const Config& c) {
  ConnectionLimits l;
  l.worker_threads = c.http_threads;
  const auto cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  l.min_worker_threads = std::clamp(2 * cores, 4, 16);
  l.request_timeout_s = c.request_timeout_s;
  l.keep_alive_s = c.keep_alive_s;
  l.max_connections = static_cast<std::size_t>(c.max_connections);
  return l;
}

// The body size a request announces in Content-Length, if it parses.
std::optional<std::uint64_t> announced_length(const httplib::Request& req) {
  if (!req.has_header("Content-Length")) return std::nullopt;
  const std::string v = req.get_header_value("Content-Length");
  std::uint64_t n = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), n);
  if (ec != std::errc() || end != v.data() + v.size()) return std::nullopt;
  return n;
}

}  // namespace

HttpServer::HttpServer(Service& service) : service_(service) {
  const Config& c = service_.config();
  const ConnectionLimits limits = connection_limits(c);
  server_ = std::make_unique<ConnectionServer>(limits, [this](int status) {
    service_.metrics().record_request("unknown", "unmatched", status, 0.0);
    log(LogLevel::kInfo, "connection refused", {{"status", std::to_string(status)}});
    return raw_response(connection_refusal(status, service_.config()));
  });
  service_.metrics().set_connection_source([server = server_.get()](Metrics::Gauges& g) {
    const ConnectionCounts n = server->counts();
    g.connections_open = static_cast<std::int64_t>(n.open);
    g.requests_queued = static_cast<std::int64_t>(n.queued);
    g.requests_in_progress = static_cast<std::int64_t>(n.busy);
    g.http_workers = static_cast<std::int64_t>(n.workers);
  });
  auto& s = *server_;
  s.set_payload_max_length(static_cast<std::size_t>(c.max_body_bytes));
  // Only the Keep-Alive header's text: connection_server.cpp enforces these and the timeouts.
  s.set_keep_alive_max_count(limits.max_requests_per_connection);
  s.set_keep_alive_timeout(static_cast<time_t>(limits.keep_alive_s));

  const auto handler = [this](const httplib::Request& req, httplib::Response& res) {
    serve(req, res);
  };
  s.Get(".*", handler);
  s.Post(".*", handler);
  s.Put(".*", handler);
  s.Patch(".*", handler);
  s.Delete(".*", handler);
  s.Options(".*", handler);
  using Handled = httplib::Server::HandlerResponse;
  s.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    return pre_route(req, res) ? Handled::Handled : Handled::Unhandled;
  });
  s.set_error_handler(httplib::Server::HandlerWithResponse(
      [this](const httplib::Request& req, httplib::Response& res) {
        return on_error(req, res) ? Handled::Handled : Handled::Unhandled;
      }));
  s.set_exception_handler([this](const httplib::Request& req, httplib::Response& res,
                                 std::exception_ptr ep) { on_exception(req, res, ep); });
}

// Every request cpp-httplib routes: the Service answers it; the answer is sent as a file, a
// stream or a body, then counted and logged.
void HttpServer::serve(const httplib::Request& req, httplib::Response& res) {
  const auto t0 = std::chrono::steady_clock::now();
  // No byte ranges (the contract has no 206): cpp-httplib 0.11 would cut the body to a Range
  // header's bytes under our 200 (`Range: bytes=0-10` got 11 bytes of JSON). The request is
  // cpp-httplib's own, non-const object, handed to handlers as const.
  const_cast<httplib::Request&>(req).ranges.clear();
  Response r = service_.handle(to_request(req));
  res.status = r.status;
  for (const auto& [k, v] : r.headers) res.set_header(k, v);
  if (r.file) {
    if (!send_file(*r.file, r.content_type.empty() ? "application/json" : r.content_type, res)) {
      log(LogLevel::kError, "result file unreadable", {{"file", r.file->string()}});
      set_error_body(res, error_response(500, "internal", "a result file cannot be read"));
    }
  } else if (r.stream) {
    send_stream(r.stream, r.content_type, res);
  } else if (r.status != 204 && r.status != 304) {
    send_body(req, r, res);
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  service_.metrics().record_request(req.method, r.route, res.status, seconds);
  log(res.status >= 500 ? LogLevel::kError : LogLevel::kDebug, "request",
      {{"method", req.method},
       {"path", req.path},
       {"status", std::to_string(res.status)},
       {"duration_ms", format_double(seconds * 1e3)},
       {"remote", req.remote_addr}});
}

// Refused before their body is read, from the headers alone, and the connection closed:
// a chunked body (cpp-httplib 0.11 enforces --max-body-bytes from Content-Length only: a chunked
// body would be read whole whatever its size), and a Content-Length above the limit (cpp-httplib
// would read and discard the whole body first: 300 MiB announced, the 413 came after the
// request timeout).
bool HttpServer::pre_route(const httplib::Request& req, httplib::Response& res) {
  // Methods cpp-httplib routes nowhere (it would answer 400): the service answers them as any
  // other method it does not serve, 405 with Allow on a known path, 404 elsewhere.
  if (req.method == "TRACE" || req.method == "CONNECT") {
    serve(req, res);
    return true;
  }
  std::optional<Response> refusal;
  const auto max = static_cast<std::uint64_t>(service_.config().max_body_bytes);
  if (req.has_header("Transfer-Encoding")) {
    refusal = error_response(411, "length_required",
                             "send the body with a Content-Length header (chunked transfer "
                             "encoding is not accepted)");
  } else if (const auto n = announced_length(req); n && *n > max) {
    refusal = error_response(413, "payload_too_large",
                             "the request body is larger than this daemon accepts (" +
                                 std::to_string(*n) + " bytes announced, limit " +
                                 std::to_string(max) + ")");
  }
  if (!refusal) return false;
  refuse_unread(res, *refusal);
  service_.metrics().record_request(req.method, "unmatched", res.status, 0.0);
  log(LogLevel::kInfo, "request refused before its body",
      {{"method", req.method}, {"path", req.path}, {"status", std::to_string(res.status)}});
  return true;
}

// Errors cpp-httplib answers itself (413 before the body is read, 400 for a malformed request
// line) get the same JSON body as every other error.
bool HttpServer::on_error(const httplib::Request& req, httplib::Response& res) {
  // A body already there, or a refusal of ours (Connection: close, its body streamed).
  if (!res.body.empty() || res.has_header("Connection")) return false;
  Response r;
  if (ConnectionServer::request_timed_out()) {
    r = error_response(408, "request_timeout",
                       "the request's body did not arrive within " +
                           format_double(service_.config().request_timeout_s) +
                           " s of its first byte");
    res.set_header("Connection", "close");
  } else if (res.status == 413) {
    r = error_response(413, "payload_too_large",
                       "the request body is larger than this daemon accepts (" +
                           std::to_string(service_.config().max_body_bytes) + " bytes)");
  } else if (res.status >= 500) {
    r = error_response(res.status, "internal", "internal error");
  } else {
    r = error_response(
        res.status,
        res.status == 404   ? "not_found"
        : res.status == 414 ? "uri_too_long"
                            : "bad_request",
        std::string("the request could not be handled (HTTP ") + std::to_string(res.status) + ")");
  }
  res.status = r.status;
  res.set_content(r.body, r.content_type);
  service_.metrics().record_request(req.method, "unmatched", res.status, 0.0);
  log(LogLevel::kInfo, "request refused",
      {{"method", req.method}, {"path", req.path}, {"status", std::to_string(res.status)}});
  return true;
}

// A handler's exception: 500 with what it said (the service turns its own into error bodies).
void HttpServer::on_exception(const httplib::Request& req, httplib::Response& res,
                              std::exception_ptr ep) {
  std::string what = "unknown exception";
  try {
    std::rethrow_exception(ep);
  } catch (const std::exception& e) {
    what = e.what();
  } catch (...) {
  }
  log(LogLevel::kError, "internal error", {{"path", req.path}, {"error", what}});
  set_error_body(res, error_response(500, "internal", "internal error: " + what));
  service_.metrics().record_request(req.method, "unmatched", res.status, 0.0);
}

HttpServer::~HttpServer() {
  service_.metrics().set_connection_source(nullptr);  // the server goes first
}

int HttpServer::bind() {
  const Config& c = service_.config();
  // cpp-httplib 0.11 (Debian 12) listens with a backlog of 5: fifty clients connecting at once
  // overflow it and wait for the kernel's SYN retry (1 s, then 3 s). Calling listen() again on the
  // bound socket raises the backlog (Linux, capped by net.core.somaxconn).
  int listen_fd = -1;
  server_->set_socket_options([&listen_fd](socket_t sock) {
    httplib::default_socket_options(sock);
    listen_fd = sock;
  });
  int port = c.listen_port;
  if (port == 0) {
    port = server_->bind_to_any_port(c.listen_host);
  } else if (!server_->bind_to_port(c.listen_host, port)) {
    port = -1;
  }
  if (port < 0)
    throw std::runtime_error("cannot listen on " + c.listen_host + ":" +
                             std::to_string(c.listen_port) + " (address in use or not local?)");
  if (listen_fd >= 0 && ::listen(listen_fd, kListenBacklog) != 0)
    log(LogLevel::kWarn, "listen backlog not raised", {{"error", std::strerror(errno)}});
  server_->set_socket_options(httplib::default_socket_options);
  return port;
}

bool HttpServer::run() {
  return server_->serve();
}

void HttpServer::stop() {
  server_->stop();
}

}  // namespace fragsim::server
