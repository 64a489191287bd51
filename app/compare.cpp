// `fragsim compare BASE.json VARIANT.json --out DIR` (docs/comparison.md).
#include <unistd.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "api/compare_json.h"
#include "api/run_outputs.h"
#include "api/sha256.h"
#include "app/commands.h"
#include "app/progress.h"
#include "core/common/error.h"
#include "core/run/paired.h"
#include "gis/results_export.h"

namespace fragsim::app {

namespace {

// The variant's scenario, its errors naming the variant's file: "VARIANT.json: field: ...".
PreparedRun prepare_variant(const Options& o) {
  Options vo = o;
  vo.scenario = o.variant;
  try {
    return prepare(vo);
  } catch (const InputError& e) {
    throw InputError(o.variant + (e.field().empty() ? "" : ": " + e.field()), e.message());
  }
}

std::unique_ptr<formats::OutputDir> open_dir(const std::filesystem::path& dir) {
  try {
    return std::make_unique<formats::OutputDir>(dir);
  } catch (const std::runtime_error& e) {
    throw InputError("--out", e.what());
  }
}

api::Provenance provenance_of(const PreparedRun& p) {
  api::Provenance provenance = api::build_provenance();
  provenance.scenario_sha256 = api::sha256_hex(p.text);
  return provenance;
}

void stage_run(formats::OutputDir& dir, run::RunResult& r, const PreparedRun& p) {
  r.timing.parse_s = p.parse_s;
  r.timing.build_s = p.build_s;
  api::stage_run_outputs(dir, r, *p.site, p.doc, provenance_of(p));
}

}  // namespace

int compare_command(const Options& o, const std::atomic<bool>& cancel) {
  const PreparedRun base = prepare(o);
  const PreparedRun variant = prepare_variant(o);
  std::vector<std::string> changed;
  try {
    changed =
        api::check_variant(api::scenario_to_json(base.doc), api::scenario_to_json(variant.doc));
    run::check_pairable(base.doc.scenario, variant.doc.scenario);
  } catch (const InputError& e) {
    throw InputError(o.variant + ": " + e.field(), e.message());
  }
  if (!o.quiet) {
    const std::string notes = input_notes(base), variant_notes = input_notes(variant);
    std::cerr << notes << (variant_notes == notes ? "" : variant_notes);
  }
  const auto root = open_out(o);
  const auto base_dir = open_dir(root->path() / "base");
  const auto variant_dir = open_dir(root->path() / "variant");
  ProgressLine progress(!o.quiet && ::isatty(STDERR_FILENO) == 1, false);
  run::RunControl control;
  control.cancel = &cancel;
  control.on_progress = [&](const run::Progress& pr) { progress.update(pr); };
  run::PairedRun paired =
      run::run_paired(base.doc.scenario, base.site, variant.doc.scenario, variant.site, control);
  progress.finish();
  if (paired.cancelled || cancel.load()) {
    std::cerr << "cancelled: no output written\n";
    return kExitCancelled;
  }
  stage_run(*base_dir, paired.base, base);
  stage_run(*variant_dir, paired.variant, variant);
  api::CompareInputs in;
  in.paired = &paired;
  in.base = &base.doc.scenario;
  in.base_site = base.site.get();
  in.changed = changed;
  in.base_sha256 = api::sha256_hex(base.text);
  in.variant_sha256 = api::sha256_hex(variant.text);
  in.provenance = api::build_provenance();
  const nlohmann::ordered_json compare = api::compare_to_json(in);
  if (cancel.load()) {
    std::cerr << "cancelled: no output written\n";
    return kExitCancelled;
  }
  // compare.json last: when it is there, both runs' files are (the map is made from them).
  base_dir->commit();
  variant_dir->commit();
  root->stage(api::kCompareH5FileName, [&](const std::filesystem::path& tmp) {
    api::write_compare_h5(tmp, paired, *base.site, compare);
  });
  root->commit();
  const auto dir = root->path();
  const bool map =
      gis::write_difference_map(dir / "base" / api::kResultsFileName, dir / api::kCompareH5FileName,
                                dir / gis::kDifferenceMapName);
  formats::OutputDir last(dir);
  last.stage_text(api::kCompareFileName, compare.dump(2) + "\n");
  last.commit();
  if (!o.quiet)
    std::cout << api::render_compare_text(compare, o.units) << "\nWrote " << root->path().string()
              << "/{compare.json, compare.h5, " << (map ? "density_difference.tif, " : "")
              << "base/, variant/}\n";
  return kExitOk;
}

}  // namespace fragsim::app
