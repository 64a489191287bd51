// Scalar distributions of fragment properties: inversion sampling, truncation, validation, and the
// standard normal CDF / quantile they rest on.
#include "core/fragments/distribution.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <string>

namespace fragsim::fragments {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Evaluates c[0] + c[1] r + ... + c[7] r^7 (Horner).
double poly7(const double (&c)[8], double r) {
  double s = c[7];
  for (int i = 6; i >= 0; --i) s = s * r + c[i];
  return s;
}

// Upper tail Q(x) = 1 - Phi(x), computed without cancellation: Q(x) = Phi(-x) exactly by symmetry.
double normal_upper(double x) {
  return normal_cdf(-x);
}

// Probability mass of the standard normal on [a, b] (a <= b), taken on whichever side of the
// median keeps the subtraction free of cancellation: two upper-tail values when a >= 0, two
// lower-tail values when b <= 0, else the complement of both tails.
double std_normal_mass(double a, double b) {
  if (!(a < b)) return 0.0;
  if (a >= 0.0) return normal_upper(a) - normal_upper(b);
  if (b <= 0.0) return normal_cdf(b) - normal_cdf(a);
  return (1.0 - normal_cdf(a)) - normal_upper(b);
}

// The tail probabilities truncated_std_normal inverts between, for [a, b]: Q(a), Q(b) when
// a >= 0; Phi(a), Phi(b) when b <= 0; else Phi(a), Q(b) and the mass between.
StdNormalCut std_normal_cut(double a, double b) {
  if (a >= 0.0) return {a, b, normal_upper(a), normal_upper(b), 0.0};
  if (b <= 0.0) return {a, b, normal_cdf(a), normal_cdf(b), 0.0};
  const double pa = normal_cdf(a), qb = normal_upper(b);
  return {a, b, pa, qb, (1.0 - pa) - qb};
}

// Standard normal truncated to [a, b], by inversion of u. The uniform is mapped into the CDF range
// of [a, b] on the side of the median where the probabilities are small: near Phi = 1 the values
// 1 - Phi carry all their digits while Phi itself has only ~1e-16 resolution, so an upper-tail
// truncation (say [5, 6], mass 2.9e-7) must be inverted through Q = 1 - Phi.
double truncated_std_normal(const StdNormalCut& c, double u) {
  double z;
  if (c.a >= 0.0) {
    z = -normal_quantile(c.p_a + u * (c.p_b - c.p_a));  // p_a = Q(a), p_b = Q(b)
  } else if (c.b <= 0.0) {
    z = normal_quantile(c.p_a + u * (c.p_b - c.p_a));  // p_a = Phi(a), p_b = Phi(b)
  } else {
    const double p = c.p_a + u * c.mass;  // p_a = Phi(a), p_b = Q(b)
    // Same point written as an upper-tail probability when it lies above the median.
    z = p <= 0.5 ? normal_quantile(p) : -normal_quantile(c.p_b + (1.0 - u) * c.mass);
  }
  return std::clamp(z, c.a, c.b);
}

// Shortest round-trip text of a double, for messages.
std::string num(double v) {
  if (v == kPositiveLowerBound) return "0";  // the open bound (0, ...): see distribution.h
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}

// "[lo, hi]" with "(" for the open lower bound at zero.
std::string range_text(double lo, double hi) {
  // Built by appending: GCC 12 raises a false -Wrestrict on `const char* + std::string&&`.
  std::string s(lo == kPositiveLowerBound ? "(" : "[");
  s.append(num(lo)).append(", ").append(num(hi)).append("]");
  return s;
}

std::string lower_bound_text(double phys_lo) {
  return phys_lo == kPositiveLowerBound ? "must be > 0" : "must be >= " + num(phys_lo);
}

// Truncation interval: the physical range narrowed by the explicit bounds.
struct Interval {
  double lo, hi;
};
Interval truncation(const Distribution& d, double phys_lo, double phys_hi) {
  return {d.has_min ? std::max(phys_lo, d.min) : phys_lo,
          d.has_max ? std::min(phys_hi, d.max) : phys_hi};
}

// Standardised bounds of a normal or lognormal on [lo, hi]: z = (x - mean) / sigma, or
// z = ln(x / median) / sigma_ln (x <= 0 maps to -inf, as ln X is defined only for X > 0).
Interval standard_bounds(const Distribution& d, Interval r) {
  if (d.kind == Distribution::Kind::kNormal) {
    return {(r.lo - d.mean) / d.sigma, (r.hi - d.mean) / d.sigma};
  }
  const double mu = std::log(d.median);
  const auto z = [&](double x) {
    if (x <= 0.0) return -kInf;
    return (std::log(x) - mu) / d.sigma_ln;
  };
  return {z(r.lo), z(r.hi)};
}

// Piecewise-linear table CDF at x.
double table_cdf_at(const Distribution& d, double x) {
  const auto& xs = d.table_values;
  const auto& fs = d.table_cdf;
  if (x <= xs.front()) return 0.0;
  if (x >= xs.back()) return 1.0;
  const std::size_t j =
      static_cast<std::size_t>(std::upper_bound(xs.begin(), xs.end(), x) - xs.begin());
  const std::size_t k = j - 1;  // xs[k] <= x < xs[j]
  const double t = (x - xs[k]) / (xs[j] - xs[k]);
  return fs[k] + t * (fs[j] - fs[k]);
}

// Generalised inverse of the table CDF, F^-1(p) = inf{x : F(x) >= p}. On a flat CDF segment
// (zero probability between x_k and x_k+1) this returns the segment's left end, so no sample
// ever falls inside a flat segment.
double table_quantile(const Distribution& d, double p) {
  const auto& xs = d.table_values;
  const auto& fs = d.table_cdf;
  const std::size_t j =
      static_cast<std::size_t>(std::lower_bound(fs.begin(), fs.end(), p) - fs.begin());
  if (j == 0) return xs.front();
  if (j >= fs.size()) return xs.back();
  const std::size_t k = j - 1;  // fs[k] < p <= fs[j], so fs[j] - fs[k] > 0
  const double t = (p - fs[k]) / (fs[j] - fs[k]);
  return xs[k] + t * (xs[j] - xs[k]);
}

// Probability of [r.lo, r.hi] under Mott's law, S(lo) - S(hi).
double mott_mass(double mu, Interval r) {
  return mott_survival(r.lo, mu) - mott_survival(r.hi, mu);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Mott

double mott_survival(double x, double mu) {
  if (!(x > 0.0)) return 1.0;
  return std::exp(-std::sqrt(x / mu));
}

double mott_quantile(double u, double mu, double lo, double hi) {
  // With a = sqrt(x / mu), S = exp(-a): S(x) = S(lo) - u (S(lo) - S(hi)), so
  // a = a_lo - ln(1 - u (1 - exp(a_lo - a_hi))) = a_lo - log1p(u expm1(a_lo - a_hi)).
  const double a_lo = lo > 0.0 ? std::sqrt(lo / mu) : 0.0;
  const double a_hi = std::isfinite(hi) ? std::sqrt(hi / mu) : kInf;
  const double a = a_lo - std::log1p(u * std::expm1(a_lo - a_hi));
  return std::clamp(mu * a * a, std::max(lo, 0.0), hi);
}

// ---------------------------------------------------------------------------------------------
// Standard normal

double normal_cdf(double x) {
  // Phi(x) = erfc(-x / sqrt 2) / 2. The product -x/sqrt2 carries a rounding error of up to half
  // an ulp, and erfc magnifies a relative argument error by 2 z^2 (d ln erfc / dz ~ -2z): at
  // x = -8 that is ~64 ulp. Split 1/sqrt2 = s_hi + s_lo and recover the exact product's low part
  // with an FMA, then correct erfc to first order: erfc(z + dz) = erfc(z) - 2/sqrt(pi) e^{-z^2} dz.
  if (std::isnan(x)) return x;
  constexpr double s_hi = 0x1.6a09e667f3bcdp-1;    // 1/sqrt(2) rounded to double
  constexpr double s_lo = -4.833646656726457e-17;  // 1/sqrt(2) - s_hi
  constexpr double two_over_sqrt_pi = 1.1283791670955126;
  const double w = -x;
  const double z = w * s_hi;
  const double dz = std::fma(w, s_hi, -z) + w * s_lo;
  const double e = std::erfc(z);
  if (!std::isfinite(z)) return 0.5 * e;
  return 0.5 * (e - two_over_sqrt_pi * std::exp(-z * z) * dz);
}

double normal_quantile(double p) {
  // Wichura, M. J. (1988). Algorithm AS 241: The percentage points of the normal distribution.
  // Applied Statistics 37(3), 477-484; PPND16, rational approximations of degree 7 with relative
  // accuracy about 1e-16 in three regions:
  //   |p - 1/2| <= 0.425:                     x = q A(r)/B(r),  r = 0.180625 - q^2
  //   r = sqrt(-ln min(p, 1-p)) <= 5:          x = +-C(r - 1.6)/D(r - 1.6)
  //   r > 5 (down to p ~ 1e-300 and beyond):   x = +-E(r - 5)/F(r - 5)
  static constexpr double a[8] = {3.3871328727963666080e0,  1.3314166789178437745e+2,
                                  1.9715909503065514427e+3, 1.3731693765509461125e+4,
                                  4.5921953931549871457e+4, 6.7265770927008700853e+4,
                                  3.3430575583588128105e+4, 2.5090809287301226727e+3};
  static constexpr double b[8] = {1.0,
                                  4.2313330701600911252e+1,
                                  6.8718700749205790830e+2,
                                  5.3941960214247511077e+3,
                                  2.1213794301586595867e+4,
                                  3.9307895800092710610e+4,
                                  2.8729085735721942674e+4,
                                  5.2264952788528545610e+3};
  static constexpr double c[8] = {1.42343711074968357734e0,  4.63033784615654529590e0,
                                  5.76949722146069140550e0,  3.64784832476320460504e0,
                                  1.27045825245236838258e0,  2.41780725177450611770e-1,
                                  2.27238449892691845833e-2, 7.74545014278341407640e-4};
  static constexpr double d[8] = {1.0,
                                  2.05319162663775882187e0,
                                  1.67638483018380384940e0,
                                  6.89767334985100004550e-1,
                                  1.48103976427480074590e-1,
                                  1.51986665636164571966e-2,
                                  5.47593808499534494600e-4,
                                  1.05075007164441684324e-9};
  static constexpr double e[8] = {6.65790464350110377720e0,  5.46378491116411436990e0,
                                  1.78482653991729133580e0,  2.96560571828504891230e-1,
                                  2.65321895265761230930e-2, 1.24266094738807843860e-3,
                                  2.71155556874348757815e-5, 2.01033439929228813265e-7};
  static constexpr double f[8] = {1.0,
                                  5.99832206555887937690e-1,
                                  1.36929880922735805310e-1,
                                  1.48753612908506148525e-2,
                                  7.86869131145613259100e-4,
                                  1.84631831751005468180e-5,
                                  1.42151175831644588870e-7,
                                  2.04426310338993978564e-15};
  if (std::isnan(p)) return p;
  if (p <= 0.0) return -kInf;
  if (p >= 1.0) return kInf;

  const double q = p - 0.5;
  if (std::fabs(q) <= 0.425) {
    const double r = 0.180625 - q * q;
    return q * poly7(a, r) / poly7(b, r);
  }
  // Tail: r from the smaller of p and 1 - p (1 - p is exact here since p > 0.5 + 0.425).
  double r = std::sqrt(-std::log(q < 0.0 ? p : 1.0 - p));
  double x;
  if (r <= 5.0) {
    r -= 1.6;
    x = poly7(c, r) / poly7(d, r);
  } else {
    r -= 5.0;
    x = poly7(e, r) / poly7(f, r);
  }
  return q < 0.0 ? -x : x;
}

// ---------------------------------------------------------------------------------------------
// Distribution

double Distribution::sample(double u, double phys_lo, double phys_hi) const {
  return TruncatedDistribution(*this, phys_lo, phys_hi).sample(u);
}

TruncatedDistribution::TruncatedDistribution(const Distribution& d, double phys_lo, double phys_hi)
    : d_(&d) {
  const Interval r = truncation(d, phys_lo, phys_hi);
  lo_ = r.lo;
  hi_ = r.hi;
  if (d.kind == Distribution::Kind::kNormal || d.kind == Distribution::Kind::kLognormal) {
    const Interval z = standard_bounds(d, r);
    cut_ = std_normal_cut(z.lo, z.hi);
  } else if (d.kind == Distribution::Kind::kTable) {
    f_lo_ = table_cdf_at(d, r.lo);
    f_hi_ = table_cdf_at(d, r.hi);
  }
}

double TruncatedDistribution::sample(double u) const {
  using Kind = Distribution::Kind;
  const Distribution& d = *d_;
  // Rounding in mean + sigma z may step just outside the range; the bounds are hard.
  const double lo = std::max(lo_, -std::numeric_limits<double>::max());
  const double hi = std::min(hi_, std::numeric_limits<double>::max());
  switch (d.kind) {
    case Kind::kFixed: return d.value;
    case Kind::kUniform: return d.min + u * (d.max - d.min);
    case Kind::kNormal: return std::clamp(d.mean + d.sigma * truncated_std_normal(cut_, u), lo, hi);
    case Kind::kLognormal:
      return std::clamp(d.median * std::exp(d.sigma_ln * truncated_std_normal(cut_, u)), lo, hi);
    case Kind::kTable: return std::clamp(table_quantile(d, f_lo_ + u * (f_hi_ - f_lo_)), lo_, hi_);
    case Kind::kMott: return mott_quantile(u, d.mu, std::max(lo_, 0.0), hi_);
  }
  return d.value;
}

std::string Distribution::validate(double phys_lo, double phys_hi) const {
  const auto finite = [](double v) { return std::isfinite(v); };
  const std::string lo_msg = lower_bound_text(phys_lo);
  const std::string hi_msg = "must be <= " + num(phys_hi);

  // Explicit truncation bounds (normal, lognormal, table).
  const auto check_bounds = [&]() -> std::string {
    if (has_min && !finite(min)) return "min: must be a finite number";
    if (has_max && !finite(max)) return "max: must be a finite number";
    if (has_min && has_max && !(max > min)) return "max: must be > min";
    return "";
  };

  switch (kind) {
    case Kind::kFixed:
      if (!finite(value)) return "value: must be a finite number";
      if (value < phys_lo) return "value: " + lo_msg;
      if (value > phys_hi) return "value: " + hi_msg;
      return "";

    case Kind::kUniform:
      if (!finite(min)) return "min: must be a finite number";
      if (!finite(max)) return "max: must be a finite number";
      if (!(max > min)) return "max: must be > min";
      if (min < phys_lo) return "min: " + lo_msg;
      if (max > phys_hi) return "max: " + hi_msg;
      return "";

    case Kind::kNormal:
    case Kind::kLognormal: {
      const bool normal = kind == Kind::kNormal;
      if (normal) {
        if (!finite(mean)) return "mean: must be a finite number";
        if (!finite(sigma)) return "sigma: must be a finite number";
        if (!(sigma > 0.0)) return "sigma: must be > 0";
      } else {
        if (!finite(median)) return "median: must be a finite number";
        if (!(median > 0.0)) return "median: must be > 0";
        if (!finite(sigma_ln)) return "sigma_ln: must be a finite number";
        if (!(sigma_ln > 0.0)) return "sigma_ln: must be > 0";
      }
      if (auto m = check_bounds(); !m.empty()) return m;
      const Interval r = truncation(*this, phys_lo, phys_hi);
      const Interval z = standard_bounds(*this, r);
      if (!(r.lo < r.hi) || !(std_normal_mass(z.lo, z.hi) >= kMinTruncatedMass)) {
        return std::string(normal ? "mean" : "median") + ": truncation range " +
               range_text(r.lo, r.hi) + " has no probability mass";
      }
      return "";
    }

    case Kind::kTable: {
      const auto& xs = table_values;
      const auto& fs = table_cdf;
      if (xs.size() < 2) return "table_values: needs at least 2 entries";
      if (fs.size() != xs.size()) return "table_cdf: must have as many entries as table_values";
      for (std::size_t k = 0; k < xs.size(); ++k) {
        if (!finite(xs[k]))
          return "table_values[" + std::to_string(k) + "]: must be a finite number";
        if (!finite(fs[k])) return "table_cdf[" + std::to_string(k) + "]: must be a finite number";
        if (k > 0 && !(xs[k] > xs[k - 1])) return "table_values: must be strictly increasing";
        if (k > 0 && fs[k] < fs[k - 1]) return "table_cdf: must be nondecreasing";
      }
      if (fs.front() != 0.0) return "table_cdf: must start at 0";
      if (fs.back() != 1.0) return "table_cdf: must end at 1";
      if (auto m = check_bounds(); !m.empty()) return m;
      const Interval r = truncation(*this, phys_lo, phys_hi);
      if (!(r.lo < r.hi) ||
          !(table_cdf_at(*this, r.hi) - table_cdf_at(*this, r.lo) >= kMinTruncatedMass)) {
        return "table_values: truncation range " + range_text(r.lo, r.hi) +
               " has no probability mass";
      }
      return "";
    }

    case Kind::kMott: {
      if (!finite(mu)) return "mu: must be a finite number";
      if (!(mu > 0.0)) return "mu: must be > 0";
      if (auto m = check_bounds(); !m.empty()) return m;
      const Interval r = truncation(*this, phys_lo, phys_hi);
      if (!(r.lo < r.hi) || !(mott_mass(mu, r) >= kMinTruncatedMass))
        return "mu: truncation range " + range_text(r.lo, r.hi) + " has no probability mass";
      return "";
    }
  }
  return "dist: unknown kind";
}

}  // namespace fragsim::fragments
