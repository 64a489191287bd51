#include "api/run_outputs.h"

#include "api/machine.h"

namespace fragsim::api {

formats::ResultsTexts results_texts(const run::RunResult& result, const run::Scenario& scenario,
                                    const std::string& scenario_json,
                                    const Provenance& provenance) {
  formats::ResultsTexts t;
  t.version = provenance.version;
  t.git_sha = provenance.git_sha;
  t.scenario_sha256 = provenance.scenario_sha256;
  t.scenario_json = scenario_json;
  t.summary_json = summary_to_json(result, scenario, provenance).dump();
  t.hfd_note = hfd_bound_note(result);
  t.created_utc = utc_now_iso8601();
  t.machine = machine_description();
  return t;
}

nlohmann::ordered_json stage_run_outputs(formats::OutputDir& out, const run::RunResult& result,
                                         const scene::Site& site, const ScenarioDocument& doc,
                                         const Provenance& provenance) {
  const std::string scenario_json = scenario_to_json(doc).dump();
  nlohmann::ordered_json summary = summary_to_json(result, doc.scenario, provenance);
  out.stage(kResultsFileName, [&](const std::filesystem::path& path) {
    formats::write_results_h5(path, result, site, doc.scenario,
                              results_texts(result, doc.scenario, scenario_json, provenance));
  });
  out.stage_text(kSummaryFileName, summary.dump(2) + "\n");
  return summary;
}

}  // namespace fragsim::api
