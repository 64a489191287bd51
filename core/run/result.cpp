#include "core/run/result.h"

// The names of result.h's enums, as the outputs spell them (docs/scenario.md, docs/http-api.md).
namespace fragsim::run {

const char* outcome_name(Outcome o) {
  switch (o) {
    case Outcome::kGround: return "ground";
    case Outcome::kBuilding: return "building";
    case Outcome::kMaxFlightTime: return "max_flight_time";
    case Outcome::kLeftSite: return "left_site";
    case Outcome::kStartedInside: return "started_inside";
    case Outcome::kHarmless: return "harmless";
    case Outcome::kIntegrationFailed: return "integration_failed";
    case Outcome::kEmbedded: return "embedded";
    case Outcome::kWorkLimit: return "work_limit";
    case Outcome::kGroundStepCap: return "ground_step_cap";
  }
  return "unknown";
}

const char* trajectory_event_name(TrajectoryEvent e) {
  switch (e) {
    case TrajectoryEvent::kLaunch: return "launch";
    case TrajectoryEvent::kFlight: return "flight";
    case TrajectoryEvent::kTerrainImpact: return "terrain_impact";
    case TrajectoryEvent::kTakeOff: return "take_off";
    case TrajectoryEvent::kGround: return "ground";
    case TrajectoryEvent::kBuildingHit: return "building_hit";
    case TrajectoryEvent::kEnd: return "end";
  }
  return "unknown";
}

const char* stop_reason_name(StopReason s) {
  switch (s) {
    case StopReason::kSamples: return "samples";
    case StopReason::kTargetsMet: return "targets_met";
    case StopReason::kMaxBatches: return "max_batches";
    case StopReason::kMaxWallTime: return "max_wall_time";
    case StopReason::kCancelled: return "cancelled";
    case StopReason::kTargetsUnmeetable: return "targets_unmeetable";
  }
  return "unknown";
}

}  // namespace fragsim::run
