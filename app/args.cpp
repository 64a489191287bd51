#include "app/args.h"

#include <limits>
#include <map>
#include <string_view>

#include "api/command_line.h"
#include "api/job_request.h"
#include "api/scenario_json.h"
#include "core/run/partial.h"

namespace fragsim::app {

namespace {

using api::ArgReader;

constexpr double kInfinity = std::numeric_limits<double>::infinity();

int parse_threads(const std::string& v) {
  return static_cast<int>(
      api::integer_option("--threads", v, 0, api::kMaxThreads, " (0: all hardware threads)"));
}

double parse_scale(const std::string& v) {
  return api::number_option("--samples-scale", v, "a number", {0.0, true, kInfinity});
}

// "I/N" with 0 <= I < N <= run::kMaxShards.
ShardArg parse_shard(const std::string& v) {
  const auto slash = v.find('/');
  const auto index = api::to_integer(v.substr(0, slash));
  const auto count =
      slash == std::string::npos ? std::nullopt : api::to_integer(v.substr(slash + 1));
  if (!index || !count || *index < 0 || *count < 1 || *count > run::kMaxShards || *index >= *count)
    throw UsageError("--shard: expected I/N with 0 <= I < N <= " + std::to_string(run::kMaxShards) +
                     ", got \"" + v + "\"");
  return {*index, *count};
}

// --units si|us.
bool take_units(ArgReader& r, Options& o) {
  const auto value = r.take_value("--units");
  if (!value) return false;
  const auto units = api::parse_unit_system(*value);
  if (!units) throw UsageError("--units: expected si or us, got \"" + *value + "\"");
  o.units = *units;
  return true;
}

// A value into `dest` when the current word is option `name`.
bool take_into(ArgReader& r, std::string_view name, std::string_view what, std::string& dest) {
  auto value = r.take_nonempty(name, what);
  if (value) dest = std::move(*value);
  return value.has_value();
}

// The options run, merge and compare share.
bool take_run_output(ArgReader& r, Options& o) {
  if (take_into(r, "--out", "directory name", o.out) || take_units(r, o)) return true;
  if (const auto v = r.take_value("--samples-scale")) {
    o.samples_scale = parse_scale(*v);
    return true;
  }
  if (r.take_flag("--quiet", "-q")) return o.quiet = true;
  return false;
}

bool take_threads(ArgReader& r, Options& o) {
  const auto v = r.take_value("--threads");
  if (v) o.threads = parse_threads(*v);
  return v.has_value();
}

// Options only run takes.
bool take_run_option(ArgReader& r, Options& o) {
  if (take_threads(r, o)) return true;
  if (const auto v = r.take_value("--shard")) {
    o.shard = parse_shard(*v);
    return true;
  }
  return take_into(r, "--progress-file", "file name", o.progress_file);
}

// --server, --priority and --compare-with: the values submit checks.
bool take_submit_value(ArgReader& r, Options& o) {
  if (const auto v = r.take_value("--server")) {
    if (v->rfind("http://", 0) != 0 && v->rfind("https://", 0) != 0)
      throw UsageError("--server: expected http://HOST:PORT, got \"" + *v + "\"");
    o.server = *v;
  } else if (const auto p = r.take_value("--priority")) {
    o.priority = static_cast<int>(api::integer_option("--priority", *p, -1000, 1000));
  } else if (const auto j = r.take_value("--compare-with")) {
    if (!api::is_job_id(*j))
      throw UsageError("--compare-with: expected a job id (j_ and 16 hex digits), got \"" + *j +
                       "\"");
    o.compare_with = *j;
  } else {
    return false;
  }
  return true;
}

// Options of submit.
bool take_submit_option(ArgReader& r, Options& o) {
  if (take_into(r, "--out", "directory name", o.out) || take_units(r, o)) return true;
  if (take_submit_value(r, o)) return true;
  if (const auto v = r.take_value("--token-file")) {
    o.token_file = *v;
  } else if (const auto k = r.take_value("--idempotency-key")) {
    o.idempotency_key = *k;
  } else if (r.take_flag("--no-wait")) {
    o.wait = false;
  } else if (r.take_flag("--maps")) {
    o.maps = true;
  } else if (r.take_flag("--quiet", "-q")) {
    o.quiet = true;
  } else {
    return false;
  }
  return true;
}

// A length option's value: a finite number > 0.
bool take_metres(ArgReader& r, std::string_view name, std::optional<double>& dest) {
  const auto v = r.take_value(name);
  if (v) dest = api::number_option(name, *v, "a number", {0.0, true, kInfinity});
  return v.has_value();
}

// Options of export, site import, site export-gis, shape import and groups from-munition.
bool take_file_command_option(ArgReader& r, Options& o) {
  if (o.command == Command::kExport &&
      (take_metres(r, "--pixel-m", o.pixel_m) || take_metres(r, "--smoothing-m", o.smoothing_m) ||
       take_units(r, o)))
    return true;
  if (o.command == Command::kShapeImport) return take_into(r, "--axes", "axes", o.axes);
  return take_into(r, "--out", "file name", o.out);
}

// Options of report.
bool take_report_option(ArgReader& r, Options& o) {
  return take_units(r, o) || take_into(r, "--pdf", "file name", o.pdf) ||
         take_into(r, "--compare", "file name", o.compare) ||
         take_into(r, "--out", "file name", o.out);
}

// An option of o.command at the current word; false when it is none.
bool take_option(ArgReader& r, Options& o) {
  switch (o.command) {
    case Command::kRun: return take_run_output(r, o) || take_run_option(r, o);
    case Command::kMerge: return take_run_output(r, o);
    case Command::kCompare: return take_run_output(r, o) || take_threads(r, o);
    case Command::kSubmit: return take_submit_option(r, o);
    case Command::kReport: return take_report_option(r, o);
    case Command::kExport:
    case Command::kSiteImport:
    case Command::kSiteExportGis:
    case Command::kShapeImport:
    case Command::kGroupsFromMunition: return take_file_command_option(r, o);
    default: return false;
  }
}

// An operand: the scenario or input file, then merge's partial files or compare's variant.
void take_operand(ArgReader& r, Options& o) {
  if (r.at_option()) r.unknown_option();
  std::string a = r.take_operand();
  if (o.command == Command::kMerge && !o.scenario.empty()) {
    o.parts.push_back(std::move(a));
  } else if (o.command == Command::kCompare && !o.scenario.empty() && o.variant.empty()) {
    o.variant = std::move(a);
  } else if (!o.scenario.empty()) {
    throw UsageError("more than one scenario file (\"" + a + "\")");
  } else {
    o.scenario = std::move(a);
  }
}

// The command named by args[0] (and args[1] for "site ..."); returns the number of words it took.
std::size_t parse_command(const std::vector<std::string>& args, Options& o) {
  static const std::map<std::string, Command> commands = {
      {"run", Command::kRun},           {"validate", Command::kValidate},
      {"submit", Command::kSubmit},     {"export", Command::kExport},
      {"merge", Command::kMerge},       {"report", Command::kReport},
      {"compare", Command::kCompare},   {"--help", Command::kHelp},
      {"-h", Command::kHelp},           {"help", Command::kHelp},
      {"--version", Command::kVersion}, {"version", Command::kVersion}};
  const std::string& first = args[0];
  if (first == "site") {
    if (args.size() < 2 || (args[1] != "import" && args[1] != "export-gis"))
      throw UsageError(
          "site: expected \"site import IMPORT.json --out SITE.json\" or \"site export-gis "
          "SITE.json --out DIR\"");
    o.command = args[1] == "import" ? Command::kSiteImport : Command::kSiteExportGis;
    return 2;
  }
  if (first == "shape") {
    if (args.size() < 2 || args[1] != "import")
      throw UsageError("shape: expected \"shape import FILE [--axes y_up]\"");
    o.command = Command::kShapeImport;
    return 2;
  }
  if (first == "groups") {
    if (args.size() < 2 || args[1] != "from-munition")
      throw UsageError(
          "groups: expected \"groups from-munition MUNITION.json [--out GROUPS.json]\"");
    o.command = Command::kGroupsFromMunition;
    return 2;
  }
  const auto it = commands.find(first);
  if (it == commands.end()) throw UsageError("unknown command \"" + first + "\"");
  o.command = it->second;
  return 1;
}

// The operands and options each command needs.
void check_complete(const Options& o) {
  switch (o.command) {
    case Command::kReport:
      if (o.scenario.empty()) throw UsageError("report: missing RESULTS.h5");
      if (o.out.empty()) throw UsageError("report needs --out REPORT.html");
      return;
    case Command::kExport:
      if (o.scenario.empty()) throw UsageError("export: missing RESULTS.h5");
      if (o.out.empty()) throw UsageError("export needs --out DIR");
      return;
    case Command::kSiteExportGis:
      if (o.scenario.empty()) throw UsageError("site export-gis: missing SITE.json");
      if (o.out.empty()) throw UsageError("site export-gis needs --out DIR");
      return;
    case Command::kSiteImport:
      if (o.scenario.empty()) throw UsageError("site import: missing IMPORT.json");
      if (o.out.empty()) throw UsageError("site import needs --out SITE.json");
      return;
    case Command::kShapeImport:
      if (o.scenario.empty()) throw UsageError("shape import: missing FILE (.stl, .obj, .ply)");
      return;
    case Command::kGroupsFromMunition:
      if (o.scenario.empty()) throw UsageError("groups from-munition: missing MUNITION.json");
      return;
    default: break;
  }
  if (o.scenario.empty()) throw UsageError("missing SCENARIO.json");
  if (o.command == Command::kRun && o.out.empty()) throw UsageError("run needs --out DIR");
  if (o.command == Command::kCompare) {
    if (o.variant.empty()) throw UsageError("compare: missing VARIANT.json");
    if (o.out.empty()) throw UsageError("compare needs --out DIR");
  }
  if (o.command == Command::kMerge) {
    if (o.out.empty()) throw UsageError("merge needs --out DIR");
    if (o.parts.empty()) throw UsageError("merge: no partial files (PART.fsp ...)");
  }
  if (o.maps && o.out.empty()) throw UsageError("--maps needs --out DIR (the maps go to DIR/maps)");
}

}  // namespace

Options parse_args(const std::vector<std::string>& args) {
  Options o;
  if (args.empty()) throw UsageError("missing command");
  ArgReader r(args, parse_command(args, o));
  if (o.command == Command::kHelp || o.command == Command::kVersion) return o;
  while (!r.done()) {
    if (r.take_flag("--help", "-h")) {
      o.command = Command::kHelp;
      return o;
    }
    if (!take_option(r, o)) take_operand(r, o);
  }
  check_complete(o);
  return o;
}

namespace {

// The usage text in three parts: synopsis, commands, options.
constexpr char kSynopsis[] = R"(fragsim - Monte Carlo fragment throw over 3-D terrain

Usage:
  fragsim run SCENARIO.json --out DIR [--threads N] [--samples-scale X] [--quiet]
              [--shard I/N] [--progress-file FILE] [--units si|us]
  fragsim merge SCENARIO.json PART.fsp... --out DIR [--samples-scale X] [--quiet]
                [--units si|us]
  fragsim compare BASE.json VARIANT.json --out DIR [--threads N] [--samples-scale X]
                  [--quiet] [--units si|us]
  fragsim validate SCENARIO.json
  fragsim site import IMPORT.json --out SITE.json
  fragsim site export-gis SITE.json --out DIR
  fragsim shape import FILE [--axes z_up|y_up|x,-z,y]
  fragsim groups from-munition MUNITION.json [--out GROUPS.json]
  fragsim export RESULTS.h5 --out DIR [--pixel-m X] [--smoothing-m X] [--units si|us]
  fragsim report RESULTS.h5 --out REPORT.html [--pdf REPORT.pdf] [--units si|us]
                 [--compare COMPARE.json]
  fragsim submit SCENARIO.json [--server URL] [--token-file FILE] [--priority N]
                 [--idempotency-key KEY] [--compare-with JOB_ID] [--no-wait]
                 [--out DIR [--maps]] [--quiet]
                 [--units si|us]
  fragsim --version
  fragsim --help
An option's value follows it (--out DIR) or joins it (--out=DIR).

)";

constexpr char kCommands[] = R"(Commands:
  run        Validate the scenario, simulate it and write DIR/summary.json and DIR/results.h5.
             The files appear only when the run completes (Ctrl-C cancels: nothing is written).
  merge      Merge the partial files of `run --shard` (docs/cluster.md), in any order, into
             the outputs `run` writes: the figures are bit-identical to one process's run.
             Every shard 0..N-1 must be there once, from the same scenario and --samples-scale.
  compare    Paired what-if (docs/comparison.md): the same histories (same seed, groups and
             settings) flown over BASE's site and VARIANT's (which may change the site, its
             terrain, buildings and materials, and the atmosphere). Writes DIR/base/ and
             DIR/variant/ (each as `run` writes it) and DIR/compare.json and DIR/compare.h5:
             each figure's base and variant values and their difference with its paired
             standard error, far smaller than two independent runs' when the sites treat most
             fragments alike. Takes --threads, --samples-scale, --quiet and --units.
  validate   Check the scenario (JSON contract and site geometry) without running it.
  site import
             Build a site from GIS files (docs/gis.md): a DEM raster (GeoTIFF, DTED, ASCII
             grid, ...) or triangle-mesh terrain (STL, OBJ, PLY; a material per file or per
             group), building footprints (GeoPackage, shapefile, GeoJSON, ...) and material
             zones named in IMPORT.json, in a projected CRS. SITE.json is a site object as a
             scenario's "site" and POST /v1/sites take it; it is checked (and built) before it
             is written.
  site export-gis
             The inverse: a site (or a scenario's inline site) with a grid terrain and a CRS as
             DIR/terrain.tif, DIR/buildings.gpkg and DIR/import.json (which imports them back).
  shape import
             Print a scenario fragment "shape" from a mesh file (STL, OBJ, PLY; docs/gis.md):
             {"type": "polyhedron", "vertices_m": [...]}, the file's distinct vertices in the
             scenario's axes (--axes: z_up, the default; y_up for a y-up file, = x,-z,y; or
             three of x,-x,y,-y,z,-z), centred on their mean. Fragsim uses their convex hull.
  groups from-munition
             Fragment groups (a scenario's "fragment_groups" array) from a munition: case,
             charge, explosive (a built-in table or explicit sqrt(2E) and Mott constant) and
             polar spray zones (docs/scenario.md, "Fragment groups from a munition"): Gurney
             launch speed, Mott mass law, N0 = case mass / (2 mu), one group per zone. The
             derivation of every number goes to stderr; the groups to GROUPS.json (written
             only when the whole input is valid) or stdout.
  export     Write a run's results as GIS files into DIR (docs/gis.md): the PTN density as
             GeoTIFF (and in classes with a colour table), the hazardous area, buildings and
             HFD as GeoPackage, GeoJSON (RFC 7946) and KML, in the site's CRS / WGS 84, with
             a site-plan boundary: the envelope of the sector HFDs and a smoothed contour
             (closing radius --smoothing-m X, default 2 raster cells, at least 1 m).
  report     Write the study report of a run (docs/report.md): one self-contained HTML page
             (figures, tables, provenance, limitations, the normalised scenario; no network
             needed to view it) and, with --pdf, the same page as PDF printed by headless
             chromium. --units us shows ft, ft-lb, lb and densities per 600 ft² (SI stays
             in the files). Refuses a cancelled run's results. --compare COMPARE.json (of
             `fragsim compare`, whose base or variant this run is) adds the paired
             comparison to the Results section.
  submit     Run the scenario on a fragsimd server (docs/http-api.md): an inline site is
             uploaded first (POST /v1/sites) and the job names it by site_id; then the job's
             progress is followed and its summary printed (--out DIR also downloads
             summary.json and results.h5). Ctrl-C stops following; the job keeps running.

)";

constexpr char kOptions[] = R"(Options (run):
  --out DIR           Output directory (created if missing).
  --threads N         Worker threads; overrides settings.threads (0: all hardware threads).
                      Results do not depend on it.
  --samples-scale X   Multiply every group's samples (histories) by X, e.g. 0.1 for a quick look.
                      The real fragment counts are unchanged; standard errors grow.
  --quiet, -q         No progress and no report on success (errors still go to stderr).
  --shard I/N         Run only shard I (0-based) of N: of every group the histories
                      [floor(I n/N), floor((I+1) n/N)). Writes DIR/partial.fsp, for `merge`.
                      Not with settings.precision.
  --progress-file F   Keep F (JSON: state, histories_done, histories_total, elapsed_s) up to
                      date, rewritten whole about every 0.5 s; for batch systems and fragsimd.
  --units si|us       Units of the printed summary (run, merge, submit): si (default), or US
                      customary: ft, per 600 ft², sectors by bearing (docs/units.md). The files
                      stay SI. export --units us adds US fields (hfd_ft, ...) to the SI ones.

Options (submit):
  --server URL        fragsimd address (default http://127.0.0.1:8080).
  --token-file FILE   Bearer token: the first token in FILE (one per line, # comments).
  --priority N        Job priority in [-1000, 1000] (default 0; higher runs first).
  --idempotency-key K Resubmitting with the same key returns the same job.
  --compare-with J    Submit the scenario as the variant of a paired comparison with job J
                      (docs/comparison.md); prints the comparison, and --out also downloads
                      compare.json and compare.h5.
  --no-wait           Print the job id and return once the job is queued.
  --out DIR           Download summary.json and results.h5 into DIR when the job is done.
  --maps              With --out: also download the job's GIS maps (GET /v1/jobs/{id}/maps,
                      the files `fragsim export` writes) into DIR/maps.

Exit status: 0 success, 2 invalid input or command line (the message names the field),
             1 internal error (submit: server unreachable, job failed), 130 cancelled.
The scenario format is described in docs/scenario.md.
)";

}  // namespace

const char* usage_text() {
  static const std::string text = std::string(kSynopsis) + kCommands + kOptions;
  return text.c_str();
}

}  // namespace fragsim::app
