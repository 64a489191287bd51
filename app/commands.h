#pragma once
// The `fragsim` commands. Each returns the process exit code or throws: fragsim::InputError and
// app::UsageError mean invalid input (exit 2), anything else an internal error (exit 1).
#include <atomic>
#include <memory>
#include <string>

#include "api/scenario_json.h"
#include "app/args.h"
#include "core/run/result.h"
#include "core/scene/site.h"
#include "formats/output_dir.h"
#include "formats/partial_file.h"

namespace fragsim::app {

inline constexpr int kExitOk = 0;
inline constexpr int kExitInternal = 1;
inline constexpr int kExitInvalidInput = 2;
inline constexpr int kExitCancelled = 130;  // 128 + SIGINT, as shells report it

// A whole file; InputError(field, "cannot read PATH: reason") when it cannot be read.
std::string read_file(const std::string& path, const std::string& field = "");

int validate_command(const Options& options);

// What run, merge and fragsim-mpi share: the scenario parsed, overridden (--threads,
// --samples-scale) and checked, its site built, --out checked. Throws InputError.
struct PreparedRun {
  std::string text;  // the scenario file as read
  api::ScenarioDocument doc;
  std::shared_ptr<const scene::Site> site;
  double parse_s = 0.0, build_s = 0.0;
};
PreparedRun prepare(const Options& options);
PreparedRun prepare_text(const Options& options, std::string text);
// What a person should know about valid input before the run (stderr, not with --quiet): the
// materials marked illustrative, the groups that can land beyond the terrain (core/run/reach.h).
std::string input_notes(const PreparedRun& prepared);
// What a partial of this run must share with the others it is merged with.
formats::PartialIdentity identity_of(const Options& options, const PreparedRun& prepared);
// --out, created if missing (and removed again unless committed). A directory that cannot be
// made is invalid input: InputError("--out", "cannot create directory ...: reason").
std::unique_ptr<formats::OutputDir> open_out(const Options& options);
// summary.json, results.h5, ... into --out, all at once; the report on stdout unless --quiet.
int write_outputs(const Options& options, const PreparedRun& prepared, run::RunResult& result,
                  const std::atomic<bool>& cancel, formats::OutputDir& out);
// --shard I/N: `part` as DIR/partial.fsp, staged and committed (temporary and rename: a killed
// process leaves no partial.fsp); "Shard I of N: ..." on stdout unless --quiet.
int write_partial(const Options& options, const PreparedRun& prepared, const run::PartialRun& part,
                  formats::OutputDir& out);
// `fragsim site import`: GIS files to a site document (gis/site_import.h).
int site_import_command(const Options& options);
// `fragsim site export-gis`: a site document to GIS files (gis/site_to_gis.h).
int site_export_gis_command(const Options& options);
// `fragsim shape import FILE --axes y_up`: a mesh file's vertices as a scenario shape.
int shape_import_command(const Options& options);
// `fragsim groups from-munition MUNITION.json [--out GROUPS.json]` (api/munition_json.h).
int groups_from_munition_command(const Options& options);
// `fragsim export`: results.h5 to GIS files (gis/results_export.h).
int export_command(const Options& options);

// `fragsim report`: results.h5 to the study report (report/report.h).
int report_command(const Options& options);
// `cancel` is set by the SIGINT/SIGTERM handler.
int run_command(const Options& options, const std::atomic<bool>& cancel);
// `fragsim merge`: the partial files of `run --shard` into run's outputs (docs/cluster.md).
int merge_command(const Options& options, const std::atomic<bool>& cancel);
// `fragsim compare`: the base and variant scenarios paired (core/run/paired.h), into --out.
int compare_command(const Options& options, const std::atomic<bool>& cancel);
// Runs the scenario on a fragsimd server; `cancel` stops following (the job keeps running).
int submit_command(const Options& options, const std::atomic<bool>& cancel);

}  // namespace fragsim::app
