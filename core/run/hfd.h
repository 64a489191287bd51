#pragma once
// The hazardous fragment distance (HFD) of a PTN density field, overall and per 10-degree
// sector, and whether the terrain's boundary cuts it (docs/scenario.md, "When the site boundary
// cuts the HFD").
//
// The HFD is the largest horizontal distance from the HFD origin of a terrain triangle centroid
// whose density is at or above the threshold. The density is only known on the terrain: when a
// triangle touching the terrain's boundary (Site::terrain_boundary_triangles) is at or above the
// threshold, the hazardous area runs off the model in that triangle's sector, and the sector's
// HFD, and with it the overall HFD, is only a lower bound.
#include <array>
#include <cstdint>
#include <vector>

#include "core/common/types.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::run {

inline constexpr int kHfdSectors = 36;  // sector k: azimuth [10k, 10k + 10) deg from +x to +y
using SectorFigures = std::array<double, kHfdSectors>;
using SectorFlags = std::array<bool, kHfdSectors>;

// The sector of the horizontal offset (dx, dy) from the HFD origin.
int hfd_sector(double dx, double dy);

// The point the HFD is measured from, input coordinates: settings.hfd_origin_m, else the first
// group's frame origin, else the site's local origin.
Vec3 hfd_origin_input(const Scenario& sc, const scene::Site& site);

// Which figures of one density field the boundary cut.
struct BoundaryCut {
  SectorFlags sectors{};  // a boundary triangle of the sector is at or above the threshold
  int sector_count = 0;   // of them
  bool any() const { return sector_count > 0; }
};

// The triangles whose centroids set an HFD, overall and per sector (-1: no triangle at or above
// the threshold). Of triangles at the same distance, the first (lowest index) sets it.
struct HfdTriangles {
  std::int64_t overall = -1;
  std::array<std::int64_t, kHfdSectors> by_sector;
  HfdTriangles() { by_sector.fill(-1); }
};

// The HFD of a density field and of the fields mean -+ 1 se (its band), each with the sectors the
// terrain's boundary cuts, and the triangles that set the HFD and the sectors' HFDs.
struct HfdFigures {
  double hfd_m = 0.0, lower_m = 0.0, upper_m = 0.0;
  SectorFigures by_sector_m{};
  BoundaryCut cut, lower_cut, upper_cut;
  double max_boundary_density_per_m2 = 0.0;
  HfdTriangles set_by;
};

// The geometry an HFD is measured on: the HFD origin, the site's triangles and the sectors of the
// triangles touching the terrain's boundary. A triangle's distance and sector are computed when a
// density makes it count (hazardous), as the HFD always did, unless `keep_distances` keeps the
// distances of all triangles (precision checks, the importance learner: they look at many
// fields of one run).
class HfdGeometry {
 public:
  HfdGeometry(const scene::Site& site, const Vec3& origin_local, bool keep_distances = false);

  // The HFD of `density` (0 when no triangle is at or above the threshold), per sector, and the
  // triangles that set them.
  double hfd(const std::vector<double>& density, double threshold,
             SectorFigures* by_sector = nullptr, HfdTriangles* set_by = nullptr) const;
  // The sectors whose HFD of `density` the terrain's boundary cuts.
  BoundaryCut cut(const std::vector<double>& density, double threshold) const;
  // The largest density on a triangle touching the boundary (0 without one).
  double max_boundary_density(const std::vector<double>& density) const;
  // All of the above for a density field and its standard errors.
  HfdFigures figures(const std::vector<double>& density, const std::vector<double>& std_error,
                     double threshold) const;

  // Every triangle's centroid distance (m); empty unless kept.
  const std::vector<double>& distances() const { return distance_; }

 private:
  Vec2 offset(std::uint32_t triangle) const;  // centroid - origin, horizontal
  double distance(std::uint32_t triangle) const;

  const scene::Site& site_;
  Vec3 origin_;
  std::vector<double> distance_;               // per triangle when kept
  std::vector<std::uint8_t> boundary_sector_;  // per boundary triangle
};

}  // namespace fragsim::run
