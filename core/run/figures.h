#pragma once
// A run's figures from its folded tallies: the PTN density field and its standard errors, the
// HFD with its band, sectors, site-boundary cuts and attribution, the building figures and the
// outcomes (docs/architecture.md, "Data flow"; the estimators: docs/precision.md).
#include <cstdint>

#include "core/run/partial.h"
#include "core/run/result.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::run {

// Turns the folded tallies of `batches` batches into the result's figures.
void fill_figures(const Scenario& sc, const scene::Site& site, const PartialRun& p,
                  std::int64_t batches, RunResult& r);

}  // namespace fragsim::run
