#pragma once
// Limits on what a site may hold (docs/scenario.md, "Limits"): coordinate magnitudes, the
// terrain's extent, element counts. They are far beyond any real site, and they keep every
// quantity the site build sizes from the input (bucket grids, cell counts, float coordinates in
// Embree, integer cell indices) finite and bounded.
//
// check_site_limits() is called by the api layer right after parsing (so a bad document is
// refused with its field path before anything is built) and again by Site::build (core may be
// called directly). It only reads the spec: O(elements), no allocation beyond messages.
#include <cstddef>

#include "core/scene/site_spec.h"

namespace fragsim::scene {

// |x| and |y| of every input coordinate, m. Twice Earth's circumference (4.0e7 m): every
// projected coordinate system passes (UTM northings < 1e7 m, Web Mercator < 2.0e7 m), and a
// double still resolves 1.5e-8 m there (its spacing at 1e8).
inline constexpr double kMaxAbsCoordinate_m = 1e8;
// |z| of every input coordinate and of site.origin.elevation_m, m. Earth's surface lies within
// -11 km (Challenger Deep) and +8.8 km (Everest); 100 km is the edge of space (Karman line).
inline constexpr double kMaxAbsElevation_m = 1e5;
// Horizontal span of the terrain (xmax - xmin, ymax - ymin), m. Fragment ranges are kilometres
// (the demo site is 2 km wide); 200 km holds a whole 1-degree elevation tile (111 km) and keeps
// site-local coordinates within 1e5 m, where Embree's floats still resolve 8 mm.
inline constexpr double kMaxTerrainExtent_m = 2e5;
// Terrain triangles and vertices of a mesh terrain: the 2^25 cells (two triangles each) a grid
// or plane may have; about 13 GB built (~190 bytes per triangle measured, docs/benchmarks.md
// section 7). fragsimd's own budget (--max-terrain-triangles) is lower by default.
inline constexpr std::size_t kMaxTerrainTriangles = std::size_t{1} << 26;
inline constexpr std::size_t kMaxTerrainVertices = std::size_t{1} << 26;
// Buildings, and their triangles all together (a footprint of n vertices, holes' included, and h
// holes counts as extruded: 4n + 4h - 4 triangles; a building mesh may have as many vertices). A
// city district has thousands of buildings.
inline constexpr std::size_t kMaxBuildings = 100000;
inline constexpr std::size_t kMaxBuildingTriangles = std::size_t{1} << 24;
// Footprint vertices of one building, its holes' included: the simplicity checks are O(n^2) and
// the roof's ear clipping O(n^2) to O(n^3); surveyed or mapped outlines have tens to hundreds of
// vertices.
inline constexpr std::size_t kMaxFootprintVertices = 1000;
// Material zones (site.terrain.zones) and the vertices of one zone's polygon: each zone is
// checked for simplicity (O(n^2)) and tested against the terrain triangles under its bounds.
inline constexpr std::size_t kMaxMaterialZones = 10000;
inline constexpr std::size_t kMaxZoneVertices = 1000;
// Height of a footprint building above its base, m: twelve times the tallest building
// (Burj Khalifa, 828 m).
inline constexpr double kMaxBuildingHeight_m = 1e4;

// Throws InputError naming the field ("site.terrain.mesh.vertices_m[2][0]: must be in [-1e+08,
// 1e+08] (got 1e+308)", "site.terrain.mesh.vertices_m: spans 3e+05 m in x ...") when the spec
// breaks a limit above. Fields that are not finite are reported as "not finite".
void check_site_limits(const SiteSpec& spec);

// The number of terrain triangles the spec would build, known before building it (a plane's
// cells are counted as the builder counts them; an upper bound when the spec is invalid, which
// the builder then refuses). Lets a caller with a memory budget refuse a site up front: a few
// bytes of plane or grid spec can ask for 2^26 triangles (about 13 GB built, at the ~190 bytes
// per triangle measured in docs/benchmarks.md section 7).
double terrain_triangles_of(const TerrainSpec& terrain);

}  // namespace fragsim::scene
