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
  build_grid();
}

// A uniform grid over [front, back] with 8 cells per node interval on average (node_above
// scans from the cell's entry). Each cell's entry is the first node strictly above the cell's
// lower edge, so it is at most the node node_above returns for any Mach number in the cell.
void DragCoefficient::build_grid() {
  const std::size_t cells = 8 * mach_.size();
  inv_cell_ = static_cast<double>(cells) / (mach_.back() - mach_.front());
  first_above_.resize(cells);
  for (std::size_t k = 0; k < cells; ++k) {
    const double lower = mach_.front() + static_cast<double>(k) / inv_cell_;
    const auto it = std::upper_bound(mach_.begin(), mach_.end(), lower);
    first_above_[k] = static_cast<std::uint32_t>(
        std::clamp<std::ptrdiff_t>(it - mach_.begin(), 1, std::ssize(mach_) - 1));
  }
}

}  // namespace fragsim::flight
