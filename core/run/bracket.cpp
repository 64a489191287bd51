// settings.ground_bracket (bracket.h; docs/physics.md, "The bracket").
#include "core/run/bracket.h"

#include <algorithm>
#include <cmath>

#include "core/common/error.h"

namespace fragsim::run {

namespace {

// A group's samples in a bracket run: samples x samples_scale, at least 1.
std::int64_t bracket_samples(const Scenario& sc, std::int64_t samples) {
  const double scale = sc.settings.ground_bracket->samples_scale;
  return std::max<std::int64_t>(1, std::llround(static_cast<double>(samples) * scale));
}

// The scenario a bracket run uses: no bracket of its own, no precision batches, no records, the
// groups' samples scaled.
Scenario variant_base(const Scenario& sc) {
  Scenario v = sc;
  v.settings.ground_bracket.reset();
  v.settings.precision.reset();
  v.settings.record_fragments = false;
  v.settings.record_trajectories = false;
  for (auto& g : v.groups) g.samples = bracket_samples(sc, g.samples);
  return v;
}

BracketFigures figures_of(const RunResult& r, double value) {
  BracketFigures f;
  f.value = value;
  f.hfd_m = r.hazardous_fragment_distance_m;
  f.hfd_lower_bound = r.site_boundary.hfd_cut;
  f.hfd_lower_m = r.hfd_lower_m;
  f.hfd_upper_m = r.hfd_upper_m;
  for (const BuildingResult& b : r.buildings) {
    f.building_impacts += b.impacts.mean;
    f.building_penetrations += b.penetrations.mean;
  }
  return f;
}

bool cancelled(const RunControl& control) {
  return control.cancel != nullptr && control.cancel->load();
}

// One run of `base` with the terrain material's `constant` set to `value`.
std::optional<BracketFigures> run_at(const Scenario& base, const std::string& constant,
                                     double value, const RunControl& control) {
  Scenario v = base;
  scene::MaterialSpec& m = v.site.materials.at(v.site.terrain.material);
  scene::set_material_constant(m, constant, value);
  RunControl quiet;
  quiet.cancel = control.cancel;
  const RunResult r = run(v, quiet);
  if (r.cancelled) return std::nullopt;
  return figures_of(r, value);
}

double swing(const BracketRow& row) {
  return std::abs(row.high.hfd_m - row.low.hfd_m);
}

}  // namespace

std::int64_t ground_bracket_histories(const Scenario& sc) {
  if (!sc.settings.ground_bracket) return 0;
  const auto it = sc.site.materials.find(sc.site.terrain.material);
  if (it == sc.site.materials.end()) return 0;
  std::int64_t per_run = 0;
  for (const auto& g : sc.groups) per_run += bracket_samples(sc, g.samples);
  const auto runs = static_cast<std::int64_t>(1 + 2 * scene::effective_ranges(it->second).size());
  return per_run * runs;  // <= 17 x 1e9 x groups: far from overflow
}

void check_ground_bracket(const Scenario& sc) {
  if (!sc.settings.ground_bracket) return;
  if (!sc.settings.bounce)
    throw InputError("settings.ground_bracket",
                     "needs settings.bounce: true (without bounce no ground constant is used)");
  const auto it = sc.site.materials.find(sc.site.terrain.material);
  if (it == sc.site.materials.end() || scene::effective_ranges(it->second).empty())
    throw InputError("settings.ground_bracket",
                     "the terrain material \"" + sc.site.terrain.material +
                         "\" has no ranges to run (give it `ranges`, or a fast_contact law)");
}

std::shared_ptr<const GroundBracket> run_ground_bracket(const Scenario& sc,
                                                        const RunControl& control) {
  check_ground_bracket(sc);
  auto out = std::make_shared<GroundBracket>();
  const Scenario base = variant_base(sc);
  const scene::MaterialSpec& m = base.site.materials.at(base.site.terrain.material);
  out->material = base.site.terrain.material;
  out->samples_scale = sc.settings.ground_bracket->samples_scale;
  for (const auto& g : base.groups) out->histories_per_run += g.samples;
  RunControl quiet;
  quiet.cancel = control.cancel;
  const RunResult nominal = run(base, quiet);
  out->cancelled = nominal.cancelled;
  if (out->cancelled) return out;
  out->nominal = figures_of(nominal, 0.0);
  for (const auto& [constant, range] : scene::effective_ranges(m)) {
    BracketRow row;
    row.constant = constant;
    row.nominal = *scene::material_constant(m, constant);
    const auto low = run_at(base, constant, range[0], control);
    const auto high = low ? run_at(base, constant, range[1], control) : std::nullopt;
    if (!low || !high || cancelled(control)) {
      out->cancelled = true;
      break;
    }
    row.low = *low;
    row.high = *high;
    out->rows.push_back(row);
  }
  std::stable_sort(out->rows.begin(), out->rows.end(),
                   [](const BracketRow& a, const BracketRow& b) { return swing(a) > swing(b); });
  return out;
}

}  // namespace fragsim::run
