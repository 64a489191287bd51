// libFuzzer target: fragsimd's request handler (Service::handle) without sockets.
//
// Input: an HTTP-like text (fuzz/corpus/fuzz_service has examples)
//   METHOD PATH[?k=v&k2=v2]
//   header-name: value
//   ...
//   <empty line>
//   body
// "{site}" and "{job}" in the path, query and body stand for a stored site and a finished job,
// so that the routes serving results have something to serve. Without an Authorization header
// the request carries a valid token.
//
// Every answer must be a 2xx-4xx whose JSON body parses (errors with code and message); a 500
// is an internal error, i.e. a finding. The scheduler is stopped after start: queued jobs never
// run, and the data directory is restored from a snapshot every kRequestsPerReset inputs so that
// the queue and site limits are not reached for good and the disk does not fill.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <thread>

#include "fuzz/fuzz_support.h"
#include "server/log.h"
#include "server/service.h"

namespace {

namespace fs = std::filesystem;
using fragsim::server::Request;
using fragsim::server::Response;
using fragsim::server::Service;

constexpr int kRequestsPerReset = 500;
constexpr const char* kToken = "fuzz-token-0123456789";

// The site of examples/minimal as it was before it grew to a 3 km plane (a 400 m plane of 10 m
// cells), and a job of 40 histories on it.
constexpr const char* kSite = R"({
  "origin": {"crs": "local", "easting_m": 0, "northing_m": 0, "elevation_m": 0},
  "terrain": {"plane": {"elevation_m": 0, "extent_m": [-200, -200, 200, 200], "cell_m": 10},
              "material": "soil"},
  "materials": {
    "soil": {"friction": 0.9, "restitution": 0.2},
    "wall": {"friction": 0.5, "restitution": 0.3, "penetration": {"ke_per_area_j_per_m2": 2.0e6}}
  },
  "buildings": [{"id": "B1", "footprint_m": [[60, -10], [80, -10], [80, 10], [60, 10]],
                 "height_m": 6, "wall": "wall", "roof": "wall"}]
})";

std::string job_body(const std::string& site_id) {
  return R"({"schema": "fragsim.scenario/1", "site_id": ")" + site_id + R"(",
  "fragment_groups": [{"name": "g", "count": 100, "samples": 40,
    "frame": {"origin_m": [0, 0, 1]}, "shape": {"type": "sphere", "density_kg_m3": 7850},
    "mass_kg": 0.05, "speed_mps": 200, "direction": {"elevation_deg": [0, 45],
    "azimuth_deg": [-30, 30]}, "cd": 0.47}],
  "settings": {"seed": 7, "threads": 1, "record_fragments": true, "bounce": true}})";
}

class Fixture {
 public:
  Fixture() {
    std::string tmpl = (fs::temp_directory_path() / "fragsim-fuzz-service-XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) fragsim::fuzz::fail("mkdtemp " + tmpl);
    base_ = tmpl;
    std::ofstream(base_ / "tokens") << kToken << "\n";
    fragsim::server::set_log_level(fragsim::server::LogLevel::kError);
    make_pristine();
  }
  ~Fixture() {
    service_.reset();
    std::error_code ec;
    fs::remove_all(base_, ec);
  }

  Service& service() {
    if (!service_ || ++uses_ > kRequestsPerReset) reset();
    return *service_;
  }
  const std::string& site_id() const { return site_id_; }
  const std::string& job_id() const { return job_id_; }

 private:
  fragsim::server::Config config(const fs::path& data) const {
    fragsim::server::Config c;
    c.data_dir = data.string();
    c.token_file = (base_ / "tokens").string();
    c.threads = 1;
    c.job_nice = 0;
    c.max_sites = 8;
    // Larger than the other targets' kMaxFuzzTerrainTriangles (2^16, fuzz_support.h): the
    // service builds sites but its scheduler runs no histories.
    c.max_terrain_triangles = 1 << 18;
    c.max_queued_jobs = 16;
    c.min_free_bytes = 0;  // the fuzzed requests, not the CI disk's free space, decide the answers
    c.max_body_bytes = 1 << 20;
    c.max_samples_per_job = 1'000'000;
    return c;
  }

  // A data directory holding one site and one finished job, made once with a running scheduler.
  void make_pristine() {
    Service s(config(base_ / "pristine"));
    Request site{"POST", "/v1/sites", {}, headers(), kSite};
    const Response r = s.handle(site);
    if (r.status != 201) fragsim::fuzz::fail("site not stored: " + r.body);
    site_id_ = nlohmann::json::parse(r.body).at("site_id").get<std::string>();
    Request job{"POST", "/v1/jobs", {}, headers(), job_body(site_id_)};
    const Response j = s.handle(job);
    if (j.status != 202) fragsim::fuzz::fail("job not queued: " + j.body);
    job_id_ = nlohmann::json::parse(j.body).at("job_id").get<std::string>();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(2);
    while (true) {
      const Response st = s.handle({"GET", "/v1/jobs/" + job_id_, {}, headers(), ""});
      const std::string state = nlohmann::json::parse(st.body).at("state").get<std::string>();
      if (state == "done") break;
      if (state != "queued" && state != "running") fragsim::fuzz::fail("job ended " + st.body);
      if (std::chrono::steady_clock::now() > deadline) fragsim::fuzz::fail("job takes too long");
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }

  void reset() {
    service_.reset();
    const fs::path live = base_ / "live";
    copy_without_alarms(base_ / "pristine", live);
    service_ = std::make_unique<Service>(config(live));
    service_->shutdown();  // no job runs: an input costs one request, not a Monte Carlo run
    uses_ = 1;
  }

  // libFuzzer's -max_total_time/-timeout checks come as SIGALRM, installed without SA_RESTART;
  // libstdc++'s fs::copy does not retry a sendfile/copy_file_range interrupted by one (EINTR
  // became a "cannot copy: Interrupted system call" abort in CI). The signal is held, not lost.
  static void copy_without_alarms(const fs::path& from, const fs::path& to) {
    sigset_t alarm, previous;
    sigemptyset(&alarm);
    sigaddset(&alarm, SIGALRM);
    pthread_sigmask(SIG_BLOCK, &alarm, &previous);
    std::error_code ec;
    fs::remove_all(to, ec);
    if (!ec) fs::copy(from, to, fs::copy_options::recursive, ec);
    pthread_sigmask(SIG_SETMASK, &previous, nullptr);
    if (ec) fragsim::fuzz::fail("cannot restore " + to.string() + ": " + ec.message());
  }

  static std::map<std::string, std::string> headers() {
    return {{"authorization", std::string("Bearer ") + kToken},
            {"content-type", "application/json"}};
  }

  fs::path base_;
  std::string site_id_;
  std::string job_id_;
  std::unique_ptr<Service> service_;
  int uses_ = 0;
};

// On the heap and deleted at exit (atexit), so that the data directory goes before the
// sanitizers' exit-time checks run; a static would be destroyed in no particular order.
Fixture* g_fixture = nullptr;

Fixture& fixture() {
  if (g_fixture == nullptr) g_fixture = new Fixture;
  return *g_fixture;
}

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
}

void substitute(std::string& s) {
  replace_all(s, "{site}", fixture().site_id());
  replace_all(s, "{job}", fixture().job_id());
}

// Cuts the next line off `rest` (without its "\n" or "\r\n").
std::string next_line(std::string_view& rest) {
  const std::size_t end = rest.find('\n');
  std::string_view line = rest.substr(0, end);
  rest.remove_prefix(end == std::string_view::npos ? rest.size() : end + 1);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return std::string(line);
}

Request parse_request(std::string_view text) {
  Request req;
  std::string first = next_line(text);
  const std::size_t space = first.find(' ');
  req.method = first.substr(0, space);
  std::string target = space == std::string::npos ? "" : first.substr(space + 1);
  const std::size_t question = target.find('?');
  req.path = target.substr(0, question);
  substitute(req.path);
  if (question != std::string::npos) {
    std::string_view query = std::string_view(target).substr(question + 1);
    while (!query.empty()) {
      const std::size_t amp = query.find('&');
      const std::string_view pair = query.substr(0, amp);
      query.remove_prefix(amp == std::string_view::npos ? query.size() : amp + 1);
      const std::size_t eq = pair.find('=');
      std::string value = eq == std::string_view::npos ? "" : std::string(pair.substr(eq + 1));
      substitute(value);
      req.query[std::string(pair.substr(0, eq))] = value;
    }
  }
  for (std::string line = next_line(text); !line.empty(); line = next_line(text)) {
    const std::size_t colon = line.find(':');
    std::size_t value_at = colon == std::string::npos ? line.size() : colon + 1;
    while (value_at < line.size() && line[value_at] == ' ') ++value_at;
    req.headers[fragsim::server::ascii_lower(line.substr(0, colon))] = line.substr(value_at);
  }
  req.headers.emplace("authorization", std::string("Bearer ") + kToken);
  req.body = std::string(text);
  substitute(req.body);
  return req;
}

void check_response(const Request& req, Response& r) {
  const std::string what = req.method + " " + req.path + " -> " + std::to_string(r.status) + " ";
  if (r.status < 200 || r.status >= 500) fragsim::fuzz::fail(what + r.body);
  if (r.stream) {
    std::string piece;
    std::size_t total = 0;
    for (bool more = true; more && total < (64u << 20); total += piece.size()) {
      piece.clear();
      more = r.stream(piece);
    }
  }
  if (r.content_type != "application/json" || r.body.empty()) return;
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(r.body);  // throws on invalid UTF-8 too
  } catch (const nlohmann::json::exception& e) {
    fragsim::fuzz::fail(what + "body is not JSON (" + e.what() + "): " + r.body);
  }
  if (r.status >= 400 && !(j.contains("code") && j.contains("message")))
    fragsim::fuzz::fail(what + "error body without code and message: " + r.body);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fixture();  // the pristine data directory, made before the first input is timed
  std::atexit([] {
    delete g_fixture;
    g_fixture = nullptr;
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const Request req = parse_request(fragsim::fuzz::as_text(data, size));
  Response r = fixture().service().handle(req);
  // FRAGSIM_FUZZ_VERBOSE=1: one line per request, to see what a corpus reaches.
  static const bool verbose = std::getenv("FRAGSIM_FUZZ_VERBOSE") != nullptr;
  if (verbose)
    std::fprintf(stderr, "%s %s -> %d %.200s\n", req.method.c_str(), req.path.c_str(), r.status,
                 r.body.c_str());
  check_response(req, r);
  return 0;
}
