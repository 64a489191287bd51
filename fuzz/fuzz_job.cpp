// libFuzzer target: bytes as the body of fragsimd's POST /v1/jobs. A "site_id" resolves against a
// catalogue of one site (examples/minimal's former 400 m plane, id in fuzz/corpus/fuzz_job); an
// inline site gets the full geometry check, as in Service::post_job.
#include <cstddef>
#include <cstdint>

#include "api/job_request.h"
#include "api/site_document.h"
#include "fuzz/fuzz_support.h"

namespace {

// The site of examples/minimal/scenario.json as it was before it grew to a 3 km plane (a 400 m
// plane of 10 m cells), as a stored site.
constexpr const char* kStoredSite = R"({
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

const fragsim::api::SiteDocument& stored_site() {
  static const fragsim::api::SiteDocument doc =
      fragsim::api::parse_site_document(nlohmann::json::parse(kStoredSite));
  return doc;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // The corpus names this id; print it so that a changed normalisation is noticed.
  std::fprintf(stderr, "fuzz_job: stored site %s\n", stored_site().site_id.c_str());
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace fragsim;
  const api::SiteResolver resolve = [](const std::string& id) -> const nlohmann::json* {
    return id == stored_site().site_id ? &stored_site().normalised : nullptr;
  };
  api::JobRequest jr;
  try {
    jr = api::parse_job_request(api::parse_json_text(fuzz::as_text(data, size)), resolve);
    if (!jr.document.site_id) {
      if (fuzz::too_large_to_build(jr.document.scenario.site.terrain)) return 0;
      (void)api::validate_scenario(jr.document.scenario);
    }
  } catch (const InputError&) {
    return 0;
  }
  // The daemon stores jr.scenario and its scheduler parses it again when the job runs: an
  // accepted job must not fail there (no InputError is caught from here on).
  (void)api::parse_scenario_document(api::parse_json_text(jr.scenario.dump()), &resolve);
  return 0;
}
