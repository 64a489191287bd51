#pragma once
// Builders of the 2-D bucket index over terrain triangles (internal to core/scene).
#include <array>
#include <cstdint>
#include <vector>

#include "core/scene/site.h"

namespace fragsim::scene::detail {

// Plane and grid terrains: bucket (i, j) is exactly cell (i, j) of an ncx x ncy cell grid whose
// two triangles are 2*(j*ncx + i) and 2*(j*ncx + i) + 1. Traversal is then exact: the buckets a
// segment passes through are the cells it crosses.
TerrainIndex2D make_cell_index(const Vec2& origin, const Vec2& cell, int ncx, int ncy,
                               const std::vector<Vec3>& vertices,
                               const std::vector<std::array<std::uint32_t, 3>>& triangles);

// General meshes: square buckets of about half the mean projected triangle area; a
// triangle is listed in every bucket its xy-projection overlaps (exact separating-axis test
// against the bucket grown by 1e-9 of its size, so triangles touching a bucket's edge or corner
// are listed on both sides and a segment running along a bucket edge still finds them).
TerrainIndex2D make_mesh_index(const std::vector<Vec3>& vertices,
                               const std::vector<std::array<std::uint32_t, 3>>& triangles);

// Mean number of triangle references per non-empty bucket (diagnostics and tests).
double mean_bucket_occupancy(const TerrainIndex2D& index);

}  // namespace fragsim::scene::detail
