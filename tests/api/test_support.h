#pragma once
// Shared helpers for the api tests: fixtures from the source tree and error capture.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "api/scenario_json.h"
#include "core/common/error.h"
#include "core/run/result.h"

namespace fragsim::api::testing {

using Json = nlohmann::json;
using FieldMessage = std::pair<std::string, std::string>;

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in.good()) << "cannot read " << path;
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Removes, when a test passes, the directories fresh_test_dir made for it; a failed test's are
// kept to look at. Daemon tests leave results of up to 300 MB each: left behind on every run they
// filled the CI machine's disk (stop 33).
class TestDirCleaner : public ::testing::EmptyTestEventListener {
 public:
  static TestDirCleaner& instance() {
    static TestDirCleaner* cleaner = [] {
      auto* c = new TestDirCleaner;  // the listener list owns it
      ::testing::UnitTest::GetInstance()->listeners().Append(c);
      return c;
    }();
    return *cleaner;
  }
  void add(const std::filesystem::path& dir) { dirs_.push_back(dir); }
  void OnTestEnd(const ::testing::TestInfo& info) override {
    if (info.result()->Passed()) {
      std::error_code ignored;
      for (const auto& d : dirs_) std::filesystem::remove_all(d, ignored);
    }
    dirs_.clear();
  }

 private:
  std::vector<std::filesystem::path> dirs_;
};

// An empty directory of the test's own under the system temp directory (process id and test name
// in its name, so parallel test processes never share one). Removed first if a crashed run left it,
// and removed after the test if it passes (TestDirCleaner).
inline std::filesystem::path fresh_test_dir(const std::string& prefix) {
  namespace fs = std::filesystem;
  const fs::path dir =
      fs::temp_directory_path() / (prefix + std::to_string(::getpid()) + "_" +
                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
  fs::remove_all(dir);
  fs::create_directories(dir);
  TestDirCleaner::instance().add(dir);
  return dir;
}

inline std::filesystem::path source_path(const std::string& relative) {
  return std::filesystem::path(FRAGSIM_SOURCE_DIR) / relative;
}

// A building result with figures on two surfaces (wall, roof) and a residual energy.
inline run::BuildingResult example_building() {
  run::BuildingResult b;
  b.id = "B1";
  b.impacts = {12.5, 0.25};
  b.penetrations = {3.0, 0.5};
  b.impacts_by_surface[1] = {10.0, 0.2};
  b.impacts_by_surface[2] = {2.5, 0.1};
  b.penetrations_by_surface[2] = {3.0, 0.5};
  b.residual_ke_j = {4000.0, 300.0};
  return b;
}

inline Json minimal_example() {
  return Json::parse(read_text(source_path("examples/minimal/scenario.json")));
}

// `scenario` (or a site) on a 400 m x 400 m plane of 10 m cells (3,200 triangles), as the
// minimal example had before it grew to hold its fragments: a small site for tests of formats,
// exports and services, where the site's size is not the point. Most fragments leave it, so its
// HFD is cut by the site boundary.
inline Json on_small_plane(Json scenario) {
  Json& site = scenario.contains("site") ? scenario["site"] : scenario;
  site["terrain"]["plane"]["extent_m"] = {-200, -200, 200, 200};
  site["terrain"]["plane"]["cell_m"] = 10;
  return scenario;
}

// The minimal example on a coarse plane (4 x 4 cells of 100 m) at UTM-sized coordinates, its
// building moved along: input coordinates far from the local ones.
inline run::Scenario far_plane_scenario() {
  run::Scenario sc = parse_scenario(minimal_example());
  auto& plane = std::get<scene::PlaneTerrainSpec>(sc.site.terrain.geometry);
  plane.extent_m = {500000, 4000000, 500400, 4000400};
  plane.cell_m = 100;
  plane.elevation_m = 250;
  sc.site.buildings[0].footprint_m = {
      {500260, 4000190}, {500280, 4000190}, {500280, 4000210}, {500260, 4000210}};
  return sc;
}

inline Json demo_example() {
  return Json::parse(read_text(source_path("examples/demo/scenario.json")));
}
inline Json kitchen_sink() {
  return Json::parse(read_text(source_path("tests/api/data/kitchen_sink.json")));
}

// (field, message) of the InputError that parsing throws; ("<no error>", "") if it parses.
inline FieldMessage parse_error(const Json& j) {
  try {
    parse_scenario_document(j);
  } catch (const InputError& e) {
    return {e.field(), e.message()};
  }
  return {"<no error>", ""};
}

inline FieldMessage parse_text_error(const std::string& text) {
  try {
    parse_scenario_document_text(text);
  } catch (const InputError& e) {
    return {e.field(), e.message()};
  }
  return {"<no error>", ""};
}

// Parsing and the geometry checks of Site::build.
inline FieldMessage validation_error(const Json& j) {
  try {
    validate_scenario(parse_scenario(j));
  } catch (const InputError& e) {
    return {e.field(), e.message()};
  }
  return {"<no error>", ""};
}

}  // namespace fragsim::api::testing
