#pragma once
// Cheap test for "is this segment far from every building?" along a path of consecutive segments
// (flight chords, ground steps), ahead of Site::segment_near_buildings.
#include "core/common/types.h"
#include "core/scene/site.h"

namespace fragsim::scene {

// Skips the per-building box pre-test far from every building. It keeps a checkpoint c and the
// horizontal distance d from c to the nearest building box; a segment with both ends closer than
// d to c lies in that disc (it is convex), and no point of the disc is in a building's box. Only
// when an end leaves the disc is the distance measured again, from the segment's start.
class BuildingProximity {
 public:
  explicit BuildingProximity(const Site& site) : site_(site) {}
  // False: the segment a-b provably overlaps no building's bounding box in xy.
  bool maybe_near(const Vec3& a, const Vec3& b) {
    if (!site_.has_buildings()) return false;
    if (inside(a) && inside(b)) return false;
    c_ = Vec2(a.x(), a.y());
    const double d = site_.building_distance_xy(a.x(), a.y());
    d2_ = d * d;
    return !inside(b);
  }

 private:
  bool inside(const Vec3& p) const {
    const double dx = p.x() - c_.x(), dy = p.y() - c_.y();
    return dx * dx + dy * dy < d2_;
  }
  const Site& site_;
  Vec2 c_{0, 0};
  double d2_ = -1.0;  // no checkpoint yet
};

}  // namespace fragsim::scene
