#include "app/commands.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "api/sha256.h"
#include "api/summary_json.h"
#include "app/progress.h"
#include "core/common/error.h"
#include "core/run/partial.h"
#include "core/run/precision.h"
#include "core/run/reach.h"
#include "core/run/run.h"
#include "formats/output_dir.h"
#include "formats/partial_file.h"

namespace fragsim::app {

std::string read_file(const std::string& path, const std::string& field) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(field, "cannot read " + path + ": " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(field, "cannot read " + path + ": " + std::strerror(errno));
  return text.str();
}

namespace {

// Materials whose thresholds the scenario itself marks as illustrative (not for decisions).
std::string illustrative_note(const api::ScenarioDocument& doc) {
  std::string names;
  for (const auto& [name, notes] : doc.material_notes) {
    if (!notes.illustrative) continue;
    names += names.empty() ? name : ", " + name;
  }
  return names.empty() ? "" : "note: materials marked illustrative: " + names + "\n";
}

// Fragment groups that can reach beyond the terrain (core/run/reach.h): a "warning:" line each
// when plain, a "note:" line when a single pilot fragment got there. The input is valid all
// the same.
std::string reach_warnings(const run::Scenario& sc, const scene::Site& site) {
  std::string text;
  for (const run::ReachWarning& w : run::groups_beyond_terrain(sc, site))
    text += std::string(w.severity()) + ": " + run::reach_message(w) + "\n";
  return text;
}

const char* terrain_form(const scene::TerrainSpec& t) {
  switch (t.geometry.index()) {
    case 0: return "plane";
    case 1: return "grid";
    default: return "mesh";
  }
}

// --threads and --samples-scale act on the parsed scenario; the recorded scenario JSON shows them.
void apply_overrides(const Options& o, run::Scenario& sc) {
  if (o.threads) sc.settings.threads = *o.threads;
  if (!o.samples_scale) return;
  std::int64_t total = 0;
  for (auto& g : sc.groups) {
    const double scaled = std::round(static_cast<double>(g.samples) * *o.samples_scale);
    if (scaled > static_cast<double>(api::kMaxSamplesPerGroup))
      throw InputError("--samples-scale", "gives more than " +
                                              std::to_string(api::kMaxSamplesPerGroup) +
                                              " samples for group \"" + g.name + "\"");
    g.samples = std::max<std::int64_t>(1, static_cast<std::int64_t>(scaled));
    total += g.samples;
  }
  if (sc.settings.record_fragments && total > api::kMaxRecordedFragments)
    throw InputError("--samples-scale", "would record " + std::to_string(total) +
                                            " histories with settings.record_fragments (limit " +
                                            std::to_string(api::kMaxRecordedFragments) + ")");
}

}  // namespace

int validate_command(const Options& o) {
  const std::string text = read_file(o.scenario);
  const api::ScenarioDocument doc = api::parse_scenario_document_text(text);
  const auto site = api::validate_scenario(doc.scenario);
  const run::Scenario& sc = doc.scenario;
  std::int64_t samples = 0;
  double fragments = 0.0;
  for (const auto& g : sc.groups) {
    samples += g.samples;
    fragments += g.count;
  }
  std::cout << "ok: " << o.scenario << "\n"
            << "  site: " << terrain_form(sc.site.terrain) << " terrain ("
            << site->terrain_triangle_count() << " triangles), " << site->buildings().size()
            << (site->buildings().size() == 1 ? " building, " : " buildings, ")
            << sc.site.materials.size() << " materials\n"
            << "  fragment groups: " << sc.groups.size() << " (" << samples << " samples, "
            << fragments << " real fragments)\n";
  std::cerr << illustrative_note(doc) << reach_warnings(sc, *site);
  return kExitOk;
}

std::string input_notes(const PreparedRun& p) {
  return illustrative_note(p.doc) + reach_warnings(p.doc.scenario, *p.site);
}

formats::PartialIdentity identity_of(const Options& o, const PreparedRun& p) {
  return {api::sha256_hex(p.text), o.samples_scale.value_or(1.0)};
}

PreparedRun prepare(const Options& o) {
  return prepare_text(o, read_file(o.scenario));
}

PreparedRun prepare_text(const Options& o, std::string text) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  PreparedRun p;
  p.text = std::move(text);
  p.doc = api::parse_scenario_document_text(p.text);
  apply_overrides(o, p.doc.scenario);
  const auto t1 = Clock::now();
  p.site = api::validate_scenario(p.doc.scenario);  // builds the site
  p.parse_s = std::chrono::duration<double>(t1 - t0).count();
  p.build_s = std::chrono::duration<double>(Clock::now() - t1).count();
  std::error_code ec;
  if (std::filesystem::exists(o.out, ec) && !std::filesystem::is_directory(o.out, ec))
    throw InputError("--out", o.out + " exists and is not a directory");
  return p;
}

std::unique_ptr<formats::OutputDir> open_out(const Options& o) {
  try {
    return std::make_unique<formats::OutputDir>(o.out);
  } catch (const std::runtime_error& e) {
    throw InputError("--out", e.what());
  }
}

int write_outputs(const Options& o, const PreparedRun& p, run::RunResult& result,
                  const std::atomic<bool>& cancel, formats::OutputDir& out) {
  result.timing.parse_s = p.parse_s;
  result.timing.build_s = p.build_s;
  api::Provenance provenance = api::build_provenance();
  provenance.scenario_sha256 = api::sha256_hex(p.text);
  const nlohmann::ordered_json summary =
      api::stage_run_outputs(out, result, *p.site, p.doc, provenance);
  if (cancel.load()) {
    std::cerr << "cancelled: no output written\n";
    return kExitCancelled;
  }
  out.commit();
  if (!o.quiet) {
    std::cout << api::render_summary_text(summary, o.units) << "\nWrote "
              << (out.path() / "summary.json").string() << " and "
              << (out.path() / "results.h5").string() << "\n";
  }
  return kExitOk;
}

int write_partial(const Options& o, const PreparedRun& p, const run::PartialRun& part,
                  formats::OutputDir& out) {
  out.stage("partial.fsp", [&](const std::filesystem::path& tmp) {
    formats::write_partial_file(tmp, part, identity_of(o, p));
  });
  out.commit();
  if (!o.quiet)
    std::cout << "Shard " << o.shard->index << " of " << o.shard->count << ": "
              << part.histories_done << " histories in " << part.wall_s << " s\nWrote "
              << (out.path() / "partial.fsp").string() << "\n";
  return kExitOk;
}

int run_command(const Options& o, const std::atomic<bool>& cancel) {
  // Everything that can be wrong with the input is found before anything is created.
  ProgressFile progress_file(o.progress_file);
  try {
    const PreparedRun p = prepare(o);
    if (o.shard && o.shard->count > 1 && p.doc.scenario.settings.precision)
      throw InputError("settings.precision",
                       "cannot be split into shards (--shard I/N with N > 1): its checks at batch "
                       "boundaries need every history of a batch in one process (--shard 0/1 "
                       "runs it whole as one partial)");
    if (!o.quiet) std::cerr << input_notes(p);
    // Created before the run, so that an --out that cannot be made fails now, not after it; it
    // is removed again (if created here) unless the outputs are committed.
    const std::unique_ptr<formats::OutputDir> out = open_out(o);
    ProgressLine progress(!o.quiet && ::isatty(STDERR_FILENO) == 1, !o.quiet);
    run::RunControl control;
    control.cancel = &cancel;
    control.on_progress = [&](const run::Progress& pr) {
      progress.update(pr);
      progress_file.update(pr);
    };
    const run::Shard shard = o.shard ? run::Shard{o.shard->index, o.shard->count} : run::Shard{};
    run::PartialRun part = run::run_partial(p.doc.scenario, p.site, shard, control);
    progress.finish();
    if (part.cancelled || cancel.load()) {
      std::cerr << "cancelled: no output written\n";
      progress_file.finish("cancelled");
      return kExitCancelled;
    }
    int code = kExitOk;
    if (o.shard) {
      code = write_partial(o, p, part, *out);
    } else {
      if (p.doc.scenario.settings.ground_bracket && !o.quiet)
        std::cerr << "settings.ground_bracket: running the bracket of the ground constants\n";
      run::RunControl bracket_control;
      bracket_control.cancel = &cancel;
      run::RunResult result =
          run::finish(p.doc.scenario, *p.site, std::move(part), bracket_control);
      if ((result.ground_bracket && result.ground_bracket->cancelled) || cancel.load()) {
        std::cerr << "cancelled: no output written\n";
        progress_file.finish("cancelled");
        return kExitCancelled;
      }
      code = write_outputs(o, p, result, cancel, *out);
    }
    progress_file.finish(code == kExitOk ? "done" : "cancelled");
    return code;
  } catch (...) {
    progress_file.finish("failed");
    throw;
  }
}

int merge_command(const Options& o, const std::atomic<bool>& cancel) {
  const PreparedRun p = prepare(o);
  const formats::PartialIdentity expected = identity_of(o, p);
  const std::size_t bins = run::tally_bins(p.doc.scenario, *p.site).total;
  std::optional<run::PartialRun> merged;
  for (const std::string& path : o.parts) {
    formats::PartialIdentity id;
    run::PartialRun part = formats::read_partial_file(path, bins, id);
    if (id.scenario_sha256 != expected.scenario_sha256)
      throw InputError(path, "a shard of another scenario file (its SHA-256 is " +
                                 id.scenario_sha256 + ", " + o.scenario + "'s " +
                                 expected.scenario_sha256 + ")");
    if (id.samples_scale != expected.samples_scale)
      throw InputError(path, "a shard run with another --samples-scale");
    if (part.cancelled)  // `fragsim run --shard` writes nothing when cancelled
      throw InputError(path,
                       "the partial of a cancelled shard, which fragsim never writes "
                       "(a damaged or forged file): nothing to merge");
    if (!merged) {
      merged = std::move(part);
      continue;
    }
    try {
      run::merge(*merged, std::move(part));
    } catch (const InputError& e) {
      throw InputError(path, e.message());
    }
  }
  run::RunResult result = run::finish(p.doc.scenario, *p.site, std::move(*merged));
  return write_outputs(o, p, result, cancel, *open_out(o));
}

}  // namespace fragsim::app
