#pragma once
// The one bracketing root finder of the core: the Illinois variant of regula falsi (Dowell &
// Jarratt 1971, BIT 11: superlinear, order ~1.44, and it never leaves its bracket). Every event
// time of a history is located with it: where a path crosses a plane (impact/contacts.h), where a
// body's clearance from a terrain plane reaches zero (the flight's contact search), where a path
// on the ground leaves its triangle or reaches the end of a crease edge (impact/ground_phase.cpp).
#include <algorithm>
#include <cmath>

namespace fragsim {

struct RootBracket {
  double lo = 0.0, hi = 0.0;  // lo: last time known on the "before" side; hi: first on the "after"
  double last = 0.0;          // the last probe (the root estimate when the loop stopped)
  bool converged = false;     // stopped on tolerance or an exact zero, not on the iteration cap
};

// Narrows [lo, hi] around the sign change of f: f_lo = f(lo) and f_hi = f(hi) of opposite signs
// (f_hi may be 0). Each iteration probes the regula falsi point t; it stops when f(t) == 0 or the
// bracket was already within tol_t * max(1, |t|). An end kept twice in a row has the other end's
// value halved (Illinois), which restores superlinear convergence on convex or concave f.
// `hi` is always on or after the root, `lo` before it: callers that must not pass an event take
// `lo`, callers that must reach it take `hi`.
template <class F>
RootBracket illinois(const F& f, double lo, double hi, double f_lo, double f_hi, double tol_t,
                     int max_iterations = 100) {
  const bool before_positive = f_lo > 0.0;
  int side = 0;
  for (int it = 0; it < max_iterations; ++it) {
    const double t = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
    const double ft = f(t);
    if (ft == 0.0 || (hi - lo) <= tol_t * std::max(1.0, std::abs(t))) {
      if (ft == 0.0 || (ft > 0.0) != before_positive)
        hi = t;
      else
        lo = t;
      return {lo, hi, t, true};
    }
    if ((ft > 0.0) == before_positive) {
      lo = t;
      f_lo = ft;
      if (side == -1) f_hi *= 0.5;
      side = -1;
    } else {
      hi = t;
      f_hi = ft;
      if (side == 1) f_lo *= 0.5;
      side = 1;
    }
  }
  return {lo, hi, 0.5 * (lo + hi), false};
}

}  // namespace fragsim
