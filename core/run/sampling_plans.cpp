#include "core/run/sampling_plans.h"

namespace fragsim::run {

SamplingPlans::Cells drawable(SamplingPlans::Cells cells, const LaunchStrata& strata) {
  if (!strata.on() || strata.sobol()) return cells;  // a Sobol point draws from uniform cells too
  for (auto& c : cells)
    if (c.uniform())
      c = fragments::DirectionCells::equal(c.n_elevation(), c.n_azimuth(), c.n_speed(), c.n_mass());
  return cells;
}

void learn(DirectionLearner& learner, const ChunkOutput& c, LearnerInput* out) {
  std::uint32_t begin = 0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(c.count); ++i) {
    const std::uint32_t end = c.ptn_end[i];
    const std::int32_t bi = c.building_index[i];
    const std::int32_t building =
        bi >= 0 ? static_cast<std::int32_t>(c.buildings[static_cast<std::size_t>(bi)].building)
                : -1;
    if (out != nullptr)
      learner.observe(c.group, c.cells[i], c.weights[i] / c.weight, building, c.ptn.data() + begin,
                      c.ptn.data() + end, *out);
    else
      learner.add(c.group, c.cells[i], c.weights[i] / c.weight, building, c.ptn.data() + begin,
                  c.ptn.data() + end);
    begin = end;
  }
}

}  // namespace fragsim::run
