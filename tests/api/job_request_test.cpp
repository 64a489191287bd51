// Job requests to fragsimd (POST /v1/jobs): the two daemon keys (priority, idempotency_key), the
// scenario by "site_id" through a SiteResolver, and the JSON text limits of parse_json_text.
#include "api/job_request.h"

#include <gtest/gtest.h>

#include <string>

#include "api/site_document.h"
#include "test_support.h"

namespace fragsim::api {
namespace {

using testing::FieldMessage;
using testing::Json;
using testing::minimal_example;

// A resolver over one stored site (the daemon's registry holds normalised site JSON).
struct OneSite {
  std::string id;
  Json site;
  int calls = 0;
  SiteResolver resolver() {
    return [this](const std::string& site_id) -> const Json* {
      ++calls;
      return site_id == id ? &site : nullptr;
    };
  }
};

OneSite minimal_site() {
  const SiteDocument doc = parse_site_document(minimal_example()["site"]);
  return {doc.site_id, doc.normalised, 0};
}

// The minimal example with its inline site replaced by a site_id.
Json by_site_id(const std::string& id) {
  Json j = minimal_example();
  j.erase("site");
  j["site_id"] = id;
  return j;
}

SiteResolver no_sites() {
  return [](const std::string&) -> const Json* { return nullptr; };
}

FieldMessage request_error(const Json& body, const SiteResolver& resolve) {
  try {
    parse_job_request(body, resolve);
  } catch (const InputError& e) {
    return {e.field(), e.message()};
  }
  return {"<no error>", ""};
}

FieldMessage request_error(const Json& body) {
  return request_error(body, no_sites());
}

// ---- priority ----

TEST(JobRequest, PriorityDefaultsToZeroAndIsRemovedFromTheScenario) {
  const JobRequest r = parse_job_request(minimal_example(), no_sites());
  EXPECT_EQ(r.priority, 0);
  EXPECT_FALSE(r.idempotency_key.has_value());
  EXPECT_EQ(r.scenario, minimal_example());
  EXPECT_FALSE(r.document.site_id.has_value());
}

TEST(JobRequest, PriorityWithinRangeIsAccepted) {
  for (const int p : {kMinJobPriority, -1, 0, 7, kMaxJobPriority}) {
    Json body = minimal_example();
    body["priority"] = p;
    const JobRequest r = parse_job_request(body, no_sites());
    EXPECT_EQ(r.priority, p);
    EXPECT_FALSE(r.scenario.contains("priority"));
    EXPECT_EQ(r.scenario, minimal_example());
  }
}

TEST(JobRequest, PriorityOutOfRangeOrWrongTypeNamesPriority) {
  for (const Json& bad :
       {Json(1001), Json(-1001), Json(1.5), Json("high"), Json(nullptr), Json(true)}) {
    Json body = minimal_example();
    body["priority"] = bad;
    EXPECT_EQ(request_error(body).first, "priority") << bad.dump();
  }
  Json body = minimal_example();
  body["priority"] = "high";
  EXPECT_EQ(request_error(body), FieldMessage("priority", "expected integer, got string"));
}

TEST(JobRequest, PriorityGivenAsIntegralNumberIsAccepted) {
  Json body = minimal_example();
  body["priority"] = 1e2;  // a number with an integral value counts as an integer
  EXPECT_EQ(parse_job_request(body, no_sites()).priority, 100);
}

// ---- idempotency_key ----

TEST(JobRequest, IdempotencyKeyIsKeptAndRemovedFromTheScenario) {
  Json body = minimal_example();
  body["idempotency_key"] = "study-42.run_1:A";
  body["priority"] = 3;
  const JobRequest r = parse_job_request(body, no_sites());
  ASSERT_TRUE(r.idempotency_key.has_value());
  EXPECT_EQ(*r.idempotency_key, "study-42.run_1:A");
  EXPECT_EQ(r.priority, 3);
  EXPECT_FALSE(r.scenario.contains("idempotency_key"));
  EXPECT_FALSE(r.scenario.contains("priority"));
  EXPECT_EQ(r.scenario, minimal_example());
}

TEST(JobRequest, IdempotencyKeyLengthBounds) {
  Json body = minimal_example();
  body["idempotency_key"] = "a";
  EXPECT_EQ(*parse_job_request(body, no_sites()).idempotency_key, "a");
  body["idempotency_key"] = std::string(kMaxIdempotencyKeyLength, 'k');
  EXPECT_EQ(parse_job_request(body, no_sites()).idempotency_key->size(), 128u);

  body["idempotency_key"] = std::string(kMaxIdempotencyKeyLength + 1, 'k');
  EXPECT_EQ(request_error(body),
            FieldMessage("idempotency_key", "must have 1 to 128 characters (got 129)"));
  body["idempotency_key"] = "";
  EXPECT_EQ(request_error(body),
            FieldMessage("idempotency_key", "must have 1 to 128 characters (got 0)"));
}

TEST(JobRequest, IdempotencyKeyCharacters) {
  for (const char* bad : {"a b", "a/b", "key#1", "caf\xc3\xa9", "a\"b", "tab\there", "a+b"}) {
    Json body = minimal_example();
    body["idempotency_key"] = bad;
    EXPECT_EQ(request_error(body),
              FieldMessage("idempotency_key", "may only contain letters, digits and . _ : -"))
        << bad;
  }
  Json body = minimal_example();
  body["idempotency_key"] = "AZaz09._:-";
  EXPECT_EQ(*parse_job_request(body, no_sites()).idempotency_key, "AZaz09._:-");
}

TEST(JobRequest, IdempotencyKeyMustBeAString) {
  Json body = minimal_example();
  body["idempotency_key"] = 42;
  EXPECT_EQ(request_error(body), FieldMessage("idempotency_key", "expected string, got integer"));
}

// ---- The scenario part ----

TEST(JobRequest, TopLevelMustBeAnObject) {
  EXPECT_EQ(request_error(Json::array({1, 2})).first, "");
  EXPECT_EQ(request_error(Json("scenario")).first, "");
}

TEST(JobRequest, TotalSamplesSumsTheGroups) {
  Json body = minimal_example();
  Json second = body["fragment_groups"][0];
  second["name"] = "second";
  second["samples"] = 300;
  body["fragment_groups"].push_back(second);
  const JobRequest r = parse_job_request(body, no_sites());
  EXPECT_EQ(r.total_samples, 2300);
  ASSERT_EQ(r.document.scenario.groups.size(), 2u);
}

TEST(JobRequest, ScenarioErrorsKeepTheirPaths) {
  Json body = minimal_example();
  body["priority"] = 5;
  body["fragment_groups"][0]["mass_kg"] = "heavy";
  EXPECT_EQ(request_error(body).first, "fragment_groups[0].mass_kg");
  body = minimal_example();
  body["settings"]["integrater"] = {};
  EXPECT_EQ(request_error(body),
            FieldMessage("settings.integrater", "unknown key (did you mean \"integrator\"?)"));
}

TEST(JobRequest, DaemonKeysAreNotScenarioKeys) {
  // Outside a job request they are unknown keys of the scenario.
  Json j = minimal_example();
  j["priority"] = 1;
  EXPECT_EQ(testing::parse_error(j).first, "priority");
}

// ---- site_id ----

TEST(JobRequestSiteId, ResolvedSiteGivesTheSameScenarioAsTheInlineSite) {
  OneSite store = minimal_site();
  const JobRequest r = parse_job_request(by_site_id(store.id), store.resolver());
  EXPECT_EQ(store.calls, 1);
  ASSERT_TRUE(r.document.site_id.has_value());
  EXPECT_EQ(*r.document.site_id, store.id);
  EXPECT_FALSE(r.scenario.contains("site"));
  EXPECT_EQ(r.scenario["site_id"], store.id);

  const ScenarioDocument inline_doc = parse_scenario_document(minimal_example());
  EXPECT_EQ(scenario_to_json(r.document.scenario), scenario_to_json(inline_doc.scenario));
  EXPECT_EQ(scenario_to_json(r.document), scenario_to_json(inline_doc));
  EXPECT_EQ(r.total_samples, 2000);
}

TEST(JobRequestSiteId, ResolvedSiteWithABuiltInMaterialMatchesInline) {
  // The site uses the built-in "hard" ground material without defining it; its normalised form
  // carries the material, and the scenario by id is still the inline one.
  Json scenario = minimal_example();
  scenario["site"]["terrain"]["material"] = "hard";
  const SiteDocument doc = parse_site_document(scenario["site"]);
  OneSite store{doc.site_id, doc.normalised, 0};
  Json body = scenario;
  body.erase("site");
  body["site_id"] = doc.site_id;
  const JobRequest r = parse_job_request(body, store.resolver());
  const ScenarioDocument inline_doc = parse_scenario_document(scenario);
  EXPECT_EQ(scenario_to_json(r.document), scenario_to_json(inline_doc));
}

TEST(JobRequestSiteId, UnknownSiteId) {
  OneSite store = minimal_site();
  EXPECT_EQ(request_error(by_site_id("s_0000000000000000"), store.resolver()),
            FieldMessage("site_id", "unknown site \"s_0000000000000000\""));
}

TEST(JobRequestSiteId, SiteAndSiteIdTogetherAreRefused) {
  OneSite store = minimal_site();
  Json body = minimal_example();
  body["site_id"] = store.id;
  EXPECT_EQ(request_error(body, store.resolver()),
            FieldMessage("site_id", "give either an inline site or a site_id, not both"));
}

TEST(JobRequestSiteId, SiteIdMustBeAString) {
  OneSite store = minimal_site();
  Json body = by_site_id("x");
  body["site_id"] = 17;
  EXPECT_EQ(request_error(body, store.resolver()),
            FieldMessage("site_id", "expected string, got integer"));
}

TEST(JobRequestSiteId, RefusedWithoutAResolver) {
  const Json body = by_site_id("s_0123456789abcdef");
  const FieldMessage no_resolver = testing::parse_error(body);
  EXPECT_EQ(no_resolver.first, "site_id");
  EXPECT_NE(no_resolver.second.find("inline \"site\""), std::string::npos) << no_resolver.second;

  const SiteResolver empty;  // an empty std::function counts as no resolver
  try {
    parse_scenario_document(body, &empty);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "site_id");
  }
}

TEST(JobRequestSiteId, NeitherSiteNorSiteId) {
  Json body = minimal_example();
  body.erase("site");
  EXPECT_EQ(request_error(body), FieldMessage("site", "is required"));
}

// ---- Job ids ----

TEST(JobRequest, IsJobId) {
  EXPECT_TRUE(is_job_id("j_0123456789abcdef"));
  EXPECT_TRUE(is_job_id("j_ffffffffffffffff"));
  EXPECT_FALSE(is_job_id("j_0123456789ABCDEF"));   // upper case
  EXPECT_FALSE(is_job_id("j_0123456789abcde"));    // 15 digits
  EXPECT_FALSE(is_job_id("j_0123456789abcdef0"));  // 17 digits
  EXPECT_FALSE(is_job_id("j_0123456789abcdeg"));
  EXPECT_FALSE(is_job_id("s_0123456789abcdef"));
  EXPECT_FALSE(is_job_id("J_0123456789abcdef"));
  EXPECT_FALSE(is_job_id("j-0123456789abcdef"));
  EXPECT_FALSE(is_job_id("j_../../etc/passwd"));
  EXPECT_FALSE(is_job_id(""));
}

// ---- JSON text: malformed and too deep ----

std::string nested_arrays(std::size_t depth) {
  return std::string(depth, '[') + std::string(depth, ']');
}

TEST(JobRequestJsonText, NestingUpToTheLimitIsAccepted) {
  const Json j = parse_json_text(nested_arrays(kMaxJsonDepth));
  const Json* p = &j;
  std::size_t depth = 0;
  while (p->is_array()) {
    ++depth;
    if (p->empty()) break;
    p = &(*p)[0];
  }
  EXPECT_EQ(depth, kMaxJsonDepth);
}

TEST(JobRequestJsonText, NestingBeyondTheLimitIsTooDeep) {
  try {
    parse_json_text(nested_arrays(kMaxJsonDepth + 1));
    ADD_FAILURE() << "expected JsonTooDeepError";
  } catch (const JsonTooDeepError& e) {
    EXPECT_NE(e.message().find("64"), std::string::npos) << e.what();
  }
  // Objects count as well, and a smaller limit applies when asked for.
  EXPECT_THROW(parse_json_text(R"({"a": {"b": {"c": 1}}})", 2), JsonTooDeepError);
  EXPECT_NO_THROW(parse_json_text(R"({"a": {"b": 1}})", 2));
}

TEST(JobRequestJsonText, ErrorsAreInputErrors) {
  // The daemon maps both to 400 and everything else of InputError to 422: they must be caught as
  // InputError by a caller that does not know them.
  EXPECT_THROW(parse_json_text(nested_arrays(100)), InputError);
  EXPECT_THROW(parse_json_text("{"), InputError);
}

TEST(JobRequestJsonText, MalformedJsonGivesLineAndColumn) {
  try {
    parse_json_text("{\n  \"a\": 1,\n  \"b\": ]\n}");
    ADD_FAILURE() << "expected MalformedJsonError";
  } catch (const MalformedJsonError& e) {
    EXPECT_EQ(e.field(), "");
    EXPECT_NE(e.message().find("malformed JSON at line 3, column 8"), std::string::npos)
        << e.message();
  }
  EXPECT_THROW(parse_json_text(""), MalformedJsonError);
  EXPECT_THROW(parse_json_text("{\"a\": 1} trailing"), MalformedJsonError);
}

TEST(JobRequestJsonText, DuplicateKeyAndOverflowNameTheirPath) {
  try {
    parse_json_text(R"({"site": {"terrain": 1, "terrain": 2}})");
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(FieldMessage(e.field(), e.message()), FieldMessage("site.terrain", "duplicate key"));
  }
  try {
    parse_json_text(R"({"a": [1, 1e999]})");
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(FieldMessage(e.field(), e.message()), FieldMessage("a[1]", "not finite"));
  }
}

}  // namespace
}  // namespace fragsim::api
