#pragma once
// A run of a scenario written to `dir` as `fragsim run` writes it (summary.json, results.h5): the
// input of the export tests.
#include <filesystem>
#include <nlohmann/json.hpp>

#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "core/run/run.h"
#include "formats/output_dir.h"

namespace fragsim::gis::testing {

// Returns the path of the results.h5 written.
inline std::filesystem::path write_run(const nlohmann::json& scenario,
                                       const std::filesystem::path& dir) {
  const api::ScenarioDocument doc = api::parse_scenario_document(scenario);
  const auto site = api::validate_scenario(doc.scenario);
  const run::RunResult result = run::run(doc.scenario);
  formats::OutputDir out(dir);
  api::stage_run_outputs(out, result, *site, doc, api::build_provenance());
  out.commit();
  return dir / api::kResultsFileName;
}

}  // namespace fragsim::gis::testing
