#include "api/run_outputs.h"

#include "formats/results_h5.h"

namespace fragsim::api {

nlohmann::ordered_json stage_run_outputs(formats::OutputDir& out, const run::RunResult& result,
                                         const scene::Site& site, const ScenarioDocument& doc,
                                         const Provenance& provenance) {
  const std::string scenario_json = scenario_to_json(doc).dump();
  nlohmann::ordered_json summary = summary_to_json(result, doc.scenario, provenance);
  out.stage(kResultsFileName, [&](const std::filesystem::path& path) {
    formats::write_results_h5(path, result, site, doc.scenario, scenario_json, provenance);
  });
  out.stage_text(kSummaryFileName, summary.dump(2) + "\n");
  return summary;
}

}  // namespace fragsim::api
