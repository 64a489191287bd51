#pragma once
// What the study report is made of (docs/report.md): one results.h5 (formats/results_h5.h, format 5
// or later) read once: the figures exactly as summary.json holds them, the normalised scenario,
// the provenance attributes, the fields (gis/results_file.h) and the site-plan boundary
// (gis/plan_boundary.h).
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "gis/plan_boundary.h"
#include "gis/results_file.h"

namespace fragsim::report {

struct ReportInputs {
  std::string file_name;            // the results file's name, as given
  nlohmann::ordered_json summary;   // root attribute summary_json
  nlohmann::ordered_json scenario;  // root attribute scenario_json (normalised)
  std::string fragsim_version, git_sha, scenario_sha256, created_utc, machine;
  double wall_s = 0.0;
  std::int64_t threads = 0;
  int format_version = 0;
  gis::ResultsFile results;
  gis::PlanBoundary boundary;
  // A paired comparison this run is part of (compare.json; docs/comparison.md), and its role.
  std::optional<nlohmann::ordered_json> compare;
  std::string compare_role;  // "base" or "variant"
};

// Reads `path`. Throws InputError("RESULTS.h5", "<path>: <problem>") when it is missing, not an
// HDF5 file, not a fragsim results file, from a cancelled run (partial figures), or older than
// results format 5 (no stored summary).
ReportInputs read_report_inputs(const std::filesystem::path& path);

// Adds `compare_json` (a paired comparison's compare.json) to `in`. Throws InputError(field,
// ...) when it is not one, or compares other runs (neither scenario SHA-256 is this run's).
void add_comparison(ReportInputs& in, const std::filesystem::path& compare_json,
                    const std::string& field);

}  // namespace fragsim::report
