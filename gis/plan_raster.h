#pragma once
// Per-triangle values onto a north-up raster (docs/gis.md, "Outputs"): each cell holds the mean
// of the values of the triangles over it, weighted by the area of each triangle's plan (x, y)
// projection inside the cell, computed exactly by clipping the triangle to the cell. A cell no
// triangle covers is empty (coverage 0).
#include <array>
#include <cstdint>
#include <vector>

#include "core/common/types.h"

namespace fragsim::gis {

struct PlanRaster {
  double x0 = 0, y0 = 0;  // south-west corner of cell (0, 0)
  double cell_m = 1;
  int cols = 0, rows = 0;  // row 0 is the southernmost
  // Per cell (row-major from row 0): sum of value x area and area, for each value set.
  std::vector<double> covered_m2;
  std::vector<std::vector<double>> weighted;  // [value set][cell]

  std::size_t index(int col, int row) const {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(cols) +
           static_cast<std::size_t>(col);
  }
  // The mean of value set k in a cell; NaN where nothing covers it.
  double mean(std::size_t k, int col, int row) const;
};

// The raster over the triangles' plan extent: cells of `cell_m` aligned on (xmin, ymin) of the
// vertices, enough to cover them (one more cell when the extent is not a whole number of cells).
PlanRaster make_plan_raster(const std::vector<Vec3>& vertices, double cell_m,
                            std::size_t value_sets);

// A raster of `cols` x `rows` cells of `cell_m` whose south-west corner is (x0, y0).
PlanRaster make_plan_raster_at(double x0, double y0, double cell_m, int cols, int rows,
                               std::size_t value_sets);

// Adds triangle (a, b, c) with values[k] for each value set.
void add_triangle(PlanRaster& r, const Vec2& a, const Vec2& b, const Vec2& c,
                  const std::vector<double>& values);

// Area of the part of triangle (a, b, c) inside the box [lo, hi] (Sutherland-Hodgman clipping).
double clipped_area(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& lo, const Vec2& hi);

}  // namespace fragsim::gis
