#include "core/flight/lanes.h"

#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/flight/dopri5.h"

// GCC's vector extensions: a 32-byte vector of doubles is one AVX register in the AVX2 build and
// two SSE2 registers in the other. Every helper is inlined into the two entry points, so no such
// vector crosses a call (the ABI note GCC gives for that does not apply).
#pragma GCC diagnostic ignored "-Wpsabi"

namespace fragsim::flight {
namespace {

using V = double __attribute__((vector_size(32)));
using Mask = std::int64_t __attribute__((vector_size(32)));
static_assert(sizeof(V) == kLanes * sizeof(double));

#define FRAGSIM_LANE_INLINE [[gnu::always_inline]] inline

FRAGSIM_LANE_INLINE V load(const double* p) {
  V v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
FRAGSIM_LANE_INLINE void store(double* p, const V& v) { std::memcpy(p, &v, sizeof v); }
FRAGSIM_LANE_INLINE V splat(double x) { return V{x, x, x, x}; }
FRAGSIM_LANE_INLINE V abs(const V& x) {
  const Mask no_sign = {INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX};
  return reinterpret_cast<V>(reinterpret_cast<Mask>(x) & no_sign);
}
// x > y ? x : y per lane, as SSE2's maxpd (Eigen's cwiseMax on packets); the two differ from
// std::max only for NaN, where the attempt's error is NaN either way.
FRAGSIM_LANE_INLINE V max(const V& x, const V& y) { return x > y ? x : y; }

// What the right-hand sides read of the lanes' models.
struct Lanes {
  const LaneModels& models;
  const Atmosphere& atmosphere;
  V wind[3];
  V gravity, area, mass, offset;
  explicit Lanes(const LaneModels& m) : models(m), atmosphere(*m.model[0]->atmosphere) {
    const Vec3& w = atmosphere.wind();
    for (int i = 0; i < 3; ++i) wind[i] = splat(w[i]);
    for (int l = 0; l < kLanes; ++l) {
      const FlightModel& f = *m.model[l];
      gravity[l] = f.gravity_mps2;
      area[l] = f.area_m2;
      mass[l] = f.mass_kg;
      offset[l] = f.altitude_offset_m;
    }
  }
};

// FlightModel::acceleration with drag, per lane: a = -g e_z - k |v_rel| v_rel (paper eqs. 3-5),
// k = rho Cd A / (2 m), with the relative speed. The same operations in the same order as the
// scalar function (|v_rel|^2 summed as Eigen sums a 3-vector: (x^2 + y^2) + z^2).
FRAGSIM_LANE_INLINE void acceleration(const Lanes& c, const V* p, const V* v, V* a, V& speed) {
  const V r0 = v[0] - c.wind[0], r1 = v[1] - c.wind[1], r2 = v[2] - c.wind[2];
  const V squared = (r0 * r0 + r1 * r1) + r2 * r2;
  const V altitude = p[2] + c.offset;
  V rho, cd;
  for (int l = 0; l < kLanes; ++l) {
    speed[l] = std::sqrt(squared[l]);
    rho[l] = c.atmosphere.density(altitude[l]);
    const DragCoefficient& d = *c.models.model[l]->cd;
    cd[l] = d.is_constant() ? d.at_mach(0.0)
                            : d.at_mach(speed[l] / c.atmosphere.sound_speed(altitude[l]));
  }
  const V k = 0.5 * rho * cd * c.area / c.mass;
  const V ks = k * speed;
  a[0] = 0.0 - ks * r0;
  a[1] = 0.0 - ks * r1;
  a[2] = -c.gravity - ks * r2;
}

// TrajectoryIntegrator::ArcRhs: (p, v, t)' = (v, a, 1) / |v_rel|.
FRAGSIM_LANE_INLINE void rhs(const Lanes& c, const V (&y)[7], V (&dy)[7]) {
  V a[3], speed;
  acceleration(c, y, y + 3, a, speed);
  const V dt_ds = 1.0 / speed;
  for (int i = 0; i < 3; ++i) {
    dy[i] = y[3 + i] * dt_ds;
    dy[3 + i] = a[i] * dt_ds;
  }
  dy[6] = dt_ds;
}
// TrajectoryIntegrator::Rhs: (p, v)' = (v, a).
FRAGSIM_LANE_INLINE void rhs(const Lanes& c, const V (&y)[6], V (&dy)[6]) {
  V a[3], speed;
  acceleration(c, y, y + 3, a, speed);
  for (int i = 0; i < 3; ++i) {
    dy[i] = y[3 + i];
    dy[3 + i] = a[i];
  }
}

// Dopri5::scaled_rms(err, y0, y1): the sum of squares in Eigen's order for a fixed-size vector
// on SSE2 packets, (q0 + (q2 + q4)) + (q1 + (q3 + q5)) [+ q6].
template <int N>
FRAGSIM_LANE_INLINE V error_norm(const V (&err)[N], const V (&y0)[N], const V (&y1)[N],
                                 double rtol, double atol) {
  V q2[N];
  for (int i = 0; i < N; ++i) {
    const V sc = atol + rtol * max(abs(y0[i]), abs(y1[i]));
    const V q = err[i] / sc;
    q2[i] = q * q;
  }
  V sum = (q2[0] + (q2[2] + q2[4])) + (q2[1] + (q2[3] + q2[5]));
  if constexpr (N == 7) sum = sum + q2[6];
  const V mean = sum / static_cast<double>(N);
  V norm;
  for (int l = 0; l < kLanes; ++l) norm[l] = std::sqrt(mean[l]);
  return norm;
}

// Dopri5::attempt, lane by lane.
template <int N>
FRAGSIM_LANE_INLINE void attempt(const LaneModels& models, double rtol, double atol,
                                 bool estimate, LaneAttempt<N>& a) {
  using namespace dopri5_tableau;
  const Lanes c(models);
  const V h = load(a.h);
  V y0[N], k1[N], k2[N], k3[N], k4[N], k5[N], k6[N], k7[N], y1[N], y[N];
  for (int i = 0; i < N; ++i) {
    y0[i] = load(a.y0.c[i]);
    k1[i] = load(a.f0.c[i]);
  }
  for (int i = 0; i < N; ++i) y[i] = y0[i] + h * (a21 * k1[i]);
  rhs(c, y, k2);
  for (int i = 0; i < N; ++i) y[i] = y0[i] + h * (a31 * k1[i] + a32 * k2[i]);
  rhs(c, y, k3);
  for (int i = 0; i < N; ++i) y[i] = y0[i] + h * (a41 * k1[i] + a42 * k2[i] + a43 * k3[i]);
  rhs(c, y, k4);
  for (int i = 0; i < N; ++i)
    y[i] = y0[i] + h * (a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i]);
  rhs(c, y, k5);
  for (int i = 0; i < N; ++i)
    y[i] = y0[i] + h * (a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i] + a65 * k5[i]);
  rhs(c, y, k6);
  for (int i = 0; i < N; ++i)
    y1[i] = y0[i] + h * (b1 * k1[i] + b3 * k3[i] + b4 * k4[i] + b5 * k5[i] + b6 * k6[i]);
  rhs(c, y1, k7);
  for (int i = 0; i < N; ++i) {
    store(a.k2.c[i], k2[i]);
    store(a.k3.c[i], k3[i]);
    store(a.k4.c[i], k4[i]);
    store(a.k5.c[i], k5[i]);
    store(a.k6.c[i], k6[i]);
    store(a.k7.c[i], k7[i]);
    store(a.y1.c[i], y1[i]);
  }
  if (!estimate) {
    store(a.err, splat(0.0));
    return;
  }
  V err[N];
  for (int i = 0; i < N; ++i)
    err[i] = h * (e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] + e7 * k7[i]);
  store(a.err, error_norm(err, y0, y1, rtol, atol));
}

}  // namespace

bool lanes_supported(const LaneModels& m) {
  for (const FlightModel* f : m.model) {
    if (f == nullptr || f->atmosphere == nullptr || f->cd == nullptr || f->area_m2 == 0.0)
      return false;
    if (f->atmosphere != m.model[0]->atmosphere) return false;
  }
  return true;
}

bool lanes_have_avx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

__attribute__((target("avx2"))) void attempt_lanes_avx2(const LaneModels& m, double rtol,
                                                        double atol, bool estimate,
                                                        LaneAttempt<7>& a) {
  attempt(m, rtol, atol, estimate, a);
}
__attribute__((target("avx2"))) void attempt_lanes_avx2(const LaneModels& m, double rtol,
                                                        double atol, bool estimate,
                                                        LaneAttempt<6>& a) {
  attempt(m, rtol, atol, estimate, a);
}
void attempt_lanes_sse2(const LaneModels& m, double rtol, double atol, bool estimate,
                        LaneAttempt<7>& a) {
  attempt(m, rtol, atol, estimate, a);
}
void attempt_lanes_sse2(const LaneModels& m, double rtol, double atol, bool estimate,
                        LaneAttempt<6>& a) {
  attempt(m, rtol, atol, estimate, a);
}

void attempt_lanes(const LaneModels& m, double rtol, double atol, bool estimate,
                   LaneAttempt<7>& a) {
  if (lanes_have_avx2())
    attempt_lanes_avx2(m, rtol, atol, estimate, a);
  else
    attempt_lanes_sse2(m, rtol, atol, estimate, a);
}
void attempt_lanes(const LaneModels& m, double rtol, double atol, bool estimate,
                   LaneAttempt<6>& a) {
  if (lanes_have_avx2())
    attempt_lanes_avx2(m, rtol, atol, estimate, a);
  else
    attempt_lanes_sse2(m, rtol, atol, estimate, a);
}

}  // namespace fragsim::flight
