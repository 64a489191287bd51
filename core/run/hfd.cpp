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
  if (!(az >= 0.0)) return 0;  // NaN (a position that is not a number): no cast of it (UB)
  return std::clamp(static_cast<int>(az / 10.0), 0, kHfdSectors - 1);
}

Vec3 hfd_origin_input(const Scenario& sc, const scene::Site& site) {
  if (sc.settings.hfd_origin_m) return *sc.settings.hfd_origin_m;
  return sc.groups.empty() ? site.local_origin() : sc.groups[0].frame.origin_m;
}

HfdGeometry::HfdGeometry(const scene::Site& site, const Vec3& origin_local, bool keep_distances)
    : site_(site), origin_(origin_local) {
  if (keep_distances) {
    distance_.resize(site.terrain_triangle_count());
    for (std::uint32_t t = 0; t < distance_.size(); ++t) {
      const Vec2 d = offset(t);
      distance_[t] = std::hypot(d.x(), d.y());
    }
  }
  for (const std::uint32_t t : site.terrain_boundary_triangles()) {
    const Vec2 d = offset(t);
    boundary_sector_.push_back(static_cast<std::uint8_t>(hfd_sector(d.x(), d.y())));
  }
}

Vec2 HfdGeometry::offset(std::uint32_t t) const {
  const Vec3 c = site_.terrain_triangle_centroid(t);
  return Vec2(c.x() - origin_.x(), c.y() - origin_.y());
}

// std::hypot, as the HFD has always been measured (Vec2::norm rounds differently).
double HfdGeometry::distance(std::uint32_t t) const {
  if (!distance_.empty()) return distance_[t];
  const Vec2 d = offset(t);
  return std::hypot(d.x(), d.y());
}

double HfdGeometry::hfd(const std::vector<double>& density, double threshold,
                        SectorFigures* by_sector, HfdTriangles* set_by) const {
  SectorFigures sectors;
  if (set_by != nullptr && by_sector == nullptr) by_sector = &sectors;
  if (set_by != nullptr) *set_by = HfdTriangles{};
  double best = 0.0;
  if (by_sector) by_sector->fill(0.0);
  for (std::uint32_t t = 0; t < density.size(); ++t) {
    if (!hazardous(density[t], threshold)) continue;
    const double r = distance(t);
    if (set_by != nullptr && (set_by->overall < 0 || r > best)) set_by->overall = t;
    best = std::max(best, r);
    if (by_sector) {
      const Vec2 d = offset(t);
      const auto k = static_cast<std::size_t>(hfd_sector(d.x(), d.y()));
      double& s = (*by_sector)[k];
      if (set_by != nullptr && (set_by->by_sector[k] < 0 || r > s)) set_by->by_sector[k] = t;
      s = std::max(s, r);
    }
  }
  return best;
}

BoundaryCut HfdGeometry::cut(const std::vector<double>& density, double threshold) const {
  BoundaryCut c;
  const auto& boundary = site_.terrain_boundary_triangles();
  for (std::size_t k = 0; k < boundary.size(); ++k) {
    const std::uint32_t t = boundary[k];
    if (t >= density.size() || !hazardous(density[t], threshold)) continue;
    bool& flag = c.sectors[boundary_sector_[k]];
    c.sector_count += flag ? 0 : 1;
    flag = true;
  }
  return c;
}

double HfdGeometry::max_boundary_density(const std::vector<double>& density) const {
  double best = 0.0;
  for (const std::uint32_t t : site_.terrain_boundary_triangles())
    if (t < density.size() && density[t] > best) best = density[t];
  return best;
}

HfdFigures HfdGeometry::figures(const std::vector<double>& density,
                                const std::vector<double>& std_error, double threshold) const {
  HfdFigures f;
  f.hfd_m = hfd(density, threshold, &f.by_sector_m, &f.set_by);
  f.cut = cut(density, threshold);
  f.max_boundary_density_per_m2 = max_boundary_density(density);
  std::vector<double> shifted(density.size());
  for (std::size_t t = 0; t < shifted.size(); ++t) shifted[t] = density[t] - std_error[t];
  f.lower_m = hfd(shifted, threshold);
  f.lower_cut = cut(shifted, threshold);
  for (std::size_t t = 0; t < shifted.size(); ++t) shifted[t] = density[t] + std_error[t];
  f.upper_m = hfd(shifted, threshold);
  f.upper_cut = cut(shifted, threshold);
  return f;
}

}  // namespace fragsim::run
