#include "core/flight/flight_model.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/common/error.h"

namespace fragsim::flight {

DragCoefficient::DragCoefficient(const fragments::CdSpec& spec) : constant_(spec.constant) {
  if (spec.mach.empty() && spec.cd.empty()) {
    if (!std::isfinite(constant_) || constant_ < 0.0)
      throw InputError("cd", "must be finite and >= 0");
    return;
  }
  if (spec.mach.size() != spec.cd.size())
    throw InputError("cd", "mach and cd must have the same length");
  for (std::size_t i = 0; i < spec.mach.size(); ++i) {
    if (!std::isfinite(spec.mach[i]) || spec.mach[i] < 0.0)
      throw InputError("cd.mach[" + std::to_string(i) + "]", "must be finite and >= 0");
    if (i > 0 && !(spec.mach[i] > spec.mach[i - 1]))
      throw InputError("cd.mach[" + std::to_string(i) + "]", "must be strictly increasing");
    if (!std::isfinite(spec.cd[i]) || spec.cd[i] < 0.0)
      throw InputError("cd.cd[" + std::to_string(i) + "]", "must be finite and >= 0");
  }
  if (spec.mach.size() == 1) {
    // A one-point table is a constant: keep the hot path free of the Mach number.
    constant_ = spec.cd[0];
    return;
  }
  mach_ = spec.mach;
  cd_ = spec.cd;
}

double DragCoefficient::at_mach(double mach) const {
  if (mach_.empty()) return constant_;
  if (!(mach > mach_.front())) return cd_.front();  // clamped (and NaN-safe)
  if (mach >= mach_.back()) return cd_.back();
  // First node strictly above `mach`; tables are short, binary search is enough.
  const auto it = std::upper_bound(mach_.begin(), mach_.end(), mach);
  const std::size_t j = static_cast<std::size_t>(it - mach_.begin());
  const double w = (mach - mach_[j - 1]) / (mach_[j] - mach_[j - 1]);
  return cd_[j - 1] + w * (cd_[j] - cd_[j - 1]);
}

Vec3 FlightModel::acceleration(const Vec3& p, const Vec3& v) const {
  // paper eqs. 3-5: a = -g e_z - (rho Cd A / 2m) |v_rel| v_rel, v_rel = v - wind.
  Vec3 a(0.0, 0.0, -gravity_mps2);
  if (atmosphere == nullptr || cd == nullptr || area_m2 == 0.0) return a;  // vacuum
  const Vec3 v_rel = v - atmosphere->wind();
  const double speed = v_rel.norm();
  const double altitude = p.z() + altitude_offset_m;
  // Only a Mach table needs the speed of sound (saves a table lookup per evaluation otherwise).
  const double cd_value =
      cd->is_constant() ? cd->at_mach(0.0) : cd->at_mach(speed / atmosphere->sound_speed(altitude));
  const double k = 0.5 * atmosphere->density(altitude) * cd_value * area_m2 / mass_kg;
  a -= (k * speed) * v_rel;
  return a;
}

}  // namespace fragsim::flight
