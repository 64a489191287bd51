#include "core/flight/lanes.h"

#include <cmath>
#include <cstdint>

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

FRAGSIM_LANE_INLINE V splat(double x) {
  return V{x, x, x, x};
}
FRAGSIM_LANE_INLINE V abs(const V& x) {
  const Mask no_sign = {INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX};
  return reinterpret_cast<V>(reinterpret_cast<Mask>(x) & no_sign);
}
// x > y ? x : y per lane, as SSE2's maxpd (Eigen's cwiseMax on packets); the two differ from
// std::max only for NaN, where the attempt's error is NaN either way.
FRAGSIM_LANE_INLINE V max(const V& x, const V& y) {
  return x > y ? x : y;
}
// Correctly rounded per lane, as std::sqrt (one vector instruction: the file is compiled with
// -fno-math-errno, core/CMakeLists.txt).
FRAGSIM_LANE_INLINE V sqrt(const V& x) {
  V r;
  for (int l = 0; l < kLanes; ++l) r[l] = std::sqrt(x[l]);
  return r;
}

// What the right-hand sides read of the lanes' models.
struct Lanes {
  const LaneIO (&io)[kLanes];
  const Atmosphere& atmosphere;
  V wind[3];
  V gravity, area, mass, offset;
  Mask in_time;
  explicit Lanes(const LaneIO (&lanes)[kLanes])
      : io(lanes), atmosphere(*lanes[0].model->atmosphere) {
    const Vec3& w = atmosphere.wind();
    for (int i = 0; i < 3; ++i) wind[i] = splat(w[i]);
    for (int l = 0; l < kLanes; ++l) {
      const FlightModel& f = *io[l].model;
      gravity[l] = f.gravity_mps2;
      area[l] = f.area_m2;
      mass[l] = f.mass_kg;
      offset[l] = f.altitude_offset_m;
      in_time[l] = io[l].in_time ? -1 : 0;
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
  speed = sqrt(squared);
  V rho, cd;
  for (int l = 0; l < kLanes; ++l) {
    rho[l] = c.atmosphere.density(altitude[l]);
    const DragCoefficient& d = *c.io[l].model->cd;
    cd[l] = d.is_constant() ? d.at_mach(0.0)
                            : d.at_mach(speed[l] / c.atmosphere.sound_speed(altitude[l]));
  }
  const V k = 0.5 * rho * cd * c.area / c.mass;
  const V ks = k * speed;
  a[0] = 0.0 - ks * r0;
  a[1] = 0.0 - ks * r1;
  a[2] = -c.gravity - ks * r2;
}

// TrajectoryIntegrator::ArcRhs, (p, v, t)' = (v, a, 1) / |v_rel|, in path-length lanes, and
// ::Rhs, (p, v)' = (v, a), in time lanes (dt/ds = 1, and v x 1 = v exactly).
FRAGSIM_LANE_INLINE void rhs(const Lanes& c, const V (&y)[7], V (&dy)[7]) {
  V a[3], speed;
  acceleration(c, y, y + 3, a, speed);
  const V dt_ds = c.in_time ? splat(1.0) : 1.0 / speed;
  for (int i = 0; i < 3; ++i) {
    dy[i] = y[3 + i] * dt_ds;
    dy[3 + i] = a[i] * dt_ds;
  }
  dy[6] = dt_ds;
}

// Dopri5::scaled_rms(err, y0, y1): the sum of squares in Eigen's order for a fixed-size vector
// on SSE2 packets, (q0 + (q2 + q4)) + (q1 + (q3 + q5)) [+ q6], over 6 components in time lanes.
FRAGSIM_LANE_INLINE V error_norm(const V (&err)[7], const V (&y0)[7], const V (&y1)[7], double rtol,
                                 double atol, const Mask& in_time) {
  V q2[7];
  for (int i = 0; i < 7; ++i) {
    const V sc = atol + rtol * max(abs(y0[i]), abs(y1[i]));
    const V q = err[i] / sc;
    q2[i] = q * q;
  }
  const V sum = (q2[0] + (q2[2] + q2[4])) + (q2[1] + (q2[3] + q2[5]));
  const V mean = in_time ? sum / 6.0 : (sum + q2[6]) / 7.0;
  return sqrt(mean);
}

// Dopri5::attempt, lane by lane.
FRAGSIM_LANE_INLINE void attempt(const LaneIO (&io)[kLanes], double rtol, double atol) {
  using namespace dopri5_tableau;
  const Lanes c(io);
  const V h{io[0].h, io[1].h, io[2].h, io[3].h};
  V y0[7], k1[7], k2[7], k3[7], k4[7], k5[7], k6[7], k7[7], y1[7], y[7];
  for (int i = 0; i < 6; ++i) {
    y0[i] = V{io[0].y0[i], io[1].y0[i], io[2].y0[i], io[3].y0[i]};
    k1[i] = V{io[0].f0[i], io[1].f0[i], io[2].f0[i], io[3].f0[i]};
  }
  for (int l = 0; l < kLanes; ++l) {  // a time lane's 7th component: t' = 1, never read
    y0[6][l] = io[l].in_time ? 0.0 : io[l].y0[6];
    k1[6][l] = io[l].in_time ? 1.0 : io[l].f0[6];
  }
  for (int i = 0; i < 7; ++i) y[i] = y0[i] + h * (a21 * k1[i]);
  rhs(c, y, k2);
  for (int i = 0; i < 7; ++i) y[i] = y0[i] + h * (a31 * k1[i] + a32 * k2[i]);
  rhs(c, y, k3);
  for (int i = 0; i < 7; ++i) y[i] = y0[i] + h * (a41 * k1[i] + a42 * k2[i] + a43 * k3[i]);
  rhs(c, y, k4);
  for (int i = 0; i < 7; ++i)
    y[i] = y0[i] + h * (a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i]);
  rhs(c, y, k5);
  for (int i = 0; i < 7; ++i)
    y[i] = y0[i] + h * (a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i] + a65 * k5[i]);
  rhs(c, y, k6);
  for (int i = 0; i < 7; ++i)
    y1[i] = y0[i] + h * (b1 * k1[i] + b3 * k3[i] + b4 * k4[i] + b5 * k5[i] + b6 * k6[i]);
  rhs(c, y1, k7);
  V err[7];
  for (int i = 0; i < 7; ++i)
    err[i] = h * (e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] + e7 * k7[i]);
  const V norm = error_norm(err, y0, y1, rtol, atol, c.in_time);
  for (int l = 0; l < kLanes; ++l) {
    const int n = io[l].in_time ? 6 : 7;
    const LaneOut& o = io[l].out;
    for (int i = 0; i < n; ++i) {
      o.k1[i] = io[l].f0[i];
      o.k7[i] = k7[i][l];
      o.y1[i] = y1[i][l];
    }
    *io[l].err = norm[l];
  }
  // Dopri5::build_dense's sum, in its order (d2 = 0).
  for (int i = 0; i < 7; ++i) {
    const V d = d1 * k1[i] + d3 * k3[i] + d4 * k4[i] + d5 * k5[i] + d6 * k6[i] + d7 * k7[i];
    for (int l = 0; l < kLanes; ++l)
      if (i < 6 || !io[l].in_time) io[l].out.dense_sum[i] = d[l];
  }
}

}  // namespace

bool lane_ready(const FlightModel& f) {
  return f.atmosphere != nullptr && f.cd != nullptr && f.area_m2 != 0.0;
}

bool lanes_have_avx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

__attribute__((target("avx2"))) void attempt_lanes_avx2(const LaneIO (&io)[kLanes], double rtol,
                                                        double atol) {
  attempt(io, rtol, atol);
}
void attempt_lanes_sse2(const LaneIO (&io)[kLanes], double rtol, double atol) {
  attempt(io, rtol, atol);
}
void attempt_lanes(const LaneIO (&io)[kLanes], double rtol, double atol) {
  if (lanes_have_avx2())
    attempt_lanes_avx2(io, rtol, atol);
  else
    attempt_lanes_sse2(io, rtol, atol);
}

}  // namespace fragsim::flight
