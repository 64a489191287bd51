#pragma once
// Pseudo-trajectory-normal (PTN) prisms (paper eqs. 37-39): every terrain triangle extruded
// vertically up to the person height H is a prism; a hazardous fragment whose path crosses it adds
// weight / A_PTN to its density, where A_PTN is the prism's area projected normal to the path:
//   A_PTN = sum_faces A_i max(0, n_i . v_hat)                              (eqs. 38-39)
// For a vertical extrusion the top and bottom faces are the triangle itself (normals +/-n), so
// their two terms add up to A |n . v_hat|, and a side face over edge e has area H |e_xy| and a
// horizontal outward normal; with N_e = the outward edge normal scaled by |e_xy|:
//   A_PTN = A |n . v_hat| + H sum_e max(0, N_e . v_hat_xy).
// Vertical fall gives A_PTN = A (the plain count/area density); horizontal flight gives H times the
// width of the triangle across the path.
#include <array>
#include <cstdint>
#include <vector>

#include "core/common/types.h"
#include "core/scene/site.h"

namespace fragsim::tally {

class PtnPrisms {
 public:
  PtnPrisms(const scene::Site& site, double person_height_m);

  double person_height_m() const { return h_; }
  std::size_t size() const { return count_; }

  // Eqs. 38-39 for a unit direction of travel.
  double projected_area(std::uint32_t triangle, const Vec3& dir_unit) const;

  // The part [s_in, s_out] of the straight segment a + s (b - a), s in [0, 1], that lies inside
  // the prism of `triangle` (between its ground plane and H above it, inside its xy-projection).
  // Returns false when the segment misses the prism (or only touches it in a single point while
  // moving across it, which has zero measure).
  bool clip(std::uint32_t triangle, const Vec3& a, const Vec3& b, double& s_in,
            double& s_out) const;

  // Starts loading a prism's data (a hint for walks that know the next triangle ahead).
  void prefetch(std::uint32_t triangle) const { __builtin_prefetch(&(*triangles_)[triangle]); }

  // Highest point of any prism (terrain max z + H): a path above it crosses no prism.
  double top_z() const { return top_z_; }

 private:
  // A prism's geometry is computed from the triangle's vertices when it is tested, not stored:
  // stored, it took 120 bytes per terrain triangle and was built for every run (0.96 GB and
  // 2.7 s of a 4.1 s run on an 8-million-triangle site; docs/benchmarks.md section 7).
  struct Prism {
    // xy-projection as three half-planes N_k . p <= c_k (N_k outward, |N_k| = |edge_k|).
    std::array<Vec2, 3> edge_normal;
    std::array<double, 3> edge_c;
    // ground plane z = gx x + gy y + gz
    double gx, gy, gz;
    Vec3 area_normal;  // A * n (n upward unit normal)
  };
  Prism prism(std::uint32_t triangle) const;

  const std::vector<Vec3>* vertices_;
  const std::vector<std::array<std::uint32_t, 3>>* triangles_;
  std::size_t count_;
  double h_;
  double top_z_;
};

}  // namespace fragsim::tally
