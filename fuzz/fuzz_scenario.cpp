// libFuzzer target: bytes as a scenario document, the path of `fragsim validate` (parse, then
// build the site with its geometry checks), then a few histories of what was accepted.
#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace fragsim;
  api::ScenarioDocument doc;
  std::shared_ptr<const scene::Site> site;
  try {
    doc = api::parse_scenario_document_text(fuzz::as_text(data, size));
    if (fuzz::too_large_to_build(doc.scenario.site.terrain)) return 0;
    site = api::validate_scenario(doc.scenario);
  } catch (const InputError&) {
    return 0;  // refused with a field path: what the contract promises
  }
  fuzz::check_scenario_round_trip(doc);
  fuzz::run_a_few_histories(doc.scenario, site);
  return 0;
}
