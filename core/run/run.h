#pragma once
// One Monte Carlo run: sample histories, fly them, tally. Thread pool over chunks of histories.
// Results are bit-identical for any thread count, chunk size and shard split (exact sums:
// tally/exact_sum.h; shards: run/partial.h).
#include <memory>

#include "core/run/control.h"
#include "core/run/result.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::run {

// Runs the scenario on an already built site (the daemon shares one Site between jobs).
RunResult run(const Scenario& scenario, std::shared_ptr<const scene::Site> site,
              const RunControl& control = {});

// Convenience: builds the site from scenario.site, then runs. Throws InputError on bad geometry.
RunResult run(const Scenario& scenario, const RunControl& control = {});

}  // namespace fragsim::run
