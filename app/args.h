#pragma once
// Command-line arguments of `fragsim`.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "api/command_line.h"
#include "api/units.h"

namespace fragsim::app {

// A malformed command line (exit code 2, like invalid input); api/command_line.h reads it.
using UsageError = api::InvocationError;

enum class Command {
  kHelp,
  kVersion,
  kRun,
  kValidate,
  kSubmit,
  kSiteImport,
  kSiteExportGis,
  kShapeImport,
  kExport,
  kMerge,
  kReport,
  kCompare,
  kGroupsFromMunition
};

struct ShardArg {
  std::int64_t index = 0;
  std::int64_t count = 1;
};

struct Options {
  Command command = Command::kHelp;
  std::string scenario;  // run, validate, submit; site import: IMPORT.json; groups: MUNITION.json
  std::string out;       // run: --out DIR (required); site import, groups from-munition: --out FILE
  std::optional<int> threads;           // run: --threads N overrides settings.threads
  std::optional<double> samples_scale;  // run: --samples-scale X multiplies every group's samples
  bool quiet = false;                   // run, submit, merge: no progress, no report
  std::optional<ShardArg> shard;        // run: --shard I/N writes DIR/partial.fsp
  std::string progress_file;            // run: --progress-file FILE (JSON, rewritten atomically)
  // run, merge, submit: the printed summary's units; export: US fields beside the SI ones;
  // report: the units the page shows
  api::UnitSystem units = api::UnitSystem::kSi;  // --units si|us (docs/units.md)
  std::vector<std::string> parts;                // merge: the partial files
  std::string variant;                           // compare: VARIANT.json (BASE.json in scenario)
  // submit
  std::string server = "http://127.0.0.1:8080";
  std::string token_file;
  std::optional<int> priority;
  std::string idempotency_key;
  std::string compare_with;  // submit: --compare-with JOB_ID (a paired comparison's base job)
  bool wait = true;          // follow the job to its end
  bool maps = false;         // with --out: also download the job's GIS maps into DIR/maps
  // export (RESULTS.h5 in `scenario`, DIR in `out`)
  std::optional<double> pixel_m;
  std::optional<double> smoothing_m;  // export: the site-plan boundary's closing radius
  // shape import (FILE in `scenario`): --axes z_up | y_up | x,-z,y
  std::string axes = "z_up";
  // report (RESULTS.h5 in `scenario`, --out REPORT.html in `out`, `units`): --pdf FILE
  std::string pdf;
  std::string compare;  // report: --compare COMPARE.json (the run's paired comparison)
};

Options parse_args(const std::vector<std::string>& args);  // args without argv[0]

const char* usage_text();

}  // namespace fragsim::app
