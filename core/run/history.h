#pragma once
// One fragment history: launch checks, flight, contacts, tallies. Pure function of its inputs
// (scenario, site, group, history index, seed); writes its tally contributions to a ChunkOutput.
#include <cstdint>
#include <limits>
#include <vector>

#include "core/flight/atmosphere.h"
#include "core/flight/flight_model.h"
#include "core/fragments/sampling.h"
#include "core/run/result.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"
#include "core/tally/ptn_prisms.h"
#include "core/tally/stratum_pieces.h"

namespace fragsim::run {

struct PtnContribution {
  std::uint32_t triangle;
  double value;                                          // weight / A_PTN
  PtnMechanism mechanism = PtnMechanism::kDirectFlight;  // in the padding: no larger
};

struct BuildingContribution {
  std::uint32_t building;
  std::uint8_t surface;
  bool penetrated;
  double residual_ke_j;
};

// Everything a chunk of histories produces, per history, in history order.
struct ChunkOutput {
  std::uint32_t group = 0;
  std::int64_t first_history = 0;
  std::int64_t count = 0;
  bool last_of_batch = false;          // the run's (shard's) last chunk of its batch
  double weight = 0.0;                 // count / samples of the group
  std::vector<double> weights;         // per history: weight x likelihood ratio (== weight without
                                       // importance sampling)
  std::vector<std::uint32_t> cells;    // per history: launch direction cell (importance sampling)
  std::vector<std::uint32_t> ptn_end;  // per history: end offset into ptn
  std::vector<PtnContribution> ptn;
  std::vector<std::int32_t> building_index;  // per history: index into buildings, or -1
  std::vector<BuildingContribution> buildings;
  std::vector<Outcome> outcomes;
  // per history: the HFD sector (core/run/hfd.h) of the point where it left the site with
  // kinetic energy >= hazardous_ke_j, or -1
  std::vector<std::int8_t> exit_sector;
  std::vector<FragmentRecord> records;
  std::vector<TrajectoryRecord> trajectories;
  RunStats stats;
  double integration_s = 0.0, geometry_s = 0.0, tally_s = 0.0;
  // The histories' tally contributions as exact stratum pieces, built on the worker after the
  // last history (Reducer::prefold, core/run/reducer.h) and added under the fold's lock.
  std::vector<tally::StratumPiece> pieces;
};

// Immutable, shared by all workers of one run.
struct RunContext {
  const Scenario* scenario = nullptr;
  const scene::Site* site = nullptr;
  flight::Atmosphere atmosphere;
  std::vector<flight::DragCoefficient> cd;     // per group
  std::vector<fragments::GroupLaunch> launch;  // per group: its launch constants
  tally::PtnPrisms prisms;
  double terrain_min_z = 0.0;   // local
  double terrain_max_z = 0.0;   // local
  double terrain_min_nz = 1.0;  // smallest z of a terrain triangle's unit normal (> 0)
  // A plane or grid terrain (a continuous height field over the grid's rectangle): the steepest
  // slope of its triangles (tan of the largest inclination); +inf for a mesh terrain.
  double lattice_max_slope = std::numeric_limits<double>::infinity();
  Vec3 hfd_origin{0, 0, 0};      // local (core/run/hfd.h)
  double top_z = 0.0;            // highest point anything can be hit or tallied (local)
  bool step_min_at_ends = true;  // no updraft: a step's lowest point is one of its ends
  bool still_air = true;         // no wind: drag only removes mechanical energy
  RunContext(const Scenario& sc, const scene::Site& s);
};

// Per-thread scratch space reused between histories (no allocation in the steady state).
struct HistoryScratch {
  std::vector<PtnContribution> ptn;
  std::vector<std::uint32_t> seen;  // per terrain triangle: stamp of the last history that took it
  std::uint32_t stamp = 0;
};

// Appends the histories simulated into `piece` (a ChunkOutput that was empty) to `to`, exactly
// as if they had been simulated into `to`, and empties `piece` (its capacity kept). Histories in
// lanes (core/run/lane_runner.h) end out of order; each writes into its own piece, appended in
// history order.
void append_histories(ChunkOutput& to, ChunkOutput& piece);
// Empties what histories write into a ChunkOutput (its per-history arrays, stats and timers).
void clear_histories(ChunkOutput& piece);

// `cells`: the group's launch-direction cells for this batch (importance sampling), or null;
// `stratum`: the history's launch stratum (settings.stratified_launch), or null.
void simulate_history(const RunContext& ctx, std::uint32_t group, std::int64_t history,
                      bool record_trajectory, HistoryScratch& scratch, ChunkOutput& out,
                      const fragments::DirectionCells* cells = nullptr,
                      const fragments::LaunchStratum* stratum = nullptr);

}  // namespace fragsim::run
