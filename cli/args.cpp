#include "cli/args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>

#include "api/job_request.h"
#include "api/scenario_json.h"
#include "core/run/partial.h"

namespace fragsim::cli {

namespace {

// "--name value" or "--name=value"; advances k past what it consumed.
bool take_value(const std::vector<std::string>& args, std::size_t& k, const std::string& name,
                std::string& value) {
  const std::string& a = args[k];
  if (a == name) {
    if (k + 1 >= args.size()) throw UsageError(name + " needs a value");
    value = args[++k];
    return true;
  }
  if (a.rfind(name + "=", 0) == 0) {
    value = a.substr(name.size() + 1);
    return true;
  }
  return false;
}

// "--name value" whose value may not be empty ("--name: empty <what>"), into `dest`.
bool take_nonempty(const std::vector<std::string>& args, std::size_t& k, const std::string& name,
                   const char* what, std::string& dest) {
  std::string value;
  if (!take_value(args, k, name, value)) return false;
  if (value.empty()) throw UsageError(name + ": empty " + what);
  dest = value;
  return true;
}

int parse_threads(const std::string& v) {
  char* end = nullptr;
  const long n = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || n < 0 || n > api::kMaxThreads)
    throw UsageError("--threads: expected an integer in [0, " + std::to_string(api::kMaxThreads) +
                     "] (0: all hardware threads), got \"" + v + "\"");
  return static_cast<int>(n);
}

double parse_scale(const std::string& v) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !std::isfinite(x) || !(x > 0))
    throw UsageError("--samples-scale: expected a number > 0, got \"" + v + "\"");
  return x;
}

// "I/N" with 0 <= I < N <= run::kMaxShards.
ShardArg parse_shard(const std::string& v) {
  const auto slash = v.find('/');
  auto num = [&](const std::string& t, std::int64_t& out) {
    char* end = nullptr;
    errno = 0;
    const long long x = std::strtoll(t.c_str(), &end, 10);
    if (t.empty() || *end != '\0' || errno != 0 || t[0] < '0' || t[0] > '9') return false;
    out = x;
    return true;
  };
  ShardArg s;
  if (slash == std::string::npos || !num(v.substr(0, slash), s.index) ||
      !num(v.substr(slash + 1), s.count) || s.count < 1 || s.count > run::kMaxShards ||
      s.index >= s.count)
    throw UsageError("--shard: expected I/N with 0 <= I < N <= " + std::to_string(run::kMaxShards) +
                     ", got \"" + v + "\"");
  return s;
}

// --units si|us; true when args[k] was it (k advanced past its value).
bool take_units(const std::vector<std::string>& args, std::size_t& k, Options& o) {
  std::string value;
  if (!take_value(args, k, "--units", value)) return false;
  const auto units = api::parse_unit_system(value);
  if (!units) throw UsageError("--units: expected si or us, got \"" + value + "\"");
  o.units = *units;
  return true;
}

// The options run and merge share; true when args[k] was one (k advanced past its value).
bool take_run_output(const std::vector<std::string>& args, std::size_t& k, Options& o) {
  std::string value;
  if (take_nonempty(args, k, "--out", "directory name", o.out)) return true;
  if (take_units(args, k, o)) return true;
  if (take_value(args, k, "--samples-scale", value)) {
    o.samples_scale = parse_scale(value);
    return true;
  }
  if (args[k] == "--quiet" || args[k] == "-q") {
    o.quiet = true;
    return true;
  }
  return false;
}

// Options only run takes; true when args[k] was one (k advanced past its value).
bool take_run_option(const std::vector<std::string>& args, std::size_t& k, Options& o) {
  std::string value;
  if (take_value(args, k, "--threads", value)) {
    o.threads = parse_threads(value);
    return true;
  }
  if (take_value(args, k, "--shard", value)) {
    o.shard = parse_shard(value);
    return true;
  }
  return take_nonempty(args, k, "--progress-file", "file name", o.progress_file);
}

int parse_priority(const std::string& v) {
  char* end = nullptr;
  const long p = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || p < -1000 || p > 1000)
    throw UsageError("--priority: expected an integer in [-1000, 1000], got \"" + v + "\"");
  return static_cast<int>(p);
}

// Options of submit; true when args[k] was one (k advanced past its value).
bool take_submit_option(const std::vector<std::string>& args, std::size_t& k, Options& o) {
  const std::string& a = args[k];
  std::string value;
  if (take_nonempty(args, k, "--out", "directory name", o.out)) return true;
  if (take_units(args, k, o)) return true;
  if (take_value(args, k, "--server", value)) {
    if (value.rfind("http://", 0) != 0 && value.rfind("https://", 0) != 0)
      throw UsageError("--server: expected http://HOST:PORT, got \"" + value + "\"");
    o.server = value;
  } else if (take_value(args, k, "--token-file", value)) {
    o.token_file = value;
  } else if (take_value(args, k, "--priority", value)) {
    o.priority = parse_priority(value);
  } else if (take_value(args, k, "--idempotency-key", value)) {
    o.idempotency_key = value;
  } else if (take_value(args, k, "--compare-with", value)) {
    if (!api::is_job_id(value))
      throw UsageError("--compare-with: expected a job id (j_ and 16 hex digits), got \"" + value +
                       "\"");
    o.compare_with = value;
  } else if (a == "--no-wait") {
    o.wait = false;
  } else if (a == "--maps") {
    o.maps = true;
  } else if (a == "--quiet" || a == "-q") {
    o.quiet = true;
  } else {
    return false;
  }
  return true;
}

// A length option's value: a finite number > 0.
double positive_metres(const std::string& name, const std::string& value) {
  char* end = nullptr;
  const double x = std::strtod(value.c_str(), &end);
  if (value.empty() || *end != '\0' || !std::isfinite(x) || !(x > 0))
    throw UsageError(name + ": expected a number > 0, got \"" + value + "\"");
  return x;
}

// Options of export, site import and site export-gis; true when args[k] was one.
bool take_file_command_option(const std::vector<std::string>& args, std::size_t& k, Options& o) {
  std::string value;
  if (o.command == Command::kExport && take_value(args, k, "--pixel-m", value)) {
    o.pixel_m = positive_metres("--pixel-m", value);
    return true;
  }
  if (o.command == Command::kExport && take_value(args, k, "--smoothing-m", value)) {
    o.smoothing_m = positive_metres("--smoothing-m", value);
    return true;
  }
  if (o.command == Command::kExport && take_units(args, k, o)) return true;
  if (o.command == Command::kShapeImport) return take_nonempty(args, k, "--axes", "axes", o.axes);
  return take_nonempty(args, k, "--out", "file name", o.out);
}

// Options of report; true when args[k] was one.
bool take_report_option(const std::vector<std::string>& args, std::size_t& k, Options& o) {
  if (take_units(args, k, o)) return true;
  if (take_nonempty(args, k, "--pdf", "file name", o.pdf)) return true;
  if (take_nonempty(args, k, "--compare", "file name", o.compare)) return true;
  return take_nonempty(args, k, "--out", "file name", o.out);
}

// An option of o.command at args[k], or an operand (the scenario or input file, or merge's
// partial files); k is advanced past an option's value.
void take_argument(const std::vector<std::string>& args, std::size_t& k, Options& o) {
  const std::string& a = args[k];
  const bool is_option = a.size() > 1 && a[0] == '-';
  std::string value;
  switch (o.command) {
    case Command::kRun:
      if (take_run_output(args, k, o) || take_run_option(args, k, o)) return;
      break;
    case Command::kMerge:
      if (take_run_output(args, k, o)) return;
      if (!is_option && !o.scenario.empty()) {
        o.parts.push_back(a);
        return;
      }
      break;
    case Command::kCompare:
      if (take_run_output(args, k, o)) return;
      if (take_value(args, k, "--threads", value)) {
        o.threads = parse_threads(value);
        return;
      }
      if (!is_option && !o.scenario.empty() && o.variant.empty()) {
        o.variant = a;
        return;
      }
      break;
    case Command::kSubmit:
      if (take_submit_option(args, k, o)) return;
      break;
    case Command::kReport:
      if (take_report_option(args, k, o)) return;
      break;
    case Command::kExport:
    case Command::kSiteImport:
    case Command::kSiteExportGis:
    case Command::kShapeImport:
    case Command::kGroupsFromMunition:
      if (take_file_command_option(args, k, o)) return;
      break;
    default: break;
  }
  if (is_option) throw UsageError("unknown option \"" + a + "\"");
  if (!o.scenario.empty()) throw UsageError("more than one scenario file (\"" + a + "\")");
  o.scenario = a;
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
  const std::size_t first_argument = parse_command(args, o);
  if (o.command == Command::kHelp || o.command == Command::kVersion) return o;
  for (std::size_t k = first_argument; k < args.size(); ++k) {
    if (args[k] == "--help" || args[k] == "-h") {
      o.command = Command::kHelp;
      return o;
    }
    take_argument(args, k, o);
  }
  check_complete(o);
  return o;
}

const char* usage_text() {
  return R"(fragsim - Monte Carlo fragment throw over 3-D terrain

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

Commands:
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

Options (run):
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
}

}  // namespace fragsim::cli
