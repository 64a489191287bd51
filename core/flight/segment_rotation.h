#pragma once
// The attitude of a fragment along one flight segment: torque-free rotation from the segment's
// start state, queried at many nearly increasing times by the contact search (run/history.cpp).
#include <array>
#include <limits>
#include <optional>
#include <utility>

#include "core/common/types.h"
#include "core/flight/torque_free.h"

namespace fragsim::flight {

class SegmentRotation {
 public:
  explicit SegmentRotation(const Vec3& inertia_kg_m2) : inertia_(inertia_kg_m2) {}

  void set_rtol(double rtol) { rtol_ = rtol; }
  double start_time() const { return t0_; }

  // Starts a flight segment's rotation at time t.
  void start(const RotationState& s, double t) {
    s0_ = s;
    t0_ = t;
    cache_t_ = base_t_ = t;
    cache_ = base_ = s;
    // An asymmetric spinning body: set up the exact torque-free solution once for the segment
    // (axisymmetric bodies use propagate_torque_free's cheap closed form; near the separatrix
    // the solution is not valid and the cached numerical path is used).
    asym_.reset();
    for (auto& e : recent_) e.t = std::numeric_limits<double>::quiet_NaN();
    if (s.omega_body.squaredNorm() > 0.0 && !has_two_equal_moments(inertia_)) {
      AsymmetricTorqueFree sol(inertia_, s);
      if (sol.valid()) asym_.emplace(std::move(sol));
    }
  }

  // Rotation state at time t of the segment (torque-free from its start). Times are asked for
  // in nearly increasing order, so the propagation starts from the latest cached state at or
  // before t: each call integrates a short interval, never the whole segment again.
  RotationState at(double t) const {
    if (s0_.omega_body.squaredNorm() == 0.0 || t == t0_) return s0_;
    if (asym_) return asym_at(t);
    if (t == cache_t_) return cache_;
    if (t == base_t_) return base_;
    // Start from the latest known state at or before t: the cache, the base, or the segment's
    // start.
    const RotationState* from = &s0_;
    double t_from = t0_;
    if (base_t_ > t_from && base_t_ < t) {
      from = &base_;
      t_from = base_t_;
    }
    if (cache_t_ > t_from && cache_t_ < t) {
      from = &cache_;
      t_from = cache_t_;
    }
    const RotationState s = propagate_torque_free(inertia_, *from, t - t_from, rtol_);
    if (t > cache_t_) {
      cache_t_ = t;
      cache_ = s;
    }
    return s;
  }
  Quat attitude(double t) const { return at(t).q.normalized(); }

  // No later query of this segment is before t: keep its state as the base (each query then
  // integrates at most from the start of the chord being examined).
  void advance_base(double t) const {
    if (asym_ || s0_.omega_body.squaredNorm() == 0.0 || t <= base_t_) return;
    base_ = at(t);
    base_t_ = t;
  }

 private:
  // The exact solution at t, remembered for the last few times asked: the contact search asks
  // for the same times again (a chord's end is the next chord's start; a second contact plane is
  // searched at the first one's sample times). A pure function of t: the same bits either way.
  RotationState asym_at(double t) const {
    for (const Recent& e : recent_)
      if (e.t == t) return e.s;
    Recent& slot = recent_[next_recent_];
    next_recent_ = (next_recent_ + 1) % kRecent;
    slot.t = t;
    slot.s = asym_->at(t - t0_);
    return slot.s;
  }

  static constexpr int kRecent = 8;
  struct Recent {
    double t = std::numeric_limits<double>::quiet_NaN();
    RotationState s;
  };
  mutable std::array<Recent, kRecent> recent_{};
  mutable int next_recent_ = 0;
  Vec3 inertia_;
  double rtol_ = 1e-9;
  RotationState s0_;  // attitude at t0_ (start of the current flight segment)
  double t0_ = 0.0;
  mutable RotationState cache_;  // latest state computed in this segment
  mutable double cache_t_ = 0.0;
  mutable RotationState base_;  // state at base_t_: no query comes before it
  mutable double base_t_ = 0.0;
  std::optional<AsymmetricTorqueFree> asym_;  // exact rotation of this segment
};

}  // namespace fragsim::flight
