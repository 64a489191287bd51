#pragma once
// Loopback test support: the daemon process (daemon_process.h) plus the requests the tests repeat.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "formats/results_h5.h"
#include "tests/api/test_support.h"
#include "tests/sanitizer_build.h"
#include "tests/server/daemon_process.h"

namespace fragsim::server::testing {

using Json = nlohmann::json;

// An empty directory of the test's own (process id and test name in its name).
inline fs::path fresh_dir(const std::string& prefix) {
  return api::testing::fresh_test_dir(prefix);
}

inline Json demo_scenario() {
  return Json::parse(read_text(source_path("examples/demo/scenario.json")));
}
inline Json minimal_scenario() {
  return Json::parse(read_text(source_path("examples/minimal/scenario.json")));
}

// POST /v1/sites with the scenario's inline site; returns the site id.
inline std::string upload_site(httplib::Client& c, const Json& scenario) {
  auto r = c.Post("/v1/sites", scenario.at("site").dump(), "application/json");
  EXPECT_TRUE(r);
  if (!r) return "";
  EXPECT_TRUE(r->status == 201 || r->status == 200) << r->status << " " << r->body;
  return Json::parse(r->body).at("site_id").get<std::string>();
}

// The scenario with its site replaced by site_id.
inline Json by_site_id(Json scenario, const std::string& site_id) {
  scenario.erase("site");
  scenario["site_id"] = site_id;
  return scenario;
}

inline std::string submit(httplib::Client& c, const Json& job) {
  auto r = c.Post("/v1/jobs", job.dump(), "application/json");
  EXPECT_TRUE(r);
  if (!r) return "";
  EXPECT_EQ(r->status, 202) << r->body;
  return Json::parse(r->body).at("job_id").get<std::string>();
}

inline Json job_status(httplib::Client& c, const std::string& id) {
  auto r = c.Get("/v1/jobs/" + id);
  if (!r || r->status != 200) return Json();
  return Json::parse(r->body);
}

// Polls until the job is in a final state (or the generous deadline passes: then it fails).
inline Json wait_final(httplib::Client& c, const std::string& id, int seconds = 600) {
  const auto deadline = Clock::now() + std::chrono::seconds(seconds);
  Json s;
  while (Clock::now() < deadline) {
    s = job_status(c, id);
    const std::string state = s.value("state", "");
    if (state == "done" || state == "failed" || state == "cancelled") return s;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ADD_FAILURE() << "job " << id << " did not finish; last status " << s.dump();
  return s;
}

// A socket connected to 127.0.0.1:port whose reads time out after 10 s; -1 when it cannot be.
inline int connect_loopback(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  timeval timeout{10, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0) return fd;
  ::close(fd);
  return -1;
}

// Appends what the server sends until it closes (or 10 s pass), then closes `fd`.
inline std::string read_to_close(int fd, std::string answer = {}) {
  char buf[4096];
  for (ssize_t n; (n = ::recv(fd, buf, sizeof buf, 0)) > 0;) answer.append(buf, n);
  ::close(fd);
  return answer;
}

// Sends `request` (raw HTTP bytes) to 127.0.0.1:port in one write, then reads until the server
// closes or 10 s pass; returns what was read. One write matters for a request the server answers
// before reading its body: a client library writing headers and body separately may find the
// connection closed between the two (EPIPE) before it reads the answer.
inline std::string raw_exchange(int port, const std::string& request) {
  const int fd = connect_loopback(port);
  if (fd < 0) return "";
  ::send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  return read_to_close(fd);
}

// Sends `request` in pieces of `piece` bytes, `pause` apart, while the server accepts them, then
// reads until it closes (10 s at most); returns what was read.
inline std::string pieces_exchange(int port, const std::string& request, std::size_t piece,
                                   std::chrono::milliseconds pause) {
  const int fd = connect_loopback(port);
  if (fd < 0) return "";
  for (std::size_t at = 0; at < request.size(); at += piece) {
    const std::size_t n = std::min(piece, request.size() - at);
    if (::send(fd, request.data() + at, n, MSG_NOSIGNAL) != static_cast<ssize_t>(n)) break;
    std::this_thread::sleep_for(pause);
  }
  return read_to_close(fd);
}

// Sends `head`, then one byte ('x') every `pause` up to `bytes` times while the server accepts
// them, then reads until the server closes (10 s at most); returns what was read.
inline std::string trickle_exchange(int port, const std::string& head, int bytes,
                                    std::chrono::milliseconds pause) {
  const int fd = connect_loopback(port);
  if (fd < 0) return "";
  std::string answer;
  if (::send(fd, head.data(), head.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(head.size())) {
    char buf[4096];
    for (int k = 0; k < bytes; ++k) {
      std::this_thread::sleep_for(pause);
      const ssize_t got = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
      if (got > 0) answer.append(buf, static_cast<std::size_t>(got));
      if (got == 0 || ::send(fd, "x", 1, MSG_NOSIGNAL) != 1) break;
    }
  }
  return read_to_close(fd, std::move(answer));
}

// ---- Whole runs compared ----

// Every dataset of two results.h5 files, byte for byte (attributes hold timing and creation time
// and may differ).
inline void expect_same_datasets(const fs::path& a, const fs::path& b) {
  const auto names = formats::list_datasets(a);
  ASSERT_EQ(names, formats::list_datasets(b));
  ASSERT_FALSE(names.empty());
  for (const auto& name : names)
    EXPECT_EQ(formats::read_dataset_raw(a, name), formats::read_dataset_raw(b, name)) << name;
}

// summary.json without what legitimately differs between two runs of one scenario: run time,
// and the hash of the scenario text (a file for the CLI, the stored request for the daemon).
inline Json comparable_summary(const std::string& text) {
  Json s = Json::parse(text);
  s.erase("timing");
  s["provenance"].erase("scenario_sha256");
  return s;
}

// `fragsim run` on `scenario` into dir/cli-<name>; returns that directory.
inline fs::path cli_run(const fs::path& dir, const std::string& name, const Json& scenario) {
  const fs::path file = dir / (name + ".json");
  write_text(file, scenario.dump());
  const fs::path out = dir / ("cli-" + name);
  EXPECT_EQ(run_process({FRAGSIM_CLI, "run", file.string(), "--out", out.string(), "--quiet",
                         "--threads", "1"},
                        dir / "cli.log"),
            0)
      << read_text(dir / "cli.log");
  return out;
}

// Downloads a finished job's results.h5 and summary.json into dir/<job_id>/.
inline fs::path download(httplib::Client& c, const fs::path& dir, const std::string& id) {
  const fs::path out = dir / id;
  fs::create_directories(out);
  auto h5 = c.Get("/v1/jobs/" + id + "/results.h5");
  EXPECT_TRUE(h5 && h5->status == 200);
  if (h5) write_text(out / "results.h5", h5->body);
  auto summary = c.Get("/v1/jobs/" + id + "/summary");
  EXPECT_TRUE(summary && summary->status == 200);
  if (summary) write_text(out / "summary.json", summary->body);
  return out;
}

inline Json with_seed(Json scenario, std::uint64_t seed) {
  scenario["settings"]["seed"] = seed;
  return scenario;
}

using fragsim::testing::kSanitized;

// The samples factor of a job that only has to outlast what a test does to it (a kill -9, a
// SIGTERM, a cancel, clients polling): `release_factor` in a Release build, a quarter of it in a
// sanitizer build, where the job is about as long in seconds. CI's sanitizer steps ran the
// Release-sized jobs, 4-6 minutes a test, and went past CI's 90 minutes (docs/testing.md).
inline double outlasting(double release_factor) {
  return kSanitized ? release_factor / 4.0 : release_factor;
}

inline Json scaled_samples(Json scenario, double factor) {
  for (auto& g : scenario["fragment_groups"])
    g["samples"] = static_cast<std::int64_t>(g["samples"].get<double>() * factor);
  return scenario;
}

}  // namespace fragsim::server::testing
