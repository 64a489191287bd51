#pragma once
// Importance sampling of launch directions and speeds (settings.precision.direction_importance,
// docs/precision.md). A group's direction and speed are drawn from three uniforms (u_elevation,
// u_azimuth, u_speed) on the unit cube, where their density is uniform (sample_direction, and
// the speed distribution's inverse CDF). DirectionCells cuts the cube into n_elevation x
// n_azimuth x n_speed cells and draws from a piecewise-constant density q instead: a cell c with
// probability q_c, then a uniform point in it. The history's weight is multiplied by the
// likelihood ratio p_c / q_c = (1/N) / q_c, so every estimate stays unbiased for any q with
// q_c > 0 in every cell (docs/precision.md, "Importance sampling").
#include <cstdint>
#include <vector>

#include "core/fragments/group.h"

// Stratified launch sampling (settings.stratified_launch, docs/precision.md) reuses the cells:
// stratum j of J fixes u_cell in [j/J, (j+1)/J), which, through the cells' cumulative q, sends
// the strata to the cells in proportion to q.

namespace fragsim::fragments {

class DirectionCells {
 public:
  // Uniform: directions are drawn as without importance sampling (likelihood ratio exactly 1);
  // only the cell of each direction is reported.
  DirectionCells(int n_elevation, int n_azimuth, int n_speed = 1, int n_mass = 1);
  // Cell probabilities q (size n_elevation * n_azimuth * n_speed * n_mass, index
  // ((i_e * n_a + i_a) * n_s + i_s) * n_m + i_m, all > 0; normalised here).
  DirectionCells(int n_elevation, int n_azimuth, int n_speed, int n_mass, std::vector<double> q);
  DirectionCells(int n_elevation, int n_azimuth, int n_speed, std::vector<double> q)
      : DirectionCells(n_elevation, n_azimuth, n_speed, 1, std::move(q)) {}

  // Cells of equal probability, drawn through q like learnt ones (so that a stratified u_cell
  // stratifies the cells: settings.stratified_launch); the likelihood ratio is exactly 1.
  static DirectionCells equal(int n_elevation, int n_azimuth, int n_speed = 1, int n_mass = 1);
  // Equal cells for `strata` strata of u_cell over the directions of `d`: about one cell per
  // stratum, never more cells than strata, shaped so that a cell spans about as much elevation
  // as azimuth on the sphere (one row or column where a range has zero width); with
  // `with_speed`, as many speed cells as elevation cells.
  static DirectionCells for_strata(std::int64_t strata, const DirectionSpec& d, bool with_speed);

  int n_elevation() const { return n_e_; }
  int n_azimuth() const { return n_a_; }
  int n_speed() const { return n_s_; }
  int n_mass() const { return n_m_; }
  int cells() const { return n_e_ * n_a_ * n_s_ * n_m_; }
  bool uniform() const { return q_.empty(); }
  double probability(std::uint32_t cell) const;  // q_c

  std::uint32_t cell_of(double u_elevation, double u_azimuth, double u_speed,
                        double u_mass = 0.5) const;

  struct Draw {
    double u_elevation = 0.5, u_azimuth = 0.5, u_speed = 0.5;  // where in the unit hypercube
    double u_mass = 0.5;
    double likelihood_ratio = 1.0;  // p_c / q_c
    std::uint32_t cell = 0;
  };
  // u_elevation, u_azimuth, u_speed, u_mass place the point inside the cell that u_cell picks.
  Draw draw(double u_elevation, double u_azimuth, double u_speed, double u_cell,
            double u_mass = 0.5) const;
  // As draw, with the azimuth within the cell taken from where u_cell falls in the cell's share
  // of the cumulative q (uniform on [0, 1) given the cell, so the density is unchanged): strata
  // of u_cell finer than the cells then also stratify the azimuth within each cell. Needs q.
  Draw draw_filling(double u_elevation, double u_speed, double u_cell, double u_mass = 0.5) const;

 private:
  int n_e_, n_a_, n_s_, n_m_;
  std::vector<double> q_, cdf_;  // empty: uniform
};

}  // namespace fragsim::fragments
