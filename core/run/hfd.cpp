#include "core/run/hfd.h"

#include <algorithm>
#include <cmath>

namespace fragsim::run {

namespace {

bool hazardous(double density, double threshold) {
  return density >= threshold && density > 0.0;  // false for NaN
}

}  // namespace

int hfd_sector(double dx, double dy) {
  double az = std::atan2(dy, dx) / kDegToRad;
  if (az < 0.0) az += 360.0;
  return std::clamp(static_cast<int>(az / 10.0), 0, kHfdSectors - 1);
}

Vec3 hfd_origin_input(const Scenario& sc, const scene::Site& site) {
  if (sc.settings.hfd_origin_m) return *sc.settings.hfd_origin_m;
  return sc.groups.empty() ? site.local_origin() : sc.groups[0].frame.origin_m;
}

HfdGeometry::HfdGeometry(const scene::Site& site, const Vec3& origin_local)
    : distance_(site.terrain_triangle_count()),
      sector_(site.terrain_triangle_count()),
      boundary_(site.terrain_boundary_triangles()) {
  for (std::uint32_t t = 0; t < distance_.size(); ++t) {
    const Vec3 c = site.terrain_triangle_centroid(t);
    const double dx = c.x() - origin_local.x(), dy = c.y() - origin_local.y();
    distance_[t] = std::hypot(dx, dy);
    sector_[t] = static_cast<std::uint8_t>(hfd_sector(dx, dy));
  }
}

double HfdGeometry::hfd(const std::vector<double>& density, double threshold,
                        SectorFigures* by_sector) const {
  double best = 0.0;
  if (by_sector) by_sector->fill(0.0);
  for (std::size_t t = 0; t < density.size(); ++t) {
    if (!hazardous(density[t], threshold)) continue;
    best = std::max(best, distance_[t]);
    if (by_sector) {
      double& s = (*by_sector)[sector_[t]];
      s = std::max(s, distance_[t]);
    }
  }
  return best;
}

BoundaryCut HfdGeometry::cut(const std::vector<double>& density, double threshold) const {
  BoundaryCut c;
  for (const std::uint32_t t : boundary_) {
    if (t >= density.size() || !hazardous(density[t], threshold)) continue;
    bool& flag = c.sectors[sector_[t]];
    c.sector_count += flag ? 0 : 1;
    flag = true;
  }
  return c;
}

double HfdGeometry::max_boundary_density(const std::vector<double>& density) const {
  double best = 0.0;
  for (const std::uint32_t t : boundary_)
    if (t < density.size() && density[t] > best) best = density[t];
  return best;
}

}  // namespace fragsim::run
