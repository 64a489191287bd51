#pragma once
// summary.json ("schema": "fragsim.result/1"): the headline figures of one run, each tallied figure
// with its standard error, plus timing, counters and provenance. Field list in docs/scenario.md.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "api/units.h"
#include "core/run/precision.h"
#include "core/run/result.h"
#include "core/run/scenario.h"

namespace fragsim::api {

inline constexpr const char* kResultSchema = "fragsim.result/1";

struct Provenance {
  std::string version;                         // fragsim version (fragsim/version.h)
  std::string git_sha;                         // of the build
  std::optional<std::string> scenario_sha256;  // of the scenario file as read, when there is one
};

// This build's version and git sha.
Provenance build_provenance();

// Keys keep a fixed, readable order (schema first, outcomes in enum order).
nlohmann::ordered_json summary_to_json(const run::RunResult& result, const run::Scenario& scenario,
                                       const Provenance& provenance);

// When the terrain's boundary cuts the HFD (RunResult::site_boundary): "HFD ≥ 278.1 m: hazardous
// density reaches the site boundary in 36 of 36 sectors; extend the terrain"; else empty.
std::string hfd_bound_note(const run::RunResult& result);

// settings.precision: the last batch boundary's check of the targets (summary.json "precision",
// also the daemon's live job progress).
nlohmann::ordered_json precision_report_json(const run::PrecisionReport& report);

// A plain-text report of a summary (as made by summary_to_json): headline figures, a table of
// buildings (expected impacts and penetrations, each +/- one standard error), outcome counts,
// run time and throughput. In US units (docs/units.md) distances are in ft, densities per
// 600 ft², the site boundary's cut sectors named by bearing; site coordinates stay in metres.
std::string render_summary_text(const nlohmann::ordered_json& summary,
                                UnitSystem units = UnitSystem::kSi);

}  // namespace fragsim::api
