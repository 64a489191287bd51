#pragma once
// The files of one finished run, as `fragsim run` and fragsimd both write them:
//   summary.json  (summary_to_json, indented)
//   results.h5    (write_results_h5, with the normalised scenario as provenance)
#include <nlohmann/json.hpp>

#include "api/scenario_json.h"
#include "api/summary_json.h"
#include "core/run/result.h"
#include "core/scene/site.h"
#include "formats/output_dir.h"
#include "formats/results_h5.h"

namespace fragsim::api {

inline constexpr const char* kSummaryFileName = "summary.json";
inline constexpr const char* kResultsFileName = "results.h5";

// What results.h5 records beside the figures (formats::ResultsTexts): the provenance, the
// normalised scenario, the summary's figures, the HFD's boundary note, the time and the machine.
formats::ResultsTexts results_texts(const run::RunResult& result, const run::Scenario& scenario,
                                    const std::string& scenario_json, const Provenance& provenance);

// Stages both files in `out` (nothing is visible until out.commit()); returns the summary.
nlohmann::ordered_json stage_run_outputs(formats::OutputDir& out, const run::RunResult& result,
                                         const scene::Site& site, const ScenarioDocument& doc,
                                         const Provenance& provenance);

}  // namespace fragsim::api
