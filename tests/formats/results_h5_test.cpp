// results.h5: write a synthetic RunResult on a real (small) site, read every part back.
#include "formats/results_h5.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <stdexcept>

#include "api/run_outputs.h"
#include "api/test_support.h"
#include "formats/h5_writer.h"
#include "formats/output_dir.h"
#include "fragsim/version.h"
#include "small_disk.h"

namespace fragsim::formats {
namespace {

namespace fs = std::filesystem;

class ResultsH5 : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = api::testing::fresh_test_dir("fragsim_h5_test_");
    // A coarse plane far from the origin, so that input != local coordinates.
    scenario_ = api::testing::far_plane_scenario();
    site_ = scene::Site::build(scenario_.site);
    result_ = make_result();
  }
  void TearDown() override { fs::remove_all(dir_); }

  run::RunResult make_result() const {
    run::RunResult r;
    r.samples = 2000;
    r.histories_done = 2000;
    r.real_fragments = 1000;
    r.seed = 0xfedcba9876543210ull;  // needs all 64 bits
    const std::size_t m = site_->terrain_triangle_count();
    for (std::size_t t = 0; t < m; ++t) {
      r.ptn_density_per_m2.push_back(0.001 * static_cast<double>(t));
      r.ptn_std_error_per_m2.push_back(0.0001 * static_cast<double>(t));
    }
    r.max_ptn_density_per_m2 = r.ptn_density_per_m2.back();
    r.max_ptn_triangle = static_cast<std::int64_t>(m - 1);
    r.hfd_origin_m = Vec3(500200, 4000200, 251);
    r.hazardous_fragment_distance_m = 150.0;
    r.hfd_lower_m = 140.0;
    r.hfd_upper_m = 160.0;
    r.hfd_by_sector_m[7] = 150.0;
    r.buildings.push_back(api::testing::example_building());
    r.outcome_histories = {48, 10, 0, 1942, 0, 0, 0, 3};
    r.outcome_fragments[0] = {24.0, 3.5};
    r.outcome_fragments[1] = {5.0, 1.5};
    r.outcome_fragments[3] = {971.0, 3.75};
    for (std::uint32_t h = 0; h < 3; ++h) {
      run::FragmentRecord f;
      f.group = 0;
      f.history = h;
      f.weight = 0.5;
      f.mass_kg = 0.05 + h;
      f.area_m2 = 1e-4;
      f.launch_position_m = Vec3(500200, 4000200, 251);
      f.launch_velocity_mps = Vec3(300, h, 10);
      f.outcome = h == 1 ? run::Outcome::kBuilding : run::Outcome::kGround;
      f.end_time_s = 1.5 * h;
      f.end_position_m = Vec3(500260, 4000200 + h, 252);
      f.end_velocity_mps = Vec3(200, 0, -5);
      f.impact_angle_deg = 30;
      f.impact_ke_j = 1000;
      f.building = h == 1 ? 0 : -1;
      f.surface = h == 1 ? 1 : -1;
      f.penetrated = h == 1;
      f.residual_ke_j = h == 1 ? 400 : 0;
      f.bounces = h;
      f.ground_impacts = 3 * h;
      f.takeoffs = h + 1;
      f.ground_path_m = 2.0 * h;
      r.fragments.push_back(f);
    }
    run::TrajectoryRecord a;
    a.group = 0;
    a.history = 0;
    a.t_s = {0, 0.5, 1.0};
    a.position_m = {Vec3(0, 0, 1), Vec3(10, 0, 3), Vec3(20, 0, 2)};
    a.velocity_mps = {Vec3(20, 0, 4), Vec3(20, 0, 0), Vec3(20, 0, -2)};
    a.event = {run::TrajectoryEvent::kLaunch, run::TrajectoryEvent::kFlight,
               run::TrajectoryEvent::kTerrainImpact};
    run::TrajectoryRecord c;
    c.group = 0;
    c.history = 5;
    c.t_s = {0, 0.25};
    c.position_m = {Vec3(0, 0, 1), Vec3(-5, 1, 2)};
    c.velocity_mps = {Vec3(-20, 4, 4), Vec3(0, 0, 0)};
    c.event = {run::TrajectoryEvent::kLaunch, run::TrajectoryEvent::kEnd};
    r.trajectories = {a, c};
    r.timing.wall_s = 1.25;
    r.timing.threads = 2;
    return r;
  }

  fs::path write(const std::string& name, const run::RunResult& r, bool record = true) {
    const fs::path path = dir_ / name;
    write_at(path, r, record);
    return path;
  }
  void write_at(const fs::path& path, const run::RunResult& r, bool record = true) {
    run::Scenario sc = scenario_;
    sc.settings.record_fragments = record;
    sc.settings.record_trajectories = record;
    api::Provenance p = api::build_provenance();
    p.scenario_sha256 = std::string(64, 'a');
    write_results_h5(path, r, *site_, sc,
                     api::results_texts(r, sc, api::scenario_to_json(sc).dump(), p));
  }

  fs::path dir_;
  run::Scenario scenario_;
  std::shared_ptr<const scene::Site> site_;
  run::RunResult result_;
};

// The superblock checksum the writer mends in the in-memory file's image (h5::reseal_superblock):
// lookup3 over a file HDF5 wrote to disk itself (an older fragsimd, tests/server/data) gives the
// checksum HDF5 stored; a changed byte gives another.
TEST(H5Image, Lookup3IsTheSuperblockChecksumHdf5Writes) {
  const std::string file = api::testing::read_text(
      api::testing::source_path("tests/server/data/store-v1/jobs/j_cfdf454a3ec0d3ad/results.h5"));
  ASSERT_GT(file.size(), 48u);
  ASSERT_EQ(file[8], 2) << "superblock version";
  const auto* p = reinterpret_cast<const unsigned char*>(file.data());
  const std::uint32_t stored = p[44] | (p[45] << 8) | (p[46] << 16) | (std::uint32_t{p[47]} << 24);
  EXPECT_EQ(h5::lookup3(p, 44), stored);
  std::string changed = file.substr(0, 48);
  changed[30] ^= 1;
  EXPECT_NE(h5::lookup3(reinterpret_cast<const unsigned char*>(changed.data()), 44), stored);
  h5::reseal_superblock(changed, "changed");
  EXPECT_EQ(h5::lookup3(reinterpret_cast<const unsigned char*>(changed.data()), 44),
            static_cast<std::uint32_t>(static_cast<unsigned char>(changed[44]) |
                                       (static_cast<unsigned char>(changed[45]) << 8) |
                                       (static_cast<unsigned char>(changed[46]) << 16) |
                                       (static_cast<unsigned char>(changed[47]) << 24)));
  // Jenkins' own test vector for hashlittle: "Four score and seven years ago", initval 0.
  const std::string four = "Four score and seven years ago";
  EXPECT_EQ(h5::lookup3(reinterpret_cast<const unsigned char*>(four.data()), four.size()),
            0x17770551U);
}

// HDF5 1.10 cannot survive a file whose writes fail (a failed H5Fclose leaves a dangling id that
// crashed fragsim at exit); the writer builds the file in memory and writes it in one piece. On a
// full disk: StorageFullError with the path and the file's size, no file, and HDF5 still sound:
// the next file is written and read back, and this process exits cleanly (ctest sees a crash).
TEST_F(ResultsH5, AFullDiskIsStorageFullAndHdf5GoesOn) {
  std::string why;
  const auto disk = fragsim::testing::SmallDisk::make(dir_ / "disk", 256 << 10, &why);
  if (!disk) GTEST_SKIP() << "no small file system here: " << why;
  const fs::path big = write("big.h5", result_);
  const auto size = static_cast<std::int64_t>(fs::file_size(big));
  ASSERT_GT(size, 16 << 10);
  disk->fill_leaving(size / 2);
  const fs::path path = dir_ / "disk" / "results.h5";
  try {
    write_at(path, result_);
    FAIL() << "a file of " << size << " bytes written with " << disk->available() << " free";
  } catch (const StorageFullError& e) {
    EXPECT_EQ(e.path(), path);
    EXPECT_EQ(e.bytes_needed(), size);
  }
  EXPECT_FALSE(fs::exists(path));  // the file made for it went again
  disk->free_filler();
  write_at(path, result_);
  EXPECT_EQ(static_cast<std::int64_t>(fs::file_size(path)), size);
  EXPECT_EQ(read_attribute_int64(path, "/", "samples"), 2000);
  EXPECT_EQ(read_dataset_double(path, "/ptn/density_per_m2"), result_.ptn_density_per_m2);
}

TEST_F(ResultsH5, RootAttributes) {
  const fs::path f = write("r.h5", result_);
  EXPECT_EQ(read_attribute_string(f, "/", "file_type"), "fragsim.results");
  EXPECT_EQ(read_attribute_int64(f, "/", "format_version"), 5);
  // summary_json (format 5): summary.json's figures, the same function's output.
  api::Provenance p = api::build_provenance();
  p.scenario_sha256 = std::string(64, 'a');
  EXPECT_EQ(read_attribute_string(f, "/", "summary_json"),
            api::summary_to_json(result_, scenario_, p).dump());
  EXPECT_EQ(read_attribute_string(f, "/", "hfd_bound"), "none");
  EXPECT_EQ(read_attribute_string(f, "/", "fragsim_version"), kVersion);
  EXPECT_EQ(read_attribute_string(f, "/", "git_sha"), kGitSha);
  EXPECT_EQ(read_attribute_string(f, "/", "scenario_sha256"), std::string(64, 'a'));
  EXPECT_EQ(read_attribute_uint64(f, "/", "seed"), 0xfedcba9876543210ull);
  EXPECT_EQ(read_attribute_int64(f, "/", "samples"), 2000);
  EXPECT_EQ(read_attribute_int64(f, "/", "histories_done"), 2000);
  EXPECT_EQ(read_attribute_double(f, "/", "real_fragments"), 1000.0);
  EXPECT_EQ(read_attribute_int64(f, "/", "cancelled"), 0);
  EXPECT_EQ(read_attribute_double(f, "/", "wall_s"), 1.25);
  EXPECT_EQ(read_attribute_int64(f, "/", "threads"), 2);
  const std::string created = read_attribute_string(f, "/", "created_utc");
  EXPECT_EQ(created.size(), 20u) << created;  // 2024-01-02T03:04:05Z
  // The scenario JSON reads back and parses to the same scenario.
  const auto stored = nlohmann::json::parse(read_attribute_string(f, "/", "scenario_json"));
  run::Scenario sc = scenario_;
  sc.settings.record_fragments = sc.settings.record_trajectories = true;
  EXPECT_EQ(stored, api::scenario_to_json(sc));
}

TEST_F(ResultsH5, TerrainInInputCoordinates) {
  const fs::path f = write("r.h5", result_);
  const std::size_t n = site_->terrain_vertices().size(), m = site_->terrain_triangle_count();
  EXPECT_EQ(dataset_shape(f, "/terrain/vertices_m"), (std::vector<std::uint64_t>{n, 3}));
  EXPECT_EQ(dataset_shape(f, "/terrain/triangles"), (std::vector<std::uint64_t>{m, 3}));
  EXPECT_EQ(dataset_shape(f, "/terrain/area_m2"), (std::vector<std::uint64_t>{m}));
  const auto v = read_dataset_double(f, "/terrain/vertices_m");
  double xmin = 1e300, xmax = -1e300;
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3 expected = site_->to_input(site_->terrain_vertices()[k]);
    EXPECT_EQ(v[3 * k], expected.x());
    EXPECT_EQ(v[3 * k + 1], expected.y());
    EXPECT_EQ(v[3 * k + 2], 250.0);  // the plane's input elevation
    xmin = std::min(xmin, v[3 * k]);
    xmax = std::max(xmax, v[3 * k]);
  }
  EXPECT_EQ(xmin, 500000.0);
  EXPECT_EQ(xmax, 500400.0);
  const auto t = read_dataset_int64(f, "/terrain/triangles");
  for (std::size_t k = 0; k < m; ++k)
    for (std::size_t c = 0; c < 3; ++c)
      EXPECT_EQ(t[3 * k + c], static_cast<std::int64_t>(site_->terrain_triangles()[k][c]));
  double total = 0;
  for (double a : read_dataset_double(f, "/terrain/area_m2")) total += a;
  EXPECT_NEAR(total, 400.0 * 400.0, 1e-6);
}

// Each terrain triangle's material, by index into the site's material names: the base
// material without zones, a zone's where one holds the triangle's centroid.
TEST_F(ResultsH5, TerrainMaterialPerTriangle) {
  const auto materials_of = [&](const fs::path& f) {
    const auto names = read_dataset_strings(f, "/terrain/material_names");
    std::vector<std::string> out;
    for (const std::int64_t k : read_dataset_int64(f, "/terrain/material"))
      out.push_back(names.at(static_cast<std::size_t>(k)));
    return out;
  };
  const std::string base = scenario_.site.terrain.material;
  EXPECT_EQ(materials_of(write("plain.h5", result_)),
            std::vector<std::string>(site_->terrain_triangle_count(), base));
  std::string other;
  for (const auto& [name, m] : scenario_.site.materials)
    if (name != base) other = name;
  ASSERT_FALSE(other.empty());
  scenario_.site.terrain.zones = {
      {other, {{500000, 4000000}, {500200, 4000000}, {500200, 4000400}, {500000, 4000400}}}};
  site_ = scene::Site::build(scenario_.site);
  const auto zoned = materials_of(write("zoned.h5", result_));
  ASSERT_EQ(zoned.size(), site_->terrain_triangle_count());
  for (std::size_t t = 0; t < zoned.size(); ++t) {
    const double x =
        site_->to_input(site_->terrain_triangle_centroid(static_cast<std::uint32_t>(t))).x();
    EXPECT_EQ(zoned[t], x < 500200 ? other : base) << t;
  }
}

TEST_F(ResultsH5, PtnHfdBuildingsOutcomes) {
  const fs::path f = write("r.h5", result_);
  EXPECT_EQ(read_dataset_double(f, "/ptn/density_per_m2"), result_.ptn_density_per_m2);
  EXPECT_EQ(read_dataset_double(f, "/ptn/std_error_per_m2"), result_.ptn_std_error_per_m2);
  EXPECT_EQ(read_attribute_double(f, "/ptn", "max_density_per_m2"), result_.max_ptn_density_per_m2);
  EXPECT_EQ(read_attribute_int64(f, "/ptn", "max_triangle"), result_.max_ptn_triangle);
  EXPECT_EQ(dataset_shape(f, "/hfd/hazardous_fragment_distance_m"), std::vector<std::uint64_t>{});
  EXPECT_EQ(read_dataset_double(f, "/hfd/hazardous_fragment_distance_m"),
            std::vector<double>{150.0});
  EXPECT_EQ(read_dataset_double(f, "/hfd/band_m"), (std::vector<double>{140.0, 160.0}));
  EXPECT_EQ(read_dataset_double(f, "/hfd/origin_m"), (std::vector<double>{500200, 4000200, 251}));
  EXPECT_EQ(read_dataset_double(f, "/hfd/by_sector_m").size(), 36u);
  EXPECT_EQ(read_dataset_double(f, "/hfd/by_sector_m")[7], 150.0);
  EXPECT_EQ(read_dataset_double(f, "/hfd/threshold_per_m2"),
            std::vector<double>{scenario_.settings.hfd_threshold_per_m2});

  EXPECT_EQ(read_dataset_strings(f, "/buildings/id"), std::vector<std::string>{"B1"});
  EXPECT_EQ(read_dataset_double(f, "/buildings/expected_impacts"), std::vector<double>{12.5});
  EXPECT_EQ(read_dataset_double(f, "/buildings/impacts_std_error"), std::vector<double>{0.25});
  EXPECT_EQ(read_dataset_double(f, "/buildings/expected_penetrations"), std::vector<double>{3.0});
  EXPECT_EQ(read_dataset_double(f, "/buildings/penetrations_std_error"), std::vector<double>{0.5});
  EXPECT_EQ(read_dataset_double(f, "/buildings/residual_ke_j"), std::vector<double>{4000.0});
  EXPECT_EQ(read_dataset_double(f, "/buildings/residual_ke_std_error_j"),
            std::vector<double>{300.0});
  EXPECT_EQ(dataset_shape(f, "/buildings/impacts_by_surface"), (std::vector<std::uint64_t>{1, 4}));
  EXPECT_EQ(read_dataset_double(f, "/buildings/impacts_by_surface"),
            (std::vector<double>{0, 10.0, 2.5, 0}));
  EXPECT_EQ(read_dataset_double(f, "/buildings/impacts_by_surface_std_error"),
            (std::vector<double>{0, 0.2, 0.1, 0}));
  EXPECT_EQ(read_dataset_double(f, "/buildings/penetrations_by_surface"),
            (std::vector<double>{0, 0, 3.0, 0}));
  const std::size_t bt = site_->building_triangles().size();
  EXPECT_EQ(dataset_shape(f, "/buildings/triangles"), (std::vector<std::uint64_t>{bt, 3}));
  EXPECT_EQ(read_dataset_int64(f, "/buildings/triangle_building"),
            std::vector<std::int64_t>(bt, 0));
  const auto bv = read_dataset_double(f, "/buildings/vertices_m");
  for (std::size_t k = 0; k < bv.size(); k += 3) {
    EXPECT_GE(bv[k], 500260.0);
    EXPECT_LE(bv[k], 500280.0);
  }

  EXPECT_EQ(read_dataset_strings(f, "/outcomes/name"),
            (std::vector<std::string>{"ground", "building", "max_flight_time", "left_site",
                                      "started_inside", "harmless", "integration_failed",
                                      "embedded", "work_limit", "ground_step_cap"}));
  EXPECT_EQ(read_dataset_int64(f, "/outcomes/histories"),
            (std::vector<std::int64_t>{48, 10, 0, 1942, 0, 0, 0, 3, 0, 0}));
  EXPECT_EQ(read_dataset_double(f, "/outcomes/fragments"),
            (std::vector<double>{24.0, 5.0, 0, 971.0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(read_dataset_double(f, "/outcomes/fragments_std_error")[3], 3.75);
}

// Issue 22: where the terrain's boundary cuts the HFD, and the hazardous fragments that left.
// What sets the HFD (issue 23): per mechanism and group, rows in the order of the names; the
// shares at the HFD's triangle (row 0) and each sector's (row 1 + k).
TEST_F(ResultsH5, HfdAttribution) {
  scenario_.groups.resize(2);
  scenario_.groups[0].name = "case";
  scenario_.groups[1].name = "rear closure";
  run::RunResult r = result_;
  run::HfdAttribution& a = r.hfd_attribution;
  a.by_mechanism[2].hfd_m = 150.0;
  a.by_mechanism[2].lower_m = 140.0;
  a.by_mechanism[2].by_sector_m[7] = 150.0;
  a.by_mechanism[1].cut.sectors[4] = true;
  a.by_mechanism[1].cut.sector_count = 1;
  a.by_group.resize(2);
  a.by_group[1].hfd_m = 150.0;
  a.at_hfd.triangle = 3;
  a.at_hfd.distance_m = 150.0;
  a.at_hfd.density_per_m2 = 0.5;
  a.at_hfd.by_mechanism = {0.25, 0.0, 0.75};
  a.at_hfd.by_group = {0.0, 1.0};
  a.at_sector_hfd[7] = a.at_hfd;
  const fs::path f = write("attribution.h5", r);
  EXPECT_EQ(read_dataset_strings(f, "/hfd/attribution/mechanism_names"),
            (std::vector<std::string>{"direct_flight", "after_ricochet", "ground"}));
  EXPECT_EQ(read_dataset_strings(f, "/hfd/attribution/group_names"),
            (std::vector<std::string>{"case", "rear closure"}));
  EXPECT_EQ(read_dataset_double(f, "/hfd/attribution/by_mechanism/hfd_m"),
            (std::vector<double>{0.0, 0.0, 150.0}));
  EXPECT_EQ(dataset_shape(f, "/hfd/attribution/by_mechanism/by_sector_m"),
            (std::vector<std::uint64_t>{3, 36}));
  EXPECT_EQ(read_dataset_double(f, "/hfd/attribution/by_mechanism/by_sector_m")[2 * 36 + 7], 150.0);
  EXPECT_EQ(read_dataset_double(f, "/hfd/attribution/by_mechanism/band_m")[4], 140.0);
  EXPECT_EQ(read_dataset_double(f, "/hfd/attribution/by_mechanism/bound"),
            (std::vector<double>{0.0, 1.0, 0.0}));
  EXPECT_EQ(read_dataset_double(f, "/hfd/attribution/by_mechanism/by_sector_bound")[36 + 4], 1.0);
  EXPECT_EQ(read_dataset_double(f, "/hfd/attribution/by_group/hfd_m"),
            (std::vector<double>{0.0, 150.0}));
  EXPECT_EQ(read_attribute_string(f, "/hfd/attribution", "by_group_omitted_reason"), "");
  const auto triangle = read_dataset_int64(f, "/hfd/attribution/at_hfd/triangle");
  ASSERT_EQ(triangle.size(), 37u);
  EXPECT_EQ(triangle[0], 3);
  EXPECT_EQ(triangle[1 + 7], 3);
  EXPECT_EQ(triangle[1], -1);
  EXPECT_EQ(read_dataset_double(f, "/hfd/attribution/at_hfd/distance_m")[0], 150.0);
  EXPECT_EQ(dataset_shape(f, "/hfd/attribution/at_hfd/share_by_mechanism"),
            (std::vector<std::uint64_t>{37, 3}));
  const auto mech = read_dataset_double(f, "/hfd/attribution/at_hfd/share_by_mechanism");
  EXPECT_EQ(std::vector<double>(mech.begin(), mech.begin() + 3),
            (std::vector<double>{0.25, 0.0, 0.75}));
  const auto group = read_dataset_double(f, "/hfd/attribution/at_hfd/share_by_group");
  EXPECT_EQ(dataset_shape(f, "/hfd/attribution/at_hfd/share_by_group"),
            (std::vector<std::uint64_t>{37, 2}));
  EXPECT_EQ(group[1], 1.0);

  r.hfd_attribution.by_group.clear();
  r.hfd_attribution.by_group_omitted_reason = "too many groups";
  const fs::path omitted = write("omitted.h5", r);
  EXPECT_EQ(read_attribute_string(omitted, "/hfd/attribution", "by_group_omitted_reason"),
            "too many groups");
  EXPECT_THROW(read_dataset_double(omitted, "/hfd/attribution/by_group/hfd_m"), std::runtime_error);
  EXPECT_THROW(read_dataset_double(omitted, "/hfd/attribution/at_hfd/share_by_group"),
               std::runtime_error);
}

// settings.ground_bracket: rows per constant in the result's order, columns low and high.
TEST_F(ResultsH5, GroundBracket) {
  EXPECT_THROW(read_dataset_double(write("no_bracket.h5", result_), "/ground_bracket/hfd_m"),
               std::runtime_error);
  run::RunResult r = result_;
  auto b = std::make_shared<run::GroundBracket>();
  b->material = "soil";
  b->samples_scale = 0.5;
  b->nominal.hfd_m = 157.0;
  run::BracketRow row;
  row.constant = "roughness_deg";
  row.nominal = 2.0;
  row.low = {0.0, 421.8, false, 400.0, 430.0, 15.8, 2.25};
  row.high = {5.0, 139.2, true, 130.0, 150.0, 10.7, 1.38};
  b->rows = {row, row};
  b->rows[1].constant = "exit_angle_ratio";
  r.ground_bracket = b;
  const fs::path f = write("bracket.h5", r);
  EXPECT_EQ(read_dataset_strings(f, "/ground_bracket/constant"),
            (std::vector<std::string>{"roughness_deg", "exit_angle_ratio"}));
  EXPECT_EQ(dataset_shape(f, "/ground_bracket/hfd_m"), (std::vector<std::uint64_t>{2, 2}));
  EXPECT_EQ(read_dataset_double(f, "/ground_bracket/hfd_m"),
            (std::vector<double>{421.8, 139.2, 421.8, 139.2}));
  EXPECT_EQ(read_dataset_double(f, "/ground_bracket/value")[1], 5.0);
  EXPECT_EQ(read_dataset_double(f, "/ground_bracket/hfd_bound")[1], 1.0);
  EXPECT_EQ(read_dataset_double(f, "/ground_bracket/building_impacts")[0], 15.8);
  EXPECT_EQ(read_attribute_string(f, "/ground_bracket", "material"), "soil");
}

TEST_F(ResultsH5, SiteBoundaryFlagsAndLeavers) {
  const fs::path none = write("none.h5", result_);
  EXPECT_EQ(read_dataset_double(none, "/hfd/bound"), std::vector<double>{0.0});
  EXPECT_EQ(read_attribute_string(none, "/hfd", "bound"), "none");
  EXPECT_EQ(read_attribute_string(none, "/hfd", "note"), "");
  // The 4 x 4-cell plane: its 12 outer cells are the boundary.
  EXPECT_EQ(read_dataset_int64(none, "/hfd/boundary_triangles").size(), 24u);

  run::RunResult r = result_;
  run::SiteBoundary& b = r.site_boundary;
  b.hfd_cut = b.band_upper_cut = true;
  b.hfd_sectors_cut = 1;
  b.hfd_sector_cut[7] = true;
  b.max_boundary_density_per_m2 = 0.03;
  b.left_hazardous = {12.5, 2.5};
  b.left_hazardous_by_sector[7] = {12.5, 2.5};
  b.left_hazardous_histories = 25;
  const fs::path f = write("cut.h5", r);
  EXPECT_EQ(read_attribute_string(f, "/", "hfd_bound"), "lower");
  EXPECT_EQ(read_attribute_string(f, "/hfd", "bound"), "lower");
  EXPECT_EQ(read_attribute_string(f, "/hfd", "note"), api::hfd_bound_note(r));
  EXPECT_EQ(read_dataset_double(f, "/hfd/bound"), std::vector<double>{1.0});
  EXPECT_EQ(read_dataset_double(f, "/hfd/band_bound"), (std::vector<double>{0.0, 1.0}));
  std::vector<double> sectors(36, 0.0);
  sectors[7] = 1.0;
  EXPECT_EQ(read_dataset_double(f, "/hfd/by_sector_bound"), sectors);
  const auto boundary = read_dataset_int64(f, "/hfd/boundary_triangles");
  EXPECT_EQ(std::vector<std::uint32_t>(boundary.begin(), boundary.end()),
            site_->terrain_boundary_triangles());
  EXPECT_EQ(read_dataset_double(f, "/hfd/boundary_max_density_per_m2"), std::vector<double>{0.03});
  EXPECT_EQ(read_dataset_int64(f, "/hfd/left_site_hazardous_histories"),
            std::vector<std::int64_t>{25});
  EXPECT_EQ(read_dataset_double(f, "/hfd/left_site_hazardous_fragments"),
            std::vector<double>{12.5});
  EXPECT_EQ(read_dataset_double(f, "/hfd/left_site_hazardous_fragments_std_error"),
            std::vector<double>{2.5});
  EXPECT_EQ(read_dataset_double(f, "/hfd/left_site_hazardous_by_sector")[7], 12.5);
  EXPECT_EQ(read_dataset_double(f, "/hfd/left_site_hazardous_by_sector_std_error")[7], 2.5);
}

TEST_F(ResultsH5, FragmentAndTrajectoryRecords) {
  const fs::path f = write("r.h5", result_);
  EXPECT_EQ(read_dataset_int64(f, "/fragments/history"), (std::vector<std::int64_t>{0, 1, 2}));
  EXPECT_EQ(read_dataset_double(f, "/fragments/mass_kg"), (std::vector<double>{0.05, 1.05, 2.05}));
  EXPECT_EQ(dataset_shape(f, "/fragments/launch_velocity_mps"), (std::vector<std::uint64_t>{3, 3}));
  EXPECT_EQ(read_dataset_double(f, "/fragments/launch_velocity_mps"),
            (std::vector<double>{300, 0, 10, 300, 1, 10, 300, 2, 10}));
  EXPECT_EQ(read_dataset_double(f, "/fragments/end_position_m")[4], 4000201.0);
  EXPECT_EQ(read_dataset_int64(f, "/fragments/outcome"), (std::vector<std::int64_t>{0, 1, 0}));
  EXPECT_EQ(read_dataset_int64(f, "/fragments/building"), (std::vector<std::int64_t>{-1, 0, -1}));
  EXPECT_EQ(read_dataset_int64(f, "/fragments/surface"), (std::vector<std::int64_t>{-1, 1, -1}));
  EXPECT_EQ(read_dataset_int64(f, "/fragments/penetrated"), (std::vector<std::int64_t>{0, 1, 0}));
  EXPECT_EQ(read_dataset_int64(f, "/fragments/bounces"), (std::vector<std::int64_t>{0, 1, 2}));
  EXPECT_EQ(read_dataset_int64(f, "/fragments/ground_impacts"),
            (std::vector<std::int64_t>{0, 3, 6}));
  EXPECT_EQ(read_dataset_int64(f, "/fragments/takeoffs"), (std::vector<std::int64_t>{1, 2, 3}));
  EXPECT_EQ(read_dataset_double(f, "/fragments/residual_ke_j"), (std::vector<double>{0, 400, 0}));
  EXPECT_EQ(read_dataset_double(f, "/fragments/ground_path_m"), (std::vector<double>{0, 2, 4}));
  EXPECT_EQ(read_dataset_double(f, "/fragments/end_time_s"), (std::vector<double>{0, 1.5, 3.0}));
  EXPECT_EQ(read_attribute_string(f, "/fragments/outcome", "names"),
            "ground,building,max_flight_time,left_site,started_inside,harmless,integration_failed,"
            "embedded,work_limit,ground_step_cap");

  EXPECT_EQ(read_dataset_int64(f, "/trajectories/history"), (std::vector<std::int64_t>{0, 5}));
  EXPECT_EQ(read_dataset_int64(f, "/trajectories/offsets"), (std::vector<std::int64_t>{0, 3, 5}));
  EXPECT_EQ(read_dataset_double(f, "/trajectories/t_s"),
            (std::vector<double>{0, 0.5, 1.0, 0, 0.25}));
  EXPECT_EQ(dataset_shape(f, "/trajectories/position_m"), (std::vector<std::uint64_t>{5, 3}));
  EXPECT_EQ(read_dataset_double(f, "/trajectories/position_m")[12], -5.0);
  EXPECT_EQ(dataset_shape(f, "/trajectories/velocity_mps"), (std::vector<std::uint64_t>{5, 3}));
  EXPECT_EQ(read_dataset_double(f, "/trajectories/velocity_mps")[8], -2.0);
  EXPECT_EQ(read_dataset_int64(f, "/trajectories/event"),
            (std::vector<std::int64_t>{0, 1, 2, 0, 6}));
  EXPECT_EQ(read_attribute_string(f, "/trajectories/event", "names"),
            "launch,flight,terrain_impact,take_off,ground,building_hit,end");
  // A record whose columns disagree in length is a logic error, not a half-written file.
  run::RunResult bad = result_;
  bad.trajectories[0].event.pop_back();
  EXPECT_THROW(write("bad.h5", bad), std::logic_error);
}

TEST_F(ResultsH5, RecordsAreAbsentUnlessRequested) {
  const fs::path f = write("r.h5", result_, /*record=*/false);
  for (const std::string& name : list_datasets(f)) {
    EXPECT_NE(name.rfind("/fragments/", 0), 0u) << name;
    EXPECT_NE(name.rfind("/trajectories/", 0), 0u) << name;
  }
  EXPECT_THROW(read_dataset_double(f, "/fragments/mass_kg"), std::runtime_error);
}

TEST_F(ResultsH5, IdenticalResultsGiveBitIdenticalDatasets) {
  const fs::path a = write("a.h5", result_);
  const fs::path b = write("b.h5", result_);
  const auto names = list_datasets(a);
  EXPECT_EQ(names, list_datasets(b));
  EXPECT_GT(names.size(), 40u);
  for (const auto& name : names)
    EXPECT_EQ(read_dataset_raw(a, name), read_dataset_raw(b, name)) << name;
  // The comparison can fail: one changed bit in one value shows up.
  run::RunResult changed = result_;
  changed.ptn_density_per_m2[3] = std::nextafter(changed.ptn_density_per_m2[3], 1.0);
  const fs::path c = write("c.h5", changed);
  EXPECT_NE(read_dataset_raw(a, "/ptn/density_per_m2"), read_dataset_raw(c, "/ptn/density_per_m2"));
  EXPECT_EQ(read_dataset_raw(a, "/ptn/std_error_per_m2"),
            read_dataset_raw(c, "/ptn/std_error_per_m2"));
}

TEST_F(ResultsH5, LargeFieldsAreCompressedAndReadBackExactly) {
  // More than 2^16 values: the chunked + deflate path.
  scenario_.site.terrain.geometry = scene::PlaneTerrainSpec{0.0, {0, 0, 2000, 2000}, 10.0};
  scenario_.site.buildings.clear();
  site_ = scene::Site::build(scenario_.site);
  run::RunResult r = make_result();
  r.buildings.clear();
  ASSERT_GT(r.ptn_density_per_m2.size(), 65536u);
  const fs::path f = write("big.h5", r);
  EXPECT_EQ(read_dataset_double(f, "/ptn/density_per_m2"), r.ptn_density_per_m2);
  EXPECT_EQ(read_dataset_strings(f, "/buildings/id"), std::vector<std::string>{});
  EXPECT_EQ(dataset_shape(f, "/buildings/impacts_by_surface"), (std::vector<std::uint64_t>{0, 4}));
  EXPECT_LT(fs::file_size(f), r.ptn_density_per_m2.size() * 8u * 2u);  // compression did something
}

TEST_F(ResultsH5, ScenarioJsonAttributeOfAnySize) {
  const std::string big(
      300000, 'x');  // the demo scenario is ~220 kB; attributes > 64 kB need dense storage
  const fs::path f = dir_ / "big_attr.h5";
  write_results_h5(f, result_, *site_, scenario_,
                   api::results_texts(result_, scenario_, big, api::build_provenance()));
  EXPECT_EQ(read_attribute_string(f, "/", "scenario_json"), big);
}

TEST_F(ResultsH5, MismatchedResultIsALogicError) {
  run::RunResult r = result_;
  r.ptn_density_per_m2.pop_back();
  EXPECT_THROW(write("bad.h5", r), std::logic_error);
  EXPECT_FALSE(fs::exists(dir_ / "bad.h5"));
  r = result_;
  r.buildings.clear();
  EXPECT_THROW(write("bad.h5", r), std::logic_error);
}

TEST_F(ResultsH5, NeverOverwritesAndReportsMissingObjects) {
  const fs::path f = write("r.h5", result_);
  EXPECT_THROW(write("r.h5", result_), std::runtime_error);
  EXPECT_THROW(read_dataset_double(f, "/no/such"), std::runtime_error);
  EXPECT_THROW(read_attribute_string(f, "/", "no_such"), std::runtime_error);
  EXPECT_THROW(list_datasets(dir_ / "missing.h5"), std::runtime_error);
}

}  // namespace
}  // namespace fragsim::formats
