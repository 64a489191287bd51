#pragma once
// One DOPRI5 attempt for kLanes independent drag flights at once (SIMD over histories), giving in
// every lane the same bits as Dopri5::attempt on TrajectoryIntegrator's right-hand sides
// (Rhs in time, ArcRhs in path length): the same IEEE operations on the same operands in the same
// order, lane by lane. The arithmetic runs on kLanes-wide vectors (AVX2 when the CPU has it,
// chosen at run time, otherwise SSE2 pairs); the table lookups (density, speed of sound, Cd(Mach))
// are the scalar inline functions, once per lane. Neither build contracts a * b + c into an FMA,
// so both give the same bits.
//
// Status (docs/benchmarks.md §1, "SIMD over histories: the attempt alone"): measured against the
// scalar attempt by bench/bench_lanes.cpp and checked bit for bit by
// tests/core/flight/lanes_test.cpp; the history loop does not call it yet (it takes one history
// at a time, docs/architecture.md).
#include "core/flight/flight_model.h"

namespace fragsim::flight {

inline constexpr int kLanes = 4;

// An attempt's state vectors, component-major: c[i][lane].
template <int N>
struct LaneVectors {
  alignas(32) double c[N][kLanes];
};

// The lanes' flights. Every lane needs drag (an atmosphere, a Cd and an area > 0), and all lanes
// share one atmosphere (so one wind); `lanes_supported` says whether a set qualifies. Lanes may
// differ in Cd, area, mass, gravity and altitude offset.
struct LaneModels {
  const FlightModel* model[kLanes];
};
bool lanes_supported(const LaneModels& models);

// Inputs and outputs of one attempt per lane: from y0 with f0 = f(y0) over h (per lane) to the
// stages k2..k7, the 5th-order result y1 (k7 = f(y1)) and, with `estimate`, the error norm
// (RMS of err_i / (atol + rtol max(|y0_i|, |y1_i|))), as Dopri5::attempt returns it.
template <int N>
struct LaneAttempt {
  LaneVectors<N> y0, f0;
  alignas(32) double h[kLanes];
  LaneVectors<N> k2, k3, k4, k5, k6, k7, y1;
  alignas(32) double err[kLanes];
};

// In path length s (state p, v, t; ArcRhs) and in time (state p, v; Rhs). rtol and atol as in
// Dopri5Options. The dispatching entry points pick AVX2 when the CPU has it.
void attempt_lanes(const LaneModels& models, double rtol, double atol, bool estimate,
                   LaneAttempt<7>& a);
void attempt_lanes(const LaneModels& models, double rtol, double atol, bool estimate,
                   LaneAttempt<6>& a);
// The two builds, for the benchmark and the tests (the AVX2 one only where the CPU has it).
bool lanes_have_avx2();
void attempt_lanes_avx2(const LaneModels& models, double rtol, double atol, bool estimate,
                        LaneAttempt<7>& a);
void attempt_lanes_avx2(const LaneModels& models, double rtol, double atol, bool estimate,
                        LaneAttempt<6>& a);
void attempt_lanes_sse2(const LaneModels& models, double rtol, double atol, bool estimate,
                        LaneAttempt<7>& a);
void attempt_lanes_sse2(const LaneModels& models, double rtol, double atol, bool estimate,
                        LaneAttempt<6>& a);

}  // namespace fragsim::flight
