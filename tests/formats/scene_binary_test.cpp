// The browser's scene format (formats/scene_binary.h): header, alignment, arrays that round-trip, a
// site far from (0, 0) kept to float precision through offset_m, a results.h5 read back with its
// trajectories sampled evenly, each terrain triangle's material (zones) from a site and from a
// results.h5, and a results.h5 older than format 4 (no /terrain/material) still read.
#include "formats/scene_binary.h"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "api/run_outputs.h"
#include "api/test_support.h"
#include "formats/results_h5.h"
#include "fragsim/version.h"

namespace fragsim::formats {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// A decoded scene: the header and the data block.
struct Decoded {
  Json header;
  std::string data;

  template <class T>
  std::vector<T> array(const std::string& name) const {
    const Json& a = header.at("arrays").at(name);
    const std::size_t offset = a.at("offset"), bytes = a.at("bytes");
    EXPECT_EQ(offset % 8, 0u) << name;
    EXPECT_LE(offset + bytes, data.size()) << name;
    std::vector<T> out(bytes / sizeof(T));
    std::memcpy(out.data(), data.data() + offset, bytes);
    return out;
  }
};

Decoded decode(const std::string& bytes) {
  EXPECT_EQ(bytes.substr(0, 8), "FSSCENE1");
  std::uint32_t h = 0;
  std::memcpy(&h, bytes.data() + 8, 4);
  EXPECT_EQ((12 + h) % 8, 0u);
  return {Json::parse(bytes.substr(12, h)), bytes.substr(12 + h)};
}

TEST(SceneBinary, HeaderDescribesAlignedArraysThatRoundTrip) {
  SceneArrays s;
  s.offset_m = {452300, 3839800, 400};
  s.terrain_vertices = {0, 0, 0, 1, 0, 0, 0, 1, 0.5f};
  s.terrain_triangles = {0, 1, 2};
  s.density_per_m2 = {0.25f};
  s.std_error_per_m2 = {0.125f};
  s.building_ids = {"B1", "h\xC3\xBCtte"};
  s.triangle_surface = {1, 2, 3};  // 3 bytes: the next array must still start aligned
  s.trajectory_offsets = {0, 2};
  const Decoded d = decode(encode_scene(s));
  EXPECT_EQ(d.header["format"], "fragsim.scene/1");
  EXPECT_EQ(d.header["offset_m"], Json({452300.0, 3839800.0, 400.0}));
  EXPECT_EQ(d.header["building_ids"], Json({"B1", "h\xC3\xBCtte"}));
  EXPECT_EQ(d.header["arrays"]["terrain_vertices"]["shape"], Json({3, 3}));
  EXPECT_EQ(d.header["arrays"]["terrain_vertices"]["type"], "f32");
  EXPECT_EQ(d.header["arrays"]["terrain_triangles"]["type"], "u32");
  EXPECT_EQ(d.header["arrays"]["density_per_m2"]["shape"], Json({1}));
  EXPECT_EQ(d.header["arrays"]["triangle_surface"]["type"], "u8");
  EXPECT_EQ(d.array<float>("terrain_vertices"), s.terrain_vertices);
  EXPECT_EQ(d.array<std::uint32_t>("terrain_triangles"), s.terrain_triangles);
  EXPECT_EQ(d.array<float>("std_error_per_m2"), s.std_error_per_m2);
  EXPECT_EQ(d.array<std::uint8_t>("triangle_surface"), s.triangle_surface);
  EXPECT_EQ(d.array<std::uint32_t>("trajectory_offsets"), s.trajectory_offsets);
  // Empty arrays are left out; a site's scene says nothing of trajectories.
  EXPECT_FALSE(d.header["arrays"].contains("building_vertices"));
  EXPECT_FALSE(d.header.contains("trajectories"));
}

TEST(SceneBinary, MaterialIndicesAreU8UpTo256NamesElseU16) {
  SceneArrays s;
  s.terrain_vertices = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  s.terrain_triangles = {0, 1, 2};
  s.terrain_material = {255};
  s.material_names.assign(256, "m");
  Decoded d = decode(encode_scene(s));
  EXPECT_EQ(d.header["arrays"]["terrain_material"]["type"], "u8");
  EXPECT_EQ(d.array<std::uint8_t>("terrain_material"), std::vector<std::uint8_t>{255});
  EXPECT_EQ(d.header["material_names"].size(), 256u);
  s.material_names.assign(300, "m");
  s.terrain_material = {299};
  s.triangle_surface = {1};  // after a 2-byte array, still aligned
  d = decode(encode_scene(s));
  EXPECT_EQ(d.header["arrays"]["terrain_material"]["type"], "u16");
  EXPECT_EQ(d.header["arrays"]["terrain_material"]["shape"], Json({1}));
  EXPECT_EQ(d.array<std::uint16_t>("terrain_material"), std::vector<std::uint16_t>{299});
  EXPECT_EQ(d.array<std::uint8_t>("triangle_surface"), std::vector<std::uint8_t>{1});
}

class SceneFromRun : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = api::testing::fresh_test_dir("fragsim_scene_test_");
    // A UTM-sized site: float32 alone would keep only 0.25 m here; offset_m keeps 0.1 mm.
    scenario_ = api::testing::far_plane_scenario();
    scenario_.settings.record_trajectories = true;
    site_ = scene::Site::build(scenario_.site);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A result with density 0.001 t on triangle t and `trajectories` trajectories of t + 1 points.
  fs::path write(int trajectories) const {
    run::RunResult r;
    r.samples = r.histories_done = 10;
    for (std::size_t t = 0; t < site_->terrain_triangle_count(); ++t) {
      r.ptn_density_per_m2.push_back(0.001 * static_cast<double>(t));
      r.ptn_std_error_per_m2.push_back(0.0001 * static_cast<double>(t));
    }
    r.buildings.push_back(api::testing::example_building());
    for (int k = 0; k < trajectories; ++k) {
      run::TrajectoryRecord tr;
      tr.group = static_cast<std::uint32_t>(k % 2);
      tr.history = static_cast<std::uint64_t>(k);
      for (int p = 0; p <= k; ++p) {
        tr.t_s.push_back(p);
        tr.position_m.push_back(Vec3(500200.0 + k, 4000200.0 + p, 251.5));
        tr.velocity_mps.push_back(Vec3(3, 4, 0));
        tr.event.push_back(run::TrajectoryEvent::kFlight);
      }
      r.trajectories.push_back(tr);
    }
    const fs::path path = dir_ / ("r" + std::to_string(trajectories) + ".h5");
    write_results_h5(path, r, *site_, scenario_,
                     api::results_texts(r, scenario_, api::scenario_to_json(scenario_).dump(),
                                        api::build_provenance()));
    return path;
  }

  // The west half (x < 500200) of the far plane in another material than the base one.
  void zone_west_half() {
    for (const auto& [name, m] : scenario_.site.materials)
      if (name != scenario_.site.terrain.material) other_ = name;
    ASSERT_FALSE(other_.empty());
    scenario_.site.terrain.zones = {
        {other_, {{500000, 4000000}, {500200, 4000000}, {500200, 4000400}, {500000, 4000400}}}};
    site_ = scene::Site::build(scenario_.site);
    ASSERT_TRUE(site_->terrain_has_zones());
  }

  // The scene's materials, checked against the site's, triangle by triangle; how many triangles
  // are in the zone's material.
  std::size_t expect_site_materials(const Decoded& d) const {
    std::vector<std::string> names;
    for (const scene::Material& m : site_->materials()) names.push_back(m.name);
    EXPECT_EQ(d.header.at("material_names"), Json(names));
    EXPECT_EQ(d.header["arrays"]["terrain_material"]["type"], "u8");
    const auto material = d.array<std::uint8_t>("terrain_material");
    EXPECT_EQ(material.size(), site_->terrain_triangle_count());
    std::size_t in_zone = 0;
    for (std::uint32_t t = 0; t < material.size(); ++t) {
      EXPECT_EQ(material[t], site_->terrain_triangle_material(t)) << t;
      in_zone += names.at(material[t]) == other_;
    }
    return in_zone;
  }

  fs::path dir_;
  std::string other_;
  run::Scenario scenario_;
  std::shared_ptr<const scene::Site> site_;
};

TEST_F(SceneFromRun, SiteSceneKeepsInputCoordinatesThroughTheOffset) {
  const Decoded d = decode(encode_scene(scene_from_site(*site_)));
  const Vec3 offset(d.header["offset_m"][0], d.header["offset_m"][1], d.header["offset_m"][2]);
  EXPECT_EQ(offset, Vec3(500200, 4000200, 250));  // the terrain box's centre, whole metres
  const auto v = d.array<float>("terrain_vertices");
  ASSERT_EQ(v.size(), 3 * site_->terrain_vertices().size());
  for (std::size_t k = 0; k < site_->terrain_vertices().size(); ++k) {
    const Vec3 input = site_->to_input(site_->terrain_vertices()[k]);
    const Vec3 back = offset + Vec3(v[3 * k], v[3 * k + 1], v[3 * k + 2]);
    EXPECT_LT((back - input).norm(), 1e-4) << k;
  }
  const auto tris = d.array<std::uint32_t>("terrain_triangles");
  EXPECT_EQ(tris.size(), 3 * site_->terrain_triangle_count());
  EXPECT_EQ(d.header["building_ids"], Json({"B1"}));
  const auto owner = d.array<std::uint32_t>("triangle_building");
  EXPECT_EQ(owner.size(), site_->building_triangles().size());
  EXPECT_EQ(d.array<std::uint8_t>("triangle_surface").size(), owner.size());
  const auto bv = d.array<float>("building_vertices");
  const Vec3 corner = offset + Vec3(bv[0], bv[1], bv[2]);
  EXPECT_LT((corner - site_->to_input(site_->building_vertices()[0])).norm(), 1e-4);
  EXPECT_FALSE(d.header["arrays"].contains("density_per_m2"));
}

TEST_F(SceneFromRun, ResultsSceneHoldsTheDensityAndAnEvenSampleOfTrajectories) {
  const fs::path f = write(10);
  const Decoded d = decode(encode_scene(scene_from_results(f, 4)));
  const auto density = d.array<float>("density_per_m2");
  ASSERT_EQ(density.size(), site_->terrain_triangle_count());
  for (std::size_t t = 0; t < density.size(); ++t)
    EXPECT_EQ(density[t], static_cast<float>(0.001 * static_cast<double>(t)));
  EXPECT_EQ(d.array<float>("std_error_per_m2")[3], static_cast<float>(0.0003));
  EXPECT_EQ(d.header["trajectories"], Json({{"recorded", 10}, {"sent", 4}}));
  // Trajectories 0, 2, 5, 7 (j * 10 / 4): 1, 3, 6 and 8 points.
  EXPECT_EQ(d.array<std::uint32_t>("trajectory_offsets"),
            (std::vector<std::uint32_t>{0, 1, 4, 10, 18}));
  EXPECT_EQ(d.array<std::uint32_t>("trajectory_group"), (std::vector<std::uint32_t>{0, 0, 1, 1}));
  const auto points = d.array<float>("trajectory_points");
  const Vec3 offset(d.header["offset_m"][0], d.header["offset_m"][1], d.header["offset_m"][2]);
  // Point 2 of the third sent trajectory (index 5): (500205, 4000202, 251.5).
  const std::size_t row = 4 + 2;
  EXPECT_LT((offset + Vec3(points[3 * row], points[3 * row + 1], points[3 * row + 2]) -
             Vec3(500205, 4000202, 251.5))
                .norm(),
            1e-4);
  for (const float s : d.array<float>("trajectory_speed")) EXPECT_FLOAT_EQ(s, 5.0f);
  EXPECT_EQ(d.header["building_ids"], Json({"B1"}));
  EXPECT_GT(d.array<std::uint32_t>("building_triangles").size(), 0u);
}

TEST_F(SceneFromRun, TrajectoriesCanBeLeftOutAndFewerThanAskedAreAllSent) {
  const fs::path f = write(3);
  const Decoded none = decode(encode_scene(scene_from_results(f, 0)));
  EXPECT_EQ(none.header["trajectories"], Json({{"recorded", 3}, {"sent", 0}}));
  EXPECT_FALSE(none.header["arrays"].contains("trajectory_points"));
  const Decoded all = decode(encode_scene(scene_from_results(f, 200)));
  EXPECT_EQ(all.header["trajectories"], Json({{"recorded", 3}, {"sent", 3}}));
  EXPECT_EQ(all.array<std::uint32_t>("trajectory_offsets"),
            (std::vector<std::uint32_t>{0, 1, 3, 6}));
}

TEST_F(SceneFromRun, SiteSceneCarriesEachTriangleMaterial) {
  const Decoded plain = decode(encode_scene(scene_from_site(*site_)));
  EXPECT_EQ(expect_site_materials(plain), 0u);  // one material: every triangle the base one
  zone_west_half();
  // The 4 x 4 plane of 100 m cells: the two western columns, 16 of 32 triangles.
  EXPECT_EQ(expect_site_materials(decode(encode_scene(scene_from_site(*site_)))), 16u);
}

TEST_F(SceneFromRun, ResultsSceneCarriesEachTriangleMaterial) {
  zone_west_half();
  const Decoded d = decode(encode_scene(scene_from_results(write(0), 0)));
  EXPECT_EQ(expect_site_materials(d), 16u);
}

// A results.h5 of format < 4 has no /terrain/material: its scene has no materials, and loads.
TEST_F(SceneFromRun, ResultsWithoutMaterialsStillLoad) {
  zone_west_half();
  const fs::path f = write(0);
  const hid_t file = H5Fopen(f.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  EXPECT_GE(H5Ldelete(file, "/terrain/material", H5P_DEFAULT), 0);
  EXPECT_GE(H5Ldelete(file, "/terrain/material_names", H5P_DEFAULT), 0);
  H5Fclose(file);
  const Decoded d = decode(encode_scene(scene_from_results(f, 0)));
  EXPECT_FALSE(d.header["arrays"].contains("terrain_material"));
  EXPECT_FALSE(d.header.contains("material_names"));
  EXPECT_EQ(d.array<float>("density_per_m2").size(), site_->terrain_triangle_count());
}

TEST_F(SceneFromRun, AFileThatIsNotResultsIsAnError) {
  const fs::path f = dir_ / "not.h5";
  std::ofstream(f) << "not HDF5";
  EXPECT_THROW(scene_from_results(f, 10), std::runtime_error);
}

}  // namespace
}  // namespace fragsim::formats
