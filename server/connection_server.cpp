#include "server/connection_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <unordered_map>
#include <vector>

#include "server/log.h"

namespace fragsim::server {

namespace {

using Clock = std::chrono::steady_clock;

// Set by the stream of the request a worker has in hand when its read deadline passes.
thread_local bool t_request_timed_out = false;

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

// One client connection and the bytes read from it that no request has consumed yet.
struct Connection {
  int fd = -1;
  std::string pending;
  Clock::time_point idle_since;
  std::optional<Clock::time_point> request_start;  // first byte of the request being received
  std::size_t served = 0;
};
using ConnectionPtr = std::unique_ptr<Connection>;

// Whether `pending` holds a request line and headers up to their blank line, within `max_bytes`
// (headers that end beyond are refused with 431 however fast they came). cpp-httplib ends the
// headers only at a line that is exactly CRLF, after a line ending in LF.
bool headers_complete(const std::string& pending, std::size_t max_bytes) {
  const std::size_t end = pending.find("\n\r\n");
  return end != std::string::npos && end + 3 <= max_bytes;
}

// Waits until fd is ready for `events` or the deadline passes.
bool wait_ready(int fd, short events, Clock::time_point deadline) {
  for (;;) {
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) return false;
    pollfd p{fd, events, 0};
    const int n = ::poll(&p, 1, static_cast<int>(std::min<std::int64_t>(left.count(), 1000)));
    if (n > 0) return true;
    if (n < 0 && errno != EINTR) return false;
  }
}

void close_connection(int fd) {
  ::shutdown(fd, SHUT_RDWR);
  ::close(fd);
}

// Best effort on a socket whose buffer is empty: a refusal is a few hundred bytes.
void send_and_close(int fd, const std::string& bytes) {
  (void)::send(fd, bytes.data(), bytes.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  close_connection(fd);
}

// The stream cpp-httplib reads a request from and writes its answer to: bytes the watcher read
// first, then the socket, under total deadlines.
class DeadlineStream final : public httplib::Stream {
 public:
  DeadlineStream(Connection& c, const ConnectionLimits& limits)
      : c_(c),
        limits_(limits),
        read_deadline_(*c.request_start + seconds(limits.request_timeout_s)) {}
  ~DeadlineStream() override { c_.pending.erase(0, pos_); }

  bool is_readable() const override {
    return pos_ < c_.pending.size() || wait_ready(c_.fd, POLLIN, read_deadline_);
  }
  bool is_writable() const override { return wait_ready(c_.fd, POLLOUT, write_deadline()); }

  ssize_t read(char* ptr, size_t size) override {
    if (pos_ == c_.pending.size()) {
      c_.pending.clear();
      pos_ = 0;
      if (!fill()) return -1;
    }
    const std::size_t n = std::min(size, c_.pending.size() - pos_);
    std::memcpy(ptr, c_.pending.data() + pos_, n);
    pos_ += n;
    return static_cast<ssize_t>(n);
  }

  // Small writes (cpp-httplib writes the status line and headers, then the body) are gathered
  // and sent together: one segment instead of two.
  ssize_t write(const char* ptr, size_t size) override {
    if (out_.size() + size <= kGather) {
      out_.append(ptr, size);
      return static_cast<ssize_t>(size);
    }
    if (!flush()) return -1;
    return send_some(ptr, size);
  }

  // Sends what write() gathered; false if the client does not take it in time.
  bool flush() {
    for (std::size_t done = 0; done < out_.size();) {
      const ssize_t n = send_some(out_.data() + done, out_.size() - done);
      if (n < 0) return false;
      done += static_cast<std::size_t>(n);
    }
    out_.clear();
    return true;
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    address(::getpeername, ip, port);
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    address(::getsockname, ip, port);
  }
  socket_t socket() const override { return c_.fd; }
  bool timed_out() const { return timed_out_; }

 private:
  ssize_t send_some(const char* ptr, size_t size) {
    if (!write_start_) write_start_ = Clock::now();
    for (;;) {
      if (!wait_ready(c_.fd, POLLOUT, write_deadline())) return -1;
      const ssize_t n = ::send(c_.fd, ptr, size, MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n >= 0) {
        sent_ += static_cast<std::size_t>(n);
        return n;
      }
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return -1;
    }
  }

  // Reads what has arrived (at least one byte) into the pending buffer; first sends what was
  // gathered (an interim "100 Continue" must reach the client before its body is awaited).
  bool fill() {
    if (!flush()) return false;
    constexpr std::size_t kChunk = 16 << 10;
    for (;;) {
      if (!wait_ready(c_.fd, POLLIN, read_deadline_)) {
        timed_out_ = t_request_timed_out = Clock::now() >= read_deadline_;
        return false;
      }
      c_.pending.resize(kChunk);
      const ssize_t n = ::recv(c_.fd, c_.pending.data(), kChunk, MSG_DONTWAIT);
      c_.pending.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
      if (n > 0) return true;
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) return false;
    }
  }

  Clock::time_point write_deadline() const {
    const auto start = write_start_.value_or(Clock::now());
    return start + seconds(limits_.request_timeout_s +
                           static_cast<double>(sent_) / limits_.min_send_bytes_per_s);
  }

  template <class Get>
  void address(Get get, std::string& ip, int& port) const {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    ip.clear();
    port = 0;
    if (get(c_.fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return;
    char host[64] = {};
    if (addr.ss_family == AF_INET) {
      const auto* a = reinterpret_cast<const sockaddr_in*>(&addr);
      ::inet_ntop(AF_INET, &a->sin_addr, host, sizeof host);
      port = ntohs(a->sin_port);
    } else if (addr.ss_family == AF_INET6) {
      const auto* a = reinterpret_cast<const sockaddr_in6*>(&addr);
      ::inet_ntop(AF_INET6, &a->sin6_addr, host, sizeof host);
      port = ntohs(a->sin6_port);
    }
    ip = host;
  }

  Connection& c_;
  const ConnectionLimits& limits_;
  Clock::time_point read_deadline_;
  std::optional<Clock::time_point> write_start_;
  std::size_t sent_ = 0;
  std::size_t pos_ = 0;  // bytes of c_.pending consumed
  bool timed_out_ = false;
  static constexpr std::size_t kGather = 16 << 10;
  std::string out_;  // written, not yet sent
};

}  // namespace

// The watcher (one thread, epoll) holds connections between requests; the workers handle one
// request each and give the connection back.
class ConnectionServer::Impl {
 public:
  Impl(ConnectionServer& server, const ConnectionLimits& limits, RawRefusal refusal)
      : server_(server), limits_(limits), refusal_(std::move(refusal)) {
    epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
    wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (epoll_fd_ < 0 || wake_fd_ < 0)
      throw std::runtime_error(std::string("connection watcher: ") + std::strerror(errno));
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = wake_fd_;
    ::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, wake_fd_, &ev);
  }
  ~Impl() {
    stop();
    ::close(wake_fd_);
    ::close(epoll_fd_);
  }

  void start() {
    stopping_ = false;
    watcher_ = std::thread([this] { watch(); });
    std::lock_guard lock(mutex_);
    add_workers(std::min(limits_.min_worker_threads, limits_.worker_threads));
  }

  // Closes idle connections, lets the requests in hand finish, joins the threads.
  void stop() {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
      stopping_ = true;
    }
    wake();
    work_ready_.notify_all();
    if (watcher_.joinable()) watcher_.join();
    std::vector<std::unique_ptr<Worker>> workers;
    {
      std::lock_guard lock(mutex_);
      workers.swap(workers_);
    }
    for (auto& w : workers) w->thread.join();
    std::lock_guard lock(mutex_);
    for (auto& [fd, c] : idle_) close_connection(fd);
    for (auto& c : queue_) close_connection(c->fd);
    for (auto& [fd, until] : closing_) ::close(fd);
    open_ -= idle_.size() + queue_.size() + closing_.size();
    idle_.clear();
    queue_.clear();
    closing_.clear();
  }

  void adopt(int fd) {
    const int on = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);  // no 40 ms Nagle/ACK stall
    if (open_.fetch_add(1) >= limits_.max_connections) {
      --open_;
      send_and_close(fd, refusal_(503));
      return;
    }
    auto c = std::make_unique<Connection>();
    c->fd = fd;
    c->idle_since = Clock::now();
    park(std::move(c));
  }

  ConnectionCounts counts() const {
    std::lock_guard lock(mutex_);
    return {open_.load(), queue_.size(), busy_, workers_.size()};
  }

 private:
  // A connection between requests: to a worker if a whole request's headers are already here
  // (pipelined), else watched.
  void park(ConnectionPtr c) {
    if (headers_complete(c->pending, limits_.max_header_bytes)) {
      enqueue(std::move(c));
      return;
    }
    std::lock_guard lock(mutex_);
    if (stopping_) {
      close_now(std::move(c));
      return;
    }
    const int fd = c->fd;
    idle_[fd] = std::move(c);
    epoll_event ev{};
    ev.events = EPOLLIN | EPOLLRDHUP;
    ev.data.fd = fd;
    if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &ev) != 0) {
      close_idle(fd);
    } else if (idle_[fd]->pending.size() > limits_.max_header_bytes) {
      refuse_idle(fd, 431);  // pipelined headers beyond the limit: no more bytes may come
    }
  }

  void enqueue(ConnectionPtr c) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) {
        close_now(std::move(c));
        return;
      }
      queue_.push_back(std::move(c));
    }
    work_ready_.notify_one();
  }

  void watch() {
    constexpr auto kSweep = std::chrono::milliseconds(50);
    std::vector<epoll_event> events(256);
    auto next_sweep = Clock::now() + kSweep;
    while (!is_stopping()) {
      const int n = ::epoll_wait(epoll_fd_, events.data(), static_cast<int>(events.size()),
                                 static_cast<int>(kSweep.count()));
      for (int k = 0; k < n; ++k) {
        const int fd = events[static_cast<std::size_t>(k)].data.fd;
        if (fd != wake_fd_) on_readable(fd);
      }
      if (const auto now = Clock::now(); now >= next_sweep) {
        expire(now);
        next_sweep = now + kSweep;
      }
    }
  }

  // Reads what arrived on an idle connection; hands it to a worker once its headers are in.
  void on_readable(int fd) {
    ConnectionPtr ready;
    {
      std::lock_guard lock(mutex_);
      if (closing_.count(fd) != 0) {
        drain_closing(fd);
        return;
      }
      const auto it = idle_.find(fd);
      if (it == idle_.end()) return;
      Connection& c = *it->second;
      const bool open = read_available(c);
      if (!open) {
        close_idle(fd);
        return;
      }
      if (!c.pending.empty() && !c.request_start) c.request_start = Clock::now();
      if (headers_complete(c.pending, limits_.max_header_bytes)) {
        ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
        ready = std::move(it->second);
        idle_.erase(it);
      } else if (c.pending.size() > limits_.max_header_bytes) {
        refuse_idle(fd, 431);
        return;
      }
    }
    if (ready) enqueue(std::move(ready));
  }

  // Non-blocking reads until nothing more is there; false when the peer closed or failed.
  bool read_available(Connection& c) const {
    char buf[16 << 10];
    while (c.pending.size() <= limits_.max_header_bytes) {
      const ssize_t n = ::recv(c.fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        c.pending.append(buf, static_cast<std::size_t>(n));
        continue;
      }
      if (n == 0) return false;
      return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
    }
    return true;
  }

  // Headers too slow: 408; idle too long: closed without a word (RFC 9112 §9.5).
  void expire(Clock::time_point now) {
    std::vector<int> slow, idle;
    {
      std::lock_guard lock(mutex_);
      for (const auto& [fd, c] : idle_) {
        if (c->request_start && now - *c->request_start > seconds(limits_.request_timeout_s))
          slow.push_back(fd);
        else if (!c->request_start && now - c->idle_since > seconds(limits_.keep_alive_s))
          idle.push_back(fd);
      }
      for (const int fd : slow) refuse_idle(fd, 408);
      for (const int fd : idle) close_idle(fd);
      std::vector<int> lingered;
      for (const auto& [fd, until] : closing_)
        if (now >= until) lingered.push_back(fd);
      for (const int fd : lingered) finish_closing(fd);
      grow_if_stalled(now);
    }
  }

  struct Worker {
    std::thread thread;
    std::optional<Clock::time_point> since;  // start of the request in hand (under mutex_)
  };

  // With mutex_ held.
  void add_workers(int n) {
    for (int k = 0; k < n; ++k) {
      workers_.push_back(std::make_unique<Worker>());
      Worker* w = workers_.back().get();
      w->thread = std::thread([this, w] { work(*w); });
    }
  }

  // With mutex_ held. A few workers serve the quick requests best (64 threads all runnable on
  // 2 cores doubled the p99 under load); a request that takes long (a site upload, a slow
  // client's download) adds a worker while requests wait, up to worker_threads.
  void grow_if_stalled(Clock::time_point now) {
    if (queue_.empty() || workers_.size() >= static_cast<std::size_t>(limits_.worker_threads))
      return;
    std::size_t stalled = 0;
    for (const auto& w : workers_)
      if (w->since && now - *w->since > seconds(limits_.stall_s)) ++stalled;
    const std::size_t healthy = workers_.size() - stalled;
    const auto wanted = static_cast<std::size_t>(limits_.min_worker_threads);
    if (healthy < wanted) add_workers(1);
  }

  void work(Worker& self) {
    for (;;) {
      ConnectionPtr c;
      {
        std::unique_lock lock(mutex_);
        work_ready_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
        if (queue_.empty()) return;  // stopping, nothing left
        c = std::move(queue_.front());
        queue_.pop_front();
        ++busy_;
        self.since = Clock::now();
      }
      serve_one(std::move(c));
      std::lock_guard lock(mutex_);
      --busy_;
      self.since.reset();
    }
  }

  // One request on a worker; the connection goes back to the watcher unless it is to close.
  void serve_one(ConnectionPtr c) {
    bool keep = false;
    {
      DeadlineStream stream(*c, limits_);
      const bool last = is_stopping() || c->served + 1 >= limits_.max_requests_per_connection;
      bool closed = false;
      t_request_timed_out = false;
      const bool ok = server_.process_request(stream, last, closed, nullptr);
      const bool sent = stream.flush();  // also after a failure: a refusal's answer is gathered
      // cpp-httplib answers a body that stopped coming (400, 408 from our error handler) and
      // would keep the connection: the rest of the body would be read as a next request.
      keep = ok && sent && !closed && !last && !stream.timed_out();
    }  // the stream gives back the bytes it has not consumed (a pipelined next request)
    ++c->served;
    if (!keep) {
      linger(std::move(c));
      return;
    }
    c->idle_since = Clock::now();
    c->request_start = c->pending.empty() ? std::nullopt : std::optional(c->idle_since);
    park(std::move(c));
  }

  // With mutex_ held.
  void close_idle(int fd) {
    ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
    idle_.erase(fd);
    close_connection(fd);
    --open_;
  }
  // The refusal is sent and the connection half-closed; what the client still sends is read
  // and dropped for up to a second before closing. Closing with unread bytes would make the
  // kernel reset the connection, and the client could lose the refusal.
  void refuse_idle(int fd, int status) {
    idle_.erase(fd);
    const std::string bytes = refusal_(status);
    (void)::send(fd, bytes.data(), bytes.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
    start_closing(fd);
  }
  // With mutex_ held; fd is registered with epoll.
  void start_closing(int fd) {
    ::shutdown(fd, SHUT_WR);
    closing_[fd] = Clock::now() + std::chrono::seconds(1);
    drain_closing(fd);
  }
  // A connection a worker is done with (its answer sent): closed the same careful way, since
  // the client may still be sending (a body cut at its deadline, a request after the last).
  void linger(ConnectionPtr c) {
    std::lock_guard lock(mutex_);
    epoll_event ev{};
    ev.events = EPOLLIN | EPOLLRDHUP;
    ev.data.fd = c->fd;
    if (stopping_ || ::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, c->fd, &ev) != 0) {
      close_now(std::move(c));
      return;
    }
    start_closing(c->fd);
  }
  void drain_closing(int fd) {
    char buf[16 << 10];
    for (;;) {
      const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      if (n < 0 && errno == EINTR) continue;
      finish_closing(fd);
      return;
    }
  }
  void finish_closing(int fd) {
    ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
    closing_.erase(fd);
    ::close(fd);
    --open_;
  }
  void close_now(ConnectionPtr c) {
    close_connection(c->fd);
    --open_;
  }

  bool is_stopping() const {
    std::lock_guard lock(mutex_);
    return stopping_;
  }
  void wake() const {
    const std::uint64_t one = 1;
    (void)!::write(wake_fd_, &one, sizeof one);
  }

  ConnectionServer& server_;
  const ConnectionLimits limits_;
  const RawRefusal refusal_;
  int epoll_fd_ = -1;
  int wake_fd_ = -1;

  mutable std::mutex mutex_;
  bool stopping_ = true;
  std::unordered_map<int, ConnectionPtr> idle_;         // watched, between requests
  std::deque<ConnectionPtr> queue_;                     // headers in, waiting for a worker
  std::unordered_map<int, Clock::time_point> closing_;  // refused: drained until then
  std::size_t busy_ = 0;
  std::atomic<std::size_t> open_{0};
  std::condition_variable work_ready_;
  std::thread watcher_;
  std::vector<std::unique_ptr<Worker>> workers_;
};

namespace {

// cpp-httplib's accept loop hands each connection to process_and_close_socket through this
// queue; ours only registers it with the watcher, so it runs in the accept thread. The loop calls
// on_idle when no connection came for the idle interval: a stop requested before the loop ran.
class InlineQueue final : public httplib::TaskQueue {
 public:
  InlineQueue(httplib::Server& server, std::shared_ptr<std::atomic<bool>> stop)
      : server_(server), stop_(std::move(stop)) {}
  void enqueue(std::function<void()> fn) override { fn(); }
  void shutdown() override {}
  void on_idle() override {
    if (*stop_) server_.stop();
  }

 private:
  httplib::Server& server_;
  std::shared_ptr<std::atomic<bool>> stop_;
};

}  // namespace

ConnectionServer::ConnectionServer(const ConnectionLimits& limits, RawRefusal refusal)
    : impl_(std::make_unique<Impl>(*this, limits, std::move(refusal))),
      stop_requested_(std::make_shared<std::atomic<bool>>(false)) {
  new_task_queue = [this] { return new InlineQueue(*this, stop_requested_); };
  set_idle_interval(0, 100'000);
}

ConnectionServer::~ConnectionServer() = default;

bool ConnectionServer::serve() {
  impl_->start();
  const bool ok = listen_after_bind();  // a stop already requested ends it within 100 ms
  impl_->stop();
  return ok;
}

void ConnectionServer::stop() {
  *stop_requested_ = true;
  httplib::Server::stop();
}

bool ConnectionServer::request_timed_out() {
  return t_request_timed_out;
}

ConnectionCounts ConnectionServer::counts() const {
  return impl_->counts();
}

bool ConnectionServer::process_and_close_socket(socket_t sock) {
  impl_->adopt(sock);
  return true;
}

}  // namespace fragsim::server
