#include "api/job_request.h"

#include <limits>

#include "api/json_fields.h"
#include "core/run/bracket.h"

namespace fragsim::api {

namespace {

bool idempotency_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == ':' || c == '-';
}

}  // namespace

JobRequest parse_job_request(const nlohmann::json& body, const SiteResolver& resolve) {
  if (!body.is_object())
    fail("", "expected a JSON object (a scenario) at the top level, got " + json_type_name(body));
  JobRequest req;
  req.scenario = body;
  if (const auto it = body.find("priority"); it != body.end()) {
    req.priority =
        static_cast<int>(read_integer(*it, "priority", kMinJobPriority, kMaxJobPriority));
    req.scenario.erase("priority");
  }
  if (const auto it = body.find("idempotency_key"); it != body.end()) {
    const std::string key = read_string(*it, "idempotency_key");
    if (key.empty() || key.size() > kMaxIdempotencyKeyLength)
      fail("idempotency_key", "must have 1 to " + std::to_string(kMaxIdempotencyKeyLength) +
                                  " characters (got " + std::to_string(key.size()) + ")");
    for (const char c : key)
      if (!idempotency_char(c))
        fail("idempotency_key", "may only contain letters, digits and . _ : -");
    req.idempotency_key = key;
    req.scenario.erase("idempotency_key");
  }
  StoredRequest stored = split_stored_request(req.scenario);
  req.compare_with = stored.compare_with;
  req.document = parse_scenario_document(stored.scenario, &resolve);
  for (const auto& g : req.document.scenario.groups) req.total_samples += g.samples;
  if (const auto& p = req.document.scenario.settings.precision) {  // at most this many
    const std::int64_t cap = std::numeric_limits<std::int64_t>::max() / p->max_batches;
    req.total_samples = req.total_samples > cap ? std::numeric_limits<std::int64_t>::max()
                                                : req.total_samples * p->max_batches;
  }
  if (req.compare_with) {  // both runs
    const std::int64_t max = std::numeric_limits<std::int64_t>::max();
    req.total_samples = req.total_samples > max / 2 ? max : 2 * req.total_samples;
  }
  req.bracket_samples = run::ground_bracket_histories(req.document.scenario);
  return req;
}

StoredRequest split_stored_request(const nlohmann::json& request) {
  StoredRequest out{request, std::nullopt};
  const auto it = request.find("compare_with");
  if (it == request.end()) return out;
  const std::string id = read_string(*it, "compare_with");
  if (!is_job_id(id))
    fail("compare_with", "expected the id of the base job (j_ and 16 hex digits), got \"" +
                             id.substr(0, 40) + "\"");
  out.compare_with = id;
  out.scenario.erase("compare_with");
  return out;
}

bool is_job_id(std::string_view s) {
  if (s.size() != 18 || s[0] != 'j' || s[1] != '_') return false;
  for (std::size_t k = 2; k < s.size(); ++k) {
    const char c = s[k];
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

}  // namespace fragsim::api
