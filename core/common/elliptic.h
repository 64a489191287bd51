#pragma once
// Carlson's symmetric elliptic integrals (B. C. Carlson, "Numerical computation of real or complex
// elliptic integrals", Numerical Algorithms 10 (1995) 13-26), real arguments only. Used for the
// exact surface area of an ellipsoid (DLMF 19.33.2) and the exact torque-free rotation of an
// asymmetric body (complete and incomplete integrals of the first and third kind).

namespace fragsim {

// R_F(x, y, z) = 1/2 int_0^inf dt / sqrt((t+x)(t+y)(t+z)); x, y, z >= 0, at most one zero.
double carlson_rf(double x, double y, double z);

// R_D(x, y, z) = 3/2 int_0^inf dt / (sqrt((t+x)(t+y)) (t+z)^(3/2)); x, y >= 0 (not both 0), z > 0.
double carlson_rd(double x, double y, double z);

// R_J(x, y, z, p) = 3/2 int_0^inf dt / (sqrt((t+x)(t+y)(t+z)) (t+p)); x, y, z >= 0 (at most one
// zero), p > 0.
double carlson_rj(double x, double y, double z, double p);

// R_G(x, y, z) = 1/(4 pi) int over the unit sphere of sqrt(x s1^2 + y s2^2 + z s3^2); x, y, z >= 0.
double carlson_rg(double x, double y, double z);

}  // namespace fragsim
