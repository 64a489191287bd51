#pragma once
// The seam where the bounce model plugs in. When a fragment reaches the terrain, the run asks
// respond_to_ground_impact() what happens next. Without bounce (this slice) the history ends at
// its first ground impact. The bounce issue replaces the body with the Mirtich/Stronge impulse
// solver (paper eqs. 6-36): it updates velocity and spin and returns kContinue, or kRest once the
// fragment has come to rest.
#include "core/common/types.h"
#include "core/scene/site.h"

namespace fragsim::impact {

struct GroundImpact {
  double t_s = 0.0;
  Vec3 position_m{0, 0, 0};  // local
  Vec3 velocity_mps{0, 0, 0};
  Vec3 normal{0, 0, 1};      // terrain triangle's upward unit normal
  std::uint32_t triangle = 0;
  std::uint16_t material = 0;
};

enum class GroundResponse { kStop, kContinue, kRest };

// No bounce model in this slice: every ground impact ends the history. (The api layer rejects
// settings.bounce = true until the bounce model exists, rather than silently ignoring it.)
inline GroundResponse respond_to_ground_impact(GroundImpact&) { return GroundResponse::kStop; }

}  // namespace fragsim::impact
