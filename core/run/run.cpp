#include "core/run/run.h"

#include <chrono>
#include <utility>

#include "core/run/partial.h"

// A whole run in one process: its one shard's partial, finished (core/run/partial.h).
namespace fragsim::run {

RunResult run(const Scenario& sc, std::shared_ptr<const scene::Site> site,
              const RunControl& control) {
  PartialRun p = run_partial(sc, site, Shard{}, control);
  return finish(sc, *site, std::move(p), control);
}

RunResult run(const Scenario& sc, const RunControl& control) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto site = scene::Site::build(sc.site);
  const double build_s = std::chrono::duration<double>(Clock::now() - t0).count();
  RunResult r = run(sc, std::move(site), control);
  r.timing.build_s = build_s;
  return r;
}

}  // namespace fragsim::run
