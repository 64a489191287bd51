// fragsimd's request handling without sockets: Service::handle(Request) -> Response. Routing,
// authentication, content types, error bodies, sites, jobs and their life cycle, results, metrics
// (docs/http-api.md is the contract).
#include "server/service.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <thread>
#include <tuple>

#include "api/job_request.h"
#include "api/scenario_json.h"
#include "api/sha256.h"
#include "api/site_document.h"
#include "api/test_support.h"
#include "core/run/run.h"
#include "gis/results_export.h"
#include "server/openapi_text.h"
#include "server/ui_assets.h"
#include "small_disk.h"
#include "store_support.h"

namespace fragsim::server {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using api::testing::minimal_example;

constexpr const char* kToken = "test-token-1";
constexpr const char* kOtherToken = "second-token";
constexpr const char* kUnknownJob = "j_0123456789abcdef";
constexpr const char* kUnknownSite = "s_0000000000000000";
// Far more histories than a test lasts: keeps the worker busy so that later jobs stay queued.
// The service's destructor stops it (a running job is requeued at shutdown).
constexpr std::int64_t kBlockerSamples = 50'000'000;

// The minimal example on a 400 m plane of 10 m cells (api::testing::on_small_plane): the
// service's tests need a small valid site, not one that holds every fragment.
Json small_example() {
  return api::testing::on_small_plane(minimal_example());
}

Json minimal_site() {
  return small_example()["site"];
}

// The minimal example by site_id, `samples` histories.
Json job_on(const std::string& site_id, std::int64_t samples = 200) {
  Json j = small_example();
  j.erase("site");
  j["site_id"] = site_id;
  j["fragment_groups"][0]["samples"] = samples;
  return j;
}

Json blocker_job(const std::string& site_id) {
  Json j = job_on(site_id, kBlockerSamples);
  j["settings"]["record_fragments"] = false;
  j["priority"] = api::kMaxJobPriority;
  return j;
}

// The body, also of a streamed response (consumed: call once per response).
Json body_of(const Response& r) {
  std::string body = r.body;
  if (r.stream)
    while (r.stream(body)) {
    }
  return Json::parse(body);
}

std::optional<std::string> header(const Response& r, const std::string& name) {
  const auto lower = [](std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
  };
  for (const auto& [k, v] : r.headers)
    if (lower(k) == lower(name)) return v;
  return std::nullopt;
}

// An error response as the contract has it: status, JSON body {code, message, field}.
void expect_error(const Response& r, int status, const std::string& code,
                  const std::optional<std::string>& field = std::nullopt) {
  EXPECT_EQ(r.status, status) << r.body;
  EXPECT_EQ(r.content_type, "application/json");
  Json j;
  try {
    j = body_of(r);
  } catch (const std::exception&) {
    ADD_FAILURE() << "error body is not JSON: " << r.body;
    return;
  }
  ASSERT_TRUE(j.is_object()) << r.body;
  EXPECT_EQ(j.size(), 3u) << r.body;
  EXPECT_EQ(j.value("code", ""), code) << r.body;
  ASSERT_TRUE(j.contains("message")) << r.body;
  EXPECT_TRUE(j["message"].is_string());
  EXPECT_FALSE(j["message"].get<std::string>().empty());
  ASSERT_TRUE(j.contains("field")) << r.body;
  if (field) {
    EXPECT_EQ(j["field"], *field) << r.body;
  } else {
    EXPECT_TRUE(j["field"].is_null()) << r.body;
  }
}

std::size_t count_occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = api::testing::fresh_test_dir("fragsim_service_test_");
    std::ofstream(dir_ / "tokens") << "# fragsimd test tokens\n\n"
                                   << kToken << "\n  " << kOtherToken << "  \n";
  }
  void TearDown() override {
    service_.reset();
    fs::remove_all(dir_);
  }

  Config config() const {
    Config c;
    c.data_dir = (dir_ / "data").string();
    c.token_file = (dir_ / "tokens").string();
    c.auth = true;
    c.threads = 1;
    c.min_free_bytes = 16 << 20;  // the CI machine's disk runs close to full (the default: 512 MiB)
    return c;
  }
  Service& start(const std::function<void(Config&)>& adjust = {}) {
    Config c = config();
    if (adjust) adjust(c);
    service_ = std::make_unique<Service>(c);
    return *service_;
  }
  void restart() {
    service_.reset();
    service_ = std::make_unique<Service>(config());
  }

  Response call(const std::string& method, const std::string& path,
                std::map<std::string, std::string> query = {}, std::string body = {},
                std::map<std::string, std::string> headers = {}, bool auth = true) {
    Request req;
    req.method = method;
    req.path = path;
    req.query = std::move(query);
    req.headers = std::move(headers);
    if (auth && !req.headers.count("authorization"))
      req.headers["authorization"] = std::string("Bearer ") + kToken;
    req.body = std::move(body);
    return service_->handle(req);
  }
  Response get(const std::string& path, std::map<std::string, std::string> query = {}) {
    return call("GET", path, std::move(query));
  }
  Response get_anonymous(const std::string& path) { return call("GET", path, {}, {}, {}, false); }
  Response del(const std::string& path) { return call("DELETE", path); }
  Response post_text(const std::string& path, const std::string& text,
                     const std::string& content_type = "application/json") {
    std::map<std::string, std::string> headers;
    if (!content_type.empty()) headers["content-type"] = content_type;
    return call("POST", path, {}, text, headers);
  }
  Response post(const std::string& path, const Json& body) { return post_text(path, body.dump()); }

  // Posts the minimal example's site; returns its id.
  std::string add_site(const Json& site = minimal_site()) {
    const Response r = post("/v1/sites", site);
    EXPECT_TRUE(r.status == 201 || r.status == 200) << r.status << " " << r.body;
    return body_of(r).value("site_id", "");
  }
  // Posts a job; returns its id (asserting 202).
  std::string add_job(const Json& body) {
    const Response r = post("/v1/jobs", body);
    EXPECT_EQ(r.status, 202) << r.body;
    return body_of(r).value("job_id", "");
  }
  // A done job of 200 samples on the minimal site placed in UTM 11N (a CRS, so that every map
  // and the site-plan boundary are made); returns its id (expecting it done).
  std::string done_job_in_utm() {
    Json site = minimal_site();
    site["origin"] = {{"crs", "EPSG:32611"},
                      {"easting_m", 500000.0},
                      {"northing_m", 3700000.0},
                      {"elevation_m", 0.0}};
    const std::string id = add_job(job_on(add_site(site), 200));
    EXPECT_EQ(wait_for_state(id, "done")["state"], "done");
    return id;
  }
  Json job(const std::string& id) {
    const Response r = get("/v1/jobs/" + id);
    EXPECT_EQ(r.status, 200) << r.body;
    return body_of(r);
  }
  // Polls the job until `done(status)`; a generous deadline, no timing assertion.
  Json wait_for(const std::string& id, const std::function<bool(const Json&)>& done) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    Json j = job(id);
    while (!done(j) && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      j = job(id);
    }
    return j;
  }
  Json wait_for_state(const std::string& id, const std::string& state) {
    return wait_for(id,
                    [&](const Json& j) { return j["state"] == state || j["state"] == "failed"; });
  }
  // The blocker job, once it runs (the worker is then busy until the test ends or cancels it).
  std::string running_blocker(const std::string& site) {
    const std::string id = add_job(blocker_job(site));
    EXPECT_EQ(wait_for_state(id, "running")["state"], "running");
    return id;
  }
  // A small job that stays queued behind a running blocker (the lowest priority).
  static Json queued_behind(const std::string& site) {
    Json j = job_on(site, 100);
    j["priority"] = -1000;
    return j;
  }
  std::string metrics_text() {
    const Response r = get("/metrics");
    EXPECT_EQ(r.status, 200) << r.body;
    return r.body;
  }

  fs::path dir_;
  std::unique_ptr<Service> service_;
};

using ServiceRouting = ServiceTest;
using ServiceAuth = ServiceTest;
using ServiceInput = ServiceTest;
using ServiceSites = ServiceTest;
using ServiceJobs = ServiceTest;
using ServiceQueue = ServiceTest;
using ServiceResults = ServiceTest;
using ServiceMetrics = ServiceTest;

// ---- Routing ----

TEST_F(ServiceRouting, UnknownPathIs404WithAnErrorBody) {
  start();
  for (const char* path : {"/v1/nothing", "/v1", "/v1/health/", "/v2/health", "/v1/sites/",
                           "/v1/jobs//summary", "/v1/jobs/j_0123456789abcdef/other"}) {
    SCOPED_TRACE(path);
    const Response r = get(path);
    expect_error(r, 404, "not_found");
    EXPECT_EQ(r.route, "unmatched");
  }
  // The route is checked before the token.
  expect_error(get_anonymous("/v1/nothing"), 404, "not_found");
}

TEST_F(ServiceRouting, MalformedOrUnknownIdsAre404) {
  start();
  for (const char* path :
       {"/v1/sites/abc", "/v1/sites/S_0123456789ABCDEF", "/v1/sites/j_0123456789abcdef",
        "/v1/sites/s_0000000000000000", "/v1/jobs/abc", "/v1/jobs/..",
        "/v1/jobs/s_0123456789abcdef", "/v1/jobs/j_0123456789abcdef",
        "/v1/jobs/j_0123456789abcdef/summary", "/v1/jobs/j_0123456789abcdef/ptn",
        "/v1/jobs/x/results.h5", "/v1/jobs/j_0123456789abcdef/buildings",
        "/v1/jobs/j_0123456789abcdef/maps", "/v1/jobs/j_0123456789abcdef/maps/hazard.kml",
        "/v1/jobs/j_0123456789abcdef/maps/", "/v1/jobs/j_0123456789abcdef/plan_boundary"}) {
    SCOPED_TRACE(path);
    expect_error(get(path), 404, "not_found");
  }
  expect_error(del("/v1/jobs/j_0123456789abcdef"), 404, "not_found");
  expect_error(del("/v1/sites/s_0000000000000000"), 404, "not_found");
}

TEST_F(ServiceRouting, OtherMethodIs405WithAllow) {
  start();
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"PUT", "/v1/sites", "GET, POST"},
      {"DELETE", "/v1/jobs", "GET, POST"},
      {"DELETE", "/v1/health", "GET"},
      {"POST", "/v1/openapi.yaml", "GET"},
      {"PATCH", "/metrics", "GET"},
      {"POST", "/v1/jobs/j_0123456789abcdef", "GET, DELETE"},
      {"PUT", "/v1/sites/s_0123456789abcdef", "GET, DELETE"},
      {"DELETE", "/v1/jobs/j_0123456789abcdef/summary", "GET"},
      {"POST", "/v1/jobs/j_0123456789abcdef/results.h5", "GET"},
  };
  for (const auto& [method, path, allow] : cases) {
    SCOPED_TRACE(method + " " + path);
    const Response r = call(method, path);
    expect_error(r, 405, "method_not_allowed");
    EXPECT_EQ(header(r, "Allow"), allow);
    // Checked before the token.
    const Response anonymous = call(method, path, {}, {}, {}, false);
    EXPECT_EQ(anonymous.status, 405);
    EXPECT_EQ(header(anonymous, "Allow"), allow);
  }
}

TEST_F(ServiceRouting, HeadIsTreatedAsGet) {
  start();
  const Response head = call("HEAD", "/v1/health", {}, {}, {}, false);
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.route, "/v1/health");
  EXPECT_EQ(body_of(head)["status"], "ok");

  const Response sites = call("HEAD", "/v1/sites");
  EXPECT_EQ(sites.status, 200);
  EXPECT_EQ(body_of(sites), Json::parse(R"({"sites": []})"));
  EXPECT_EQ(call("HEAD", "/v1/jobs").status, 200);
  expect_error(call("HEAD", std::string("/v1/jobs/") + kUnknownJob), 404, "not_found");
  // HEAD needs the token like GET.
  expect_error(call("HEAD", "/v1/sites", {}, {}, {}, false), 401, "unauthorized");
}

TEST_F(ServiceRouting, MatchedRoutesAreLabelledWithTheirPattern) {
  start();
  EXPECT_EQ(get("/v1/health").route, "/v1/health");
  EXPECT_EQ(get("/v1/sites").route, "/v1/sites");
  EXPECT_EQ(get(std::string("/v1/jobs/") + kUnknownJob).route, "/v1/jobs/{id}");
  EXPECT_EQ(get(std::string("/v1/jobs/") + kUnknownJob + "/ptn").route, "/v1/jobs/{id}/ptn");
  EXPECT_EQ(call("PUT", "/v1/sites").route, "/v1/sites");
  EXPECT_EQ(get_anonymous("/metrics").route, "/metrics");
}

TEST_F(ServiceRouting, OrderOfChecks) {
  // docs/http-api.md: route (404), method (405), token (401), query parameters (400), content
  // type of a POST (415), JSON text (400), contract (422).
  start();
  const std::map<std::string, std::string> bad_query = {{"x", "1"}};
  const std::map<std::string, std::string> text_plain = {{"content-type", "text/plain"}};
  expect_error(call("POST", "/v1/nothing", bad_query, "{", text_plain, false), 404, "not_found");
  expect_error(call("PUT", "/v1/jobs", bad_query, "{", text_plain, false), 405,
               "method_not_allowed");
  expect_error(call("POST", "/v1/jobs", bad_query, "{", text_plain, false), 401, "unauthorized");
  expect_error(call("POST", "/v1/jobs", bad_query, "{", text_plain), 400, "bad_parameter", "x");
  expect_error(call("POST", "/v1/sites", bad_query, "{", text_plain), 400, "bad_parameter", "x");
  expect_error(call("POST", "/v1/jobs", {}, "{", text_plain), 415, "unsupported_media_type");
  expect_error(post_text("/v1/jobs", "{"), 400, "malformed_json");
  expect_error(post_text("/v1/jobs", "{}"), 422, "invalid_input", "schema");
}

// ---- Authentication ----

TEST_F(ServiceAuth, MissingTokenIs401WithWwwAuthenticate) {
  start();
  const Response r = get_anonymous("/v1/sites");
  expect_error(r, 401, "unauthorized");
  const auto challenge = header(r, "WWW-Authenticate");
  ASSERT_TRUE(challenge.has_value());
  EXPECT_EQ(challenge->rfind("Bearer", 0), 0u) << *challenge;
}

TEST_F(ServiceAuth, WrongTokenIs401) {
  start();
  for (const std::string& value :
       {std::string("Bearer wrong"), std::string("Bearer test-token-"),
        std::string("Bearer test-token-1x"), std::string("Bearer  test-token-1"),
        std::string("Bearer "), std::string("Bearer"), std::string("Basic dGVzdC10b2tlbi0x"),
        std::string(kToken), std::string("Bearer # fragsimd test tokens"), std::string("")}) {
    SCOPED_TRACE("Authorization: " + value);
    const Response r = call("GET", "/v1/sites", {}, {}, {{"authorization", value}});
    expect_error(r, 401, "unauthorized");
    EXPECT_TRUE(header(r, "WWW-Authenticate").has_value());
  }
}

TEST_F(ServiceAuth, EveryTokenOfTheFileIsAcceptedAndTheSchemeIsCaseInsensitive) {
  start();
  for (const std::string& value :
       {std::string("Bearer ") + kToken, std::string("Bearer ") + kOtherToken,
        std::string("bearer ") + kToken, std::string("BEARER ") + kOtherToken}) {
    SCOPED_TRACE(value);
    EXPECT_EQ(call("GET", "/v1/sites", {}, {}, {{"authorization", value}}).status, 200);
  }
}

TEST_F(ServiceAuth, EveryPrivateRouteNeedsTheToken) {
  start();
  const std::string job = std::string("/v1/jobs/") + kUnknownJob;
  const std::vector<std::pair<std::string, std::string>> routes = {
      {"GET", "/metrics"},
      {"GET", "/v1/sites"},
      {"POST", "/v1/sites"},
      {"GET", "/v1/sites/s_0123456789abcdef"},
      {"DELETE", "/v1/sites/s_0123456789abcdef"},
      {"GET", "/v1/jobs"},
      {"POST", "/v1/jobs"},
      {"GET", job},
      {"DELETE", job},
      {"GET", job + "/summary"},
      {"GET", job + "/buildings"},
      {"GET", job + "/ptn"},
      {"GET", job + "/results.h5"},
      {"GET", job + "/maps"},
      {"GET", job + "/maps/hazard.kml"},
      {"GET", "/v1/sites/not-an-id"}};
  for (const auto& [method, path] : routes) {
    SCOPED_TRACE(method + " " + path);
    // A body that would be refused (415, 400) is not looked at before the token.
    const Response r = call(method, path, {}, "{not json", {}, false);
    expect_error(r, 401, "unauthorized");
  }
}

TEST_F(ServiceAuth, PublicRoutesNeedNoToken) {
  start();
  const Response health = get_anonymous("/v1/health");
  EXPECT_EQ(health.status, 200);
  EXPECT_EQ(health.content_type, "application/json");
  const Json h = body_of(health);
  EXPECT_EQ(h["status"], "ok");
  EXPECT_TRUE(h["version"].is_string());
  EXPECT_TRUE(h["git_sha"].is_string());
  EXPECT_TRUE(h["uptime_s"].is_number());
  EXPECT_GE(h["uptime_s"].get<double>(), 0.0);
  EXPECT_EQ(h["jobs"], Json::parse(R"({"queued": 0, "running": 0})"));

  const Response openapi = get_anonymous("/v1/openapi.yaml");
  EXPECT_EQ(openapi.status, 200);
  EXPECT_EQ(openapi.content_type, "application/yaml");
  EXPECT_EQ(openapi.body.rfind("openapi: 3.1.0", 0), 0u);
  // api/openapi.yaml with the scenario schema inlined (api/openapi_bundle.cmake): self-contained.
  EXPECT_EQ(openapi.body, openapi_yaml());
  EXPECT_NE(openapi.body.find("\n    scenario.site:\n"), std::string::npos);
  EXPECT_EQ(openapi.body.find("schema/scenario.schema.json#"), std::string::npos);
  const std::string source = api::testing::read_text(api::testing::source_path("api/openapi.yaml"));
  const std::size_t first_ref = source.find("schema/scenario.schema.json#");
  ASSERT_NE(first_ref, std::string::npos);
  EXPECT_EQ(openapi.body.substr(0, first_ref), source.substr(0, first_ref))
      << "up to its first reference to the scenario schema, the served document is the source";

  // A wrong token does not spoil a public route.
  EXPECT_EQ(call("GET", "/v1/health", {}, {}, {{"authorization", "Bearer wrong"}}).status, 200);
}

TEST_F(ServiceAuth, NoAuthNeedsNoToken) {
  start([](Config& c) {
    c.auth = false;
    c.token_file.clear();
  });
  EXPECT_EQ(get_anonymous("/v1/sites").status, 200);
  EXPECT_EQ(get_anonymous("/metrics").status, 200);
  Json body = small_example();
  body["fragment_groups"][0]["samples"] = 10;
  const Response r =
      call("POST", "/v1/jobs", {}, body.dump(), {{"content-type", "application/json"}}, false);
  ASSERT_EQ(r.status, 202) << r.body;
  EXPECT_TRUE(body_of(r)["owner"].is_null()) << "no token, no owner";
}

// ---- Bodies and input errors ----

TEST_F(ServiceInput, PostWithoutJsonContentTypeIs415) {
  start();
  const std::string site = minimal_site().dump();
  for (const char* type : {"", "text/plain", "application/jsonx",
                           "application/x-www-form-urlencoded", "application/geo+json"}) {
    SCOPED_TRACE(type);
    expect_error(post_text("/v1/sites", site, type), 415, "unsupported_media_type");
    expect_error(post_text("/v1/jobs", job_on(kUnknownSite).dump(), type), 415,
                 "unsupported_media_type");
  }
  EXPECT_EQ(get("/v1/sites").body, R"({"sites":[]})");
}

TEST_F(ServiceInput, JsonContentTypeWithParametersIsAccepted) {
  start();
  const std::string site = minimal_site().dump();
  EXPECT_EQ(post_text("/v1/sites", site, "application/json; charset=utf-8").status, 201);
  EXPECT_EQ(post_text("/v1/sites", site, "Application/JSON;charset=UTF-8").status, 200);
  EXPECT_EQ(post_text("/v1/sites", site, "application/json ; charset=utf-8").status, 200);
}

TEST_F(ServiceInput, MalformedJsonIs400) {
  start();
  for (const char* path : {"/v1/sites", "/v1/jobs"}) {
    SCOPED_TRACE(path);
    const Response r = post_text(path, "{\"terrain\": ");
    expect_error(r, 400, "malformed_json");
    EXPECT_NE(body_of(r)["message"].get<std::string>().find("line 1"), std::string::npos) << r.body;
    expect_error(post_text(path, ""), 400, "malformed_json");
  }
}

// Any byte in any part of a request: a 4xx with a valid JSON error body, never a 500 (the error
// message echoes input; invalid UTF-8 in it made building the body throw). nlohmann's strict
// parse of the body (body_of) fails on invalid UTF-8, so expect_error checks that too.
TEST_F(ServiceInput, InvalidUtf8AnywhereIsA4xxWithAValidBody) {
  start();
  const std::string bad = "\xff\xfe\xc3(\xed\xa0\x80";  // stray, truncated, surrogate
  expect_error(get("/v1/jobs/" + bad), 404, "not_found");
  expect_error(get("/v1/" + bad), 404, "not_found");
  // Invalid bytes are written "\xNN" where a message or field echoes them.
  expect_error(get("/v1/jobs", {{"st" + bad, "1"}}), 400, "bad_parameter",
               "st\\xff\\xfe\\xc3(\\xed\\xa0\\x80");
  expect_error(get("/v1/jobs", {{"state", bad}}), 400, "bad_parameter", "state");
  expect_error(post_text("/v1/sites", "{\"terrain\": \"" + bad + "\"}"), 400, "malformed_json");
  expect_error(post_text("/v1/jobs", bad), 400, "malformed_json");
  // A string value with valid JSON escapes that decode to a lone surrogate is refused by the parser
  // as malformed too; a key that is not UTF-8 names no known field.
  expect_error(post_text("/v1/jobs", "{\"\\ud800\": 1}"), 400, "malformed_json");
  const Response auth = call("GET", "/v1/jobs", {}, {}, {{"authorization", "Bearer " + bad}});
  expect_error(auth, 401, "unauthorized");
  expect_error(call("POST", "/v1/jobs", {}, "{}", {{"content-type", bad}}), 415,
               "unsupported_media_type");
}

TEST_F(ServiceInput, NestingBeyond64LevelsIs400TooDeep) {
  start();
  const std::string too_deep = std::string(65, '[') + std::string(65, ']');
  const std::string deepest = std::string(64, '[') + std::string(64, ']');
  for (const char* path : {"/v1/sites", "/v1/jobs"}) {
    SCOPED_TRACE(path);
    const Response r = post_text(path, too_deep);
    EXPECT_EQ(r.status, 400) << r.body;
    EXPECT_EQ(body_of(r)["code"], "too_deep");
    // 64 levels are parsed (and refused as JSON that breaks the contract, not as too deep).
    const Response ok_depth = post_text(path, deepest);
    EXPECT_EQ(ok_depth.status, 422) << ok_depth.body;
    EXPECT_EQ(body_of(ok_depth)["code"], "invalid_input");
  }
  const std::string deep_object = "{\"site\": " + std::string(70, '[') + std::string(70, ']') + "}";
  EXPECT_EQ(body_of(post_text("/v1/jobs", deep_object))["code"], "too_deep");
}

// docs/http-api.md, Errors: too_deep names the path where the limit was reached.
TEST_F(ServiceInput, TooDeepNamesWhereTheLimitWasReached) {
  start();
  const std::string too_deep = std::string(65, '[') + std::string(65, ']');
  const Response r = post_text("/v1/sites", too_deep);
  EXPECT_EQ(r.status, 400);
  const Json body = body_of(r);
  EXPECT_EQ(body["code"], "too_deep");
  std::string path;
  for (int k = 0; k < 64; ++k) path += "[0]";
  EXPECT_EQ(body["field"], path);
}

TEST_F(ServiceInput, SiteErrorsAre422WithSiteRelativePaths) {
  start();
  Json site = minimal_site();
  site["terrain"] = {{"grid",
                      {{"origin_m", {0, 0}},
                       {"spacing_m", 10},
                       {"nx", "3"},
                       {"ny", 3},
                       {"elevation_m", std::vector<double>(9, 0.0)}}},
                     {"material", "soil"}};
  expect_error(post("/v1/sites", site), 422, "invalid_input", "terrain.grid.nx");

  site = minimal_site();
  site["terrain"]["plane"]["cell_m"] = -1;
  const Response r = post("/v1/sites", site);
  expect_error(r, 422, "invalid_input", "terrain.plane.cell_m");
  EXPECT_EQ(body_of(r)["message"], "must be > 0 (got -1)");

  site = minimal_site();
  site["terain"] = site["terrain"];
  expect_error(post("/v1/sites", site), 422, "invalid_input", "terain");

  // Geometry (checked when the site is built).
  site = minimal_site();
  site["buildings"][0]["footprint_m"] = {{60, -10}, {80, 10}, {80, -10}, {60, 10}};
  expect_error(post("/v1/sites", site), 422, "invalid_input", "buildings[0].footprint_m");

  EXPECT_EQ(get("/v1/sites").body, R"({"sites":[]})");
}

TEST_F(ServiceInput, JobErrorsAre422WithTheirPaths) {
  start();
  const std::string site = add_site();
  Json j = job_on(site);
  j["fragment_groups"][0]["mass_kg"] = "heavy";
  expect_error(post("/v1/jobs", j), 422, "invalid_input", "fragment_groups[0].mass_kg");

  j = job_on(site);
  j["fragment_groups"][0]["samples"] = 0;
  expect_error(post("/v1/jobs", j), 422, "invalid_input", "fragment_groups[0].samples");

  j = job_on(site);
  j["priority"] = 5000;
  expect_error(post("/v1/jobs", j), 422, "invalid_input", "priority");

  j = job_on(site);
  j["idempotency_key"] = "has space";
  expect_error(post("/v1/jobs", j), 422, "invalid_input", "idempotency_key");

  j = job_on(site);
  j["site"] = minimal_site();
  expect_error(post("/v1/jobs", j), 422, "invalid_input", "site_id");

  // An inline site gets the geometry check at submission, with the scenario's path.
  j = small_example();
  j["site"]["buildings"][0]["footprint_m"] = {{60, -10}, {80, 10}, {80, -10}, {60, 10}};
  expect_error(post("/v1/jobs", j), 422, "invalid_input", "site.buildings[0].footprint_m");

  EXPECT_EQ(get("/v1/jobs").body, R"({"jobs":[]})");
}

TEST_F(ServiceInput, UnknownSiteIdIs422) {
  start();
  const Response r = post("/v1/jobs", job_on(kUnknownSite));
  expect_error(r, 422, "invalid_input", "site_id");
  EXPECT_EQ(body_of(r)["message"], std::string("unknown site \"") + kUnknownSite + "\"");
}

TEST_F(ServiceInput, TooManySamplesIs422LimitExceeded) {
  start([](Config& c) { c.max_samples_per_job = 1000; });
  const std::string site = add_site();
  expect_error(post("/v1/jobs", job_on(site, 1001)), 422, "limit_exceeded", "fragment_groups");
  // The limit is on the sum over the groups.
  Json two = job_on(site, 600);
  Json second = two["fragment_groups"][0];
  second["name"] = "second";
  two["fragment_groups"].push_back(second);
  expect_error(post("/v1/jobs", two), 422, "limit_exceeded", "fragment_groups");
  EXPECT_EQ(get("/v1/jobs").body, R"({"jobs":[]})");
  // At the limit: accepted.
  EXPECT_EQ(post("/v1/jobs", job_on(site, 1000)).status, 202);
}

// settings.ground_bracket's runs count toward the limit: the study's 100 samples and 11 bracket
// runs (the nominal and fast_contact's five ranges at both ends) of 100 are 1200 > 1000; at
// samples_scale 0.5, 100 + 11 x 50 = 650 is accepted.
TEST_F(ServiceInput, AGroundBracketCountsTowardTheSampleLimit) {
  start([](Config& c) { c.max_samples_per_job = 1000; });
  Json j = small_example();
  j["fragment_groups"] = Json::array({j["fragment_groups"][0]});
  j["fragment_groups"][0]["samples"] = 100;
  const std::string terrain = j["site"]["terrain"]["material"];
  j["site"]["materials"][terrain].erase("embedment");
  j["site"]["materials"][terrain]["fast_contact"] = {{"bulk_density_kg_m3", 1700}};
  j["settings"]["bounce"] = true;
  j["settings"]["ground_bracket"] = {{"samples_scale", 1.0}};
  expect_error(post("/v1/jobs", j), 422, "limit_exceeded", "settings.ground_bracket");
  j["settings"]["ground_bracket"]["samples_scale"] = 0.5;
  EXPECT_EQ(post("/v1/jobs", j).status, 202);
}

// A few bytes of plane can ask for millions of triangles: refused from the spec, before building.
TEST_F(ServiceInput, TooLargeATerrainIs422BeforeItIsBuilt) {
  start();  // the default budget: 2^24 triangles
  Json huge = minimal_site();
  huge["terrain"]["plane"] = {
      {"elevation_m", 0}, {"extent_m", {-2100, -2100, 2100, 2100}}, {"cell_m", 1}};
  huge["buildings"] = Json::array();
  const Response r = post("/v1/sites", huge);
  expect_error(r, 422, "limit_exceeded", "terrain");
  EXPECT_NE(body_of(r)["message"].get<std::string>().find("35280000 triangles"), std::string::npos)
      << r.body;
  EXPECT_EQ(body_of(get("/v1/sites"))["sites"].size(), 0u);
  // Inline in a job: the same, with the scenario's path.
  Json job = small_example();
  job["site"] = huge;
  expect_error(post("/v1/jobs", job), 422, "limit_exceeded", "site.terrain");
  EXPECT_EQ(get("/v1/jobs").body, R"({"jobs":[]})");
}

TEST_F(ServiceInput, TheTerrainBudgetIsConfigurableAndInclusive) {
  start([](Config& c) { c.max_terrain_triangles = 3199; });  // the minimal site has 3200
  expect_error(post("/v1/sites", minimal_site()), 422, "limit_exceeded", "terrain");
  service_.reset();
  start([](Config& c) { c.max_terrain_triangles = 3200; });
  EXPECT_EQ(post("/v1/sites", minimal_site()).status, 201);
}

TEST_F(ServiceInput, TooManySitesIs422LimitExceeded) {
  start([](Config& c) { c.max_sites = 1; });
  const std::string first = add_site();
  Json other = minimal_site();
  other["buildings"][0]["height_m"] = 7;
  expect_error(post("/v1/sites", other), 422, "limit_exceeded");
  // The site already registered is still answered (200, no new site).
  const Response again = post("/v1/sites", minimal_site());
  EXPECT_EQ(again.status, 200);
  EXPECT_EQ(body_of(again)["site_id"], first);
  EXPECT_EQ(body_of(get("/v1/sites"))["sites"].size(), 1u);
}

// ---- Sites ----

TEST_F(ServiceSites, PostThenTheSameSiteAgain) {
  start();
  const Response created = post("/v1/sites", minimal_site());
  ASSERT_EQ(created.status, 201) << created.body;
  const Json s = body_of(created);
  const std::string id = s["site_id"];
  EXPECT_EQ(id, api::parse_site_document(minimal_site()).site_id);
  EXPECT_EQ(header(created, "Location"), "/v1/sites/" + id);
  for (const char* key : {"site_id", "created_utc", "terrain_triangles", "building_triangles",
                          "buildings", "building_ids", "materials", "extent_m", "jobs_using"})
    EXPECT_TRUE(s.contains(key)) << key;
  EXPECT_EQ(s["terrain_triangles"], 3200);
  EXPECT_EQ(s["buildings"], 1);
  EXPECT_EQ(s["building_ids"], Json::array({"B1"}));
  EXPECT_EQ(s["materials"], Json::array({"concrete_wall", "metal_roof", "soil"}));
  EXPECT_EQ(s["extent_m"], Json::array({-200, -200, 0, 200, 200, 6}));
  EXPECT_EQ(s["jobs_using"], 0);
  const auto built = api::build_site(api::parse_site_document(minimal_site()));
  EXPECT_EQ(s["building_triangles"].get<std::size_t>(), built->building_triangles().size());

  // The same site, spelt differently (key order, whitespace, 6 as 6.0): 200, same id and time.
  Json respelt = minimal_site();
  respelt["buildings"][0]["height_m"] = 6.0;
  const Response again = post_text("/v1/sites", respelt.dump(2));
  EXPECT_EQ(again.status, 200) << again.body;
  EXPECT_EQ(body_of(again), s);
  EXPECT_EQ(header(again, "Location"), "/v1/sites/" + id);
  EXPECT_EQ(body_of(get("/v1/sites"))["sites"].size(), 1u);
}

TEST_F(ServiceSites, GetListAndDelete) {
  start();
  const std::string a = add_site();
  Json other = minimal_site();
  other.erase("buildings");
  const std::string b = add_site(other);
  ASSERT_NE(a, b);

  const Json list = body_of(get("/v1/sites"));
  ASSERT_EQ(list["sites"].size(), 2u);
  EXPECT_EQ(list["sites"][0]["site_id"], a);  // oldest first
  EXPECT_EQ(list["sites"][1]["site_id"], b);
  EXPECT_EQ(list["sites"][1]["buildings"], 0);

  const Response one = get("/v1/sites/" + b);
  EXPECT_EQ(one.status, 200);
  EXPECT_EQ(body_of(one), list["sites"][1]);

  const Response deleted = del("/v1/sites/" + a);
  EXPECT_EQ(deleted.status, 204);
  EXPECT_TRUE(deleted.body.empty());
  expect_error(get("/v1/sites/" + a), 404, "not_found");
  expect_error(del("/v1/sites/" + a), 404, "not_found");
  const Json after = body_of(get("/v1/sites"));
  ASSERT_EQ(after["sites"].size(), 1u);
  EXPECT_EQ(after["sites"][0]["site_id"], b);
  // Jobs can no longer name it.
  expect_error(post("/v1/jobs", job_on(a)), 422, "invalid_input", "site_id");
  // And it can be registered again (201: new).
  EXPECT_EQ(post("/v1/sites", minimal_site()).status, 201);
}

TEST_F(ServiceSites, SitesAndJobsSurviveARestart) {
  start();
  const std::string site = add_site();
  const Response posted = post("/v1/jobs", blocker_job(site));
  ASSERT_EQ(posted.status, 202);
  const std::string job_id = body_of(posted)["job_id"];
  restart();
  const Response s = get("/v1/sites/" + site);
  EXPECT_EQ(s.status, 200) << s.body;
  const Json j = job(job_id);
  EXPECT_EQ(j["job_id"], job_id);
  EXPECT_EQ(j["site_id"], site);
  // A clean shutdown puts a running job back in the queue; it may have started again since.
  EXPECT_TRUE(j["state"] == "queued" || j["state"] == "running") << j.dump();
  EXPECT_EQ(j["histories_total"], kBlockerSamples);
}

TEST_F(ServiceSites, ASiteBeingBuiltHoldsNoOtherRequest) {
  // Issue 10: the site was built under the catalogue lock, so that every job submission, site
  // submission and deletion waited for the slowest site build in progress. A 1001 x 1001 grid
  // (2 million triangles) takes seconds to build; meanwhile the catalogue's other requests are
  // answered at once. No timing threshold on the build itself: it is only required to be long
  // against the answers' latency.
  start();
  const std::string small = add_site();
  Json big = minimal_site();
  constexpr int n = 1001;
  std::vector<double> elevation(static_cast<std::size_t>(n) * n);
  for (std::size_t k = 0; k < elevation.size(); ++k)
    elevation[k] = 0.001 * static_cast<double>(k % 97);
  big["terrain"] = {{"grid",
                     {{"origin_m", {-500, -500}},
                      {"spacing_m", 1.0},
                      {"nx", n},
                      {"ny", n},
                      {"elevation_m", elevation}}},
                    {"material", "soil"}};
  const std::string big_text = big.dump();
  using Clock = std::chrono::steady_clock;
  const auto seconds_since = [](Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  };
  std::atomic<bool> done{false};
  double build_s = 0;
  std::thread poster([&] {
    const auto t0 = Clock::now();
    const Response r = post_text("/v1/sites", big_text);
    build_s = seconds_since(t0);
    EXPECT_EQ(r.status, 201) << r.body;
    done = true;
  });
  double slowest_s = 0;
  int answered = 0;
  bool job_posted = false;
  const auto t0 = Clock::now();
  while (!done) {
    const auto t = Clock::now();
    expect_error(del(std::string("/v1/sites/") + kUnknownSite), 404, "not_found");
    if (!job_posted && seconds_since(t0) > 0.5) {
      EXPECT_EQ(post("/v1/jobs", job_on(small, 10)).status, 202);
      job_posted = true;
    }
    slowest_s = std::max(slowest_s, seconds_since(t));
    ++answered;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  poster.join();
  std::printf(
      "[ measured ] site build request %.2f s; %d other requests meanwhile, slowest %.3f s\n",
      build_s, answered, slowest_s);
  ASSERT_GT(build_s, 0.5) << "the site built too fast to show anything";
  EXPECT_TRUE(job_posted);
  EXPECT_LT(slowest_s, 0.25 * build_s);
}

TEST_F(ServiceSites, OneServicePerDataDirectory) {
  start();
  const std::string site = add_site();
  // A second service (daemon) on the same data directory refuses to start.
  EXPECT_THROW({ Service second(config()); }, std::runtime_error);
  EXPECT_EQ(get("/v1/sites/" + site).status, 200);  // the first one is unaffected
  restart();  // once the first has stopped, the directory can be used again
  EXPECT_EQ(get("/v1/sites/" + site).status, 200);
}

// ---- Jobs ----

TEST_F(ServiceJobs, PostJobIs202WithLocationAndJobStatus) {
  start();
  const std::string site = add_site();
  Json body = job_on(site, 300);
  body["priority"] = 7;
  const Response r = post("/v1/jobs", body);
  ASSERT_EQ(r.status, 202) << r.body;
  EXPECT_EQ(r.content_type, "application/json");
  const Json j = body_of(r);
  const std::string id = j["job_id"];
  EXPECT_TRUE(api::is_job_id(id)) << id;
  EXPECT_EQ(header(r, "Location"), "/v1/jobs/" + id);

  const std::vector<std::string> keys = {"job_id",          "site_id",         "state",
                                         "priority",        "idempotency_key", "owner",
                                         "created_utc",     "started_utc",     "finished_utc",
                                         "histories_done",  "histories_total", "progress",
                                         "histories_per_s", "eta_s",           "precision",
                                         "attempts",        "error",           "links"};
  for (const auto& key : keys) EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j.size(), keys.size() + 1) << j.dump();
  EXPECT_TRUE(j["warnings"].is_array()) << "the submission's warnings, with the JobStatus";
  EXPECT_EQ(j["site_id"], site);
  EXPECT_EQ(j["state"], "queued");
  EXPECT_EQ(j["priority"], 7);
  EXPECT_TRUE(j["idempotency_key"].is_null());
  // The submitting token, named by its hash: echo -n "$TOKEN" | sha256sum | cut -c1-16.
  EXPECT_EQ(j["owner"], "tok_" + api::sha256_hex(kToken).substr(0, 16));
  EXPECT_EQ(j["owner"].get<std::string>().find(kToken), std::string::npos);
  EXPECT_TRUE(j["created_utc"].is_string());
  EXPECT_TRUE(j["started_utc"].is_null());
  EXPECT_TRUE(j["finished_utc"].is_null());
  EXPECT_EQ(j["histories_done"], 0);
  EXPECT_EQ(j["histories_total"], 300);
  EXPECT_EQ(j["progress"], 0.0);
  EXPECT_TRUE(j["histories_per_s"].is_null());
  EXPECT_TRUE(j["eta_s"].is_null());
  EXPECT_EQ(j["attempts"], 0);
  EXPECT_TRUE(j["error"].is_null());
  const std::string self = "/v1/jobs/" + id;
  EXPECT_EQ(j["links"], Json({{"self", self},
                              {"summary", self + "/summary"},
                              {"buildings", self + "/buildings"},
                              {"ptn", self + "/ptn"},
                              {"results_h5", self + "/results.h5"},
                              {"maps", self + "/maps"},
                              {"plan_boundary", self + "/plan_boundary"}}));

  const Json again = job(id);
  EXPECT_EQ(again["job_id"], id);
  EXPECT_EQ(again.size(), keys.size()) << "warnings are the submission's only";
}

// Issue 22: a fragment group that can plainly reach beyond the terrain (the minimal example's
// steel spheres on a 400 m x 400 m plane) is queued all the same, with a warning naming it: by
// site_id and with the site inline, and again on an idempotent repeat. A terrain large enough:
// an empty list.
TEST_F(ServiceJobs, PostJobWarnsOfAGroupThatCanReachBeyondTheTerrain) {
  start();
  Json small = minimal_example();
  small["site"]["terrain"]["plane"]["extent_m"] = {-200, -200, 200, 200};
  small["fragment_groups"][0]["samples"] = 50;
  Json by_id = job_on(add_site(small["site"]), 50);
  by_id["idempotency_key"] = "reach";
  const Response r = post("/v1/jobs", by_id);
  ASSERT_EQ(r.status, 202) << r.body;
  const Json warnings = body_of(r)["warnings"];
  ASSERT_EQ(warnings.size(), 1u) << r.body;
  EXPECT_EQ(warnings[0].size(), 3u);
  EXPECT_EQ(warnings[0]["field"], "fragment_groups[0]");
  EXPECT_EQ(warnings[0]["severity"], "warning");
  const std::string message = warnings[0]["message"];
  EXPECT_EQ(message.rfind("fragment_groups[0] (\"steel spheres\"): about ", 0), 0u) << message;
  EXPECT_NE(message.find("extend the terrain"), std::string::npos) << message;

  const Response repeat = post("/v1/jobs", by_id);
  ASSERT_EQ(repeat.status, 200) << repeat.body;
  EXPECT_EQ(body_of(repeat)["warnings"], warnings);
  const Response inline_site = post("/v1/jobs", small);
  ASSERT_EQ(inline_site.status, 202) << inline_site.body;
  EXPECT_EQ(body_of(inline_site)["warnings"], warnings);

  Json large = small;
  large["site"]["terrain"]["plane"]["extent_m"] = {-5000, -5000, 5000, 5000};
  large["site"]["terrain"]["plane"]["cell_m"] = 250;
  const Response none = post("/v1/jobs", large);
  ASSERT_EQ(none.status, 202) << none.body;
  EXPECT_EQ(body_of(none)["warnings"], Json::array());
}

TEST_F(ServiceJobs, InlineSiteJobHasNullSiteId) {
  start();
  Json body = small_example();
  body["fragment_groups"][0]["samples"] = 100;
  const Response r = post("/v1/jobs", body);
  ASSERT_EQ(r.status, 202) << r.body;
  EXPECT_TRUE(body_of(r)["site_id"].is_null());
  EXPECT_EQ(body_of(get("/v1/sites"))["sites"].size(), 0u);  // not registered
}

TEST_F(ServiceJobs, PrecisionJobShowsItsTargetsAndStopsWithItsReason) {
  start();
  const std::string site = add_site();
  Json body = job_on(site, 200);
  body["settings"]["record_fragments"] = false;
  body["settings"]["precision"] = {{"building_abs_error", 1e-9}, {"max_batches", 400}};
  const Response r = post("/v1/jobs", body);
  ASSERT_EQ(r.status, 202) << r.body;
  const std::string id = body_of(r)["job_id"];
  EXPECT_EQ(body_of(r)["histories_total"], 200 * 400) << "the most the job may run";
  // While it runs, the job shows the last check of its targets (out of reach here).
  const Json running = wait_for(id, [](const Json& j) {
    return j["state"] != "queued" && j["state"] != "running" ? true : !j["precision"].is_null();
  });
  ASSERT_EQ(running["state"], "running") << running.dump();
  const Json& p = running["precision"];
  EXPECT_GE(p["batches"].get<int>(), 1);
  EXPECT_FALSE(p["all_met"].get<bool>());
  ASSERT_FALSE(p["targets"].empty());
  EXPECT_EQ(p["targets"][0]["figure"], "building_impacts");
  EXPECT_EQ(del("/v1/jobs/" + id).status, 200);

  // Reachable targets: done, with the reason and the last check in the summary.
  body["settings"]["precision"] = {{"building_abs_error", 100.0}, {"max_batches", 50}};
  const std::string done = add_job(body);
  ASSERT_EQ(wait_for_state(done, "done")["state"], "done");
  const Response served = get("/v1/jobs/" + done + "/summary");
  ASSERT_TRUE(served.file.has_value()) << served.status << " " << served.body;
  const Json summary = Json::parse(api::testing::read_text(*served.file));
  EXPECT_EQ(summary["stop_reason"], "targets_met");
  EXPECT_EQ(summary["batches"], 2) << "min_batches 2";
  EXPECT_EQ(summary["samples"], 400);
  EXPECT_TRUE(summary["precision"]["all_met"].get<bool>());
  EXPECT_TRUE(job(done)["precision"].is_null()) << "live only";
  // The small plane cuts the HFD: the daemon's summary says it is a lower bound (issue 22).
  EXPECT_EQ(summary["hfd_bound"], "lower");
  EXPECT_EQ(summary["site_boundary"]["note"].get<std::string>().rfind("HFD ≥ ", 0), 0u);
}

// compare_with (docs/comparison.md): the base job's scenario and this one paired in one job. The
// job's results are the variant's; GET /compare is the paired comparison, whose base figures are
// the base job's own bits (the same scenario and seed, run again); a job without compare_with has
// none (404). What cannot be paired is refused with a 422 naming the field, nothing queued.
TEST_F(ServiceJobs, CompareWithPairsTheBaseJobsHistories) {
  start();
  const std::string site = add_site();
  const std::string base = add_job(job_on(site, 300));
  ASSERT_EQ(wait_for_state(base, "done")["state"], "done");
  Json moved = minimal_site();
  moved["buildings"][0]["footprint_m"] = {{80, -10}, {100, -10}, {100, 10}, {80, 10}};
  Json variant = job_on(add_site(moved), 300);
  variant["compare_with"] = base;
  const Response r = post("/v1/jobs", variant);
  ASSERT_EQ(r.status, 202) << r.body;
  const Json accepted = body_of(r);
  EXPECT_EQ(accepted["histories_total"], 600) << "both runs";
  const std::string id = accepted["job_id"];
  ASSERT_EQ(wait_for_state(id, "done")["state"], "done");
  const Response c = get("/v1/jobs/" + id + "/compare");
  ASSERT_EQ(c.status, 200) << c.body;
  ASSERT_TRUE(c.file.has_value());
  const Json cmp = Json::parse(api::testing::read_text(*c.file));
  auto summary = [&](const std::string& job_id) {
    return Json::parse(api::testing::read_text(*get("/v1/jobs/" + job_id + "/summary").file));
  };
  const Json base_summary = summary(base), variant_summary = summary(id);
  const Json& impacts = cmp["buildings"][0]["impacts"];
  EXPECT_EQ(impacts["base"], base_summary["buildings"][0]["expected_impacts"]);
  EXPECT_EQ(impacts["variant"], variant_summary["buildings"][0]["expected_impacts"]);
  EXPECT_EQ(cmp["hfd"]["base_m"], base_summary["hazardous_fragment_distance_m"]);
  EXPECT_FALSE(cmp["changed"].empty());
  const Response h5 = get("/v1/jobs/" + id + "/compare.h5");
  EXPECT_EQ(h5.status, 200);
  EXPECT_EQ(h5.content_type, "application/x-hdf5");
  expect_error(get("/v1/jobs/" + base + "/compare"), 404, "not_found");
  // Its maps include the density difference (the same terrain in both sites).
  const Json maps = body_of(get("/v1/jobs/" + id + "/maps"));
  bool difference_map = false;
  for (const Json& f : maps["files"]) difference_map |= f["name"] == "density_difference.tif";
  EXPECT_TRUE(difference_map) << maps.dump();

  const std::size_t jobs_before = body_of(get("/v1/jobs"))["jobs"].size();
  Json bad = job_on(site, 300);
  bad["compare_with"] = "nope";
  expect_error(post("/v1/jobs", bad), 422, "invalid_input", "compare_with");
  bad["compare_with"] = kUnknownJob;
  expect_error(post("/v1/jobs", bad), 422, "invalid_input", "compare_with");
  bad["compare_with"] = base;
  bad["settings"]["seed"] = 4242;
  expect_error(post("/v1/jobs", bad), 422, "invalid_input", "settings.seed");
  bad = job_on(site, 301);
  bad["compare_with"] = base;
  expect_error(post("/v1/jobs", bad), 422, "invalid_input", "fragment_groups[0].samples");
  EXPECT_EQ(body_of(get("/v1/jobs"))["jobs"].size(), jobs_before) << "nothing queued";
}

TEST_F(ServiceJobs, IdempotencyKey) {
  start();
  const std::string site = add_site();
  Json body = job_on(site, 100);
  body["idempotency_key"] = "study-42";
  const Response first = post("/v1/jobs", body);
  ASSERT_EQ(first.status, 202) << first.body;
  const std::string id = body_of(first)["job_id"];
  EXPECT_EQ(body_of(first)["idempotency_key"], "study-42");

  // Same key, same body (whatever its spelling): 200, the same job.
  const Response repeat = post_text("/v1/jobs", body.dump(4));
  EXPECT_EQ(repeat.status, 200) << repeat.body;
  EXPECT_EQ(body_of(repeat)["job_id"], id);
  EXPECT_EQ(header(repeat, "Location"), "/v1/jobs/" + id);

  // Same key, another body: 409, field idempotency_key.
  Json changed = body;
  changed["fragment_groups"][0]["samples"] = 101;
  expect_error(post("/v1/jobs", changed), 409, "conflict", "idempotency_key");
  Json other_priority = body;
  other_priority["priority"] = 1;
  expect_error(post("/v1/jobs", other_priority), 409, "conflict", "idempotency_key");

  const Json jobs = body_of(get("/v1/jobs"));
  ASSERT_EQ(jobs["jobs"].size(), 1u);
  EXPECT_EQ(jobs["jobs"][0]["job_id"], id);

  // Without a key every POST is a new job; another key is another job.
  EXPECT_NE(add_job(job_on(site, 100)), id);
  body["idempotency_key"] = "study-43";
  EXPECT_NE(add_job(body), id);
  EXPECT_EQ(body_of(get("/v1/jobs"))["jobs"].size(), 3u);
}

TEST_F(ServiceJobs, BadQueryParametersAre400NamingTheParameter) {
  start();
  const std::string site = add_site();
  const std::string job_id = add_job(job_on(site, 100));
  const std::string ptn = "/v1/jobs/" + job_id + "/ptn";
  using Query = std::map<std::string, std::string>;
  const std::vector<std::tuple<std::string, Query, std::string>> cases = {
      {"/v1/jobs", {{"state", "foo"}}, "state"},
      {"/v1/jobs", {{"state", "Done"}}, "state"},
      {"/v1/jobs", {{"limit", "0"}}, "limit"},
      {"/v1/jobs", {{"limit", "1001"}}, "limit"},
      {"/v1/jobs", {{"limit", "-1"}}, "limit"},
      {"/v1/jobs", {{"limit", "ten"}}, "limit"},
      {"/v1/jobs", {{"limit", ""}}, "limit"},
      {"/v1/jobs", {{"limit", "99999999999"}}, "limit"},
      {"/v1/jobs", {{"sort", "asc"}}, "sort"},
      {"/v1/sites", {{"x", "1"}}, "x"},
      {"/v1/sites/" + site, {{"verbose", "1"}}, "verbose"},
      {"/v1/jobs/" + job_id, {{"verbose", "1"}}, "verbose"},
      {"/v1/jobs/" + job_id + "/summary", {{"format", "json"}}, "format"},
      {ptn, {{"min_density_per_m2", "0.1"}}, "min_density_per_m2"},
      {ptn, {{"format", "json"}, {"min_density_per_m2", "0.1"}}, "min_density_per_m2"},
      {ptn, {{"format", "xml"}}, "format"},
      {ptn, {{"format", "geojson"}, {"min_density_per_m2", "-1"}}, "min_density_per_m2"},
      {ptn, {{"format", "geojson"}, {"min_density_per_m2", "abc"}}, "min_density_per_m2"},
      {ptn, {{"format", "geojson"}, {"min_density_per_m2", "0.1x"}}, "min_density_per_m2"},
      {ptn, {{"format", "geojson"}, {"min_density_per_m2", "inf"}}, "min_density_per_m2"},
      {ptn, {{"format", "geojson"}, {"min_density_per_m2", "nan"}}, "min_density_per_m2"},
      {ptn, {{"format", "geojson"}, {"min_density_per_m2", ""}}, "min_density_per_m2"},
      {ptn, {{"threshold", "1"}}, "threshold"},
  };
  for (const auto& [path, query, field] : cases) {
    std::string q;
    for (const auto& [k, v] : query) q += k + "=" + v + "&";
    SCOPED_TRACE(path + "?" + q);
    expect_error(get(path, query), 400, "bad_parameter", field);
  }
  // A POST with a query parameter.
  const Response post_query =
      call("POST", "/v1/jobs", {{"priority", "1"}}, job_on(site, 100).dump(),
           {{"content-type", "application/json"}});
  expect_error(post_query, 400, "bad_parameter", "priority");

  // Good values.
  EXPECT_EQ(get("/v1/jobs", {{"state", "queued"}, {"limit", "1"}}).status, 200);
  EXPECT_EQ(get("/v1/jobs", {{"limit", "1000"}}).status, 200);
}

TEST_F(ServiceJobs, ListIsNewestFirstWithStateAndLimit) {
  start();
  const std::string site = add_site();
  const std::string blocker = add_job(blocker_job(site));
  ASSERT_EQ(wait_for_state(blocker, "running")["state"], "running");
  std::vector<std::string> ids;
  for (int k = 0; k < 3; ++k) {
    Json body = job_on(site, 100);
    body["priority"] = -1000;
    ids.push_back(add_job(body));
  }
  const auto listed = [&](std::map<std::string, std::string> query) {
    std::vector<std::string> out;
    const Response r = get("/v1/jobs", std::move(query));
    EXPECT_EQ(r.status, 200) << r.body;
    const Json list = body_of(r);
    for (const Json& j : list["jobs"]) out.push_back(j["job_id"]);
    return out;
  };
  EXPECT_EQ(listed({}), (std::vector<std::string>{ids[2], ids[1], ids[0], blocker}));
  EXPECT_EQ(listed({{"limit", "2"}}), (std::vector<std::string>{ids[2], ids[1]}));
  EXPECT_EQ(listed({{"state", "queued"}}), (std::vector<std::string>{ids[2], ids[1], ids[0]}));
  EXPECT_TRUE(listed({{"state", "done"}}).empty());
  EXPECT_EQ(del("/v1/jobs/" + ids[1]).status, 200);
  EXPECT_EQ(listed({{"state", "cancelled"}}), std::vector<std::string>{ids[1]});
}

// ---- The queue: a long job keeps the worker busy, later jobs stay queued ----

TEST_F(ServiceQueue, ResultsOfAJobNotDoneAre409NotReady) {
  start();
  const std::string site = add_site();
  const std::string blocker = add_job(blocker_job(site));
  Json body = job_on(site, 100);
  body["priority"] = -1000;
  const std::string queued = add_job(body);
  for (const std::string& id : {queued, blocker}) {
    for (const char* part :
         {"/summary", "/buildings", "/ptn", "/results.h5", "/maps", "/maps/hazard.kml"}) {
      SCOPED_TRACE(id + part);
      const Response r = get("/v1/jobs/" + id + part);
      expect_error(r, 409, "not_ready");
      EXPECT_FALSE(r.file.has_value());
    }
  }
  const Response geo = get("/v1/jobs/" + queued + "/ptn", {{"format", "geojson"}});
  expect_error(geo, 409, "not_ready");
  EXPECT_EQ(job(queued)["state"], "queued");
}

TEST_F(ServiceQueue, CancellingAQueuedJob) {
  start();
  const std::string site = add_site();
  add_job(blocker_job(site));
  Json body = job_on(site, 100);
  body["priority"] = -1000;
  const std::string id = add_job(body);

  const Response r = del("/v1/jobs/" + id);
  ASSERT_EQ(r.status, 200) << r.body;
  const Json j = body_of(r);
  EXPECT_EQ(j["job_id"], id);
  EXPECT_EQ(j["state"], "cancelled");
  EXPECT_TRUE(j["finished_utc"].is_string());
  EXPECT_TRUE(j["started_utc"].is_null());
  EXPECT_EQ(j["attempts"], 0);
  EXPECT_EQ(job(id)["state"], "cancelled");

  for (const char* part : {"/summary", "/buildings", "/ptn", "/results.h5", "/maps"}) {
    SCOPED_TRACE(part);
    const Response results = get("/v1/jobs/" + id + part);
    expect_error(results, 409, "not_ready");
    EXPECT_NE(body_of(results)["message"].get<std::string>().find("cancelled"), std::string::npos);
  }
  // Cancelling again: already final.
  expect_error(del("/v1/jobs/" + id), 409, "conflict");
}

TEST_F(ServiceQueue, DeletingASiteUsedByAQueuedJobIs409) {
  start();
  const std::string site = add_site();
  const std::string blocker = add_job(blocker_job(site));
  Json body = job_on(site, 100);
  body["priority"] = -1000;
  const std::string queued = add_job(body);

  EXPECT_EQ(body_of(get("/v1/sites/" + site))["jobs_using"], 2);
  expect_error(del("/v1/sites/" + site), 409, "conflict");
  EXPECT_EQ(get("/v1/sites/" + site).status, 200);

  // The queued job first (the worker would start it once the blocker is gone).
  EXPECT_EQ(del("/v1/jobs/" + queued).status, 200);
  EXPECT_EQ(body_of(get("/v1/sites/" + site))["jobs_using"], 1);
  expect_error(del("/v1/sites/" + site), 409, "conflict");  // still the blocker
  EXPECT_EQ(del("/v1/jobs/" + blocker).status, 200);
  EXPECT_EQ(body_of(get("/v1/sites/" + site))["jobs_using"], 0);
  EXPECT_EQ(del("/v1/sites/" + site).status, 204);
}

TEST_F(ServiceQueue, CancellingTheRunningJob) {
  start();
  const std::string site = add_site();
  const std::string blocker = add_job(blocker_job(site));
  const Json running = wait_for_state(blocker, "running");
  ASSERT_EQ(running["state"], "running") << running.dump();
  EXPECT_EQ(running["attempts"], 1);
  EXPECT_TRUE(running["started_utc"].is_string());

  const Response r = del("/v1/jobs/" + blocker);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(body_of(r)["state"], "cancelled");
  expect_error(get("/v1/jobs/" + blocker + "/summary"), 409, "not_ready");
  EXPECT_FALSE(fs::exists(dir_ / "data" / "jobs" / blocker / "summary.json"));
}

TEST_F(ServiceQueue, QueuedJobLimitIs422LimitExceeded) {
  start([](Config& c) { c.max_queued_jobs = 2; });
  const std::string site = add_site();
  const std::string blocker = add_job(blocker_job(site));
  ASSERT_EQ(wait_for_state(blocker, "running")["state"], "running");
  Json body = job_on(site, 100);
  body["priority"] = -1000;
  add_job(body);
  add_job(body);
  expect_error(post("/v1/jobs", body), 422, "limit_exceeded");
  EXPECT_EQ(body_of(get("/v1/jobs", {{"state", "queued"}}))["jobs"].size(), 2u);
}

TEST_F(ServiceQueue, HealthAndMetricsCountTheQueue) {
  start();
  const std::string site = add_site();
  const std::string blocker = add_job(blocker_job(site));
  ASSERT_EQ(wait_for_state(blocker, "running")["state"], "running");
  Json body = job_on(site, 100);
  body["priority"] = -1000;
  add_job(body);
  const std::string cancelled = add_job(body);
  ASSERT_EQ(del("/v1/jobs/" + cancelled).status, 200);

  EXPECT_EQ(body_of(get_anonymous("/v1/health"))["jobs"],
            Json::parse(R"({"queued": 1, "running": 1})"));
  const std::string m = metrics_text();
  EXPECT_NE(m.find("\nfragsimd_jobs{state=\"queued\"} 1\n"), std::string::npos) << m;
  EXPECT_NE(m.find("\nfragsimd_jobs{state=\"running\"} 1\n"), std::string::npos) << m;
  EXPECT_NE(m.find("\nfragsimd_jobs{state=\"cancelled\"} 1\n"), std::string::npos) << m;
  EXPECT_NE(m.find("\nfragsimd_jobs{state=\"done\"} 0\n"), std::string::npos) << m;
  EXPECT_NE(m.find("\nfragsimd_queue_length 1\n"), std::string::npos) << m;
  EXPECT_NE(m.find("\nfragsimd_sites 1\n"), std::string::npos) << m;
}

// docs/http-api.md, POST /v1/jobs and "Idempotency": a repeat with the same key and body returns
// the existing job (200) "whatever its state", even when the retried POST is the one that filled
// the queue (--max-queued-jobs).
TEST_F(ServiceQueue, IdempotentRepeatIsAnsweredWhenTheQueueIsFull) {
  start([](Config& c) { c.max_queued_jobs = 1; });
  const std::string site = add_site();
  const std::string blocker = add_job(blocker_job(site));
  ASSERT_EQ(wait_for_state(blocker, "running")["state"], "running");
  Json body = job_on(site, 100);
  body["priority"] = -1000;
  body["idempotency_key"] = "retry-after-timeout";
  const std::string id = add_job(body);  // the queue is now full
  const Response repeat = post("/v1/jobs", body);
  EXPECT_EQ(repeat.status, 200) << repeat.body;
  EXPECT_EQ(body_of(repeat).value("job_id", ""), id);
}

// docs/http-api.md, Metrics: fragsimd_histories_total counts the histories of finished (done)
// jobs; the running job's progress is in its JobStatus only.
TEST_F(ServiceQueue, HistoriesTotalCountsFinishedJobsOnly) {
  start();
  const std::string site = add_site();
  const std::string blocker = add_job(blocker_job(site));
  const Json progressed =
      wait_for(blocker, [](const Json& j) { return j["histories_done"].get<std::int64_t>() > 0; });
  ASSERT_GT(progressed["histories_done"].get<std::int64_t>(), 0) << progressed.dump();
  EXPECT_EQ(progressed["state"], "running");
  EXPECT_GT(progressed["progress"].get<double>(), 0.0);
  EXPECT_TRUE(progressed["histories_per_s"].is_number());
  EXPECT_TRUE(progressed["eta_s"].is_number());
  const std::string m = metrics_text();
  EXPECT_NE(m.find("\nfragsimd_histories_total 0\n"), std::string::npos) << m;
}

// ---- A job that runs to the end ----

TEST_F(ServiceResults, SmallJobIsDoneAndItsResultsAreServed) {
  start();
  const std::string site = add_site();
  const Json scenario = job_on(site, 200);
  const std::string id = add_job(scenario);
  const Json j = wait_for_state(id, "done");
  ASSERT_EQ(j["state"], "done") << j.dump();
  EXPECT_EQ(j["histories_done"], 200);
  EXPECT_EQ(j["histories_total"], 200);
  EXPECT_EQ(j["progress"], 1.0);
  EXPECT_EQ(j["attempts"], 1);
  EXPECT_TRUE(j["started_utc"].is_string());
  EXPECT_TRUE(j["finished_utc"].is_string());
  EXPECT_TRUE(j["error"].is_null());
  EXPECT_TRUE(j["histories_per_s"].is_null());
  EXPECT_TRUE(j["eta_s"].is_null());

  const fs::path job_dir = fs::path(config().data_dir) / "jobs" / id;

  // summary.json, served as a file.
  const Response summary = get("/v1/jobs/" + id + "/summary");
  ASSERT_EQ(summary.status, 200) << summary.body;
  ASSERT_TRUE(summary.file.has_value());
  EXPECT_EQ(fs::weakly_canonical(*summary.file), fs::weakly_canonical(job_dir / "summary.json"));
  ASSERT_TRUE(fs::is_regular_file(*summary.file));
  const Json summary_json = Json::parse(api::testing::read_text(*summary.file));
  EXPECT_EQ(summary_json["schema"], "fragsim.result/1");
  // The job's own parse is timed (the stored site was built at upload, not by the job).
  EXPECT_GT(summary_json["timing"]["parse_s"].get<double>(), 0.0);
  EXPECT_EQ(summary.content_type, "application/json");

  // Buildings, in scenario order.
  const Response buildings = get("/v1/jobs/" + id + "/buildings");
  ASSERT_EQ(buildings.status, 200) << buildings.body;
  const Json b = body_of(buildings);
  EXPECT_EQ(b["job_id"], id);
  ASSERT_EQ(b["buildings"].size(), 1u);
  EXPECT_EQ(b["buildings"][0]["id"], "B1");
  for (const char* key :
       {"expected_impacts", "impacts_std_error", "expected_penetrations", "penetrations_std_error"})
    EXPECT_TRUE(b["buildings"][0][key].is_number()) << key;

  // PTN as JSON: the same field as a direct run of the same scenario (bit for bit).
  const Response ptn = get("/v1/jobs/" + id + "/ptn");
  ASSERT_EQ(ptn.status, 200) << ptn.body;
  EXPECT_EQ(ptn.content_type, "application/json");
  const Json p = body_of(ptn);
  EXPECT_EQ(p["job_id"], id);
  EXPECT_EQ(p["triangles"], 3200);
  Json inline_scenario = small_example();
  inline_scenario["fragment_groups"][0]["samples"] = 200;
  const run::RunResult direct = run::run(api::parse_scenario(inline_scenario));
  EXPECT_EQ(p["density_per_m2"].get<std::vector<double>>(), direct.ptn_density_per_m2);
  EXPECT_EQ(p["std_error_per_m2"].get<std::vector<double>>(), direct.ptn_std_error_per_m2);
  EXPECT_EQ(b["buildings"][0]["expected_impacts"].get<double>(), direct.buildings[0].impacts.mean);

  // PTN as GeoJSON, all triangles and filtered.
  const Response geo = get("/v1/jobs/" + id + "/ptn", {{"format", "geojson"}});
  ASSERT_EQ(geo.status, 200) << geo.body;
  EXPECT_EQ(geo.content_type, "application/geo+json");
  EXPECT_EQ(body_of(geo)["features"].size(), 3200u);
  const double threshold = p["threshold_per_m2"];
  const Response hazardous =
      get("/v1/jobs/" + id + "/ptn", {{"format", "geojson"}, {"min_density_per_m2", "1e-9"}});
  ASSERT_EQ(hazardous.status, 200) << hazardous.body;
  const auto expected = static_cast<std::size_t>(std::count_if(direct.ptn_density_per_m2.begin(),
                                                               direct.ptn_density_per_m2.end(),
                                                               [](double d) { return d >= 1e-9; }));
  EXPECT_EQ(body_of(hazardous)["features"].size(), expected);
  EXPECT_GT(threshold, 0.0);

  // results.h5, served as a file.
  const Response h5 = get("/v1/jobs/" + id + "/results.h5");
  ASSERT_EQ(h5.status, 200) << h5.body;
  ASSERT_TRUE(h5.file.has_value());
  EXPECT_EQ(fs::weakly_canonical(*h5.file), fs::weakly_canonical(job_dir / "results.h5"));
  EXPECT_TRUE(fs::is_regular_file(*h5.file));
  EXPECT_EQ(h5.content_type, "application/x-hdf5");
  EXPECT_EQ(header(h5, "Content-Disposition"), "attachment; filename=\"" + id + ".h5\"");

  // HEAD like GET.
  EXPECT_EQ(call("HEAD", "/v1/jobs/" + id + "/results.h5").file, h5.file);

  // A done job is final.
  expect_error(del("/v1/jobs/" + id), 409, "conflict");
  EXPECT_EQ(job(id)["state"], "done");

  // Listing and counters.
  const Json done = body_of(get("/v1/jobs", {{"state", "done"}}));
  ASSERT_EQ(done["jobs"].size(), 1u);
  EXPECT_EQ(done["jobs"][0]["job_id"], id);
  EXPECT_TRUE(body_of(get("/v1/jobs", {{"state", "queued"}}))["jobs"].empty());
  // The counter is raised just after the job is marked done: poll (generous deadline).
  std::string m = metrics_text();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (m.find("\nfragsimd_histories_total 200\n") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    m = metrics_text();
  }
  EXPECT_NE(m.find("\nfragsimd_jobs{state=\"done\"} 1\n"), std::string::npos) << m;
  EXPECT_NE(m.find("\nfragsimd_histories_total 200\n"), std::string::npos) << m;

  // Done jobs do not hold their site.
  EXPECT_EQ(body_of(get("/v1/sites/" + site))["jobs_using"], 0);
  EXPECT_EQ(del("/v1/sites/" + site).status, 204);
  EXPECT_EQ(get("/v1/jobs/" + id + "/ptn").status, 200);  // results stay
}

// The maps route serves what `fragsim export` writes (the same function), made once on the first
// request; an interrupted export is made again and its temporaries are removed.
TEST_F(ServiceResults, MapsAreMadeOnceAndServedAsFiles) {
  start();
  const std::string id = done_job_in_utm();
  const fs::path job_dir = fs::path(config().data_dir) / "jobs" / id;
  const fs::path maps_dir = job_dir / "maps";
  EXPECT_FALSE(fs::exists(maps_dir)) << "made before anyone asked";

  const Response listing = get("/v1/jobs/" + id + "/maps");
  ASSERT_EQ(listing.status, 200) << listing.body;
  const Json m = body_of(listing);
  EXPECT_EQ(m["job_id"], id);
  EXPECT_EQ(m["crs"], "EPSG:32611");
  std::map<std::string, Json> files;
  for (const auto& f : m["files"]) files[f["name"].get<std::string>()] = f;
  for (const char* name : {"ptn_density.tif", "ptn_classes.tif", "hazard.gpkg",
                           "hazardous_area.geojson", "buildings.geojson", "hazard.kml"}) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(files.count(name));
    EXPECT_EQ(files[name]["url"], "/v1/jobs/" + id + "/maps/" + name);
    EXPECT_EQ(files[name]["bytes"].get<std::uintmax_t>(), fs::file_size(maps_dir / name));
  }
  EXPECT_EQ(files["ptn_density.tif"]["content_type"], "image/tiff");
  EXPECT_EQ(files["hazard.kml"]["content_type"], "application/vnd.google-earth.kml+xml");

  // A file: served from the job's maps directory, with its type and a download name.
  const Response tif = get("/v1/jobs/" + id + "/maps/ptn_density.tif");
  ASSERT_EQ(tif.status, 200) << tif.body;
  ASSERT_TRUE(tif.file.has_value());
  EXPECT_EQ(fs::weakly_canonical(*tif.file), fs::weakly_canonical(maps_dir / "ptn_density.tif"));
  EXPECT_EQ(tif.content_type, "image/tiff");
  EXPECT_EQ(header(tif, "Content-Disposition"),
            "attachment; filename=\"" + id + "_ptn_density.tif\"");
  // The same bytes as `fragsim export` of the job's results.h5.
  const fs::path direct = dir_ / "direct";
  gis::export_results({job_dir / "results.h5", direct, std::nullopt});
  EXPECT_EQ(api::testing::read_text(*tif.file),
            api::testing::read_text(direct / "ptn_density.tif"));

  // Made once: a second listing reads the stored one.
  const auto made = fs::last_write_time(maps_dir / "index.json");
  EXPECT_EQ(body_of(get("/v1/jobs/" + id + "/maps")), m);
  EXPECT_EQ(fs::last_write_time(maps_dir / "index.json"), made);

  // A name it does not have (or one that would leave the directory) is 404 naming those it has.
  for (const char* name : {"nope.tif", "index.json", "..", "%2e%2e", "results.h5"}) {
    SCOPED_TRACE(name);
    const Response r = get("/v1/jobs/" + id + "/maps/" + name);
    expect_error(r, 404, "not_found");
    EXPECT_NE(body_of(r)["message"].get<std::string>().find("hazard.kml"), std::string::npos);
  }

  // An export killed half-way: temporaries and no index. Start-up removes the temporaries;
  // the next request makes the set again.
  fs::remove(maps_dir / "index.json");
  fs::remove(maps_dir / "hazard.kml");
  std::ofstream(maps_dir / ".hazard.kml.tmp.0123456789abcdef.3") << "partial";
  restart();
  EXPECT_FALSE(fs::exists(maps_dir / ".hazard.kml.tmp.0123456789abcdef.3"));
  EXPECT_EQ(get("/v1/jobs/" + id + "/maps/hazard.kml").status, 200);
  EXPECT_TRUE(fs::is_regular_file(maps_dir / "hazard.kml"));
  EXPECT_TRUE(fs::is_regular_file(maps_dir / "index.json"));
}

// The site-plan boundary (gis/plan_boundary.h) in the job's input coordinates.
TEST_F(ServiceResults, ThePlanBoundaryIsAnsweredInInputCoordinates) {
  start();
  const std::string id = done_job_in_utm();
  const Json summary =
      Json::parse(api::testing::read_text(*get("/v1/jobs/" + id + "/summary").file));
  const Response r = get("/v1/jobs/" + id + "/plan_boundary");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.content_type, "application/json");
  const Json b = body_of(r);
  EXPECT_EQ(b["job_id"], id);
  EXPECT_EQ(b["origin_m"][0], summary["hfd_origin_m"][0]);
  EXPECT_EQ(b["origin_m"][1], summary["hfd_origin_m"][1]);
  EXPECT_EQ(b["exact_hfd_m"], summary["hazardous_fragment_distance_m"]);
  EXPECT_EQ(b["smoothing_m"], 20.0);  // 2 cells of the 10 m plane
  ASSERT_GT(b["exact_hfd_m"].get<double>(), 0.0) << "the job leaves no hazardous area";
  EXPECT_GE(b["smoothed_hfd_m"].get<double>(), b["exact_hfd_m"].get<double>());
  for (const char* key : {"envelope", "envelope_upper"}) {
    SCOPED_TRACE(key);
    EXPECT_EQ(b[key]["radius_m"].size(), 36u);
    EXPECT_GE(b[key]["max_radius_m"].get<double>(), b["exact_hfd_m"].get<double>());
    ASSERT_FALSE(b[key]["polygons"].empty());
  }
  // Input coordinates: round (0, 0), not at 500000 E, 3700000 N.
  for (const auto& polygon : b["smoothed"]["polygons"])
    for (const auto& ring : polygon)
      for (const auto& p : ring) {
        EXPECT_LE(std::abs(p[0].get<double>()), 2000.0);
        EXPECT_LE(std::abs(p[1].get<double>()), 2000.0);
      }
  EXPECT_EQ(
      body_of(get("/v1/jobs/" + id + "/plan_boundary", {{"smoothing_m", "5"}}))["smoothing_m"],
      5.0);
  for (const char* bad : {"-1", "0", "x", "nan", "1e999"}) {
    SCOPED_TRACE(bad);
    expect_error(get("/v1/jobs/" + id + "/plan_boundary", {{"smoothing_m", bad}}), 400,
                 "bad_parameter", "smoothing_m");
  }
}

// Concurrent first requests: one export, every request answered with the same listing.
TEST_F(ServiceResults, ConcurrentFirstMapRequestsAgree) {
  start();
  const std::string id = add_job(job_on(add_site(), 200));
  ASSERT_EQ(wait_for_state(id, "done")["state"], "done");
  std::vector<Response> answers(4);
  std::vector<std::thread> threads;
  for (auto& a : answers)
    threads.emplace_back([&a, this, &id] { a = get("/v1/jobs/" + id + "/maps"); });
  for (auto& t : threads) t.join();
  for (const auto& a : answers) {
    ASSERT_EQ(a.status, 200) << a.body;
    EXPECT_EQ(body_of(a), body_of(answers[0]));
  }
  // A site without a CRS: the maps are in local metres and the listing says what was left out.
  const Json m = body_of(answers[0]);
  EXPECT_TRUE(m["crs"].is_null());
  // The small plane cuts the HFD (said first); "local" is a label, not a CRS, so no GeoJSON or
  // KML; and no trajectories were recorded.
  ASSERT_EQ(m["notes"].size(), 4u);
  EXPECT_EQ(m["notes"][0].get<std::string>().rfind("HFD ≥ ", 0), 0u);
  EXPECT_NE(m["notes"][1].get<std::string>().find("\"local\" is not a CRS"), std::string::npos);
  EXPECT_NE(m["notes"][3].get<std::string>().find("no CRS"), std::string::npos);
  EXPECT_EQ(m["files"].size(), 5u);  // the GeoTIFFs, the GeoPackage, terrain and buildings VTKHDF
}

// ---- Purge and retention (server/purge.h, docs/operations.md) ----

std::uintmax_t tree_bytes(const fs::path& dir) {
  std::uintmax_t n = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) n += e.file_size();
  return n;
}

class ServicePurge : public ServiceTest {
 protected:
  Response purge(const std::string& id, const std::string& value = "true") {
    return call("DELETE", "/v1/jobs/" + id, {{"purge", value}});
  }
  // Polls until GET /v1/jobs/{id} answers 404 and the job's directory is gone (a purge deletes
  // the rows first, then the files: the 404 comes first); false at the deadline.
  bool wait_until_gone(const std::string& id) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < deadline) {
      if (get("/v1/jobs/" + id).status == 404 && !fs::exists(dir_ / "data" / "jobs" / id))
        return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }
};

TEST_F(ServicePurge, AFinishedJobGoesWithItsRowsAndFiles) {
  start();
  const std::string site = add_site();
  const std::string id = add_job(job_on(site, 200));
  ASSERT_EQ(wait_for_state(id, "done")["state"], "done");
  const fs::path dir = dir_ / "data" / "jobs" / id;
  ASSERT_TRUE(fs::exists(dir / "results.h5"));
  ASSERT_EQ(get("/v1/jobs/" + id + "/maps").status, 200);  // made on demand: in the directory too
  const std::uintmax_t bytes = tree_bytes(dir);

  const Response r = purge(id);
  ASSERT_EQ(r.status, 200) << r.body;
  const Json j = body_of(r);
  EXPECT_EQ(j["job_id"], id);
  EXPECT_EQ(j["purged"], true);
  EXPECT_EQ(j["state"], "done");
  EXPECT_EQ(j["bytes_freed"], bytes);
  EXPECT_FALSE(fs::exists(dir));
  for (const auto& e : fs::directory_iterator(dir_ / "data" / "jobs"))
    ADD_FAILURE() << "left in jobs/: " << e.path();

  expect_error(get("/v1/jobs/" + id), 404, "not_found");
  for (const char* part : {"/summary", "/buildings", "/results.h5", "/maps"})
    expect_error(get("/v1/jobs/" + id + part), 404, "not_found");
  EXPECT_TRUE(body_of(get("/v1/jobs"))["jobs"].empty());
  expect_error(purge(id), 404, "not_found");
  const std::string m = metrics_text();
  EXPECT_NE(m.find("fragsimd_jobs_purged_total{reason=\"request\"} 1\n"), std::string::npos) << m;
  EXPECT_NE(
      m.find("fragsimd_purged_bytes_total{reason=\"request\"} " + std::to_string(bytes) + "\n"),
      std::string::npos)
      << m;
  EXPECT_NE(m.find("fragsimd_jobs_purged_total{reason=\"age\"} 0\n"), std::string::npos) << m;
  // The site stays, and a new job on it runs.
  EXPECT_EQ(get("/v1/sites/" + site).status, 200);
  EXPECT_EQ(wait_for_state(add_job(job_on(site, 100)), "done")["state"], "done");
}

TEST_F(ServicePurge, QueuedAndRunningJobsAreNeverPurged) {
  start();
  const std::string site = add_site();
  const std::string blocker = running_blocker(site);
  const std::string queued = add_job(queued_behind(site));

  for (const std::string& id : {blocker, queued}) {
    SCOPED_TRACE(id);
    const Response r = purge(id);
    expect_error(r, 409, "conflict");
    EXPECT_NE(body_of(r)["message"].get<std::string>().find("cancel it first"), std::string::npos);
  }
  EXPECT_EQ(job(blocker)["state"], "running");
  EXPECT_EQ(job(queued)["state"], "queued");

  // Cancelled, they can go; the running one once the worker let go of it (409 with Retry-After
  // until then).
  ASSERT_EQ(del("/v1/jobs/" + queued).status, 200);
  const Response q = purge(queued);
  ASSERT_EQ(q.status, 200) << q.body;
  EXPECT_EQ(body_of(q)["state"], "cancelled");
  EXPECT_EQ(body_of(q)["bytes_freed"], 0) << "never started: no directory";
  ASSERT_EQ(del("/v1/jobs/" + blocker).status, 200);
  Response b = purge(blocker);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (b.status == 409 && std::chrono::steady_clock::now() < deadline) {
    EXPECT_EQ(header(b, "Retry-After"), "1");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    b = purge(blocker);
  }
  ASSERT_EQ(b.status, 200) << b.body;
  EXPECT_FALSE(fs::exists(dir_ / "data" / "jobs" / blocker));
  EXPECT_EQ(body_of(get("/v1/sites/" + site))["jobs_using"], 0);
}

TEST_F(ServicePurge, ThePurgeParameterIsChecked) {
  start();
  const std::string id = add_job(job_on(add_site(), 100));
  ASSERT_EQ(wait_for_state(id, "done")["state"], "done");
  // expect_error parses the body: a value that is not UTF-8 must not make it invalid JSON.
  for (const char* bad : {"yes", "1", "TRUE", "", "\xff\xfe", "true\n", "nan"})
    expect_error(purge(id, bad), 400, "bad_parameter", "purge");
  expect_error(get("/v1/jobs/" + id, {{"purge", "true"}}), 400, "bad_parameter", "purge");
  // purge=false is a cancel, and a done job cannot be cancelled.
  expect_error(purge(id, "false"), 409, "conflict");
  EXPECT_EQ(job(id)["state"], "done");
  // Unknown and malformed ids.
  expect_error(purge(kUnknownJob), 404, "not_found");
  expect_error(purge("j_nothex"), 404, "not_found");
}

TEST_F(ServicePurge, TheBaseOfAQueuedComparisonStays) {
  start();
  const std::string site = add_site();
  const std::string base = add_job(job_on(site, 100));  // as queued_behind
  ASSERT_EQ(wait_for_state(base, "done")["state"], "done");
  const std::string blocker = running_blocker(site);
  Json variant = queued_behind(site);
  variant["compare_with"] = base;
  const std::string comparison = add_job(variant);

  const Response r = purge(base);
  expect_error(r, 409, "conflict");
  EXPECT_NE(body_of(r)["message"].get<std::string>().find("compare_with"), std::string::npos);
  EXPECT_EQ(job(base)["state"], "done");
  ASSERT_EQ(del("/v1/jobs/" + comparison).status, 200);
  EXPECT_EQ(purge(base).status, 200);
  // A comparison with a purged job is refused as one with an unknown job.
  variant.erase("priority");
  expect_error(post("/v1/jobs", variant), 422, "invalid_input", "compare_with");
  EXPECT_EQ(del("/v1/jobs/" + blocker).status, 200);
}

TEST_F(ServicePurge, RetentionByAgeTakesFinishedJobsOnly) {
  start([](Config& c) {
    c.retain_days = 1e-6;  // 86 ms
    c.retain_interval_s = 0.05;
  });
  const std::string site = add_site();
  const std::string done = add_job(job_on(site, 100));
  ASSERT_TRUE(wait_until_gone(done));
  EXPECT_FALSE(fs::exists(dir_ / "data" / "jobs" / done));
  // A running job and a queued one behind it stay, however long they take.
  const std::string blocker = running_blocker(site);
  const std::string queued = add_job(queued_behind(site));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(job(blocker)["state"], "running");
  EXPECT_EQ(job(queued)["state"], "queued");
  EXPECT_NE(metrics_text().find("fragsimd_jobs_purged_total{reason=\"age\"} 1\n"),
            std::string::npos);
  // Cancelled, the queued one finishes and goes too.
  ASSERT_EQ(del("/v1/jobs/" + queued).status, 200);
  EXPECT_TRUE(wait_until_gone(queued));
  EXPECT_EQ(job(blocker)["state"], "running");
}

TEST_F(ServicePurge, RetentionByBytesTakesTheEarliestFinishedFirst) {
  start();
  const std::string site = add_site();
  const std::string first = add_job(job_on(site, 200));
  ASSERT_EQ(wait_for_state(first, "done")["state"], "done");
  const std::string second = add_job(job_on(site, 200));
  ASSERT_EQ(wait_for_state(second, "done")["state"], "done");
  const fs::path jobs = dir_ / "data" / "jobs";
  const std::uintmax_t second_bytes = tree_bytes(jobs / second);
  ASSERT_GT(tree_bytes(jobs / first), 1u);

  // Room for one of the two: the earlier finished goes, at start.
  service_.reset();
  start([&](Config& c) {
    c.retain_bytes = static_cast<std::int64_t>(second_bytes) + 1;
    c.retain_interval_s = 0.05;
  });
  ASSERT_TRUE(wait_until_gone(first));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a few more passes
  EXPECT_EQ(job(second)["state"], "done");
  EXPECT_TRUE(fs::exists(jobs / second / "results.h5"));
  const std::string m = metrics_text();
  EXPECT_NE(m.find("fragsimd_jobs_purged_total{reason=\"bytes\"} 1\n"), std::string::npos) << m;
}

TEST_F(ServicePurge, APurgeCutShortByADeathIsFinishedAtTheNextStart) {
  start();
  const std::string kept = add_job(job_on(add_site(), 100));
  ASSERT_EQ(wait_for_state(kept, "done")["state"], "done");
  service_.reset();
  // What a kill -9 during a purge can leave: the rows gone and the directory still there (not
  // yet renamed), or renamed and partly removed.
  const fs::path jobs = dir_ / "data" / "jobs";
  fs::create_directories(jobs / "j_00000000000000ab" / "maps");
  std::ofstream(jobs / "j_00000000000000ab" / "results.h5") << "left";
  fs::create_directories(jobs / ".purging-j_00000000000000cd" / "maps");
  std::ofstream(jobs / ".purging-j_00000000000000cd" / "summary.json") << "{}";
  start();
  EXPECT_FALSE(fs::exists(jobs / "j_00000000000000ab"));
  EXPECT_FALSE(fs::exists(jobs / ".purging-j_00000000000000cd"));
  EXPECT_TRUE(fs::exists(jobs / kept / "results.h5"));
  EXPECT_EQ(get("/v1/jobs/" + kept + "/summary").status, 200);
}

// ---- Metrics ----

TEST_F(ServiceMetrics, NeedsAToken) {
  start();
  expect_error(get_anonymous("/metrics"), 401, "unauthorized");
}

TEST_F(ServiceMetrics, DocumentedMetricNames) {
  start();
  service_->metrics().record_request("GET", "/v1/jobs/{id}", 200, 0.003);
  service_->metrics().record_request("GET", "/v1/jobs/{id}", 200, 0.2);
  service_->metrics().record_request("POST", "/v1/jobs", 422, 0.0005);
  const Response r = get("/metrics");
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type.rfind("text/plain", 0), 0u) << r.content_type;
  const std::string& m = r.body;
  for (
      const char* line : {
          "# TYPE fragsimd_jobs gauge\n",
          "fragsimd_jobs{state=\"queued\"} 0\n",
          "fragsimd_jobs{state=\"running\"} 0\n",
          "fragsimd_jobs{state=\"done\"} 0\n",
          "fragsimd_jobs{state=\"failed\"} 0\n",
          "fragsimd_jobs{state=\"cancelled\"} 0\n",
          "# TYPE fragsimd_queue_length gauge\n",
          "fragsimd_queue_length 0\n",
          "# TYPE fragsimd_histories_total counter\n",
          "fragsimd_histories_total 0\n",
          "# TYPE fragsimd_histories_per_second gauge\n",
          "fragsimd_histories_per_second 0\n",
          "# TYPE fragsimd_sites gauge\n",
          "fragsimd_sites 0\n",
          "# TYPE fragsimd_uptime_seconds gauge\n",
          "# TYPE fragsimd_http_requests_total counter\n",
          "fragsimd_http_requests_total{method=\"GET\",route=\"/v1/jobs/{id}\",status=\"200\"} 2\n",
          "fragsimd_http_requests_total{method=\"POST\",route=\"/v1/jobs\",status=\"422\"} 1\n",
          "# TYPE fragsimd_http_request_duration_seconds histogram\n",
          "fragsimd_http_request_duration_seconds_bucket{route=\"/v1/jobs/{id}\",le=\"0.001\"} 0\n",
          "fragsimd_http_request_duration_seconds_bucket{route=\"/v1/jobs/{id}\",le=\"0.005\"} 1\n",
          "fragsimd_http_request_duration_seconds_bucket{route=\"/v1/jobs/{id}\",le=\"0.1\"} 1\n",
          "fragsimd_http_request_duration_seconds_bucket{route=\"/v1/jobs/{id}\",le=\"0.5\"} 2\n",
          "fragsimd_http_request_duration_seconds_bucket{route=\"/v1/jobs/{id}\",le=\"+Inf\"} 2\n",
          "fragsimd_http_request_duration_seconds_count{route=\"/v1/jobs/{id}\"} 2\n",
          "fragsimd_http_request_duration_seconds_bucket{route=\"/v1/jobs\",le=\"0.001\"} 1\n",
          "fragsimd_http_request_duration_seconds_count{route=\"/v1/jobs\"} 1\n",
      }) {
    EXPECT_EQ(count_occurrences(m, line), 1u) << line << "\n" << m;
  }
  EXPECT_NE(m.find("fragsimd_uptime_seconds "), std::string::npos);
  EXPECT_NE(m.find("fragsimd_http_request_duration_seconds_sum{route=\"/v1/jobs/{id}\"} 0.203"),
            std::string::npos)
      << m;
  // Buckets: the eight documented bounds and +Inf per route.
  EXPECT_EQ(
      count_occurrences(m, "fragsimd_http_request_duration_seconds_bucket{route=\"/v1/jobs\","),
      9u);
}

TEST_F(ServiceMetrics, HandleAloneRecordsNoRequests) {
  start();
  get("/v1/sites");
  get("/v1/nothing");
  get_anonymous("/v1/health");
  const std::string m = metrics_text();
  EXPECT_EQ(m.find("fragsimd_http_requests_total{"), std::string::npos) << m;
  EXPECT_EQ(m.find("fragsimd_http_request_duration_seconds_bucket{"), std::string::npos) << m;
}

TEST_F(ServiceMetrics, SitesGauge) {
  start();
  add_site();
  Json other = minimal_site();
  other.erase("buildings");
  const std::string b = add_site(other);
  EXPECT_NE(metrics_text().find("\nfragsimd_sites 2\n"), std::string::npos);
  ASSERT_EQ(del("/v1/sites/" + b).status, 204);
  EXPECT_NE(metrics_text().find("\nfragsimd_sites 1\n"), std::string::npos);
}

// ---- The web viewer (docs/viewer.md) and the scene routes ----

using ServiceViewer = ServiceTest;

constexpr const char* kCsp =
    "default-src 'self'; img-src 'self' data: blob:; style-src 'self'; script-src 'self'; "
    "connect-src 'self'; object-src 'none'; base-uri 'none'; frame-ancestors 'none'; "
    "form-action 'self'";

TEST_F(ServiceViewer, ThePageIsPublicAndServedWithAStrictContentSecurityPolicy) {
  start();
  for (const char* path : {"/", "/ui"}) {
    const Response r = get_anonymous(path);
    EXPECT_EQ(r.status, 302) << path;
    EXPECT_EQ(header(r, "Location"), "/ui/") << path;
  }
  const Response index = get_anonymous("/ui/");
  ASSERT_EQ(index.status, 200) << index.body;
  EXPECT_EQ(index.content_type, "text/html; charset=utf-8");
  EXPECT_NE(index.body.find("src/main.js"), std::string::npos);
  EXPECT_EQ(header(index, "Content-Security-Policy"), kCsp);
  EXPECT_EQ(header(index, "X-Content-Type-Options"), "nosniff");
  EXPECT_EQ(get_anonymous("/ui/index.html").body, index.body);
  const Response script = get_anonymous("/ui/src/main.js");
  EXPECT_EQ(script.status, 200);
  EXPECT_EQ(script.content_type, "text/javascript; charset=utf-8");
  // Every embedded file is served, byte for byte.
  for (const UiFile& f : embedded_ui_files()) {
    const Response r = get_anonymous("/ui/" + std::string(f.path));
    EXPECT_EQ(r.status, 200) << f.path;
    EXPECT_EQ(r.body, f.bytes) << f.path;
  }
  EXPECT_EQ(call("HEAD", "/ui/", {}, {}, {}, false).status, 200);
  // Revalidation: the same ETag gets a 304 without a body; another (a changed file) the file.
  const std::string etag = header(index, "ETag").value_or("");
  EXPECT_EQ(etag.size(), 34u);
  const Response again = call("GET", "/ui/", {}, {}, {{"if-none-match", etag}}, false);
  EXPECT_EQ(again.status, 304);
  EXPECT_TRUE(again.body.empty());
  EXPECT_EQ(header(again, "ETag"), etag);
  EXPECT_EQ(call("GET", "/ui/", {}, {}, {{"if-none-match", "\"0\""}}, false).body, index.body);
  EXPECT_NE(header(script, "ETag"), etag);
  const Response post = call("POST", "/ui/", {}, "x", {}, false);
  expect_error(post, 405, "method_not_allowed");
  EXPECT_EQ(header(post, "Allow"), "GET");
}

TEST_F(ServiceViewer, OnlyTheViewersOwnFilesAreServed) {
  start();
  for (const char* path :
       {"/ui/../README.md", "/ui/src/../../CMakeLists.txt", "/ui/src/.hidden", "/ui/src/",
        "/ui/src//main.js", "/ui/test/harness.mjs", "/ui/package.json", "/ui/node_modules/x.js",
        "/ui/src/%2e%2e/x", "/ui/vendor/nothing.js", "/uix", "/ui/src/a b.js"}) {
    SCOPED_TRACE(path);
    expect_error(get_anonymous(path), 404, "not_found");
  }
  EXPECT_EQ(ui_file_path(""), "index.html");
  EXPECT_EQ(ui_file_path("vendor/three.module.min.js"), "vendor/three.module.min.js");
  EXPECT_EQ(ui_file_path("src/a/b.js"), "src/a/b.js");
  EXPECT_EQ(ui_file_path("src/a/../b.js"), std::nullopt);
  EXPECT_EQ(ui_content_type("src/style.css"), "text/css; charset=utf-8");
  EXPECT_EQ(ui_content_type("vendor/LICENSE"), "application/octet-stream");
}

TEST_F(ServiceViewer, ThePageCanComeFromAFolderOrBeTurnedOff) {
  const fs::path ui = dir_ / "ui";
  fs::create_directories(ui / "src");
  std::ofstream(ui / "index.html") << "<!doctype html><title>dev</title>";
  std::ofstream(ui / "src" / "main.js") << "export const x = 1;\n";
  start([&](Config& c) { c.ui_dir = ui.string(); });
  EXPECT_EQ(get_anonymous("/ui/").body, "<!doctype html><title>dev</title>");
  EXPECT_EQ(get_anonymous("/ui/src/main.js").body, "export const x = 1;\n");
  expect_error(get_anonymous("/ui/src/other.js"), 404, "not_found");
  service_.reset();
  start([](Config& c) { c.ui = false; });
  for (const char* path : {"/", "/ui", "/ui/", "/ui/src/main.js"}) {
    SCOPED_TRACE(path);
    expect_error(get_anonymous(path), 404, "not_found");
  }
}

// No Access-Control-* header unless origins are configured; then only for those origins.
TEST_F(ServiceViewer, CorsIsOffByDefaultAndOnlyForConfiguredOrigins) {
  start();
  const std::map<std::string, std::string> from_other = {
      {"origin", "https://hazx.example.org"}, {"authorization", std::string("Bearer ") + kToken}};
  Response r = call("GET", "/v1/jobs", {}, {}, from_other);
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(header(r, "Access-Control-Allow-Origin"), std::nullopt);
  std::map<std::string, std::string> preflight = {{"origin", "https://hazx.example.org"},
                                                  {"access-control-request-method", "POST"}};
  expect_error(call("OPTIONS", "/v1/jobs", {}, {}, preflight, false), 405, "method_not_allowed");

  service_.reset();
  start([](Config& c) { c.cors_origins = {"https://hazx.example.org"}; });
  r = call("GET", "/v1/jobs", {}, {}, from_other);
  EXPECT_EQ(header(r, "Access-Control-Allow-Origin"), "https://hazx.example.org");
  EXPECT_EQ(header(r, "Vary"), "Origin");
  EXPECT_EQ(header(r, "Access-Control-Expose-Headers"), "Location, Content-Disposition");
  // A 401 carries the header too, so that the page can read why.
  r = call("GET", "/v1/jobs", {}, {}, {{"origin", "https://hazx.example.org"}}, false);
  EXPECT_EQ(r.status, 401);
  EXPECT_EQ(header(r, "Access-Control-Allow-Origin"), "https://hazx.example.org");
  const Response ok = call("OPTIONS", "/v1/jobs", {}, {}, preflight, false);
  EXPECT_EQ(ok.status, 204);
  EXPECT_EQ(header(ok, "Access-Control-Allow-Origin"), "https://hazx.example.org");
  EXPECT_EQ(header(ok, "Access-Control-Allow-Headers"), "Authorization, Content-Type");
  EXPECT_EQ(header(ok, "Access-Control-Allow-Methods"), "GET, POST, DELETE");
  // Another origin: no grant (the browser then refuses), and its preflight is not answered.
  r = call(
      "GET", "/v1/jobs", {}, {},
      {{"origin", "https://evil.example"}, {"authorization", std::string("Bearer ") + kToken}});
  EXPECT_EQ(header(r, "Access-Control-Allow-Origin"), std::nullopt);
  EXPECT_EQ(header(r, "Vary"), "Origin");
  preflight["origin"] = "https://evil.example";
  expect_error(call("OPTIONS", "/v1/jobs", {}, {}, preflight, false), 405, "method_not_allowed");
}

// A scene an older daemon cached (sites/<id>.scene.bin: no terrain materials) is not served: the
// current version is built beside it, and both go with the site.
TEST_F(ServiceViewer, AnOlderDaemonsCachedSceneIsNotServed) {
  start();
  const std::string site = add_site();
  const fs::path dir = fs::path(config().data_dir) / "sites";
  const fs::path old_scene = dir / (site + ".scene.bin");
  { std::ofstream(old_scene) << "FSSCENE1 an older daemon's scene"; }
  const Response r = get("/v1/sites/" + site + "/scene");
  ASSERT_EQ(r.status, 200) << r.body;
  ASSERT_TRUE(r.file.has_value());
  EXPECT_EQ(fs::weakly_canonical(*r.file), fs::weakly_canonical(dir / (site + ".scene.v2.bin")));
  EXPECT_NE(api::testing::read_text(*r.file).find("material_names"), std::string::npos);
  EXPECT_EQ(del("/v1/sites/" + site).status, 204);
  EXPECT_FALSE(fs::exists(old_scene));
  EXPECT_FALSE(fs::exists(dir / (site + ".scene.v2.bin")));
}

// The scene of a site and of a done job (the format itself: tests/formats/scene_binary_test.cpp).
TEST_F(ServiceViewer, ScenesOfSitesAndDoneJobs) {
  start();
  const std::string site = add_site();
  // Written once, then served as a file (server/scene_files.h).
  Response r = get("/v1/sites/" + site + "/scene");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.content_type, "application/vnd.fragsim.scene");
  ASSERT_TRUE(r.file.has_value());
  const fs::path site_scene = fs::path(config().data_dir) / "sites" / (site + ".scene.v2.bin");
  EXPECT_EQ(fs::weakly_canonical(*r.file), fs::weakly_canonical(site_scene));
  const std::string site_bytes = api::testing::read_text(site_scene);
  EXPECT_EQ(site_bytes.substr(0, 8), "FSSCENE1");
  EXPECT_EQ(get("/v1/sites/" + site + "/scene").file, r.file);
  expect_error(get("/v1/sites/" + std::string(kUnknownSite) + "/scene"), 404, "not_found");
  expect_error(get_anonymous("/v1/sites/" + site + "/scene"), 401, "unauthorized");

  Json scenario = job_on(site, 200);
  scenario["settings"]["record_trajectories"] = true;
  const std::string id = add_job(scenario);
  ASSERT_EQ(wait_for_state(id, "done")["state"], "done");
  // The default sample is stored beside results.h5; another is built for the request.
  r = get("/v1/jobs/" + id + "/scene");
  ASSERT_EQ(r.status, 200) << r.body;
  ASSERT_TRUE(r.file.has_value());
  const fs::path job_scene = fs::path(config().data_dir) / "jobs" / id / "scene.v2.bin";
  EXPECT_EQ(fs::weakly_canonical(*r.file), fs::weakly_canonical(job_scene));
  EXPECT_NE(api::testing::read_text(job_scene).find("\"sent\":200"), std::string::npos);
  r = get("/v1/jobs/" + id + "/scene", {{"max_trajectories", "5"}});
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_FALSE(r.file.has_value());
  std::uint32_t h = 0;
  std::memcpy(&h, r.body.data() + 8, 4);
  const Json head = Json::parse(r.body.substr(12, h));
  EXPECT_EQ(head["arrays"]["density_per_m2"]["shape"], Json({3200}));
  EXPECT_EQ(head["trajectories"]["sent"], 5);
  EXPECT_GT(head["trajectories"]["recorded"].get<int>(), 5);
  EXPECT_EQ(head["building_ids"], Json({"B1"}));
  for (const char* bad : {"-1", "10001", "x", "", "1e3", "99999999999999999999"}) {
    SCOPED_TRACE(bad);
    expect_error(get("/v1/jobs/" + id + "/scene", {{"max_trajectories", bad}}), 400,
                 "bad_parameter", "max_trajectories");
  }
  expect_error(get("/v1/jobs/" + id + "/scene", {{"trajectories", "1"}}), 400, "bad_parameter",
               "trajectories");
  expect_error(get("/v1/jobs/" + std::string(kUnknownJob) + "/scene"), 404, "not_found");
  const std::string busy = add_job(blocker_job(site));
  expect_error(get("/v1/jobs/" + busy + "/scene"), 409, "not_ready");
  EXPECT_EQ(del("/v1/jobs/" + busy).status, 200);
  // A deleted site takes its scene file along; the job's stays with its results.
  wait_for_state(busy, "cancelled");
  EXPECT_EQ(del("/v1/sites/" + site).status, 204);
  EXPECT_FALSE(fs::exists(site_scene));
  EXPECT_EQ(get("/v1/jobs/" + id + "/scene").status, 200);
}

// ---- Disk space (server/disk_guard.h, docs/operations.md) ----

// Without a small file system: a guard set above any disk's size refuses new work with 507.
TEST_F(ServiceTest, AGuardAboveTheDiskRefusesNewJobsAndSitesWith507) {
  start();
  const std::string site = add_site();
  const std::string done = add_job(job_on(site, 100));
  ASSERT_EQ(wait_for_state(done, "done")["state"], "done");
  service_.reset();
  start([](Config& c) { c.min_free_bytes = std::int64_t{1} << 62; });

  const Json h = body_of(get("/v1/health"));
  EXPECT_TRUE(h["storage"]["short"].get<bool>()) << h;
  EXPECT_EQ(h["storage"]["min_free_bytes"], std::int64_t{1} << 62);
  EXPECT_GT(h["storage"]["free_bytes"].get<std::int64_t>(), 0);
  const std::string m = metrics_text();
  EXPECT_NE(m.find("\nfragsimd_data_free_bytes "), std::string::npos) << m;
  EXPECT_NE(m.find("\nfragsimd_data_min_free_bytes 4611686018427387904\n"), std::string::npos);
  const Response r = post("/v1/jobs", job_on(site, 100));
  expect_error(r, 507, "storage_full");
  EXPECT_NE(body_of(r)["message"].get<std::string>().find("--min-free-bytes"), std::string::npos);
  Json other = minimal_site();
  other["origin"] = {{"crs", "local"}, {"easting_m", 10.0}, {"northing_m", 0.0}};
  expect_error(post("/v1/sites", other), 507, "storage_full");
  EXPECT_EQ(post("/v1/sites", minimal_site()).status, 200);  // known: nothing to write
  // What exists is still served, and a job that cannot be retried says so first.
  EXPECT_EQ(get("/v1/jobs/" + done + "/summary").status, 200);
  expect_error(post_text("/v1/jobs/" + done + "/retry", ""), 409, "conflict");
  expect_error(post_text("/v1/jobs/" + std::string(kUnknownJob) + "/retry", ""), 404, "not_found");
  EXPECT_EQ(body_of(get("/v1/jobs"))["jobs"].size(), 1u);
}

// On a tmpfs of its own (tests/small_disk.h; skipped where it cannot be mounted).
class ServiceDisk : public ServiceTest {
 protected:
  void SetUp() override {
    ServiceTest::SetUp();
    std::string why;
    disk_ = fragsim::testing::SmallDisk::make(dir_ / "data", 32 << 20, &why);
    if (!disk_) GTEST_SKIP() << "no small file system here: " << why;
  }
  void TearDown() override {
    service_.reset();
    disk_.reset();
    ServiceTest::TearDown();
  }
  std::unique_ptr<fragsim::testing::SmallDisk> disk_;
};

TEST_F(ServiceDisk, AShortDiskRefusesNewWorkAndHoldsQueuedJobsUntilSpaceIsFreed) {
  start([](Config& c) { c.min_free_bytes = 8 << 20; });
  const std::string site = add_site();
  const std::string earlier = add_job(job_on(site, 100));
  ASSERT_EQ(wait_for_state(earlier, "done")["state"], "done");
  const std::string blocker = running_blocker(site);
  const std::string queued = add_job(queued_behind(site));

  disk_->fill_leaving(4 << 20);
  EXPECT_TRUE(body_of(get("/v1/health"))["storage"]["short"].get<bool>());
  expect_error(post("/v1/jobs", job_on(site, 100)), 507, "storage_full");
  // The running job's cancel goes through; the queued one waits instead of starting.
  ASSERT_EQ(del("/v1/jobs/" + blocker).status, 200);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // the worker checks each second
  EXPECT_EQ(job(queued)["state"], "queued");
  EXPECT_EQ(get("/v1/jobs/" + earlier + "/results.h5").status, 200);

  disk_->free_filler();
  EXPECT_FALSE(body_of(get("/v1/health"))["storage"]["short"].get<bool>());
  EXPECT_EQ(wait_for_state(queued, "done")["state"], "done");
  EXPECT_EQ(add_job(job_on(site, 100)).size(), 18u);
}

// A job whose results meet a full disk fails as storage_full, naming the file and the bytes,
// leaves nothing behind, and is done when retried after space was freed; earlier results stay.
TEST_F(ServiceDisk, AJobThatMeetsAFullDiskFailsAsStorageFullAndIsDoneWhenRetried) {
  start([](Config& c) { c.min_free_bytes = 0; });  // no guard: the job runs into the wall
  const std::string site = add_site();
  const std::string earlier = add_job(job_on(site, 400));
  ASSERT_EQ(wait_for_state(earlier, "done")["state"], "done");
  const fs::path jobs = dir_ / "data" / "jobs";
  const std::string earlier_h5 = api::testing::read_text(jobs / earlier / "results.h5");
  const auto bytes = static_cast<std::int64_t>(tree_bytes(jobs / earlier));

  disk_->fill_leaving(bytes / 3);
  Json body = job_on(site, 400);
  body["settings"]["seed"] = 99;
  const std::string id = add_job(body);
  const Json failed = wait_for_state(id, "failed");
  ASSERT_EQ(failed["state"], "failed") << failed;
  EXPECT_EQ(failed["error"]["code"], "storage_full") << failed;
  const std::string message = failed["error"]["message"].get<std::string>();
  EXPECT_NE(message.find("No space left on device writing " + (jobs / id).string() + "/"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find(" bytes needed)"), std::string::npos) << message;
  EXPECT_TRUE(!fs::exists(jobs / id) || fs::is_empty(jobs / id));
  expect_error(get("/v1/jobs/" + id + "/summary"), 409, "not_ready");
  EXPECT_EQ(api::testing::read_text(jobs / earlier / "results.h5"), earlier_h5);

  disk_->free_filler();
  const Response r = post_text("/v1/jobs/" + id + "/retry", "");
  ASSERT_EQ(r.status, 202) << r.body;
  EXPECT_EQ(header(r, "Location"), "/v1/jobs/" + id);
  EXPECT_TRUE(body_of(r)["error"].is_null()) << r.body;
  const Json done = wait_for_state(id, "done");
  ASSERT_EQ(done["state"], "done") << done;
  EXPECT_EQ(done["histories_done"], 400);
  EXPECT_EQ(get("/v1/jobs/" + id + "/summary").status, 200);
  expect_error(post_text("/v1/jobs/" + id + "/retry", ""), 409, "conflict");
}

// ---- Roles (docs/operations.md, "Roles") ----

class ServiceRoles : public ServiceTest {
 protected:
  void SetUp() override {
    ServiceTest::SetUp();
    std::ofstream(dir_ / "tokens") << "# one token per role, and one from before roles\n"
                                   << "reader-token read\n"
                                   << "submitter-token submit\n"
                                   << "other-submitter\tsubmit\n"
                                   << "operator-token admin\n"
                                   << "old-token\n"
                                   << kToken << "\n";  // the fixture's own (admin)
  }
  Response as(const std::string& token, const std::string& method, const std::string& path,
              std::map<std::string, std::string> query = {}, const std::string& body = {}) {
    std::map<std::string, std::string> headers{{"authorization", "Bearer " + token}};
    if (method == "POST") headers["content-type"] = "application/json";
    return call(method, path, std::move(query), body, std::move(headers));
  }
  std::string job_as(const std::string& token, const Json& body) {
    const Response r = as(token, "POST", "/v1/jobs", {}, body.dump());
    EXPECT_EQ(r.status, 202) << r.body;
    return body_of(r).value("job_id", "");
  }
};

// Every route for every role: allowed -> its answer (2xx, or the 409 of a job in the wrong state:
// past the role check); refused -> 403 `forbidden` naming the role and what is needed. A token
// without a role is admin, as every token was before roles.
TEST_F(ServiceRoles, EveryRouteForEveryRole) {
  start();
  const std::string admin = "operator-token";
  const std::string site =
      body_of(as(admin, "POST", "/v1/sites", {}, minimal_site().dump()))["site_id"];
  const std::string done = job_as("submitter-token", job_on(site, 200));
  ASSERT_EQ(wait_for_state(done, "done")["state"], "done");
  Json variant = job_on(site, 200);
  variant["compare_with"] = done;
  const std::string compared = job_as("submitter-token", variant);
  ASSERT_EQ(wait_for_state(compared, "done")["state"], "done");
  const std::string blocker = job_as(admin, blocker_job(site));
  ASSERT_EQ(wait_for_state(blocker, "running")["state"], "running");
  const std::string map_name = body_of(get("/v1/jobs/" + done + "/maps"))["files"][0]["name"];

  // Per attempt, a fresh object where the request consumes one.
  const auto queued_job = [&] {
    return "/v1/jobs/" + job_as("submitter-token", queued_behind(site));
  };
  const auto finished_job = [&] {
    const std::string id = job_as(admin, queued_behind(site));
    EXPECT_EQ(as(admin, "DELETE", "/v1/jobs/" + id).status, 200);
    return "/v1/jobs/" + id;
  };
  int fresh_sites = 0;
  const auto unused_site = [&] {
    Json moved = minimal_site();
    moved["origin"] = {
        {"crs", "local"}, {"easting_m", 1000.0 * ++fresh_sites}, {"northing_m", 0.0}};
    return "/v1/sites/" +
           body_of(as(admin, "POST", "/v1/sites", {}, moved.dump())).value("site_id", "");
  };
  const auto fixed = [](std::string p) { return [p] { return p; }; };
  const std::string j = "/v1/jobs/" + done, c = "/v1/jobs/" + compared;
  struct Row {
    std::string method;
    std::function<std::string()> path;
    std::map<std::string, std::string> query;
    std::string body;
    Role needs;
    std::set<int> allowed;  // the answers past the role check
  };
  const std::vector<Row> rows = {
      {"GET", fixed("/metrics"), {}, "", Role::kRead, {200}},
      {"GET", fixed("/v1/whoami"), {}, "", Role::kRead, {200}},
      {"GET", fixed("/v1/sites"), {}, "", Role::kRead, {200}},
      {"POST", fixed("/v1/sites"), {}, minimal_site().dump(), Role::kSubmit, {200}},
      {"GET", fixed("/v1/sites/" + site), {}, "", Role::kRead, {200}},
      {"GET", fixed("/v1/sites/" + site + "/scene"), {}, "", Role::kRead, {200}},
      {"DELETE", unused_site, {}, "", Role::kAdmin, {204}},
      {"GET", fixed("/v1/jobs"), {}, "", Role::kRead, {200}},
      {"POST", fixed("/v1/jobs"), {}, queued_behind(site).dump(), Role::kSubmit, {202}},
      {"GET", fixed(j), {}, "", Role::kRead, {200}},
      {"DELETE", queued_job, {}, "", Role::kSubmit, {200}},
      {"DELETE", finished_job, {{"purge", "true"}}, "", Role::kAdmin, {200}},
      {"POST", [&] { return j + "/retry"; }, {}, "", Role::kSubmit, {409}},  // done: not failed
      {"GET", fixed(j + "/summary"), {}, "", Role::kRead, {200}},
      {"GET", fixed(j + "/buildings"), {}, "", Role::kRead, {200}},
      {"GET", fixed(j + "/ptn"), {}, "", Role::kRead, {200}},
      {"GET", fixed(j + "/results.h5"), {}, "", Role::kRead, {200}},
      {"GET", fixed(j + "/maps"), {}, "", Role::kRead, {200}},
      {"GET", fixed(j + "/maps/" + map_name), {}, "", Role::kRead, {200}},
      {"GET", fixed(j + "/report.html"), {}, "", Role::kRead, {200}},
      {"GET", fixed(j + "/report.pdf"), {}, "", Role::kRead, {200, 503}},  // 503: no chromium
      {"GET", fixed(j + "/scene"), {}, "", Role::kRead, {200}},
      {"GET", fixed(j + "/plan_boundary"), {}, "", Role::kRead, {200, 409}},  // 409: no CRS
      {"GET", fixed(c + "/compare"), {}, "", Role::kRead, {200}},
      {"GET", fixed(c + "/compare.h5"), {}, "", Role::kRead, {200}},
  };
  // Every authenticated route and method of the service is in the table (DELETE /v1/jobs/{id}
  // twice: cancel and purge).
  std::size_t authenticated = 0;
  for (const RouteInfo& r : route_table())
    if (!r.public_route) authenticated += r.methods.size();
  EXPECT_EQ(rows.size(), authenticated + 1);

  const std::vector<std::pair<std::string, Role>> tokens = {{"reader-token", Role::kRead},
                                                            {"submitter-token", Role::kSubmit},
                                                            {admin, Role::kAdmin},
                                                            {"old-token", Role::kAdmin}};
  for (const Row& row : rows) {
    for (const auto& [token, role] : tokens) {
      const std::string path = row.path();
      SCOPED_TRACE(row.method + " " + path + " as " + role_name(role) + " (" + token + ")");
      const Response r = as(token, row.method, path, row.query, row.body);
      if (role >= row.needs) {
        EXPECT_TRUE(row.allowed.count(r.status)) << r.status << " " << r.body;
      } else {
        expect_error(r, 403, "forbidden");
        const std::string m = body_of(r)["message"];
        EXPECT_NE(m.find(std::string("role (") + role_name(role) + ")"), std::string::npos) << m;
        EXPECT_NE(m.find(std::string("needs ") + role_name(row.needs)), std::string::npos) << m;
      }
    }
  }
  // Nothing a refused request asked for happened: the done job and the site are still there.
  EXPECT_EQ(job(done)["state"], "done");
  EXPECT_EQ(get("/v1/sites/" + site).status, 200);
  EXPECT_EQ(as(admin, "DELETE", "/v1/jobs/" + blocker).status, 200);
}

// A submit token cancels and retries only the jobs it submitted; admin any. Who asked is what
// /v1/whoami says.
TEST_F(ServiceRoles, ASubmitTokenActsOnItsOwnJobsOnly) {
  start();
  const std::string site = add_site();
  const std::string blocker = job_as("submitter-token", blocker_job(site));
  ASSERT_EQ(wait_for_state(blocker, "running")["state"], "running");
  const std::string mine = job_as("submitter-token", queued_behind(site));
  const std::string theirs = job_as("other-submitter", queued_behind(site));

  const Response refused = as("submitter-token", "DELETE", "/v1/jobs/" + theirs);
  expect_error(refused, 403, "forbidden");
  EXPECT_NE(body_of(refused)["message"].get<std::string>().find("another token"),
            std::string::npos);
  expect_error(as("submitter-token", "POST", "/v1/jobs/" + theirs + "/retry"), 403, "forbidden");
  EXPECT_EQ(job(theirs)["state"], "queued");
  EXPECT_EQ(as("submitter-token", "DELETE", "/v1/jobs/" + mine).status, 200);
  EXPECT_EQ(as("operator-token", "DELETE", "/v1/jobs/" + theirs).status, 200);  // admin: any
  EXPECT_EQ(as("old-token", "DELETE", "/v1/jobs/" + blocker).status, 200);
  // Unknown jobs are 404 for every role that may act, as before.
  expect_error(as("submitter-token", "DELETE", std::string("/v1/jobs/") + kUnknownJob), 404,
               "not_found");

  const Json me = body_of(as("submitter-token", "GET", "/v1/whoami"));
  EXPECT_EQ(me["role"], "submit");
  EXPECT_EQ(me["owner"], job(mine)["owner"]);
  EXPECT_TRUE(me["auth"].get<bool>());
  EXPECT_EQ(body_of(as("reader-token", "GET", "/v1/whoami"))["role"], "read");
  EXPECT_EQ(body_of(as("old-token", "GET", "/v1/whoami"))["role"], "admin");
  expect_error(as("nobody", "GET", "/v1/whoami"), 401, "unauthorized");
}

// ---- Upgrades (docs/operations.md, "Upgrades") ----

// Data directories written by real older builds of fragsimd (tests/server/data/<name>/README.txt
// says how each was made): this daemon opens each, upgrades its store, serves every done job's
// files byte for byte and its figures and scene from them, and runs what was left queued.
class ServiceUpgrade : public ServiceTest, public ::testing::WithParamInterface<const char*> {};

TEST_P(ServiceUpgrade, AnOlderDataDirectoryOpensAndServesItsResults) {
  const fs::path fixture = fs::path(FRAGSIM_SOURCE_DIR) / "tests/server/data" / GetParam();
  ASSERT_TRUE(fs::is_directory(fixture)) << fixture;
  const fs::path data = dir_ / "data";
  fs::copy(fixture, data, fs::copy_options::recursive);
  EXPECT_EQ(testing::meta_schema_version(data / "fragsimd.sqlite"), "1");
  start();
  EXPECT_EQ(testing::meta_schema_version(data / "fragsimd.sqlite"),
            std::to_string(kStoreSchemaVersion));
  const Json jobs = body_of(get("/v1/jobs"))["jobs"];
  ASSERT_FALSE(jobs.empty());
  int done = 0, rerun = 0;
  for (const Json& j : jobs) {
    const std::string id = j["job_id"];
    SCOPED_TRACE(id + " " + j["state"].get<std::string>());
    if (j["state"] == "done") {
      ++done;
      for (const char* file : {"results.h5", "summary.json"}) {
        const Response r = get("/v1/jobs/" + id + (file[0] == 'r' ? "/results.h5" : "/summary"));
        ASSERT_EQ(r.status, 200) << r.body;
        ASSERT_TRUE(r.file.has_value());
        EXPECT_EQ(api::testing::read_text(*r.file),
                  api::testing::read_text(fixture / "jobs" / id / file));
      }
      for (const char* part : {"/buildings", "/ptn", "/scene"})
        EXPECT_EQ(get("/v1/jobs/" + id + part).status, 200) << part;
      // The study report needs what earlier results lack: made, or refused saying why.
      const Response report = get("/v1/jobs/" + id + "/report.html");
      if (report.status != 200) {
        expect_error(report, 409, "report_unavailable");
        std::cout << GetParam() << " report.html: " << body_of(report)["message"] << "\n";
      }
    } else if (j["state"] == "queued" || j["state"] == "running") {
      ++rerun;
      EXPECT_EQ(wait_for_state(id, "done")["state"], "done");
    }
  }
  EXPECT_GE(done, 1);
  // The store now works as any: a new job on the fixture's site.
  const Json sites = body_of(get("/v1/sites"))["sites"];
  ASSERT_FALSE(sites.empty());
  const std::string id = add_job(job_on(sites[0]["site_id"], 100));
  EXPECT_EQ(wait_for_state(id, "done")["state"], "done");
  std::cout << GetParam() << ": " << jobs.size() << " jobs, " << done << " done, " << rerun
            << " run again\n";
}

INSTANTIATE_TEST_SUITE_P(Fixtures, ServiceUpgrade, ::testing::Values("store-v1", "store-v2"));

}  // namespace
}  // namespace fragsim::server
