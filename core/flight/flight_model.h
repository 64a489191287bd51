#pragma once
// Translational flight of one fragment: gravity + quadratic drag (paper eqs. 3-5).
//   m r'' = -m g e_z - 1/2 rho(z) Cd(Mach) A |v - w| (v - w)
#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/common/types.h"
#include "core/flight/atmosphere.h"
#include "core/fragments/group.h"

namespace fragsim::flight {

// Cd as a constant or a piecewise-linear table in Mach (clamped at the ends).
class DragCoefficient {
 public:
  DragCoefficient() = default;
  explicit DragCoefficient(const fragments::CdSpec& spec);
  double at_mach(double mach) const { return mach_.empty() ? constant_ : from_table(mach); }
  bool is_constant() const { return mach_.empty(); }

 private:
  // Inline: it is called on every right-hand side of a Mach-table fragment.
  double from_table(double mach) const {
    if (!(mach > mach_.front())) return cd_.front();  // clamped (and NaN-safe)
    if (mach >= mach_.back()) return cd_.back();
    const std::size_t j = node_above(mach);
    const double w = (mach - mach_[j - 1]) / (mach_[j] - mach_[j - 1]);
    return cd_[j - 1] + w * (cd_[j] - cd_[j - 1]);
  }
  // The first node strictly above `mach` (front < mach < back), as std::upper_bound finds it: a
  // uniform grid over the table's range gives a node at most a few below or above it, and a short
  // scan corrects the grid cell's rounding either way.
  std::size_t node_above(double mach) const {
    const double f = (mach - mach_.front()) * inv_cell_;
    std::size_t j = first_above_[std::min(static_cast<std::size_t>(f), first_above_.size() - 1)];
    while (mach_[j] <= mach) ++j;
    while (mach_[j - 1] > mach) --j;
    return j;
  }
  void build_grid();
  double constant_ = 1.0;
  std::vector<double> mach_, cd_;
  std::vector<std::uint32_t> first_above_;  // per grid cell: first node above its lower edge
  double inv_cell_ = 0.0;
};

// A null atmosphere or Cd, or zero area, means no drag (vacuum flight).
struct FlightModel {
  const Atmosphere* atmosphere = nullptr;
  const DragCoefficient* cd = nullptr;
  double gravity_mps2 = kStandardGravity_mps2;
  double area_m2 = 0.0;
  double mass_kg = 1.0;
  double altitude_offset_m = 0.0;  // altitude = local z + offset

  // Acceleration at local position p with velocity v (time-independent: wind is uniform and
  // steady). Inline: it is every right-hand side of flight and of the ground phase.
  Vec3 acceleration(const Vec3& p, const Vec3& v) const {
    double unused;
    return acceleration_impl<false>(p, v, unused);
  }
  // The same, and the relative speed |v - wind| it used (|v| in vacuum).
  Vec3 acceleration(const Vec3& p, const Vec3& v, double& rel_speed) const {
    return acceleration_impl<true>(p, v, rel_speed);
  }

 private:
  template <bool kWantSpeed>
  Vec3 acceleration_impl(const Vec3& p, const Vec3& v, double& rel_speed) const {
    // paper eqs. 3-5: a = -g e_z - (rho Cd A / 2m) |v_rel| v_rel, v_rel = v - wind.
    Vec3 a(0.0, 0.0, -gravity_mps2);
    if (atmosphere == nullptr || cd == nullptr || area_m2 == 0.0) {  // vacuum
      if constexpr (kWantSpeed) rel_speed = v.norm();
      return a;
    }
    const Vec3 v_rel = v - atmosphere->wind();
    const double speed = v_rel.norm();
    rel_speed = speed;
    const double altitude = p.z() + altitude_offset_m;
    // Only a Mach table needs the speed of sound (saves a table lookup per evaluation otherwise).
    const double cd_value = cd->is_constant()
                                ? cd->at_mach(0.0)
                                : cd->at_mach(speed / atmosphere->sound_speed(altitude));
    const double k = 0.5 * atmosphere->density(altitude) * cd_value * area_m2 / mass_kg;
    a -= (k * speed) * v_rel;
    return a;
  }
};

}  // namespace fragsim::flight
