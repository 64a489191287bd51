// fragsimd end to end: the daemon as a separate process, real HTTP over loopback.
#include <sqlite3.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <set>
#include <thread>
#include <vector>

#include "tests/server/daemon_support.h"

namespace fragsim::server::testing {
namespace {

// A job long enough to be caught running by a kill -9 or SIGTERM: the demo x 3 in Release, a
// quarter of it in a sanitizer build (outlasting()).
const double kLongJobScale = outlasting(3.0);

TEST(Daemon, DemoJobIsBitIdenticalToTheCli) {
  const fs::path dir = fresh_dir("fragsimd_demo_");
  Daemon d(dir);
  ASSERT_NO_THROW(d.start()) << d.log();
  auto c = d.client();
  // A quarter of the demo in a sanitizer build: the same comparison, a fraction of the time.
  const Json demo = kSanitized ? scaled_samples(demo_scenario(), 0.25) : demo_scenario();
  const std::string site = upload_site(*c, demo);
  const std::string id = submit(*c, by_site_id(demo, site));
  const Json status = wait_final(*c, id);
  ASSERT_EQ(status.value("state", ""), "done") << status.dump();
  EXPECT_EQ(status["histories_done"], status["histories_total"]);
  const fs::path served = download(*c, dir, id);

  const fs::path cli = cli_run(dir, "demo", demo);
  expect_same_datasets(served / "results.h5", cli / "results.h5");
  EXPECT_EQ(comparable_summary(read_text(served / "summary.json")),
            comparable_summary(read_text(cli / "summary.json")));

  // The building figures and the PTN field served as JSON are those of the files.
  auto b = c->Get("/v1/jobs/" + id + "/buildings");
  ASSERT_TRUE(b && b->status == 200);
  const Json summary = Json::parse(read_text(cli / "summary.json"));
  const Json buildings = Json::parse(b->body)["buildings"];
  ASSERT_EQ(buildings.size(), summary["buildings"].size());
  for (std::size_t k = 0; k < buildings.size(); ++k) {
    EXPECT_EQ(buildings[k]["id"], summary["buildings"][k]["id"]);
    EXPECT_EQ(buildings[k]["expected_impacts"], summary["buildings"][k]["expected_impacts"]);
    EXPECT_EQ(buildings[k]["expected_penetrations"],
              summary["buildings"][k]["expected_penetrations"]);
  }
  auto ptn = c->Get("/v1/jobs/" + id + "/ptn");
  ASSERT_TRUE(ptn && ptn->status == 200);
  const Json field = Json::parse(ptn->body);
  const auto density = formats::read_dataset_double(cli / "results.h5", "/ptn/density_per_m2");
  ASSERT_EQ(field["density_per_m2"].size(), density.size());
  for (std::size_t k = 0; k < density.size(); ++k)
    ASSERT_EQ(field["density_per_m2"][k].get<double>(), density[k]) << "triangle " << k;

  EXPECT_EQ(d.kill(SIGTERM), 0) << d.log();
}

TEST(Daemon, JobsSurviveKillNineAndRerunIdentically) {
  const fs::path dir = fresh_dir("fragsimd_crash_");
  Daemon d(dir);
  ASSERT_NO_THROW(d.start()) << d.log();
  auto c = d.client();
  const Json demo = demo_scenario();
  const std::string site = upload_site(*c, demo);
  // The first job is long enough to be caught running; the other two wait behind it.
  const Json first = scaled_samples(by_site_id(demo, site), kLongJobScale);
  const Json second = by_site_id(with_seed(scaled_samples(demo, 0.25), 7), site);
  const Json third = with_seed(minimal_scenario(), 11);  // inline site
  const std::string a = submit(*c, first);
  const std::string b = submit(*c, second);
  const std::string e = submit(*c, third);

  const auto deadline = Clock::now() + std::chrono::seconds(120);
  while (Clock::now() < deadline) {
    const Json s = job_status(*c, a);
    if (s.value("state", "") == "running" && s.value("histories_done", 0) > 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(job_status(*c, a).value("state", ""), "running");
  d.kill(SIGKILL);
  // What a daemon killed while writing leaves: temporaries, here also with the names the old
  // scheme would give a restart with the same PID (PID 1 in a container). None may block the
  // rerun, and the restart clears them.
  const std::vector<fs::path> leftovers = {d.data() / "jobs" / a / ".results.h5.tmp.1.0",
                                           d.data() / "jobs" / a / ".summary.json.tmp.1.1",
                                           d.data() / "sites" / (".x" + site + ".json.tmp.1.0")};
  for (const auto& f : leftovers) {
    fs::create_directories(f.parent_path());
    write_text(f, "partial");
  }

  ASSERT_NO_THROW(d.start()) << d.log();
  for (const auto& f : leftovers) EXPECT_FALSE(fs::exists(f)) << f;
  c = d.client();
  for (const auto& id : {a, b, e}) {
    const Json s = wait_final(*c, id);
    EXPECT_EQ(s.value("state", ""), "done") << s.dump();
  }
  EXPECT_EQ(job_status(*c, a)["attempts"], 2);
  EXPECT_EQ(job_status(*c, b)["attempts"], 1);

  // Each result equals an uninterrupted run of the same scenario.
  Json first_inline = scaled_samples(demo, kLongJobScale);
  Json second_inline = with_seed(scaled_samples(demo, 0.25), 7);
  const std::vector<std::pair<std::string, Json>> cases = {
      {a, first_inline}, {b, second_inline}, {e, third}};
  for (const auto& [id, scenario] : cases) {
    const fs::path served = download(*c, dir, id);
    const fs::path cli = cli_run(dir, id, scenario);
    expect_same_datasets(served / "results.h5", cli / "results.h5");
  }
  EXPECT_EQ(d.kill(SIGTERM), 0);

  sqlite3* db = nullptr;
  ASSERT_EQ(
      sqlite3_open_v2((d.data() / "fragsimd.sqlite").c_str(), &db, SQLITE_OPEN_READONLY, nullptr),
      SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA integrity_check", -1, &stmt, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0)), "ok");
  sqlite3_finalize(stmt);
  sqlite3_close(db);
}

// The daemon's process id inside its own PID namespace (the last NSpid field), and its id here.
std::pair<pid_t, pid_t> inner_daemon_pid(pid_t wrapper) {
  const std::string children = read_text("/proc/" + std::to_string(wrapper) + "/task/" +
                                         std::to_string(wrapper) + "/children");
  const pid_t here = static_cast<pid_t>(std::atol(children.c_str()));
  std::istringstream status(read_text("/proc/" + std::to_string(here) + "/status"));
  pid_t inside = -1;
  for (std::string line; std::getline(status, line);)
    if (line.rfind("NSpid:", 0) == 0)
      inside = static_cast<pid_t>(std::atol(line.c_str() + line.rfind('\t')));
  return {inside, here};
}

// As in the shipped container, fragsimd is PID 1 of its PID namespace, every time it starts:
// SIGTERM (ignored by PID 1 unless handled) still stops it cleanly, and after kill -9 the restart,
// with the same PID, reruns the job to the end.
TEST(Daemon, AsPidOneItStopsOnSigtermAndRerunsAfterKillNine) {
  if (std::system("unshare --pid --fork --kill-child true >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "cannot create a PID namespace here (unshare needs CAP_SYS_ADMIN)";
  const fs::path dir = fresh_dir("fragsimd_pid1_");
  Daemon d(dir);
  d.set_wrapper({"/usr/bin/unshare", "--pid", "--fork", "--kill-child"});
  ASSERT_NO_THROW(d.start()) << d.log();
  ASSERT_EQ(inner_daemon_pid(d.pid()).first, 1);
  auto c = d.client();
  const Json demo = demo_scenario();
  const std::string site = upload_site(*c, demo);
  const std::string id = submit(*c, scaled_samples(by_site_id(demo, site), kLongJobScale));
  const auto wait_running = [&] {
    const auto deadline = Clock::now() + std::chrono::seconds(120);
    while (Clock::now() < deadline) {
      const Json s = job_status(*c, id);
      if (s.value("state", "") == "running" && s.value("histories_done", 0) > 0) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  };
  ASSERT_TRUE(wait_running());
  ::kill(inner_daemon_pid(d.pid()).second, SIGTERM);
  EXPECT_EQ(d.kill(0), 0) << "PID 1 stopped cleanly on SIGTERM\n" << d.log();

  ASSERT_NO_THROW(d.start()) << d.log();
  ASSERT_EQ(inner_daemon_pid(d.pid()).first, 1);
  c = d.client();
  ASSERT_TRUE(wait_running());
  ::kill(inner_daemon_pid(d.pid()).second, SIGKILL);
  d.kill(0);

  ASSERT_NO_THROW(d.start()) << d.log();
  ASSERT_EQ(inner_daemon_pid(d.pid()).first, 1);
  c = d.client();
  const Json s = wait_final(*c, id);
  EXPECT_EQ(s.value("state", ""), "done") << s.dump() << "\n" << d.log();
  EXPECT_EQ(s["attempts"], 3) << "started, restarted after SIGTERM, restarted after kill -9";
  const fs::path served = download(*c, dir, id);
  expect_same_datasets(served / "results.h5",
                       cli_run(dir, id, scaled_samples(demo, kLongJobScale)) / "results.h5");
  ::kill(inner_daemon_pid(d.pid()).second, SIGTERM);
  EXPECT_EQ(d.kill(0), 0);
}

TEST(Daemon, ShutdownPutsTheRunningJobBackInTheQueue) {
  const fs::path dir = fresh_dir("fragsimd_term_");
  Daemon d(dir);
  ASSERT_NO_THROW(d.start()) << d.log();
  auto c = d.client();
  const std::string id = submit(*c, scaled_samples(demo_scenario(), kLongJobScale));
  const auto deadline = Clock::now() + std::chrono::seconds(120);
  while (Clock::now() < deadline && job_status(*c, id).value("state", "") != "running")
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(d.kill(SIGTERM), 0) << "a clean shutdown exits 0";
  ASSERT_NO_THROW(d.start()) << d.log();
  c = d.client();
  const Json s = wait_final(*c, id);
  EXPECT_EQ(s.value("state", ""), "done");
  EXPECT_EQ(d.log().find("interrupted by a previous daemon"), std::string::npos)
      << "a clean stop is not a crash";
}

struct BadRequest {
  std::string what;
  std::string method;
  std::string path;
  std::string body;
  std::string content_type;
  std::string token;
  int status;
  std::string code;
  std::optional<std::string> field;
};

TEST(Daemon, BadRequestsGetTheRightStatusAndTheDaemonKeepsServing) {
  const fs::path dir = fresh_dir("fragsimd_bad_");
  // A request timeout longer than the raw exchanges wait (10 s): an answer that came only after
  // the daemon gave up reading would not be seen.
  Daemon d(dir, {"--max-body-bytes", "200000", "--request-timeout-s", "60"});
  ASSERT_NO_THROW(d.start()) << d.log();
  auto c = d.client();
  const Json minimal = minimal_scenario();
  Json wrong_type = minimal;
  wrong_type["fragment_groups"][0]["mass_kg"] = "heavy";
  Json unknown_site = minimal;
  unknown_site.erase("site");
  unknown_site["site_id"] = "s_00000000000000aa";
  const std::string json = "application/json";
  const std::vector<BadRequest> cases = {
      {"malformed JSON", "POST", "/v1/jobs", "{\"schema\": ", json, kToken, 400, "malformed_json",
       std::nullopt},
      {"wrong type", "POST", "/v1/jobs", wrong_type.dump(), json, kToken, 422, "invalid_input",
       "fragment_groups[0].mass_kg"},
      {"unknown site", "POST", "/v1/jobs", unknown_site.dump(), json, kToken, 422, "invalid_input",
       "site_id"},
      {"oversized body", "POST", "/v1/sites", std::string(300000, ' '), json, kToken, 413,
       "payload_too_large", std::nullopt},
      {"missing token", "GET", "/v1/jobs", "", "", "", 401, "unauthorized", std::nullopt},
      {"wrong token", "GET", "/v1/jobs", "", "", "not-the-token", 401, "unauthorized",
       std::nullopt},
      {"wrong content type", "POST", "/v1/jobs", minimal.dump(), "text/plain", kToken, 415,
       "unsupported_media_type", std::nullopt},
      {"unknown route", "GET", "/v1/nothing", "", "", kToken, 404, "not_found", std::nullopt},
      {"unknown job", "GET", "/v1/jobs/j_0000000000000000", "", "", kToken, 404, "not_found",
       std::nullopt},
      {"not an id", "GET", "/v1/jobs/..%2F..%2Fetc", "", "", kToken, 404, "not_found",
       std::nullopt},
      {"wrong method", "PUT", "/v1/jobs", "{}", json, kToken, 405, "method_not_allowed",
       std::nullopt},
      {"bad filter", "GET", "/v1/jobs?state=finished", "", "", kToken, 400, "bad_parameter",
       "state"},
      {"too deep", "POST", "/v1/jobs", std::string(100, '[') + std::string(100, ']'), json, kToken,
       400, "too_deep", std::nullopt},
  };
  for (const auto& bad : cases) {
    SCOPED_TRACE(bad.what);
    httplib::Client raw("127.0.0.1", d.port());
    httplib::Headers headers;
    if (!bad.token.empty()) headers.emplace("Authorization", "Bearer " + bad.token);
    httplib::Result r = bad.method == "GET" ? raw.Get(bad.path, headers)
                        : bad.method == "POST"
                            ? raw.Post(bad.path, headers, bad.body, bad.content_type)
                            : raw.Put(bad.path, headers, bad.body, bad.content_type);
    ASSERT_TRUE(r) << httplib::to_string(r.error());
    EXPECT_EQ(r->status, bad.status) << r->body;
    Json body;
    ASSERT_NO_THROW(body = Json::parse(r->body)) << r->body;
    EXPECT_EQ(body.value("code", ""), bad.code) << r->body;
    EXPECT_TRUE(body.contains("message") && body["message"].is_string() &&
                !body["message"].get<std::string>().empty());
    ASSERT_TRUE(body.contains("field"));
    if (bad.field) {
      EXPECT_EQ(body["field"], *bad.field);
    } else if (!body["field"].is_null()) {
      EXPECT_TRUE(body["field"].is_string());
    }
    if (bad.status == 405) {
      EXPECT_EQ(r->get_header_value("Allow"), "GET, POST");
    }
    if (bad.status == 401) {
      EXPECT_TRUE(r->has_header("WWW-Authenticate"));
    }
    auto health = c->Get("/v1/health");
    ASSERT_TRUE(health && health->status == 200) << "the daemon stopped serving";
  }
  // A chunked body is refused before it is read (the size limit needs a Content-Length). The small
  // one goes out in a single write, so the whole request is in before the answer and the 411 is
  // read every time. The large one goes through the client library, which writes it in pieces: it
  // may see the 411 or, when the daemon has closed the connection, a write error. Either way the
  // daemon keeps serving.
  {
    SCOPED_TRACE("chunked body of 2 bytes");
    const std::string answer = raw_exchange(
        d.port(), "POST /v1/sites HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer " +
                      std::string(kToken) +
                      "\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n"
                      "Connection: close\r\n\r\n2\r\n{}\r\n0\r\n\r\n");
    ASSERT_EQ(answer.rfind("HTTP/1.1 411 ", 0), 0u) << answer;
    const std::size_t body_at = answer.find("\r\n\r\n");
    ASSERT_NE(body_at, std::string::npos) << answer;
    EXPECT_EQ(Json::parse(answer.substr(body_at + 4)).value("code", ""), "length_required");
    auto health = c->Get("/v1/health");
    ASSERT_TRUE(health && health->status == 200) << "the daemon stopped serving";
  }
  // A body announced above the limit is refused from the header, before it is sent: 300 MiB
  // announced, 10 bytes sent, the 413 comes at once and the connection is closed (the raw
  // exchange reads until the daemon closes it).
  {
    SCOPED_TRACE("300 MiB announced");
    const std::string answer = raw_exchange(
        d.port(), "POST /v1/sites HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer " +
                      std::string(kToken) +
                      "\r\nContent-Type: application/json\r\nContent-Length: 314572800\r\n\r\n"
                      "{\"terrain\":");
    ASSERT_EQ(answer.rfind("HTTP/1.1 413 ", 0), 0u) << answer;
    EXPECT_NE(answer.find("Connection: close"), std::string::npos) << answer;
    const std::size_t body_at = answer.find("\r\n\r\n");
    ASSERT_NE(body_at, std::string::npos) << answer;
    const Json body = Json::parse(answer.substr(body_at + 4));
    EXPECT_EQ(body.value("code", ""), "payload_too_large");
    EXPECT_NE(body.value("message", "").find("314572800"), std::string::npos) << body.dump();
    auto health = c->Get("/v1/health");
    ASSERT_TRUE(health && health->status == 200) << "the daemon stopped serving";
  }
  {
    SCOPED_TRACE("chunked body of 3 MB");
    httplib::Client raw("127.0.0.1", d.port());
    raw.set_bearer_token_auth(kToken);
    const std::string body(3000000, ' ');
    auto r = raw.Post(
        "/v1/sites",
        [&](std::size_t offset, httplib::DataSink& sink) {
          if (offset < body.size()) {
            sink.write(body.data() + offset, std::min<std::size_t>(4096, body.size() - offset));
          } else {
            sink.done();
          }
          return true;
        },
        "application/json");
    if (r) {
      EXPECT_EQ(r->status, 411) << r->body;
      EXPECT_EQ(Json::parse(r->body).value("code", ""), "length_required");
    } else {
      EXPECT_EQ(r.error(), httplib::Error::Write);
    }
    auto health = c->Get("/v1/health");
    ASSERT_TRUE(health && health->status == 200) << "the daemon stopped serving";
  }
  // Nothing of the refused requests was queued.
  auto jobs = c->Get("/v1/jobs");
  ASSERT_TRUE(jobs && jobs->status == 200);
  EXPECT_TRUE(Json::parse(jobs->body)["jobs"].empty());
  EXPECT_TRUE(d.alive());
}

// What a browser gets (it accepts br, gzip, deflate, zstd): text compressed with gzip by the
// daemon, not with cpp-httplib's slow Brotli; the viewer's files byte for byte; error bodies
// intact. The client here inflates gzip itself.
TEST(Daemon, BrowsersGetGzipAndErrorsKeepTheirBodies) {
  const fs::path dir = fresh_dir("fragsimd_gzip_");
  Daemon d(dir);
  ASSERT_NO_THROW(d.start()) << d.log();
  httplib::Client c("127.0.0.1", d.port());
  c.set_decompress(true);
  const httplib::Headers browser = {{"Accept-Encoding", "gzip, deflate, br, zstd"}};
  const std::string file = "vendor/three.core.js";
  httplib::Result r = c.Get("/ui/" + file, browser);
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Encoding"), "gzip");
  EXPECT_EQ(r->body, read_text(fs::path(FRAGSIM_SOURCE_DIR) / "viewer" / file));
  r = c.Get("/v1/jobs", browser);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);
  EXPECT_EQ(Json::parse(r->body).value("code", ""), "unauthorized") << r->body;
  httplib::Headers with_token = browser;
  with_token.emplace("Authorization", std::string("Bearer ") + kToken);
  r = c.Post("/v1/jobs", with_token, "{\"schema\": 1}", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Json::parse(r->body).value("field", ""), "schema") << r->body;
  // Without Accept-Encoding: the bytes as they are.
  r = c.Get("/ui/" + file);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->get_header_value("Content-Encoding"), "");
  EXPECT_EQ(r->body.size(), fs::file_size(fs::path(FRAGSIM_SOURCE_DIR) / "viewer" / file));
}

TEST(Daemon, FiftyClientsPollWhileAJobRuns) {
  const fs::path dir = fresh_dir("fragsimd_poll_");
  Daemon d(dir);
  ASSERT_NO_THROW(d.start()) << d.log();
  auto c = d.client();
  const Json demo = demo_scenario();
  const std::string site = upload_site(*c, demo);
  const std::string done = submit(*c, by_site_id(scaled_samples(demo, 0.25), site));
  ASSERT_EQ(wait_final(*c, done).value("state", ""), "done");
  const std::string running = submit(*c, by_site_id(scaled_samples(demo, outlasting(1.0)), site));

  std::atomic<int> errors{0};
  std::atomic<int> requests{0};
  std::atomic<bool> stop{false};
  std::vector<std::thread> clients;
  for (int k = 0; k < 50; ++k) {
    clients.emplace_back([&, k] {
      auto client = d.client();
      const std::vector<std::string> paths = {"/v1/jobs/" + running,
                                              "/v1/jobs/" + done,
                                              "/v1/jobs/" + done + "/summary",
                                              "/v1/jobs/" + done + "/buildings",
                                              "/v1/health",
                                              "/metrics"};
      std::size_t n = static_cast<std::size_t>(k);
      while (!stop.load()) {
        const std::string& path = paths[n++ % paths.size()];
        auto r = client->Get(path);
        ++requests;
        if (!r || r->status != 200) {
          ++errors;
          ADD_FAILURE() << path << ": "
                        << (r ? std::to_string(r->status) + " " + r->body
                              : httplib::to_string(r.error()));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    });
  }
  const Json s = wait_final(*c, running);
  stop = true;
  for (auto& t : clients) t.join();
  EXPECT_EQ(s.value("state", ""), "done");
  EXPECT_EQ(errors.load(), 0);
  EXPECT_GT(requests.load(), 50);
}

// Slow clients, as fragsimd answers them: a JSON 408 at the total deadline, while one request
// worker keeps serving everyone else; the connection gauges in /metrics.
TEST(Daemon, TricklingClientsGetAJson408AndOthersAreServed) {
  const fs::path dir = fresh_dir("fragsimd_slow_");
  Daemon d(dir, {"--request-timeout-s", "1", "--http-threads", "1"});
  ASSERT_NO_THROW(d.start()) << d.log();
  std::vector<std::thread> slow;
  std::vector<std::string> answers(3);
  for (std::size_t k = 0; k < answers.size(); ++k) {
    slow.emplace_back([&, k] {
      // Headers for the first, a body for the others, one byte every 100 ms.
      const std::string head =
          k == 0 ? "GET /v1/health HTTP/1.1\r\nHost: t\r\nX-Slow: "
                 : std::string("POST /v1/sites HTTP/1.1\r\nHost: t\r\nAuthorization: Bearer ") +
                       kToken + "\r\nContent-Type: application/json\r\nContent-Length: 999\r\n\r\n";
      answers[k] = trickle_exchange(d.port(), head, 50, std::chrono::milliseconds(100));
    });
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  auto c = d.client();
  const auto t0 = Clock::now();
  auto health = c->Get("/v1/health");
  EXPECT_TRUE(health && health->status == 200);
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 0.9);
  auto metrics = c->Get("/metrics");
  ASSERT_TRUE(metrics && metrics->status == 200);
  EXPECT_NE(metrics->body.find("\nfragsimd_http_connections "), std::string::npos);
  EXPECT_NE(metrics->body.find("\nfragsimd_http_workers "), std::string::npos);
  for (auto& t : slow) t.join();
  for (const std::string& a : answers) {
    ASSERT_NE(a.find("HTTP/1.1 408"), std::string::npos) << a;
    const Json body = Json::parse(a.substr(a.find("\r\n\r\n") + 4));
    EXPECT_EQ(body.value("code", ""), "request_timeout") << a;
  }
  EXPECT_TRUE(d.alive());
}

// GET /v1/health whose request line and headers (the blank line included) are `total` bytes, in
// header lines of at most 4 KiB.
std::string request_of_total(std::size_t total) {
  std::string head = "GET /v1/health HTTP/1.1\r\nHost: t\r\nConnection: close\r\n";
  std::size_t room = total - 2 - head.size();
  for (int k = 0; room > 0; ++k) {
    const std::size_t line = room > 8000 ? 4000 : room;
    const std::string name = "X-Pad-" + std::to_string(k) + ": ";
    head += name + std::string(line - name.size() - 2, 'a') + "\r\n";
    room -= line;
  }
  return head + "\r\n";
}

// GET /v1/health with one header line of `bytes` bytes, its CRLF included.
std::string request_with_line(std::size_t bytes) {
  const std::string name = "X-Long: ";
  return "GET /v1/health HTTP/1.1\r\nHost: t\r\nConnection: close\r\n" + name +
         std::string(bytes - name.size() - 2, 'a') + "\r\n\r\n";
}

// A request whose request line is `bytes` bytes, its CRLF included: GET of an unknown job.
std::string request_with_request_line(std::size_t bytes) {
  const std::size_t target = bytes - std::string("GET  HTTP/1.1\r\n").size();
  return "GET /v1/jobs/" + std::string(target - 9, 'a') + " HTTP/1.1\r\nHost: t\r\n" +
         "Authorization: Bearer " + kToken + "\r\nConnection: close\r\n\r\n";
}

// Each connection limit at its edge, from outside (docs/http-api.md, "Connections", "Errors"):
// the limit itself accepted, one byte more refused with the documented status and code; every
// request sent in one write and trickled (1 KiB every 2 ms).
TEST(Daemon, EachConnectionLimitHoldsAtItsEdge) {
  const fs::path dir = fresh_dir("fragsimd_limits_");
  Daemon d(dir);
  ASSERT_NO_THROW(d.start()) << d.log();
  struct Case {
    std::string what;
    std::string request;
    int status;
    std::string code;  // empty: a 200
  };
  const std::vector<Case> cases = {
      {"headers of 64 KiB", request_of_total(65536), 200, ""},
      {"headers of 64 KiB + 1", request_of_total(65537), 431, "headers_too_large"},
      {"a header line of 8 KiB", request_with_line(8192), 200, ""},
      {"a header line of 8 KiB + 1", request_with_line(8193), 400, "bad_request"},
      {"a request line of 8 KiB", request_with_request_line(8192), 404, "not_found"},
      {"a request line of 8 KiB + 1", request_with_request_line(8193), 414, "uri_too_long"},
      {"TRACE on a known path", "TRACE /v1/jobs HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n",
       405, "method_not_allowed"},
      {"CONNECT", "CONNECT t:80 HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n", 404,
       "not_found"},
  };
  for (const Case& c : cases) {
    for (const bool trickled : {false, true}) {
      SCOPED_TRACE(c.what + (trickled ? ", trickled" : ", in one write") + " (" +
                   std::to_string(c.request.size()) + " bytes)");
      const std::string answer =
          trickled ? pieces_exchange(d.port(), c.request, 1024, std::chrono::milliseconds(2))
                   : raw_exchange(d.port(), c.request);
      ASSERT_EQ(answer.substr(0, 12), "HTTP/1.1 " + std::to_string(c.status)) << answer;
      const std::size_t body = answer.find("\r\n\r\n");
      ASSERT_NE(body, std::string::npos) << answer;
      const Json j = Json::parse(answer.substr(body + 4), nullptr, false);
      if (c.code.empty()) {
        EXPECT_EQ(j.value("status", ""), "ok") << answer;
      } else {
        EXPECT_EQ(j.value("code", ""), c.code) << answer;
      }
      if (c.status == 405) {
        EXPECT_NE(answer.find("\r\nAllow: GET, POST\r\n"), std::string::npos) << answer;
      }
    }
  }
  EXPECT_TRUE(d.alive());
}

// docs/operations.md, "Backups": `fragsimd backup` while the daemon runs a job and clients poll;
// a daemon started on the backup serves the done jobs' results byte for byte and queues again
// the job that was running. A second backup to the same place is refused.
TEST(Daemon, ABackupTakenUnderLoadRestoresTheSameResults) {
  const fs::path dir = fresh_dir("fragsimd_backup_");
  fs::create_directories(dir / "live");
  fs::create_directories(dir / "restored");
  Daemon d(dir / "live");
  ASSERT_NO_THROW(d.start()) << d.log();
  auto c = d.client();
  const std::string site = upload_site(*c, minimal_scenario());
  std::vector<std::string> done;
  for (const std::uint64_t seed : {1, 2}) {
    done.push_back(submit(*c, by_site_id(with_seed(minimal_scenario(), seed), site)));
    ASSERT_EQ(wait_final(*c, done.back())["state"], "done");
  }
  const std::string running = submit(*c, scaled_samples(demo_scenario(), outlasting(50.0)));
  for (int k = 0; k < 12000 && job_status(*c, running).value("histories_done", 0) == 0; ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_EQ(job_status(*c, running)["state"], "running");

  std::atomic<bool> stop{false};
  std::thread poller([&] {  // clients at work while the backup runs
    auto p = d.client();
    while (!stop) p->Get("/v1/jobs");
  });
  const fs::path target = dir / "restored" / "data";
  const std::vector<std::string> backup = {FRAGSIMD, "backup", target.string(), "--data-dir",
                                           d.data().string()};
  const int rc = run_process(backup, dir / "backup.log");
  stop = true;
  poller.join();
  ASSERT_EQ(rc, 0) << read_text(dir / "backup.log");
  EXPECT_NE(read_text(dir / "backup.log").find("3 jobs (2 done, with their files)"),
            std::string::npos)
      << read_text(dir / "backup.log");
  EXPECT_NE(run_process(backup, dir / "again.log"), 0);  // the target exists
  EXPECT_NE(read_text(dir / "again.log").find("exists"), std::string::npos);
  EXPECT_EQ(job_status(*c, running)["state"], "running");  // the live daemon went on
  ASSERT_EQ(c->Delete("/v1/jobs/" + running)->status, 200);

  Daemon restored(dir / "restored");
  ASSERT_NO_THROW(restored.start()) << restored.log();
  auto r = restored.client();
  for (const std::string& id : done) {
    SCOPED_TRACE(id);
    for (const char* part : {"/results.h5", "/summary", "/buildings"}) {
      auto a = c->Get("/v1/jobs/" + id + part);
      auto b = r->Get("/v1/jobs/" + id + part);
      ASSERT_TRUE(a && b);
      ASSERT_EQ(b->status, 200) << part << " " << b->body;
      EXPECT_TRUE(a->body == b->body) << part << ": not the same bytes";
    }
  }
  const Json again = job_status(*r, running);
  EXPECT_TRUE(again["state"] == "queued" || again["state"] == "running") << again;
  EXPECT_NE(restored.log().find("queued again"), std::string::npos);
  ASSERT_EQ(r->Delete("/v1/jobs/" + running)->status, 200);
  EXPECT_EQ(r->Get("/v1/sites/" + site)->status, 200);
}

TEST(Daemon, CancelStopsARunningJobAndLeavesNoResults) {
  const fs::path dir = fresh_dir("fragsimd_cancel_");
  Daemon d(dir);
  ASSERT_NO_THROW(d.start()) << d.log();
  auto c = d.client();
  const std::string id = submit(*c, scaled_samples(demo_scenario(), outlasting(50.0)));
  const auto deadline = Clock::now() + std::chrono::seconds(120);
  while (Clock::now() < deadline) {
    const Json s = job_status(*c, id);
    if (s.value("state", "") == "running" && s.value("histories_done", 0) > 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const auto t0 = Clock::now();
  auto r = c->Delete("/v1/jobs/" + id);
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(Json::parse(r->body)["state"], "cancelled");
  // The contract: a cancelled job stops within a second (DELETE returns once it has stopped).
  // Checked in Release; a sanitizer build on a busy machine took 1.7 s and 3.4 s (TSan, CI,
  // 2026-11-29) while a cancelled run still computed its figures and sorted its records.
  std::cout << "DELETE returned after " << seconds << " s\n";
  EXPECT_LT(seconds, kSanitized ? 3.0 : 1.0);
  auto health = c->Get("/v1/health");
  ASSERT_TRUE(health && health->status == 200);
  EXPECT_EQ(Json::parse(health->body)["jobs"]["running"], 0);
  const Json s = job_status(*c, id);
  EXPECT_EQ(s["state"], "cancelled");
  EXPECT_LT(s["histories_done"].get<std::int64_t>(), s["histories_total"].get<std::int64_t>());
  for (const char* part : {"/summary", "/buildings", "/ptn", "/results.h5"}) {
    auto res = c->Get("/v1/jobs/" + id + part);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 409) << part;
    EXPECT_EQ(Json::parse(res->body)["code"], "not_ready") << part;
  }
  EXPECT_FALSE(fs::exists(d.data() / "jobs" / id / "results.h5"));
  auto again = c->Delete("/v1/jobs/" + id);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 409);
}

// docs/operations.md: a kill -9 while jobs are being purged leaves each job whole (row, files,
// results served) or gone (404, no directory), and the restart clears what a purge cut short.
TEST(Daemon, KillNineDuringPurgesLeavesEachJobWholeOrGone) {
  const fs::path dir = fresh_dir("fragsimd_purge_kill_");
  Daemon d(dir);
  ASSERT_NO_THROW(d.start()) << d.log();
  auto c = d.client();
  std::vector<std::string> ids;
  for (int k = 0; k < 12; ++k) ids.push_back(submit(*c, with_seed(minimal_scenario(), 100 + k)));
  for (const auto& id : ids) ASSERT_EQ(wait_final(*c, id).value("state", ""), "done") << id;

  // Purges one after another on a thread; killed once five have been answered, so that the kill
  // lands in the middle of the sixth or seventh.
  std::atomic<int> answered{0};
  std::thread purger([&] {
    auto pc = d.client();
    for (const auto& id : ids) {
      auto r = pc->Delete("/v1/jobs/" + id + "?purge=true");
      if (!r) return;  // the daemon is gone
      answered.fetch_add(1);
    }
  });
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (answered.load() < 5 && Clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  d.kill(SIGKILL);
  purger.join();
  ASSERT_GE(answered.load(), 5);

  ASSERT_NO_THROW(d.start()) << d.log();
  c = d.client();
  int gone = 0;
  for (const auto& id : ids) {
    SCOPED_TRACE(id);
    auto r = c->Get("/v1/jobs/" + id);
    ASSERT_TRUE(r);
    if (r->status == 404) {
      ++gone;
      EXPECT_FALSE(fs::exists(d.data() / "jobs" / id));
      continue;
    }
    ASSERT_EQ(r->status, 200) << r->body;
    EXPECT_EQ(Json::parse(r->body)["state"], "done");
    auto h5 = c->Get("/v1/jobs/" + id + "/results.h5");
    ASSERT_TRUE(h5);
    EXPECT_EQ(h5->status, 200);
    EXPECT_GT(h5->body.size(), 1000u);
  }
  EXPECT_GE(gone, 5);
  for (const auto& e : fs::directory_iterator(d.data() / "jobs"))
    EXPECT_FALSE(e.path().filename().string().starts_with(".purging-")) << e.path();
  // The rest can go too; then the jobs directory is empty.
  for (const auto& id : ids) {
    auto r = c->Delete("/v1/jobs/" + id + "?purge=true");
    ASSERT_TRUE(r);
    EXPECT_TRUE(r->status == 200 || r->status == 404) << r->status << " " << r->body;
  }
  EXPECT_TRUE(fs::is_empty(d.data() / "jobs"));
  EXPECT_EQ(d.kill(SIGTERM), 0);
}

}  // namespace
}  // namespace fragsim::server::testing

namespace fragsim::server::testing {
namespace {

TEST(Daemon, SubmitCommandRunsAScenarioOnTheServer) {
  const fs::path dir = fresh_dir("fragsimd_submit_");
  Daemon d(dir);
  ASSERT_NO_THROW(d.start()) << d.log();
  const std::string url = "http://127.0.0.1:" + std::to_string(d.port());
  const std::string scenario = source_path("examples/minimal/scenario.json").string();
  const fs::path out = dir / "out";
  ASSERT_EQ(run_process({FRAGSIM_CLI, "submit", scenario, "--server", url, "--token-file",
                         (dir / "tokens").string(), "--out", out.string(), "--maps", "--quiet"},
                        dir / "submit.log"),
            0)
      << read_text(dir / "submit.log");
  const fs::path cli = cli_run(dir, "minimal", minimal_scenario());
  expect_same_datasets(out / "results.h5", cli / "results.h5");
  EXPECT_EQ(comparable_summary(read_text(out / "summary.json")),
            comparable_summary(read_text(cli / "summary.json")));
  // --maps: the server's maps, the same bytes as `fragsim export` of the downloaded results.
  ASSERT_EQ(run_process({FRAGSIM_CLI, "export", (out / "results.h5").string(), "--out",
                         (dir / "local_maps").string()},
                        dir / "export.log"),
            0)
      << read_text(dir / "export.log");
  for (const char* name : {"ptn_density.tif", "ptn_classes.tif"})
    EXPECT_EQ(read_text(out / "maps" / name), read_text(dir / "local_maps" / name)) << name;
  EXPECT_TRUE(fs::is_regular_file(out / "maps" / "hazard.gpkg"));

  // --units us (docs/units.md): the printed summary in ft and per 600 ft² (stdout to a file).
  const fs::path printed = dir / "submit_us.txt";
  ASSERT_EQ(run_process({"/bin/sh", "-c", "exec \"$0\" \"$@\" > " + printed.string(), FRAGSIM_CLI,
                         "submit", scenario, "--server", url, "--token-file",
                         (dir / "tokens").string(), "--units", "us"},
                        dir / "submit_us.log"),
            0)
      << read_text(dir / "submit_us.log");
  const double hfd_m =
      Json::parse(read_text(out / "summary.json"))["hazardous_fragment_distance_m"].get<double>();
  char hfd_ft[80];
  std::snprintf(hfd_ft, sizeof hfd_ft, "Hazardous fragment distance   %.1f ft", hfd_m / 0.3048);
  EXPECT_NE(read_text(printed).find(hfd_ft), std::string::npos) << read_text(printed);
  EXPECT_NE(read_text(printed).find("  threshold                   1 per 600 ft²"),
            std::string::npos)
      << read_text(printed);

  // A wrong token is invalid input (exit 2); nothing is written.
  write_text(dir / "wrong", "not-the-token\n");
  EXPECT_EQ(run_process({FRAGSIM_CLI, "submit", scenario, "--server", url, "--token-file",
                         (dir / "wrong").string(), "--out", (dir / "out2").string()},
                        dir / "submit2.log"),
            2);
  EXPECT_NE(read_text(dir / "submit2.log").find("unauthorized"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "out2"));

  // The daemon's warnings on a job are printed (issue 22): the minimal example's group can reach
  // beyond a 400 m x 400 m plane. --no-wait: the job id on stdout, the warning on stderr.
  Json small = minimal_scenario();
  small["site"]["terrain"]["plane"]["extent_m"] = {-200, -200, 200, 200};
  small["fragment_groups"][0]["samples"] = 20;
  write_text(dir / "small.json", small.dump());
  ASSERT_EQ(run_process({FRAGSIM_CLI, "submit", (dir / "small.json").string(), "--server", url,
                         "--token-file", (dir / "tokens").string(), "--no-wait"},
                        dir / "submit_small.log"),
            0)
      << read_text(dir / "submit_small.log");
  EXPECT_NE(read_text(dir / "submit_small.log")
                .find("warning: fragment_groups[0] (\"steel spheres\"): about "),
            std::string::npos)
      << read_text(dir / "submit_small.log");

  // --compare-with (docs/comparison.md): the minimal scenario with B1 moved, as the variant of
  // the first job; the comparison is printed and downloaded with the variant's results.
  const Json jobs = Json::parse(d.client()->Get("/v1/jobs?state=done&limit=1000")->body);
  const std::string first_job = jobs["jobs"].back()["job_id"];
  Json moved = minimal_scenario();
  moved["site"]["buildings"][0]["footprint_m"] = {{80, -10}, {100, -10}, {100, 10}, {80, 10}};
  write_text(dir / "moved.json", moved.dump());
  const fs::path compared = dir / "compared";
  ASSERT_EQ(run_process({"/bin/sh", "-c", "exec \"$0\" \"$@\" > " + (dir / "cmp.txt").string(),
                         FRAGSIM_CLI, "submit", (dir / "moved.json").string(), "--server", url,
                         "--token-file", (dir / "tokens").string(), "--compare-with", first_job,
                         "--out", compared.string()},
                        dir / "submit_cmp.log"),
            0)
      << read_text(dir / "submit_cmp.log");
  EXPECT_NE(read_text(dir / "cmp.txt").find("Paired comparison (2000 histories"), std::string::npos)
      << read_text(dir / "cmp.txt");
  EXPECT_EQ(Json::parse(read_text(compared / "compare.json"))["changed"].dump(),
            R"(["site.buildings"])");
  EXPECT_TRUE(fs::is_regular_file(compared / "compare.h5"));

  // A second daemon on the same data directory refuses to start.
  Daemon other(dir);
  EXPECT_THROW(other.start(), std::runtime_error);
  EXPECT_NE(read_text(dir / "fragsimd.log").find("in use by another fragsimd"), std::string::npos);
  EXPECT_TRUE(d.alive());
  d.kill(SIGTERM);

  // No server: an internal error (exit 1), not a crash.
  EXPECT_EQ(run_process({FRAGSIM_CLI, "submit", scenario, "--server", url, "--token-file",
                         (dir / "tokens").string()},
                        dir / "submit3.log"),
            1);
}

}  // namespace
}  // namespace fragsim::server::testing
