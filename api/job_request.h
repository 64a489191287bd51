#pragma once
// A job request to fragsimd (POST /v1/jobs): a scenario (inline site or "site_id") plus two
// top-level keys that are not part of the scenario:
//   priority         integer in [-1000, 1000], default 0; higher runs first
//   idempotency_key  1-128 characters of [A-Za-z0-9._:-]; a repeated request with the same key
//                    returns the job made the first time
//   compare_with     a job id: this scenario is the variant of a paired comparison with that job's
//                    scenario as the base (docs/comparison.md); it stays in the stored request
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "api/scenario_json.h"

namespace fragsim::api {

inline constexpr int kMinJobPriority = -1000;
inline constexpr int kMaxJobPriority = 1000;
inline constexpr std::size_t kMaxIdempotencyKeyLength = 128;

struct JobRequest {
  ScenarioDocument document;  // document.site_id set when the scenario named a stored site
  int priority = 0;
  std::optional<std::string> idempotency_key;
  std::int64_t total_samples = 0;  // over all fragment groups (x precision.max_batches)
  // The histories of settings.ground_bracket's runs after the study (0 without it).
  std::int64_t bracket_samples = 0;
  std::optional<std::string> compare_with;  // the base job of a paired comparison
  nlohmann::json scenario;                  // the request without priority and idempotency_key
};

// A stored request (JobRequest::scenario) split into the scenario and compare_with.
struct StoredRequest {
  nlohmann::json scenario;
  std::optional<std::string> compare_with;
};
StoredRequest split_stored_request(const nlohmann::json& request);

// Throws InputError naming the field. `resolve` looks up "site_id". With compare_with,
// total_samples counts both runs (the base's histories flown again, then the variant's).
JobRequest parse_job_request(const nlohmann::json& body, const SiteResolver& resolve);

// True for the form job ids take ("j_" + 16 lowercase hex digits).
bool is_job_id(std::string_view s);

}  // namespace fragsim::api
