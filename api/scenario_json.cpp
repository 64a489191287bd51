// The scenario document: schema tag, site, atmosphere, gravity, fragment groups, settings; text
// parsing (line/column of malformed JSON, duplicate keys); full validation; normalised output.
#include "api/scenario_json.h"

#include <algorithm>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "api/group_json.h"
#include "api/json_fields.h"
#include "api/limits.h"
#include "api/site_json.h"
#include "core/run/bracket.h"
#include "core/run/importance.h"

namespace fragsim::api {

namespace {

flight::AtmosphereSpec parse_atmosphere(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "atmosphere");
  flight::AtmosphereSpec a;
  const std::string model = o.string("model");
  if (model == "isa") {
    a.model = flight::AtmosphereSpec::Model::kIsa;
    for (const char* key : {"density_kg_m3", "sound_speed_mps"})
      if (o.has(key)) fail(o.at(key), "only used with model \"constant\"");
  } else if (model == "constant") {
    a.model = flight::AtmosphereSpec::Model::kConstant;
    a.density_kg_m3 = o.number_or("density_kg_m3", a.density_kg_m3);
    check_ge_le(a.density_kg_m3, 0.0, limits::kMaxAirDensity_kg_m3,
                o.at("density_kg_m3"));  // 0: vacuum
    a.sound_speed_mps = o.number_or("sound_speed_mps", a.sound_speed_mps);
    check_gt_le(a.sound_speed_mps, 0.0, limits::kMaxSoundSpeed_mps, o.at("sound_speed_mps"));
  } else {
    fail(o.at("model"), "must be \"isa\" or \"constant\" (got \"" + model + "\")");
  }
  a.wind_mps = o.vec3_or("wind_mps", a.wind_mps);
  check_abs_le(a.wind_mps, limits::kMaxWind_mps, o.at("wind_mps"));
  return a;
}

// settings.precision (docs/precision.md). Each target is optional; the building ids are checked
// against the site by the caller.
run::PrecisionSettings parse_precision(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "precision");
  run::PrecisionSettings p;
  auto fraction = [&o](const char* key, std::optional<double>& out) {
    out = o.optional_number(key);
    if (out) check_gt_le(*out, 0.0, 1.0, o.at(key));
  };
  p.hfd_half_band_m = o.optional_number("hfd_half_band_m");
  if (p.hfd_half_band_m) check_gt(*p.hfd_half_band_m, 0.0, o.at("hfd_half_band_m"));
  fraction("hfd_half_band_rel", p.hfd_half_band_rel);
  fraction("building_rel_error", p.building_rel_error);
  p.building_abs_error = o.optional_number("building_abs_error");
  if (p.building_abs_error) check_gt(*p.building_abs_error, 0.0, o.at("building_abs_error"));
  if (const Json* ids = o.find("buildings")) {
    const Json& a = read_array(*ids, o.at("buildings"));
    for (std::size_t k = 0; k < a.size(); ++k)
      p.buildings.push_back(read_string(a[k], index_path(o.at("buildings"), k)));
    if (!p.building_rel_error && !p.building_abs_error)
      fail(o.at("buildings"), "needs building_rel_error or building_abs_error");
  }
  fraction("ptn_rel_error_at_hfd", p.ptn_rel_error_at_hfd);
  p.max_batches = o.integer_or("max_batches", p.max_batches, 1, kMaxPrecisionBatches);
  p.min_batches =
      o.integer_or("min_batches", std::min(p.min_batches, p.max_batches), 1, p.max_batches);
  if (const Json* d = o.find("direction_importance")) {
    const ObjectReader r(*d, o.at("direction_importance"), "direction_importance");
    run::DirectionImportanceSettings di;
    di.elevation_cells =
        static_cast<int>(r.integer_or("elevation_cells", di.elevation_cells, 1, 90));
    di.azimuth_cells = static_cast<int>(r.integer_or("azimuth_cells", di.azimuth_cells, 1, 360));
    di.speed_cells = static_cast<int>(r.integer_or("speed_cells", di.speed_cells, 1, 16));
    di.mass_cells = static_cast<int>(r.integer_or("mass_cells", di.mass_cells, 1, 16));
    di.defensive_fraction = r.number_or("defensive_fraction", di.defensive_fraction);
    check_gt_le(di.defensive_fraction, 0.0, 1.0, r.at("defensive_fraction"));
    p.direction_importance = di;
  }
  p.max_wall_s = o.number_or("max_wall_s", p.max_wall_s);
  check_ge_le(p.max_wall_s, 0.0, 1e7, o.at("max_wall_s"));  // 0: none; 1e7 s is 16 weeks
  if (p.direction_importance && p.max_batches < 2)
    fail(o.at("max_batches"),
         "must be >= 2 with direction_importance (batch 0 is the pilot it learns from)");
  return p;
}

// What settings.precision needs from the rest of the scenario: the named buildings exist; every
// group has at least 2 histories per batch (a batch's standard error needs two); recorded
// fragments stay within their limit at the largest number of batches.
void check_precision(const run::Scenario& sc, std::int64_t total_samples) {
  const run::PrecisionSettings& p = *sc.settings.precision;
  for (std::size_t k = 0; k < p.buildings.size(); ++k) {
    const auto& bs = sc.site.buildings;
    if (std::none_of(bs.begin(), bs.end(), [&](const auto& b) { return b.id == p.buildings[k]; }))
      fail(index_path("settings.precision.buildings", k),
           "no building \"" + p.buildings[k] + "\" in the site");
  }
  for (std::size_t g = 0; g < sc.groups.size(); ++g)
    if (sc.groups[g].samples < 2)
      fail(index_path("fragment_groups", g) + ".samples",
           "must be >= 2 with settings.precision (the histories per batch; a batch's standard "
           "error needs two)");
  if (const auto& d = p.direction_importance) {
    // The importance sampler's learning tables grow with groups x cells x (buildings + distance
    // bins): bounded before anything is allocated from them.
    const double cells =
        static_cast<double>(d->elevation_cells) * d->azimuth_cells * d->speed_cells * d->mass_cells;
    const std::string at = "settings.precision.direction_importance";
    if (cells > static_cast<double>(kMaxImportanceCells))
      fail(at, "has " + std::to_string(static_cast<std::int64_t>(cells)) +
                   " cells per group (elevation x azimuth x speed x mass cells); at most " +
                   std::to_string(kMaxImportanceCells));
    const double mb =
        run::DirectionLearner::table_bytes(static_cast<double>(sc.groups.size()), cells,
                                           static_cast<double>(sc.site.buildings.size())) /
        1048576.0;
    if (mb > static_cast<double>(kMaxImportanceTablesMB))
      fail(at,
           "would need about " + std::to_string(static_cast<std::int64_t>(mb)) +
               " MB of learning tables (fragment groups x cells x (buildings + 300)); at most " +
               std::to_string(kMaxImportanceTablesMB) + " MB: use fewer cells");
  }
  if (sc.settings.record_fragments && total_samples > kMaxRecordedFragments / p.max_batches)
    fail("settings.record_fragments",
         "would record up to " + std::to_string(total_samples) + " x " +
             std::to_string(p.max_batches) + " histories with settings.precision (limit " +
             std::to_string(kMaxRecordedFragments) + "); turn it off or lower max_batches");
}

// settings.stratified_launch: every group has at least 2 histories (per batch), so that a stratum
// holds two; `speed` stratifies equal cells, so it cannot go with learnt ones.
void check_stratified_launch(const run::Scenario& sc) {
  const run::StratifiedLaunchSettings& sl = *sc.settings.stratified_launch;
  if (sl.method == run::LaunchStratification::kSobol) {
    for (std::size_t g = 0; g < sc.groups.size(); ++g)
      if (sc.groups[g].samples < sl.replicates)
        fail(index_path("fragment_groups", g) + ".samples",
             "must be >= settings.stratified_launch.replicates (" + std::to_string(sl.replicates) +
                 ") with method \"sobol\" (one net per replicate)");
    return;
  }
  for (std::size_t g = 0; g < sc.groups.size(); ++g)
    if (sc.groups[g].samples < 2)
      fail(index_path("fragment_groups", g) + ".samples",
           "must be >= 2 with settings.stratified_launch (a stratum's standard error needs two "
           "histories)");
  if (sc.settings.stratified_launch->speed && sc.settings.precision &&
      sc.settings.precision->direction_importance)
    fail("settings.stratified_launch.speed",
         "cannot be true with settings.precision.direction_importance (the strata follow its "
         "cells; give it speed_cells instead)");
}

// settings.stratified_launch: "strata" of u_cell (histories_per_stratum, speed) or "sobol" nets
// (replicates); a key of the other method is refused rather than ignored.
// `replicates` defaults to 16 in a one-batch run (15 degrees of freedom for its errors) and to 4
// with settings.precision, whose batches pool theirs (3 per batch) and whose larger nets gain
// more (docs/precision.md, "Choosing R").
run::StratifiedLaunchSettings parse_stratified_launch(const ObjectReader& r, bool precision) {
  run::StratifiedLaunchSettings sl;
  const std::string method = r.string_or("method", "strata");
  if (method == "sobol") {
    sl.method = run::LaunchStratification::kSobol;
    for (const char* k : {"histories_per_stratum", "speed"})
      if (r.find(k) != nullptr)
        fail(r.at(k), "applies to method \"strata\" only (method is \"sobol\")");
    sl.replicates = r.integer_or("replicates", precision ? 4 : 16, 2, kMaxSobolReplicates);
    return sl;
  }
  if (method != "strata")
    fail(r.at("method"), "must be \"strata\" or \"sobol\" (got \"" + method + "\")");
  if (r.find("replicates") != nullptr)
    fail(r.at("replicates"), "applies to method \"sobol\" only (method is \"strata\")");
  sl.histories_per_stratum =
      r.integer_or("histories_per_stratum", sl.histories_per_stratum, 2, kMaxSamplesPerGroup);
  sl.speed = r.bool_or("speed", sl.speed);
  return sl;
}

// settings.precision.min_batches when it is not given, with Sobol nets: a batch gives each figure
// only R - 1 degrees of freedom, so the first stop on targets waits for 12 of them in all (4
// batches at the default R = 4), where a standard error is good to about +-20 % rather than the
// +-30 % of the default 2 batches at 3 each (docs/precision.md, "Choosing R"). Other
// methods keep the default.
std::int64_t sobol_min_batches(const run::StratifiedLaunchSettings& sl,
                               const run::PrecisionSettings& p) {
  if (sl.method != run::LaunchStratification::kSobol) return p.min_batches;
  constexpr std::int64_t kMinDegreesOfFreedom = 12;
  const std::int64_t per_batch = sl.replicates - 1;
  const std::int64_t batches = (kMinDegreesOfFreedom + per_batch - 1) / per_batch;
  return std::min(std::max(p.min_batches, batches), p.max_batches);
}

run::Settings parse_settings(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "settings");
  run::Settings s;
  if (const Json* seed = o.find("seed")) s.seed = read_unsigned(*seed, o.at("seed"));
  s.person_height_m = o.number_or("person_height_m", s.person_height_m);
  check_gt_le(s.person_height_m, 0.0, limits::kMaxPersonHeight_m, o.at("person_height_m"));
  s.hazardous_ke_j = o.number_or("hazardous_ke_j", s.hazardous_ke_j);
  check_gt(s.hazardous_ke_j, 0.0, o.at("hazardous_ke_j"));
  s.hfd_threshold_per_m2 = o.number_or("hfd_threshold_per_m2", s.hfd_threshold_per_m2);
  check_gt(s.hfd_threshold_per_m2, 0.0, o.at("hfd_threshold_per_m2"));
  if (const Json* h = o.find("hfd_origin_m"))
    s.hfd_origin_m = read_position(*h, o.at("hfd_origin_m"));
  s.max_flight_time_s = o.number_or("max_flight_time_s", s.max_flight_time_s);
  check_gt_le(s.max_flight_time_s, 0.0, limits::kMaxFlightTime_s, o.at("max_flight_time_s"));
  if (const Json* integrator = o.find("integrator")) {
    const ObjectReader r(*integrator, o.at("integrator"), "integrator");
    s.rtol = r.number_or("rtol", s.rtol);
    check_in(s.rtol, 1e-12, 1e-2, r.at("rtol"));
    s.sagitta_m = r.number_or("sagitta_m", s.sagitta_m);
    check_gt(s.sagitta_m, 0.0, r.at("sagitta_m"));
  }
  s.bounce = o.bool_or("bounce", s.bounce);
  if (const Json* limits = o.find("bounce_limits")) {
    const ObjectReader r(*limits, o.at("bounce_limits"), "bounce_limits");
    s.min_rebound_speed_mps = r.number_or("min_rebound_speed_mps", s.min_rebound_speed_mps);
    check_ge_le(s.min_rebound_speed_mps, 0.0, limits::kMaxImpactSpeed_mps,
                r.at("min_rebound_speed_mps"));
    s.max_bounces = r.integer_or("max_bounces", s.max_bounces, 1, 1'000'000);
    s.max_ground_steps =
        r.integer_or("max_ground_steps", s.max_ground_steps, 1, limits::kMaxGroundSteps);
  }
  s.threads = static_cast<int>(o.integer_or("threads", s.threads, 0, kMaxThreads));
  s.chunk_histories = o.integer_or("chunk_histories", s.chunk_histories, 1, kMaxSamplesPerGroup);
  s.record_fragments = o.bool_or("record_fragments", s.record_fragments);
  s.record_trajectories = o.bool_or("record_trajectories", s.record_trajectories);
  s.max_recorded_trajectories =
      o.integer_or("max_recorded_trajectories", s.max_recorded_trajectories, 0, 1'000'000);
  s.profile = o.bool_or("profile", s.profile);
  if (const Json* p = o.find("precision")) s.precision = parse_precision(*p, o.at("precision"));
  if (const Json* l = o.find("stratified_launch")) {
    const ObjectReader r(*l, o.at("stratified_launch"), "stratified_launch");
    s.stratified_launch = parse_stratified_launch(r, s.precision.has_value());
    if (s.precision && !o.find("precision")->contains("min_batches"))
      s.precision->min_batches = sobol_min_batches(*s.stratified_launch, *s.precision);
  }
  if (const Json* b = o.find("ground_bracket")) {
    const ObjectReader r(*b, o.at("ground_bracket"), "ground_bracket");
    run::GroundBracketSettings gb;
    gb.samples_scale = r.number_or("samples_scale", gb.samples_scale);
    check_gt_le(gb.samples_scale, 0.0, 1.0, r.at("samples_scale"));
    s.ground_bracket = gb;
  }
  return s;
}

Json vec3_json(const Vec3& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

// `text` with what a terminal or a JSON error body should not receive raw written as \xNN:
// bytes that are not well-formed UTF-8, and control characters. nlohmann's parse errors quote
// the last bytes read ("last read: '\"\xff'"), which may be anything the input held.
std::string printable_utf8(std::string_view text) {
  std::string out;
  auto escape = [&out](unsigned char b) {
    static const char* const kHex = "0123456789abcdef";
    out += "\\x";
    out += kHex[b >> 4];
    out += kHex[b & 15];
  };
  for (std::size_t k = 0; k < text.size();) {
    const auto b = static_cast<unsigned char>(text[k]);
    // Length of the sequence a lead byte starts (0: not a lead byte; C0, C1, F5-FF never are).
    const std::size_t n = b < 0x80                ? 1
                          : b >= 0xc2 && b < 0xe0 ? 2
                          : b >= 0xe0 && b < 0xf0 ? 3
                          : b >= 0xf0 && b < 0xf5 ? 4
                                                  : 0;
    bool ok = n > 0 && k + n <= text.size();
    for (std::size_t i = 1; ok && i < n; ++i)
      ok = (static_cast<unsigned char>(text[k + i]) & 0xc0) == 0x80;
    if (ok && n == 3) {  // no overlong forms, no surrogates
      const auto b1 = static_cast<unsigned char>(text[k + 1]);
      ok = !(b == 0xe0 && b1 < 0xa0) && !(b == 0xed && b1 >= 0xa0);
    } else if (ok && n == 4) {  // no overlong forms, nothing beyond U+10FFFF
      const auto b1 = static_cast<unsigned char>(text[k + 1]);
      ok = !(b == 0xf0 && b1 < 0x90) && !(b == 0xf4 && b1 >= 0x90);
    }
    if (!ok || (n == 1 && (b < 0x20 || b == 0x7f))) {
      escape(b);
      ++k;
    } else {
      out.append(text.substr(k, n));
      k += n;
    }
  }
  return out;
}

// Builds the DOM through nlohmann's SAX interface, tracking the path of the value being parsed:
// a key given twice in one object (the DOM parser would keep the last silently) and a number
// that overflows a double ("1e999": the DOM parser throws without saying where) are reported at
// their path; syntax errors at their line and column.
class DomBuilder {
 public:
  DomBuilder(std::string_view text, std::size_t max_depth) : text_(text), max_depth_(max_depth) {}
  Json take() { return std::move(root_); }

  // SAX interface
  bool null() { return add(nullptr); }
  bool boolean(bool v) { return add(v); }
  bool number_integer(Json::number_integer_t v) { return add(v); }
  bool number_unsigned(Json::number_unsigned_t v) { return add(v); }
  bool number_float(Json::number_float_t v, const std::string& /*text*/) { return add(v); }
  bool string(Json::string_t& v) { return add(std::move(v)); }
  bool binary(Json::binary_t& v) { return add(Json::binary(std::move(v))); }
  bool start_object(std::size_t /*size*/) { return open(Json::object()); }
  bool start_array(std::size_t /*size*/) { return open(Json::array()); }
  bool end_object() { return close(); }
  bool end_array() { return close(); }
  bool key(Json::string_t& k) {
    Level& top = levels_.back();
    if (!top.keys.insert(k).second) fail(child_path(top.path, k), "duplicate key");
    top.key = k;
    return true;
  }
  bool parse_error(std::size_t position, const std::string& /*last_token*/,
                   const nlohmann::detail::exception& e) {
    if (e.id == 406) fail(next_path(), "not finite");  // number overflow
    // position: characters read, the offending one included.
    const std::size_t stop = std::min(position == 0 ? 0 : position - 1, text_.size());
    std::size_t line = 1, column = 1;
    for (std::size_t k = 0; k < stop; ++k) {
      if (text_[k] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    // what(): "[json.exception.parse_error.101] parse error at line L, column C: <reason>".
    std::string reason = e.what();
    if (const auto c = reason.find("column "); c != std::string::npos) {
      if (const auto colon = reason.find(": ", c); colon != std::string::npos)
        reason = reason.substr(colon + 2);
    }
    throw MalformedJsonError("", "malformed JSON at line " + std::to_string(line) + ", column " +
                                     std::to_string(column) + ": " + printable_utf8(reason));
  }

 private:
  struct Level {
    Json* value;
    std::string path;
    std::string key;  // objects: the key whose value comes next
    std::set<std::string> keys;
  };

  // Path of the value about to be added.
  std::string next_path() const {
    if (levels_.empty()) return "";
    const Level& top = levels_.back();
    return top.value->is_array() ? index_path(top.path, top.value->size())
                                 : child_path(top.path, top.key);
  }
  Json* place(Json&& v) {
    if (levels_.empty()) {
      root_ = std::move(v);
      return &root_;
    }
    Level& top = levels_.back();
    if (top.value->is_array()) {
      top.value->push_back(std::move(v));
      return &top.value->back();
    }
    Json& slot = (*top.value)[top.key];
    slot = std::move(v);
    return &slot;
  }
  bool add(Json&& v) {
    place(std::move(v));
    return true;
  }
  bool open(Json&& container) {
    std::string path = next_path();
    if (levels_.size() >= max_depth_)
      throw JsonTooDeepError(path, "nested deeper than " + std::to_string(max_depth_) + " levels");
    levels_.push_back({place(std::move(container)), std::move(path), {}, {}});
    return true;
  }
  bool close() {
    levels_.pop_back();
    return true;
  }

  std::string_view text_;
  std::size_t max_depth_;
  Json root_;
  std::vector<Level> levels_;
};

}  // namespace

Json parse_json_text(std::string_view text, std::size_t max_depth) {
  DomBuilder builder(text, max_depth);
  Json::sax_parse(text.begin(), text.end(), &builder);
  return builder.take();
}

ScenarioDocument parse_scenario_document(const nlohmann::json& j, const SiteResolver* resolve) {
  if (!j.is_object()) fail("", "expected a JSON object at the top level, got " + json_type_name(j));
  // The format tag first: a document of another version fails on that, not on its new keys.
  const auto tag = j.find("schema");
  if (tag == j.end()) fail("schema", "is required");
  const std::string schema = read_string(*tag, "schema");
  if (schema != kScenarioSchema)
    fail("schema", std::string("must be \"") + kScenarioSchema + "\" (got \"" + schema + "\")");
  const ObjectReader o(j, "", "scenario");

  ScenarioDocument doc;
  doc.description = o.string_or("description", "");
  run::Scenario& sc = doc.scenario;
  if (const Json* id = o.find("site_id")) {
    const std::string site_id = read_string(*id, "site_id");
    if (o.has("site")) fail("site_id", "give either an inline site or a site_id, not both");
    if (resolve == nullptr || !*resolve)
      fail("site_id",
           "refers to a site uploaded to fragsimd; a scenario run without the server needs an "
           "inline \"site\"");
    const Json* site = (*resolve)(site_id);
    if (site == nullptr) fail("site_id", "unknown site \"" + site_id + "\"");
    sc.site = detail::parse_site(*site, "site", doc.material_notes);
    doc.site_id = site_id;
  } else {
    sc.site = detail::parse_site(o.require("site"), "site", doc.material_notes);
  }
  if (const Json* a = o.find("atmosphere")) sc.atmosphere = parse_atmosphere(*a, "atmosphere");
  sc.gravity_mps2 = o.number_or("gravity_mps2", sc.gravity_mps2);
  check_ge_le(sc.gravity_mps2, 0.0, limits::kMaxGravity_mps2, "gravity_mps2");

  const Json& groups = read_array(o.require("fragment_groups"), "fragment_groups");
  if (groups.empty())
    fail("fragment_groups", "must not be empty (give at least one fragment group)");
  std::int64_t total_samples = 0;
  for (std::size_t k = 0; k < groups.size(); ++k) {
    sc.groups.push_back(detail::parse_fragment_group(groups[k], index_path("fragment_groups", k)));
    total_samples += sc.groups.back().samples;  // <= 1e9 each: no overflow for any real count
  }

  if (const Json* s = o.find("settings")) sc.settings = parse_settings(*s, "settings");
  if (sc.settings.precision) check_precision(sc, total_samples);
  run::check_ground_bracket(sc);
  if (sc.settings.stratified_launch) check_stratified_launch(sc);
  if (sc.settings.record_fragments && total_samples > kMaxRecordedFragments)
    fail("settings.record_fragments",
         "would record " + std::to_string(total_samples) + " histories (limit " +
             std::to_string(kMaxRecordedFragments) + "); turn it off or lower the samples");
  return doc;
}

ScenarioDocument parse_scenario_document_text(std::string_view text) {
  return parse_scenario_document(parse_json_text(text));
}

run::Scenario parse_scenario(const nlohmann::json& j) {
  return parse_scenario_document(j).scenario;
}

run::Scenario parse_scenario_text(std::string_view text) {
  return parse_scenario_document_text(text).scenario;
}

std::shared_ptr<const scene::Site> validate_scenario(const run::Scenario& scenario) {
  return scene::Site::build(scenario.site);
}

namespace {

Json precision_json(const run::PrecisionSettings& p) {
  Json j = Json::object();
  auto put = [&j](const char* key, const std::optional<double>& v) {
    if (v) j[key] = *v;
  };
  put("hfd_half_band_m", p.hfd_half_band_m);
  put("hfd_half_band_rel", p.hfd_half_band_rel);
  put("building_rel_error", p.building_rel_error);
  put("building_abs_error", p.building_abs_error);
  if (!p.buildings.empty()) j["buildings"] = p.buildings;
  put("ptn_rel_error_at_hfd", p.ptn_rel_error_at_hfd);
  j["min_batches"] = p.min_batches;
  j["max_batches"] = p.max_batches;
  j["max_wall_s"] = p.max_wall_s;
  if (const auto& d = p.direction_importance)
    j["direction_importance"] = {{"elevation_cells", d->elevation_cells},
                                 {"azimuth_cells", d->azimuth_cells},
                                 {"speed_cells", d->speed_cells},
                                 {"mass_cells", d->mass_cells},
                                 {"defensive_fraction", d->defensive_fraction}};
  return j;
}

Json scenario_json(const run::Scenario& sc, const std::string& description,
                   const std::map<std::string, MaterialNotes>* notes) {
  Json out = {{"schema", kScenarioSchema}};
  if (!description.empty()) out["description"] = description;
  out["site"] = detail::site_to_json(sc.site, notes);

  Json atmosphere;
  if (sc.atmosphere.model == flight::AtmosphereSpec::Model::kConstant) {
    atmosphere = {{"model", "constant"},
                  {"density_kg_m3", sc.atmosphere.density_kg_m3},
                  {"sound_speed_mps", sc.atmosphere.sound_speed_mps}};
  } else {
    atmosphere = {{"model", "isa"}};
  }
  atmosphere["wind_mps"] = vec3_json(sc.atmosphere.wind_mps);
  out["atmosphere"] = std::move(atmosphere);
  out["gravity_mps2"] = sc.gravity_mps2;

  Json groups = Json::array();
  for (const auto& g : sc.groups) groups.push_back(detail::fragment_group_to_json(g));
  out["fragment_groups"] = std::move(groups);

  const run::Settings& s = sc.settings;
  Json settings = {
      {"seed", s.seed},
      {"person_height_m", s.person_height_m},
      {"hazardous_ke_j", s.hazardous_ke_j},
      {"hfd_threshold_per_m2", s.hfd_threshold_per_m2},
      {"max_flight_time_s", s.max_flight_time_s},
      {"integrator", {{"rtol", s.rtol}, {"sagitta_m", s.sagitta_m}}},
      {"bounce", s.bounce},
      {"bounce_limits",
       {{"min_rebound_speed_mps", s.min_rebound_speed_mps},
        {"max_bounces", s.max_bounces},
        {"max_ground_steps", s.max_ground_steps}}},
      {"threads", s.threads},
      {"chunk_histories", s.chunk_histories},
      {"record_fragments", s.record_fragments},
      {"record_trajectories", s.record_trajectories},
      {"max_recorded_trajectories", s.max_recorded_trajectories},
      {"profile", s.profile},
  };
  if (s.hfd_origin_m) settings["hfd_origin_m"] = vec3_json(*s.hfd_origin_m);
  if (s.precision) settings["precision"] = precision_json(*s.precision);
  if (const auto& l = s.stratified_launch) {
    if (l->method == run::LaunchStratification::kSobol)
      settings["stratified_launch"] = {{"method", "sobol"}, {"replicates", l->replicates}};
    else
      settings["stratified_launch"] = {{"method", "strata"},
                                       {"histories_per_stratum", l->histories_per_stratum},
                                       {"speed", l->speed}};
  }
  if (const auto& b = s.ground_bracket)
    settings["ground_bracket"] = {{"samples_scale", b->samples_scale}};
  out["settings"] = std::move(settings);
  return out;
}

}  // namespace

nlohmann::json scenario_to_json(const run::Scenario& scenario) {
  return scenario_json(scenario, "", nullptr);
}

nlohmann::json scenario_to_json(const ScenarioDocument& document) {
  return scenario_json(document.scenario, document.description, &document.material_notes);
}

}  // namespace fragsim::api
