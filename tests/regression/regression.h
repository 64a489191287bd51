#pragma once
// Regression baselines (issue 12; docs/testing.md, "Regression baselines"): the figures of whole
// runs of a few scenarios, stored in tests/regression/baselines/<name>.json, and the comparison of
// a new run against them with a tolerance derived from the standard errors.
//
// One JSON layout serves both sides: `measure` turns a run into a figures document; the stored
// baseline is such a document plus a header. `compare` walks two documents and reports every
// figure that moved beyond its tolerance:
//   |new - base| <= kSigmas * sqrt(se_new^2 + se_base^2) + floor
// (the HFD takes its se from its +-1 se band; a sector HFD is compared by its +-kSigmas se band;
// details in regression.cpp and docs/testing.md).
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/run/result.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::regression {

using Json = nlohmann::ordered_json;

// The tolerance rule (justified in regression.cpp, where the constants are used).
inline constexpr double kSigmas = 4.0;           // k: combined standard errors allowed
inline constexpr double kRelativeFloor = 1e-9;   // of max(|base|, |new|): rounding, not physics
inline constexpr double kAbsoluteFloor = 1e-12;  // in the figure's unit: a guard at zero
inline constexpr int kDensestTriangles = 20;
inline constexpr int kSectorRays = 4;  // rays through the sectors of largest HFD (+ 4 axes)
inline constexpr double kRayDistances[] = {0.5, 1.0, 1.5, 2.0};  // multiples of the (sector) HFD

// A scenario of the regression set: a scenario file, optionally changed in code.
struct Case {
  std::string name;                     // baseline file: baselines/<name>.json
  std::string file;                     // relative to the source tree
  std::optional<bool> bounce;           // overrides settings.bounce
  std::optional<double> samples_scale;  // every group's samples x scale (as fragsim run does)
  std::string changes;                  // the overrides in words, for the header
};
const std::vector<Case>& cases();
const Case& find_case(const std::string& name);  // throws std::invalid_argument

std::filesystem::path source_root();  // FRAGSIM_SOURCE_DIR
std::filesystem::path baseline_path(const Case& c);

// The case's scenario, parsed from its file with the overrides applied.
run::Scenario load_scenario(const Case& c);

// A run of the case with the site it ran on (needed for triangle centroids and sectors).
struct CaseRun {
  run::Scenario scenario;
  std::shared_ptr<const scene::Site> site;
  run::RunResult result;
  double wall_s = 0.0;
};
CaseRun run_case(const Case& c, std::optional<std::uint64_t> seed = std::nullopt);

// HFD of a density field, overall and per 10-degree sector; the definition of core/run/run.cpp
// (largest horizontal distance from `origin_local` of a triangle centroid with density >=
// threshold and > 0), repeated here to get the sectors' +-1 se band, which RunResult does not
// carry. The test checks that it reproduces RunResult's HFD, band and sectors exactly.
struct SectorHfd {
  double overall_m = 0.0;
  std::array<double, 36> sector_m{};
};
SectorHfd hazardous_distances(const scene::Site& site, const std::vector<double>& density,
                              double threshold, const Vec3& origin_local);
// Field mean + sign * se.
std::vector<double> shifted_field(const run::RunResult& r, double sign);

// One sampled terrain triangle: index and why it was chosen.
struct SampledTriangle {
  std::int64_t triangle = 0;
  std::string why;
};
// The 20 densest triangles, then triangles on rays from the HFD origin at 0.5, 1, 1.5 and 2 x
// the HFD: through the 4 sectors of largest HFD (x the sector's HFD) and along the 4 axes
// (x the HFD); no repeats.
std::vector<SampledTriangle> choose_triangles(const CaseRun& run);
std::vector<SampledTriangle> triangles_of(const Json& figures);  // as stored in a document

// The figures document of a run (inputs, HFD, sectors, max PTN, sampled PTN triangles,
// buildings, outcomes).
Json measure(const CaseRun& run, const std::vector<SampledTriangle>& triangles);

// A baseline: header (provenance) + measure(...).
struct Provenance {
  std::string commit;  // git commit of the tree that generated it (with -dirty when changed)
  std::string date;    // UTC, ISO 8601
};
Json make_baseline(const Case& c, const CaseRun& run, const Provenance& p);
Json load_baseline(const Case& c);  // throws std::runtime_error when missing or unreadable
// The stored text: the header indented, one line per sector, triangle, building and outcome (so
// that the diff of a regeneration shows figure by figure what moved).
std::string baseline_text(const Json& baseline);

// A figure beyond its tolerance.
struct Moved {
  std::string figure;  // e.g. "buildings.B06.penetrations", "hfd", "sector_hfd[4]"
  double base = 0.0, base_se = 0.0;
  double now = 0.0, now_se = 0.0;
  double combined_se = 0.0;  // sqrt(base_se^2 + now_se^2)
  double tolerance = 0.0;    // allowed |now - base|
  std::string note;          // why a sector moved; what is missing
  bool missing = false;      // the figure is not in the new run (no values)
};
struct Comparison {
  std::vector<std::string> input_mismatches;  // seed, bounce, samples, histories
  std::vector<Moved> moved;
  int figures = 0;  // figures compared
  // Every figure with a combined se > 0 (HFDs: se from the band): |now - base| / combined se,
  // and how much of its tolerance the difference used (sectors: the gap between the bands over
  // one cell, 0 when they overlap).
  struct Sigmas {
    std::string figure;
    double sigmas = 0.0;
    double used = 0.0;
  };
  std::vector<Sigmas> sigmas;
  std::pair<std::string, double> largest() const;  // largest sigmas; ("", 0) when none
  bool ok() const { return input_mismatches.empty() && moved.empty(); }
};
Comparison compare(const Json& base, const Json& now);
std::string report(const Comparison& c);  // every mismatch and moved figure, one per line

}  // namespace fragsim::regression
