#pragma once
// The scenario contract: JSON ("schema": "fragsim.scenario/1", docs/scenario.md,
// api/schema/scenario.schema.json) <-> run::Scenario.
//
// Every problem throws fragsim::InputError(path, message) with the path of the offending value in
// the document's own names and indices: "fragment_groups[1].mass_kg.sigma: must be > 0",
// "site.terrain.grid.nx: expected integer, got string", "settings.integrater: unknown key (did
// you mean "integrator"?)". parse_* checks everything except geometry; validate_scenario adds the
// geometry checks of scene::Site::build (mesh indices, zero-area triangles, footprints), which
// report paths in the same style.
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "core/common/error.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::api {

inline constexpr const char* kScenarioSchema = "fragsim.scenario/1";

// Limits on values that are legal in principle but would exhaust a machine (or a daemon).
inline constexpr std::int64_t kMaxSamplesPerGroup = 1'000'000'000;
// settings.stratified_launch.replicates: nets per group and batch (each one chunk of work).
inline constexpr std::int64_t kMaxSobolReplicates = 4096;
inline constexpr std::int64_t kMaxRecordedFragments = 10'000'000;  // with record_fragments
inline constexpr std::int64_t kMaxPrecisionBatches = 1'000'000;    // settings.precision
// direction_importance: cells per group (the default 24 x 72 x 1 x 4 is 6,912), and the learning
// tables over all groups (docs/scenario.md, "Limits").
inline constexpr std::int64_t kMaxImportanceCells = 1 << 16;
inline constexpr std::int64_t kMaxImportanceTablesMB = 1024;
inline constexpr std::int64_t kMaxThreads = 1024;

// Material provenance the core does not need: kept so that outputs can say which inputs were
// marked illustrative.
struct MaterialNotes {
  bool illustrative = false;
  std::string source;
};

// A parsed scenario plus the parts of the document that are not simulation inputs.
struct ScenarioDocument {
  run::Scenario scenario;
  std::string description;
  std::map<std::string, MaterialNotes> material_notes;  // by material name; every material
  std::optional<std::string> site_id;  // the scenario named a stored site instead of an inline one
};

// Text that is not JSON (400 in the daemon, "malformed JSON at line L, column C: ...").
class MalformedJsonError : public InputError {
 public:
  using InputError::InputError;
};
// JSON nested deeper than the parser allows (field: the path where the limit was reached).
class JsonTooDeepError : public InputError {
 public:
  using InputError::InputError;
};

inline constexpr std::size_t kMaxJsonDepth = 64;

// Parses JSON text into a DOM with the errors above; a key given twice in one object ->
// InputError("<path>.<key>", "duplicate key"); a number that overflows a double ->
// InputError(path, "not finite").
nlohmann::json parse_json_text(std::string_view text, std::size_t max_depth = kMaxJsonDepth);

// Looks up a stored site by id (the daemon's registry): its site JSON, or null when unknown.
using SiteResolver = std::function<const nlohmann::json*(const std::string& site_id)>;

// A scenario names its site inline ("site") or, on the server, by "site_id"; without a resolver a
// site_id is refused ("site_id: refers to a site uploaded to fragsimd ...").
ScenarioDocument parse_scenario_document(const nlohmann::json& j,
                                         const SiteResolver* resolve = nullptr);
// Text: parse_json_text, then parse_scenario_document.
ScenarioDocument parse_scenario_document_text(std::string_view text);

run::Scenario parse_scenario(const nlohmann::json& j);
run::Scenario parse_scenario_text(std::string_view text);

// Full validation: the geometry checks of scene::Site::build on top of what parsing checked.
// Returns the built site so that a caller about to run does not build it twice.
std::shared_ptr<const scene::Site> validate_scenario(const run::Scenario& scenario);

// Normalised JSON (every default filled in, fixed distributions as plain numbers); parsing it
// gives back the same scenario. Used for provenance (results.h5 stores it).
nlohmann::json scenario_to_json(const run::Scenario& scenario);
nlohmann::json scenario_to_json(const ScenarioDocument& document);

}  // namespace fragsim::api
