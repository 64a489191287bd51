// The cells that stratified launch sampling draws through (settings.stratified_launch,
// core/fragments/direction_cells.h): equal cells change no density, their shape follows the
// group's direction ranges, and draw_filling keeps the density while stratifying within cells.
#include "core/fragments/direction_cells.h"

#include <gtest/gtest.h>

#include <vector>

namespace fragsim::fragments {
namespace {

TEST(DirectionCells, EqualCellsHaveRatioOneAndEqualProbabilities) {
  const DirectionCells c = DirectionCells::equal(3, 7, 2);
  EXPECT_FALSE(c.uniform());
  ASSERT_EQ(c.cells(), 42);
  for (std::uint32_t k = 0; k < 42; ++k) EXPECT_DOUBLE_EQ(c.probability(k), 1.0 / 42.0);
  for (const double u : {0.001, 0.3, 0.5, 0.999}) {
    EXPECT_EQ(c.draw(0.2, 0.4, 0.6, u).likelihood_ratio, 1.0);  // bit for bit: weights unchanged
    EXPECT_EQ(c.draw_filling(0.2, 0.6, u).likelihood_ratio, 1.0);
  }
}

TEST(DirectionCells, CellsForStrataFollowTheGroupsRanges) {
  DirectionSpec sphere;  // the whole sphere: a 180 x 360 degree range, mean cos 2/pi
  const DirectionCells s = DirectionCells::for_strata(20000, sphere, false);
  EXPECT_LE(s.cells(), 20000);
  EXPECT_GE(s.cells(), 19000);
  // Cells about as wide as high on the sphere: azimuth extent 2 pi * (2/pi) = 4 vs pi.
  EXPECT_NEAR(static_cast<double>(s.n_azimuth()) / s.n_elevation(), 4.0 / kPi, 0.1);

  DirectionSpec flat;  // a horizontal fan: one elevation row, every stratum across azimuth
  flat.elevation_min_deg = flat.elevation_max_deg = 0.0;
  flat.azimuth_min_deg = -20.0;
  flat.azimuth_max_deg = 20.0;
  const DirectionCells f = DirectionCells::for_strata(200, flat, false);
  EXPECT_EQ(f.n_elevation(), 1);
  EXPECT_EQ(f.n_azimuth(), 200);

  DirectionSpec line = flat;  // one direction: a single cell (or speed cells only)
  line.azimuth_max_deg = line.azimuth_min_deg;
  EXPECT_EQ(DirectionCells::for_strata(200, line, false).cells(), 1);
  const DirectionCells speed_only = DirectionCells::for_strata(200, line, true);
  EXPECT_EQ(speed_only.n_speed(), 200);

  const DirectionCells with_speed = DirectionCells::for_strata(8000, sphere, true);
  EXPECT_LE(with_speed.cells(), 8000);
  EXPECT_EQ(with_speed.n_speed() >= with_speed.n_elevation() - 1, true);
  EXPECT_GE(with_speed.cells(), 6000);
  // Never more cells than strata, at least one, for any count.
  for (const std::int64_t n : {1, 2, 3, 7, 50, 1000003}) {
    const DirectionCells c = DirectionCells::for_strata(n, sphere, n % 2 == 1);
    EXPECT_GE(c.cells(), 1);
    EXPECT_LE(c.cells(), std::max<std::int64_t>(1, std::min<std::int64_t>(n, 1 << 18))) << n;
  }
}

// Mass cells are the innermost index; a drawn point lies in the drawn cell in all four
// dimensions, and without q the mass uniform passes through unchanged.
TEST(DirectionCells, MassCellsAreTheInnermostDimension) {
  const DirectionCells plain(2, 3, 2, 4);
  ASSERT_EQ(plain.cells(), 48);
  EXPECT_EQ(plain.cell_of(0.6, 0.5, 0.2, 0.9), ((1u * 3u + 1u) * 2u + 0u) * 4u + 3u);
  EXPECT_EQ(plain.draw(0.6, 0.5, 0.2, 0.3, 0.9).u_mass, 0.9);
  std::vector<double> q(48, 1.0);
  q[47] = 20.0;  // the last cell: elevation 1, azimuth 2, speed 1, mass 3
  const DirectionCells c(2, 3, 2, 4, q);
  for (int k = 0; k < 200; ++k) {
    const double u = (k + 0.5) / 200.0;
    const auto d = c.draw(0.3, 0.7, 0.4, u, 0.25);
    EXPECT_EQ(c.cell_of(d.u_elevation, d.u_azimuth, d.u_speed, d.u_mass), d.cell);
    const auto f = c.draw_filling(0.3, 0.4, u, 0.25);
    EXPECT_EQ(c.cell_of(f.u_elevation, f.u_azimuth, f.u_speed, f.u_mass), f.cell);
  }
  // u_cell near 1 falls in the heavy cell: q = 20 / 67 of the mass.
  const auto last = c.draw(0.5, 0.5, 0.5, 0.99, 0.5);
  EXPECT_EQ(last.cell, 47u);
  EXPECT_DOUBLE_EQ(last.u_mass, (3 + 0.5) / 4.0);
  EXPECT_DOUBLE_EQ(last.likelihood_ratio, (1.0 / 48.0) / (20.0 / 67.0));
}

// Stratified u_cell through draw_filling: each cell gets its share of the strata, every point
// lies in its cell, and within a cell the azimuths are spread evenly (stratified), not at
// random.
TEST(DirectionCells, FillingDrawStratifiesWithinTheCells) {
  const DirectionCells c(2, 2, 1, {1.0, 3.0, 2.0, 2.0});  // q = 1/8, 3/8, 2/8, 2/8
  constexpr int kStrata = 800;
  std::vector<std::vector<double>> azimuths(4);
  for (int j = 0; j < kStrata; ++j) {
    const double u_cell = (j + 0.5) / kStrata;
    const auto d = c.draw_filling(0.7, 0.2, u_cell);
    EXPECT_EQ(c.cell_of(d.u_elevation, d.u_azimuth, d.u_speed), d.cell);
    EXPECT_DOUBLE_EQ(d.likelihood_ratio, 0.25 / c.probability(d.cell));
    azimuths[d.cell].push_back(d.u_azimuth);
  }
  EXPECT_EQ(azimuths[0].size(), 100u);
  EXPECT_EQ(azimuths[1].size(), 300u);
  // Cell 1 is (elevation 0, azimuth 1): its azimuths fill [0.5, 1) evenly, one per 1/600.
  for (std::size_t k = 0; k < azimuths[1].size(); ++k)
    EXPECT_NEAR(azimuths[1][k], 0.5 + (static_cast<double>(k) + 0.5) / 600.0, 1e-12);
  EXPECT_THROW(DirectionCells(2, 2).draw_filling(0.5, 0.5, 0.5), std::logic_error);
}

}  // namespace
}  // namespace fragsim::fragments
