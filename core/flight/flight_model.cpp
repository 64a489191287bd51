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

double DragCoefficient::from_table(double mach) const {
  if (!(mach > mach_.front())) return cd_.front();  // clamped (and NaN-safe)
  if (mach >= mach_.back()) return cd_.back();
  // First node strictly above `mach`; tables are short, binary search is enough.
  const auto it = std::upper_bound(mach_.begin(), mach_.end(), mach);
  const std::size_t j = static_cast<std::size_t>(it - mach_.begin());
  const double w = (mach - mach_[j - 1]) / (mach_[j] - mach_[j - 1]);
  return cd_[j - 1] + w * (cd_[j] - cd_[j - 1]);
}

}  // namespace fragsim::flight
