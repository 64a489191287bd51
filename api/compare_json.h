#pragma once
// The JSON and HDF5 of a paired comparison (core/run/paired.h; docs/comparison.md):
//   compare.json  what changed, each figure's base and variant values and their difference with
//                 its paired and its unpaired standard error, and what limits them
//   compare.h5    the density difference per terrain triangle and its paired se (same terrain)
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "api/scenario_json.h"
#include "api/summary_json.h"
#include "api/units.h"
#include "core/run/paired.h"
#include "core/scene/site.h"

namespace fragsim::api {

inline constexpr int kCompareFormatVersion = 1;
inline constexpr const char* kCompareFileName = "compare.json";
inline constexpr const char* kCompareH5FileName = "compare.h5";

// What the variant changes, as scenario key paths ("site.buildings", "atmosphere", ...). Throws
// InputError naming the first key of `groups` or `settings` that differs: a variant may change
// anything but the fragment groups and the settings (threads and chunk_histories excepted, they
// change no result), so that its histories are the base's.
std::vector<std::string> check_variant(const nlohmann::json& base_scenario,
                                       const nlohmann::json& variant_scenario);

struct CompareInputs {
  const run::PairedRun* paired = nullptr;
  const run::Scenario* base = nullptr;
  const scene::Site* base_site = nullptr;
  std::vector<std::string> changed;  // check_variant's
  std::string base_sha256, variant_sha256;
  Provenance provenance;
};

nlohmann::ordered_json compare_to_json(const CompareInputs& in);

// compare.h5 (written at `path`, which must not exist).
void write_compare_h5(const std::filesystem::path& path, const run::PairedRun& paired,
                      const scene::Site& base_site, const nlohmann::ordered_json& compare);

// The comparison as a person reads it on a terminal (the HFD in `units`; counts have none).
std::string render_compare_text(const nlohmann::ordered_json& compare,
                                UnitSystem units = UnitSystem::kSi);

}  // namespace fragsim::api
