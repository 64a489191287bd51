#include "cli/commands.h"

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
#include <mutex>
#include <sstream>

#include "api/output_dir.h"
#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "api/sha256.h"
#include "api/summary_json.h"
#include "core/common/error.h"
#include "core/run/precision.h"
#include "core/run/run.h"

namespace fragsim::cli {

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

// " batch 4: 7 of 9 targets met, ETA 35 s" (settings.precision).
std::string precision_progress(const run::PrecisionReport& r) {
  const auto met = std::count_if(r.targets.begin(), r.targets.end(),
                                 [](const run::TargetStatus& t) { return t.met; });
  std::string s = " batch " + std::to_string(r.batches) + ": " + std::to_string(met) + " of " +
                  std::to_string(r.targets.size()) + " targets met";
  if (!r.all_met) {
    char eta[64];
    if (std::isfinite(r.eta_s))
      std::snprintf(eta, sizeof eta, ", ETA %.0f s", r.eta_s);
    else
      std::snprintf(eta, sizeof eta, ", ETA unknown");
    s += eta;
  }
  return s;
}

// Progress on stderr, rewritten in place; only when stderr is a terminal.
class ProgressLine {
 public:
  // `enabled`: a line rewritten in place (a terminal). `batch_lines`: otherwise, one line per
  // batch boundary of a settings.precision run, at most one per progress interval (logs of
  // overnight runs show the way to the targets).
  ProgressLine(bool enabled, bool batch_lines) : enabled_(enabled), batch_lines_(batch_lines) {}
  ~ProgressLine() { finish(); }
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  void update(const run::Progress& p) {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (!enabled_) {
      if (batch_lines_ && p.precision && p.precision->batches != last_batch_) {
        last_batch_ = p.precision->batches;
        std::fprintf(stderr, "%lld histories, %.1f s:%s\n",
                     static_cast<long long>(p.precision->histories), p.elapsed_s,
                     precision_progress(*p.precision).c_str());
      }
      return;
    }
    const double pct = p.histories_total > 0 ? 100.0 * static_cast<double>(p.histories_done) /
                                                   static_cast<double>(p.histories_total)
                                             : 0.0;
    std::fprintf(stderr, "\r%5.1f%%  %lld / %lld histories  %.1f s ", pct,
                 static_cast<long long>(p.histories_done),
                 static_cast<long long>(p.histories_total), p.elapsed_s);
    if (p.precision) std::fputs((precision_progress(*p.precision) + "      ").c_str(), stderr);
    std::fflush(stderr);
    shown_ = true;
  }
  void finish() {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (shown_) std::fputc('\n', stderr);
    shown_ = false;
  }

 private:
  bool enabled_;
  bool batch_lines_;
  std::int64_t last_batch_ = 0;
  bool shown_ = false;
  std::mutex mutex_;
};

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
  std::cerr << illustrative_note(doc);
  return kExitOk;
}

int run_command(const Options& o, const std::atomic<bool>& cancel) {
  // Everything that can be wrong with the input is found before anything is created.
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const std::string text = read_file(o.scenario);
  api::ScenarioDocument doc = api::parse_scenario_document_text(text);
  apply_overrides(o, doc.scenario);
  const auto t1 = Clock::now();
  const auto site = api::validate_scenario(doc.scenario);  // builds the site
  const auto t2 = Clock::now();
  std::error_code ec;
  if (std::filesystem::exists(o.out, ec) && !std::filesystem::is_directory(o.out, ec))
    throw InputError("--out", o.out + " exists and is not a directory");

  api::Provenance provenance = api::build_provenance();
  provenance.scenario_sha256 = api::sha256_hex(text);
  if (!o.quiet) std::cerr << illustrative_note(doc);

  api::OutputDir out(o.out);  // removed again (if created here) unless commit() is reached
  ProgressLine progress(!o.quiet && ::isatty(STDERR_FILENO) == 1, !o.quiet);
  run::RunControl control;
  control.cancel = &cancel;
  control.on_progress = [&progress](const run::Progress& p) { progress.update(p); };
  run::RunResult result = run::run(doc.scenario, site, control);
  result.timing.parse_s = std::chrono::duration<double>(t1 - t0).count();
  result.timing.build_s = std::chrono::duration<double>(t2 - t1).count();
  progress.finish();
  if (result.cancelled || cancel.load()) {
    std::cerr << "cancelled: no output written\n";
    return kExitCancelled;
  }

  const nlohmann::ordered_json summary =
      api::stage_run_outputs(out, result, *site, doc, provenance);
  if (cancel.load()) {
    std::cerr << "cancelled: no output written\n";
    return kExitCancelled;
  }
  out.commit();

  if (!o.quiet) {
    std::cout << api::render_summary_text(summary) << "\nWrote "
              << (out.path() / "summary.json").string() << " and "
              << (out.path() / "results.h5").string() << "\n";
  }
  return kExitOk;
}

}  // namespace fragsim::cli
