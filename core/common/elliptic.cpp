// Carlson (1995) duplication algorithms for R_F, R_D and R_J, and R_G from R_F and R_D
// (DLMF 19.21.10).
#include "core/common/elliptic.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace fragsim {

namespace {

// Tolerance r of Carlson (1995): the truncated Taylor series after the duplication steps has a
// relative error below about r. Double precision unit roundoff.
constexpr double kTol = 0x1p-53;
constexpr int kMaxSteps = 64;  // each step divides the spread by 4: 64 steps reach 4^-64 ~ 3e-39

// R_C(1, 1 + e), e > -1: atan(sqrt e) / sqrt e (e > 0), atanh(sqrt -e) / sqrt -e (e < 0); the
// Taylor series 1 - e/3 + e^2/5 - ... near e = 0 where both forms cancel.
double carlson_rc_one(double e) {
  if (std::abs(e) < 1e-3) {
    // Alternating series sum (-e)^k / (2k + 1); |e|^7 < 1e-21 beyond the last term.
    return 1.0 + e * (-1.0 / 3 + e * (1.0 / 5 + e * (-1.0 / 7 + e * (1.0 / 9 + e * (-1.0 / 11)))));
  }
  if (e > 0.0) {
    const double s = std::sqrt(e);
    return std::atan(s) / s;
  }
  const double s = std::sqrt(-e);
  return std::atanh(s) / s;
}

}  // namespace

double carlson_rf(double x, double y, double z) {
  // Duplication theorem: R_F(x,y,z) = R_F((x+l)/4, (y+l)/4, (z+l)/4), l =
  // sqrt(xy)+sqrt(yz)+sqrt(zx), draws the arguments together; once they agree to ~r^(1/6), expand
  // about their mean A (Carlson 1995, eqs. 2.2-2.4: stop when 4^-n Q < |A_n|, Q = (3r)^(-1/6)
  // max|A_0 - x_0|).
  const double a0 = (x + y + z) / 3.0;
  double q = std::pow(3.0 * kTol, -1.0 / 6.0) *
             std::max({std::fabs(a0 - x), std::fabs(a0 - y), std::fabs(a0 - z)});
  double a = a0, xm = x, ym = y, zm = z, pow4 = 1.0;
  for (int n = 0; n < kMaxSteps && pow4 * q >= std::fabs(a); ++n) {
    const double sx = std::sqrt(xm), sy = std::sqrt(ym), sz = std::sqrt(zm);
    const double lambda = sx * sy + sy * sz + sz * sx;
    xm = 0.25 * (xm + lambda);
    ym = 0.25 * (ym + lambda);
    zm = 0.25 * (zm + lambda);
    a = 0.25 * (a + lambda);
    pow4 *= 0.25;
  }
  // Normalised deviations; X + Y + Z = 0. Fifth-order series (Carlson 1995, eq. 2.3).
  const double dx = (a0 - x) * pow4 / a, dy = (a0 - y) * pow4 / a, dz = -(dx + dy);
  const double e2 = dx * dy - dz * dz, e3 = dx * dy * dz;
  return (1.0 - e2 / 10.0 + e3 / 14.0 + e2 * e2 / 24.0 - 3.0 * e2 * e3 / 44.0) / std::sqrt(a);
}

double carlson_rd(double x, double y, double z) {
  // Duplication as for R_F, plus the sum of the terms the third argument sheds at each step
  // (Carlson 1995, eqs. 2.28-2.29): R_D = 4^-N A_N^-3/2 (series) + 3 sum 4^-m /
  // (sqrt(z_m)(z_m+l_m)).
  const double a0 = (x + y + 3.0 * z) / 5.0;
  double q = std::pow(0.25 * kTol, -1.0 / 6.0) *
             std::max({std::fabs(a0 - x), std::fabs(a0 - y), std::fabs(a0 - z)});
  double a = a0, xm = x, ym = y, zm = z, pow4 = 1.0, sum = 0.0;
  for (int n = 0; n < kMaxSteps && pow4 * q >= std::fabs(a); ++n) {
    const double sx = std::sqrt(xm), sy = std::sqrt(ym), sz = std::sqrt(zm);
    const double lambda = sx * sy + sy * sz + sz * sx;
    sum += pow4 / (sz * (zm + lambda));
    xm = 0.25 * (xm + lambda);
    ym = 0.25 * (ym + lambda);
    zm = 0.25 * (zm + lambda);
    a = 0.25 * (a + lambda);
    pow4 *= 0.25;
  }
  // X + Y + 3Z = 0.
  const double dx = (a0 - x) * pow4 / a, dy = (a0 - y) * pow4 / a, dz = -(dx + dy) / 3.0;
  const double xy = dx * dy, z2 = dz * dz;
  const double e2 = xy - 6.0 * z2;
  const double e3 = (3.0 * xy - 8.0 * z2) * dz;
  const double e4 = 3.0 * (xy - z2) * z2;
  const double e5 = xy * z2 * dz;
  const double series = 1.0 - 3.0 * e2 / 14.0 + e3 / 6.0 + 9.0 * e2 * e2 / 88.0 - 3.0 * e4 / 22.0 -
                        9.0 * e2 * e3 / 52.0 + 3.0 * e5 / 26.0;
  return pow4 * series / (a * std::sqrt(a)) + 3.0 * sum;
}

double carlson_rj(double x, double y, double z, double p) {
  // Duplication on all four arguments; each step sheds 6 * 4^-n R_C(1, 1 + e_n) / d_n with
  // d_n = (sqrt p + sqrt x)(sqrt p + sqrt y)(sqrt p + sqrt z), e_n = 4^-3n delta / d_n^2,
  // delta = (p - x)(p - y)(p - z); then the expansion about the mean A with X + Y + Z + 2P = 0.
  const double a0 = (x + y + z + 2.0 * p) / 5.0;
  const double delta = (p - x) * (p - y) * (p - z);
  const double q =
      std::pow(0.25 * kTol, -1.0 / 6.0) *
      std::max({std::abs(a0 - x), std::abs(a0 - y), std::abs(a0 - z), std::abs(a0 - p)});
  double a = a0, xm = x, ym = y, zm = z, pm = p, pow4 = 1.0, pow64 = 1.0, sum = 0.0;
  for (int n = 0; n < kMaxSteps && pow4 * q >= std::abs(a); ++n) {
    const double sx = std::sqrt(xm), sy = std::sqrt(ym), sz = std::sqrt(zm), sp = std::sqrt(pm);
    const double l = sx * sy + sy * sz + sz * sx;
    const double d = (sp + sx) * (sp + sy) * (sp + sz);
    const double e = pow64 * delta / (d * d);
    sum += pow4 * carlson_rc_one(e) / d;
    xm = 0.25 * (xm + l);
    ym = 0.25 * (ym + l);
    zm = 0.25 * (zm + l);
    pm = 0.25 * (pm + l);
    a = 0.25 * (a + l);
    pow4 *= 0.25;
    pow64 *= 1.0 / 64.0;
  }
  const double dx = (a0 - x) * pow4 / a, dy = (a0 - y) * pow4 / a, dz = (a0 - z) * pow4 / a;
  const double dp = -0.5 * (dx + dy + dz);
  const double xyz = dx * dy * dz, p2 = dp * dp;
  const double e2 = dx * dy + dx * dz + dy * dz - 3.0 * p2;
  const double e3 = xyz + 2.0 * e2 * dp + 4.0 * p2 * dp;
  const double e4 = (2.0 * xyz + e2 * dp + 3.0 * p2 * dp) * dp;
  const double e5 = xyz * p2;
  const double series = 1.0 - 3.0 * e2 / 14.0 + e3 / 6.0 + 9.0 * e2 * e2 / 88.0 - 3.0 * e4 / 22.0 -
                        9.0 * e2 * e3 / 52.0 + 3.0 * e5 / 26.0;
  return pow4 * series / (a * std::sqrt(a)) + 6.0 * sum;
}

double carlson_rg(double x, double y, double z) {
  // DLMF 19.21.10: 2 R_G = z R_F - (x-z)(y-z) R_D / 3 + sqrt(xy/z). With z the middle value,
  // (x-z)(y-z) <= 0 and every term is nonnegative: no cancellation (Carlson 1995, sec. 2).
  if (x > y) std::swap(x, y);
  if (y > z) std::swap(y, z);
  if (x > y) std::swap(x, y);
  std::swap(y, z);                          // now x <= z <= y: z is the middle value
  if (z == 0.0) return 0.5 * std::sqrt(y);  // two zero arguments: R_G(0, 0, y) = sqrt(y) / 2
  return 0.5 * (z * carlson_rf(x, y, z) - (x - z) * (y - z) * carlson_rd(x, y, z) / 3.0 +
                std::sqrt(x * y / z));
}

}  // namespace fragsim
