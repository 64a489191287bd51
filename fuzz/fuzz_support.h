#pragma once
// Shared by the libFuzzer targets (docs/testing.md). A target passes when every input either
// goes through or is refused with the contract's "bad input" exception, fragsim::InputError (its
// subclasses MalformedJsonError and JsonTooDeepError included). Anything else -- another
// exception, a broken invariant, a sanitizer report, an input taking over a second -- is a
// finding: the exception escapes LLVMFuzzerTestOneInput and libFuzzer stops with the input saved.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "api/scenario_json.h"
#include "core/run/run.h"
#include "core/scene/site_limits.h"

namespace fragsim::fuzz {

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// A broken invariant: abort() so that libFuzzer records the input as a crash.
[[noreturn]] inline void fail(const std::string& what) {
  std::fprintf(stderr, "fuzz invariant broken: %s\n", what.c_str());
  std::abort();
}

// Normalising is idempotent: the normalised form parses back to itself. The daemon relies on it
// (a site's id is the hash of its normalised JSON; results.h5 stores the normalised scenario).
inline void check_scenario_round_trip(const api::ScenarioDocument& doc) {
  const nlohmann::json once = api::scenario_to_json(doc);
  const nlohmann::json twice = api::scenario_to_json(api::parse_scenario_document(once));
  if (once != twice)
    fail("scenario normalisation not idempotent:\n" + once.dump() + "\n" + twice.dump());
}

// The harness's memory budget for a site: the fuzzer runs with -rss_limit_mb=2048, and the limits
// of the contract allow a few bytes of plane spec to ask for 2^26 triangles (~13 GB). Larger
// terrains are skipped before they are built (the daemon refuses them the same way, with its
// --max-terrain-triangles; tested in tests/server). 2^16 triangles build in a quarter of a second
// under ASan + UBSan + coverage (2^18 took 1.2 s).
inline constexpr double kMaxFuzzTerrainTriangles = 1 << 16;
inline bool too_large_to_build(const scene::TerrainSpec& terrain) {
  return scene::terrain_triangles_of(terrain) > kMaxFuzzTerrainTriangles;
}

// A few histories of an accepted scenario: two per group (at most three groups; two so that a
// launch stratum is complete), at most two precision batches (importance sampling's pilot and
// one batch drawn from what it learnt), one thread, and a work cap far below the production one
// (1,000 steps and events per history), so that an input costs well under a second under ASan +
// UBSan + coverage. This reaches the physics (flight, impacts, ground phase) and the samplers
// with values no hand-written test would choose. (With up to 10 batches of one history per group
// and a cap of 20,000, an input whose histories all slide to the cap took 7 s.)
inline void run_a_few_histories(run::Scenario sc, std::shared_ptr<const scene::Site> site) {
  constexpr std::size_t kMaxGroups = 3;
  if (sc.groups.size() > kMaxGroups) sc.groups.resize(kMaxGroups);
  for (auto& g : sc.groups) g.samples = 2;
  if (auto& p = sc.settings.precision) {
    p->max_batches = std::min<std::int64_t>(p->max_batches, 2);
    p->min_batches = std::min(p->min_batches, p->max_batches);
  }
  sc.settings.threads = 1;
  sc.settings.max_history_work = 1'000;
  sc.settings.max_recorded_trajectories = 3;
  (void)run::run(sc, std::move(site));
}

}  // namespace fragsim::fuzz
