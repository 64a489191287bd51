#pragma once
// SIMD over histories: one DOPRI5 attempt for kLanes independent drag flights at once, each lane
// in path length s (TrajectoryIntegrator::ArcRhs, state p, v, t) or in time (::Rhs, state p, v),
// giving in every lane the same bits as Dopri5::attempt on that right-hand side: the same IEEE
// operations on the same operands in the same order, lane by lane. A time lane rides in the
// 7-wide arithmetic with dt/ds = 1 (multiplying by 1 is exact) and its own 6-component error
// norm. The arithmetic runs on kLanes-wide vectors (AVX2 when the CPU has it, chosen at run time,
// otherwise SSE2 pairs); the table lookups (density, speed of sound, Cd(Mach)) are the scalar
// inline functions, once per lane. Neither build contracts a * b + c into an FMA.
//
// Who calls it: core/run/lane_runner.h runs kLanes histories on fibers and hands the attempts
// their integrators post through `thread_attempt_lanes` to this kernel (docs/architecture.md,
// "Histories in lanes"). Measured: docs/benchmarks.md §1 and bench/bench_lanes.cpp.
#include "core/flight/flight_model.h"

namespace fragsim::flight {

inline constexpr int kLanes = 4;

// Where a lane's attempt writes its results (n = 7 values each in s, 6 in time): k1 (= f0), k7 =
// f(y1), the 5th-order result y1, and dense_sum = d1 k1 + d3 k3 + ... + d7 k7, the continuous
// extension's sum (Dopri5::build_dense multiplies it by the step). The stages k2..k6 themselves
// are not written: nothing else reads them after the attempt.
struct LaneOut {
  double *k1, *k7, *y1, *dense_sum;
};
// One lane's attempt, read and written in place: from y0 with f0 = f(y0) over h, and the error
// norm (RMS of err_i / (atol + rtol max(|y0_i|, |y1_i|))) into *err.
struct LaneIO {
  const FlightModel* model;
  const double* y0;
  const double* f0;
  double h;
  LaneOut out;
  double* err;
  bool in_time;
};

// True when the model can go into a lane: it has drag (an atmosphere, a Cd and an area > 0).
// All lanes of one call must share one atmosphere (one wind); they may differ in Cd, area, mass,
// gravity and altitude offset.
bool lane_ready(const FlightModel& model);

// The attempt for kLanes lanes with one rtol and atol (Dopri5Options). Picks AVX2 when the CPU
// has it. Idle lanes may repeat a busy lane's inputs with outputs to scratch.
void attempt_lanes(const LaneIO (&io)[kLanes], double rtol, double atol);
// The two builds, for the tests and the benchmark (the AVX2 one only where the CPU has it).
bool lanes_have_avx2();
void attempt_lanes_avx2(const LaneIO (&io)[kLanes], double rtol, double atol);
void attempt_lanes_sse2(const LaneIO (&io)[kLanes], double rtol, double atol);

// A thread's lane runner. When set, Dopri5 on TrajectoryIntegrator's right-hand sides posts each
// step attempt to it instead of computing it (`out`: its trial Dopri5::Stages);
// attempt() returns false when it does not take the attempt, and the caller computes it.
class AttemptLanes {
 public:
  virtual bool attempt(const FlightModel& model, int n, const double* y0, const double* f0,
                       double h, double rtol, double atol, LaneOut out, double& err) = 0;

 protected:
  ~AttemptLanes() = default;
};
inline thread_local AttemptLanes* thread_attempt_lanes = nullptr;

}  // namespace fragsim::flight
