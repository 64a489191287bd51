// Fletcher & Bowen (1968) block-drop validation of the bounce, slide and roll model
// (docs/validation.md). Runs the scenarios of examples/validation/fletcher-bowen/ (or the files
// given) and prints, per scenario, the mean travel distance of the blocks from release to rest
// with its standard error, the mean number of bounces, how the histories ended, and the cost.
//
//   build/bench/bench_fletcher_bowen [scenario.json ...]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "api/scenario_json.h"
#include "core/run/run.h"

using namespace fragsim;

int main(int argc, char** argv) {
  std::vector<std::string> paths(argv + 1, argv + argc);
  if (paths.empty()) {
    const std::filesystem::path dir =
        std::filesystem::path(FRAGSIM_SOURCE_DIR) / "examples/validation/fletcher-bowen";
    for (const auto& e : std::filesystem::directory_iterator(dir))
      if (e.path().extension() == ".json") paths.push_back(e.path().string());
    std::sort(paths.begin(), paths.end());
  }
  std::printf("%-18s %9s %9s %14s %10s %9s %8s %8s %9s\n", "scenario", "speed_fps", "speed_mps",
              "travel_m", "travel_ft", "se_ft", "bounces", "rested", "us/block");
  for (const auto& path : paths) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    run::Scenario sc = api::parse_scenario_text(text.str());
    sc.settings.record_fragments = true;
    const run::RunResult r = run::run(sc);
    double s = 0.0, s2 = 0.0, bounces = 0.0;
    int rested = 0;
    for (const auto& f : r.fragments) {
      const double d = std::hypot(f.end_position_m.x() - f.launch_position_m.x(),
                                  f.end_position_m.y() - f.launch_position_m.y());
      s += d;
      s2 += d * d;
      bounces += f.bounces;
      rested += f.outcome == run::Outcome::kGround ? 1 : 0;
    }
    const double n = static_cast<double>(r.fragments.size());
    const double mean = s / n;
    const double se = std::sqrt(std::max(0.0, (s2 / n - mean * mean) * n / (n - 1.0)) / n);
    const double v = sc.groups[0].frame.velocity_mps.norm();
    std::printf("%-18s %9.0f %9.2f %8.2f ± %4.2f %10.1f %9.1f %8.2f %4d/%-3.0f %9.1f\n",
                std::filesystem::path(path).filename().string().c_str(), v / 0.3048, v, mean, se,
                mean / 0.3048, se / 0.3048, bounces / n, rested, n,
                1e6 * r.timing.wall_s * r.timing.threads / n);
  }
  return 0;
}
