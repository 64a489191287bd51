// `fragsim submit`: the client side of fragsimd (docs/http-api.md). Uploads an inline site, submits
// the job by site_id, follows its progress, prints the summary and optionally downloads the files.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>
#include <utility>

#include "api/compare_json.h"
#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "api/summary_json.h"
#include "app/commands.h"
#include "core/common/error.h"
#include "formats/output_dir.h"

// After Eigen (through the api headers): httplib.h pulls in <resolv.h>, whose `_res` macro breaks
// Eigen's parameter names.
#include <httplib.h>

namespace fragsim::app {

namespace {

using Json = nlohmann::json;

// The first token in a token file (one per line; blank lines and # comments skipped).
std::string first_token(const std::string& path) {
  std::istringstream in(read_file(path, "--token-file"));
  std::string line;
  while (std::getline(in, line)) {
    const auto a = line.find_first_not_of(" \t\r");
    if (a == std::string::npos || line[a] == '#') continue;
    const auto b = line.find_last_not_of(" \t\r");
    return line.substr(a, b - a + 1);
  }
  throw InputError("--token-file", path + " holds no token");
}

// A failed request: the server's error body when it sent one.
class ServerError : public std::runtime_error {
 public:
  ServerError(int status, const std::string& message)
      : std::runtime_error(message), status_(status) {}
  int status() const { return status_; }

 private:
  int status_;
};

class Client {
 public:
  Client(const std::string& url, const std::string& token) : url_(url), http_(url) {
    if (!token.empty()) http_.set_bearer_token_auth(token);
    http_.set_connection_timeout(std::chrono::seconds(10));
    http_.set_read_timeout(std::chrono::seconds(600));
    http_.set_write_timeout(std::chrono::seconds(600));
  }

  // Returns (status, body); throws ServerError for a status >= 400 and for no answer.
  std::pair<int, std::string> request(const std::string& method, const std::string& path,
                                      const std::string& body = "") {
    httplib::Result res =
        method == "POST" ? http_.Post(path, body, "application/json") : http_.Get(path);
    if (!res)
      throw ServerError(0, "cannot reach " + url_ + " (" + httplib::to_string(res.error()) + ")");
    if (res->status >= 400) {
      std::string message = "HTTP " + std::to_string(res->status);
      try {
        const Json e = Json::parse(res->body);
        message += ' ';
        message += e.value("code", std::string());
        message += ": ";
        if (e.contains("field") && e["field"].is_string() && !e["field"].get<std::string>().empty())
          message += e["field"].get<std::string>() + ": ";
        message += e.value("message", std::string());
      } catch (const std::exception&) {
        message += ": " + res->body.substr(0, 200);
      }
      throw ServerError(res->status, method + " " + path + ": " + message);
    }
    return {res->status, res->body};
  }

 private:
  std::string url_;
  httplib::Client http_;
};

// The job's GIS maps (made by the server on this first request), each file as listed, into
// `dir`; the set appears at once (formats::OutputDir). Only plain file names from the listing.
void download_maps(Client& client, const std::string& job_id, const std::filesystem::path& dir) {
  const std::string base = "/v1/jobs/" + job_id + "/maps";
  const Json listing = Json::parse(client.request("GET", base).second);
  formats::OutputDir out(dir);
  for (const auto& f : listing.at("files")) {
    const std::string name = f.at("name").get<std::string>();
    if (name.empty() || name.find('/') != std::string::npos || name[0] == '.')
      throw ServerError(0, "GET " + base + ": unexpected file name \"" + name + "\"");
    out.stage_text(name, client.request("GET", base + "/" + name).second);
  }
  out.commit();
}

// "  batch 4: 7 of 9 targets met" from the job's live precision report (settings.precision).
std::string precision_line(const Json& p) {
  int met = 0, total = 0;
  for (const auto& t : p.value("targets", Json::array())) {
    ++total;
    met += t.value("met", false) ? 1 : 0;
  }
  return "  batch " + std::to_string(p.value("batches", 0LL)) + ": " + std::to_string(met) +
         " of " + std::to_string(total) + " targets met";
}

// A line on the job's state: "  running  42.0%  420 / 1000 histories  eta 3 s  batch ...".
std::string state_line(const Json& job, const std::string& state) {
  std::string line = "  " + state;
  if (state != "running") return line;
  char buf[160];
  std::snprintf(buf, sizeof buf, " %5.1f%%  %lld / %lld histories",
                100.0 * job.value("progress", 0.0),
                static_cast<long long>(job.value("histories_done", 0LL)),
                static_cast<long long>(job.value("histories_total", 0LL)));
  line += buf;
  if (job["eta_s"].is_number())
    line += "  eta " + std::to_string(static_cast<int>(job["eta_s"].get<double>() + 0.5)) + " s";
  if (const auto p = job.find("precision"); p != job.end() && p->is_object())
    line += precision_line(*p);
  return line;
}

// The daemon's warnings on a submitted job (fragment groups that can reach beyond the terrain,
// docs/http-api.md), printed as `fragsim run` prints them.
void print_warnings(const Json& reply) {
  const auto it = reply.find("warnings");
  if (it == reply.end() || !it->is_array()) return;
  for (const auto& w : *it)
    if (w.is_object())
      std::cerr << w.value("severity", std::string("warning")) << ": "
                << w.value("message", std::string()) << "\n";
}

// Uploads an inline site (POST /v1/sites) and names it by site_id in the scenario, then submits
// the job (POST /v1/jobs). Returns the job id and whether the server queued it anew (202).
std::pair<std::string, bool> submit_job(Client& client, Json scenario, const Options& o) {
  if (scenario.contains("site")) {
    const auto [status, body] = client.request("POST", "/v1/sites", scenario["site"].dump());
    const std::string site_id = Json::parse(body).at("site_id").get<std::string>();
    if (!o.quiet)
      std::cerr << (status == 201 ? "site uploaded: " : "site already on the server: ") << site_id
                << "\n";
    scenario.erase("site");
    scenario["site_id"] = site_id;
  }
  if (o.priority) scenario["priority"] = *o.priority;
  if (!o.idempotency_key.empty()) scenario["idempotency_key"] = o.idempotency_key;
  if (!o.compare_with.empty()) scenario["compare_with"] = o.compare_with;
  const auto [status, body] = client.request("POST", "/v1/jobs", scenario.dump());
  const Json reply = Json::parse(body);
  if (!o.quiet) print_warnings(reply);
  return {reply.at("job_id").get<std::string>(), status == 202};
}

// Follows the job until it ends, with a line when its state changes and about every 2 s while
// it runs. Returns its last JSON, or null when `cancel` stopped the following.
Json follow_job(Client& client, const std::string& job_id, const Options& o,
                const std::atomic<bool>& cancel) {
  std::string state;
  auto last_line = std::chrono::steady_clock::now() - std::chrono::hours(1);
  while (true) {
    Json job = Json::parse(client.request("GET", "/v1/jobs/" + job_id).second);
    const std::string now_state = job.at("state").get<std::string>();
    const auto now = std::chrono::steady_clock::now();
    if (!o.quiet && (now_state != state || now - last_line > std::chrono::seconds(2))) {
      std::cerr << state_line(job, now_state) << "\n";
      last_line = now;
    }
    state = now_state;
    if (state == "done" || state == "failed" || state == "cancelled") return job;
    if (cancel.load()) return nullptr;
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
}

// A done job's summary (printed unless quiet) and, with --out, its results (and --maps; with
// --compare-with, the comparison's files).
void fetch_results(Client& client, const std::string& job_id, const Options& o) {
  const std::string summary_text = client.request("GET", "/v1/jobs/" + job_id + "/summary").second;
  const std::string base = "/v1/jobs/" + job_id;
  const std::string compare =
      o.compare_with.empty() ? "" : client.request("GET", base + "/compare").second;
  const std::filesystem::path dir(o.out);
  if (!o.out.empty()) {
    const std::string h5 = client.request("GET", base + "/results.h5").second;
    formats::OutputDir out(o.out);
    out.stage_text(api::kSummaryFileName, summary_text);
    out.stage_text(api::kResultsFileName, h5);
    if (!compare.empty()) {
      out.stage_text(api::kCompareH5FileName, client.request("GET", base + "/compare.h5").second);
      out.stage_text(api::kCompareFileName, compare);
    }
    out.commit();
    if (o.maps) download_maps(client, job_id, dir / "maps");
  }
  if (o.quiet) return;
  std::cout << api::render_summary_text(nlohmann::ordered_json::parse(summary_text), o.units);
  if (!compare.empty())
    std::cout << "\n" << api::render_compare_text(nlohmann::ordered_json::parse(compare), o.units);
  if (!o.out.empty())
    std::cout << "\nWrote " << (dir / api::kSummaryFileName).string() << " and "
              << (dir / api::kResultsFileName).string()
              << (o.maps ? ", maps in " + (dir / "maps").string() : std::string()) << "\n";
}

}  // namespace

int submit_command(const Options& o, const std::atomic<bool>& cancel) {
  const std::string text = read_file(o.scenario);
  Json scenario = api::parse_json_text(text);
  // Check what can be checked here before anything is sent: a scenario with an inline site in
  // full; one naming a stored site (site_id) is checked by the server.
  if (!scenario.is_object() || !scenario.contains("site_id"))
    (void)api::validate_scenario(api::parse_scenario_document(scenario).scenario);
  const std::string token = o.token_file.empty() ? "" : first_token(o.token_file);
  Client client(o.server, token);
  try {
    const auto [job_id, queued] = submit_job(client, std::move(scenario), o);
    if (!o.wait) {
      std::cout << job_id << "\n";
      return kExitOk;
    }
    if (!o.quiet) std::cerr << "job " << (queued ? "queued: " : "known: ") << job_id << "\n";
    const Json job = follow_job(client, job_id, o, cancel);
    if (job.is_null()) {
      std::cerr << "stopped following; job " << job_id << " continues on the server\n";
      return kExitCancelled;
    }
    const std::string state = job.at("state").get<std::string>();
    if (state == "failed") {
      const Json& e = job["error"];
      std::cerr << "error: job " << job_id << " failed: "
                << (e.is_object() ? e.value("code", "") + ": " + e.value("message", "") : "")
                << "\n";
      return e.is_object() && e.value("code", "") == "invalid_input" ? kExitInvalidInput
                                                                     : kExitInternal;
    }
    if (state == "cancelled") {
      std::cerr << "job " << job_id << " was cancelled: no results\n";
      return kExitCancelled;
    }
    fetch_results(client, job_id, o);
    return kExitOk;
  } catch (const ServerError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return e.status() >= 400 && e.status() < 500 ? kExitInvalidInput : kExitInternal;
  }
}

}  // namespace fragsim::app
