#pragma once
// settings.ground_bracket (docs/physics.md, "The bracket"): the study run again with each
// uncertain constant of the terrain material (scene::effective_ranges: its `ranges`, and the
// documented ranges of fast_contact's constants) at each end of its range, one at a time, with the
// same seed (common random numbers: the differences are paired). A variant runs the groups'
// samples x samples_scale without settings.precision, and the nominal constants are run the same
// way, so every row is compared with a nominal of the same samples.
#include <memory>

#include "core/run/result.h"
#include "core/run/run.h"
#include "core/run/scenario.h"

namespace fragsim::run {

// The bracket of `scenario` (which must have settings.ground_bracket). `control.cancel` stops it
// between and within runs (the result then says cancelled); progress is not reported.
std::shared_ptr<const GroundBracket> run_ground_bracket(const Scenario& scenario,
                                                        const RunControl& control = {});

// The histories the bracket runs after the study: (1 + 2 x ranges) runs of the groups' samples x
// samples_scale (0 without settings.ground_bracket). For work limits (fragsimd).
std::int64_t ground_bracket_histories(const Scenario& scenario);

// Checks a scenario's bracket request: bounce on, and the terrain material has at least one
// range. Throws InputError naming settings.ground_bracket.
void check_ground_bracket(const Scenario& scenario);

}  // namespace fragsim::run
