// The cost of the reach warning's pilot (core/run/reach.h, issue 22): the time
// run::groups_beyond_terrain takes on a scenario whose site is built, and what it warns of.
// docs/scenario.md ("Warnings: fragments that can reach beyond the terrain") records it for the
// two examples. Each timing is the best and the median of 9, on one thread.
//
//   build/bench/bench_reach [--max-steps N] [scenario.json ...]
//                                  (default: examples/minimal and examples/demo)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "api/scenario_json.h"
#include "core/run/reach.h"

using namespace fragsim;
using Clock = std::chrono::steady_clock;

namespace {

void measure(const std::string& path, const run::ReachOptions& options) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const api::ScenarioDocument doc = api::parse_scenario_document_text(text.str());
  const auto site = api::validate_scenario(doc.scenario);
  std::vector<double> ms;
  std::vector<run::ReachWarning> warnings;
  for (int k = 0; k < 9; ++k) {
    const auto t0 = Clock::now();
    warnings = run::groups_beyond_terrain(doc.scenario, *site, options);
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  const std::int64_t k_pilot = run::pilot_size(doc.scenario.groups.size(), options);
  std::printf(
      "%s\n  %zu groups, K = %lld each (at most %lld trajectories): best %.1f ms, median "
      "%.1f ms\n",
      path.c_str(), doc.scenario.groups.size(), static_cast<long long>(k_pilot),
      static_cast<long long>(k_pilot * static_cast<std::int64_t>(doc.scenario.groups.size())),
      ms.front(), ms[ms.size() / 2]);
  for (const auto& w : warnings) std::printf("  warning: %s\n", run::reach_message(w).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  run::ReachOptions options;
  std::vector<std::string> paths;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--max-steps" && i + 1 < argc)
      options.max_steps = std::atoll(argv[++i]);
    else
      paths.emplace_back(argv[i]);
  }
  if (paths.empty())
    for (const char* example : {"/examples/minimal/scenario.json", "/examples/demo/scenario.json"})
      paths.push_back(std::string(FRAGSIM_SOURCE_DIR) + example);
  for (const auto& p : paths) measure(p, options);
}
