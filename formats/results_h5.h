#pragma once
// results.h5: the full fields of one run (HDF5, C API). Layout (docs/scenario.md, "results.h5"):
//
//   /                      attributes: file_type "fragsim.results", format_version (below),
//                          fragsim_version, git_sha, seed, samples, histories_done,
//                          real_fragments, cancelled, scenario_json, summary_json and machine
//                          (format 5), created_utc, wall_s, threads
//   /terrain/              vertices_m (n x 3, input coordinates), triangles (m x 3 uint32),
//                          area_m2 (m)
//   /ptn/                  density_per_m2 (m), std_error_per_m2 (m)
//   /hfd/                  hazardous_fragment_distance_m, band_m (2), by_sector_m (36),
//                          origin_m (3), threshold_per_m2
//   /hfd/attribution/      what sets the HFD (core/run/attribution.h): mechanism_names (3),
//                          group_names (g); by_mechanism/ and by_group/ (omitted when the
//                          attribute by_group_omitted_reason says why): hfd_m (k), band_m
//                          (k x 2), by_sector_m (k x 36), bound, band_bound, by_sector_bound;
//                          at_hfd/: triangle, distance_m, density_per_m2 (37: the HFD's, then
//                          sector k's), share_by_mechanism (37 x 3), share_by_group (37 x g)
//   /buildings/            id (strings), expected_impacts, impacts_std_error,
//                          expected_penetrations, penetrations_std_error (n),
//                          *_by_surface (n x 4: terrain, wall, roof, window), residual_ke_j,
//                          residual_ke_std_error_j, surface_area_m2 (n x 4), vertices_m,
//                          triangles, triangle_building, triangle_surface
//   /outcomes/             name, histories, fragments, fragments_std_error (one row per outcome)
//   /fragments/            (settings.record_fragments) one dataset per FragmentRecord field
//   /trajectories/         (settings.record_trajectories) group, history, offsets (k + 1),
//                          t_s (N), position_m (N x 3): points of trajectory i are
//                          offsets[i] .. offsets[i+1]
//
// Datasets depend only on the RunResult, the site and the scenario, so identical runs give
// bit-identical datasets (timing and the creation time are attributes).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/run/result.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::formats {

inline constexpr const char* kResultsFileType = "fragsim.results";
// 2: /hfd/bound, band_bound, by_sector_bound, boundary_* and left_site_hazardous_* (where the
// terrain's boundary cuts the HFD), the root attribute hfd_bound.
// 3: /hfd/attribution (what sets the HFD: by mechanism, by group, shares at its triangles);
// /ground_bracket with settings.ground_bracket (rows: constants, widest HFD swing first;
// columns: the low and high end).
// 4: /terrain/material (each triangle's material, an index into /terrain/material_names).
// 5: the root attributes summary_json (summary.json's figures, compact) and machine (host, CPU,
// kernel: api/machine.h), read by `fragsim report`.
inline constexpr int kResultsFormatVersion = 5;

// What results.h5 records beside the run's figures: who wrote it and the contract's texts. The
// caller makes them (api::results_texts, api/run_outputs.h), so that the file format does not
// depend on the JSON contract.
struct ResultsTexts {
  std::string version;                         // fragsim version (fragsim/version.h)
  std::string git_sha;                         // of the build
  std::optional<std::string> scenario_sha256;  // of the scenario file as read, when there is one
  std::string scenario_json;                   // the normalised scenario
  std::string summary_json;                    // summary.json's figures, compact
  std::string hfd_note;     // when the terrain's boundary cuts the HFD (else empty)
  std::string created_utc;  // ISO 8601
  std::string machine;      // host, CPU, kernel (api/machine.h)
};

// Writes a new file at `path` (fails if it exists). Throws std::runtime_error on HDF5 errors and
// std::logic_error when the result does not fit the site (PTN values != terrain triangles).
void write_results_h5(const std::filesystem::path& path, const run::RunResult& result,
                      const scene::Site& site, const run::Scenario& scenario,
                      const ResultsTexts& texts);

// ---- Readers (tests, tools). Throw std::runtime_error naming the file and object. ----

// Every dataset in the file, as absolute paths ("/ptn/density_per_m2"), sorted.
std::vector<std::string> list_datasets(const std::filesystem::path& path);
// Dimensions (empty for a scalar dataset).
std::vector<std::uint64_t> dataset_shape(const std::filesystem::path& path,
                                         const std::string& name);
// Values converted to the requested type (row-major).
std::vector<double> read_dataset_double(const std::filesystem::path& path, const std::string& name);
std::vector<std::int64_t> read_dataset_int64(const std::filesystem::path& path,
                                             const std::string& name);
std::vector<std::string> read_dataset_strings(const std::filesystem::path& path,
                                              const std::string& name);
// The stored bytes, in the dataset's own (file) type.
std::vector<unsigned char> read_dataset_raw(const std::filesystem::path& path,
                                            const std::string& name);

std::string read_attribute_string(const std::filesystem::path& path, const std::string& object,
                                  const std::string& attribute);
double read_attribute_double(const std::filesystem::path& path, const std::string& object,
                             const std::string& attribute);
std::int64_t read_attribute_int64(const std::filesystem::path& path, const std::string& object,
                                  const std::string& attribute);
std::uint64_t read_attribute_uint64(const std::filesystem::path& path, const std::string& object,
                                    const std::string& attribute);

}  // namespace fragsim::formats
