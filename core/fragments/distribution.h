#pragma once
// Scalar probability distributions of fragment properties, sampled by inversion from one uniform
// variate so that each variable consumes exactly one Philox slot.
#include <limits>
#include <string>
#include <vector>

namespace fragsim::fragments {

// Physical ranges passed to sample()/validate() are closed intervals. A quantity that must be
// strictly positive (a mass) passes this smallest normal double as phys_lo: the open bound
// (0, ...). Messages print it as 0.
inline constexpr double kPositiveLowerBound = std::numeric_limits<double>::min();

// A truncated normal, lognormal, table or Mott distribution whose range holds less probability than
// this is rejected by validate(): such a range is almost surely an input mistake (a normal cut more
// than ~7 sigma from its mean), and inside the bulk the inversion would resolve it only coarsely.
inline constexpr double kMinTruncatedMass = 1e-12;

struct Distribution {
  enum class Kind { kFixed, kUniform, kNormal, kLognormal, kTable, kMott };
  Kind kind = Kind::kFixed;
  double value = 0.0;    // fixed
  double min = 0.0;      // uniform; normal/lognormal/table/mott: lower truncation (if has_min)
  double max = 0.0;      // uniform; normal/lognormal/table/mott: upper truncation (if has_max)
  bool has_min = false;  // normal/lognormal/table/mott: an explicit truncation bound was given
  bool has_max = false;
  double mean = 0.0;                 // normal
  double sigma = 0.0;                // normal: standard deviation (> 0)
  double median = 0.0;               // lognormal: exp(mu) (> 0)
  double sigma_ln = 0.0;             // lognormal: standard deviation of ln X (> 0)
  std::vector<double> table_values;  // table: strictly increasing values x_k
  std::vector<double> table_cdf;     // table: CDF at x_k, nondecreasing from 0 to 1
  // mott: Mott's law for naturally fragmenting shell cases (Mott 1947), N(>x) = N0 exp(-(x/mu)^½):
  // CDF F(x) = 1 - exp(-sqrt(x / mu)) on x >= 0, mean 2 mu (> 0). See mott_* below.
  double mu = 0.0;

  static Distribution fixed(double v) {
    Distribution d;
    d.value = v;
    return d;
  }

  // The variate for uniform u in (0,1): inverse CDF, truncated to [lo, hi] where lo/hi come from
  // the explicit bounds and the physical range [phys_lo, phys_hi] of the quantity (a normal mass
  // is never <= 0). Pure and deterministic.
  double sample(double u, double phys_lo, double phys_hi) const;

  // Checks parameters; returns an empty string when valid, else "field: problem" relative to the
  // distribution (e.g. "sigma: must be > 0"), for the caller to prefix with its own path.
  std::string validate(double phys_lo, double phys_hi) const;
};

// A standard normal cut to [a, b], with the two tail probabilities its inversion maps u between
// (distribution.cpp, std_normal_cut) and, for a < 0 < b, the mass between them.
struct StdNormalCut {
  double a = 0.0, b = 0.0;
  double p_a = 0.0, p_b = 0.0, mass = 0.0;
};

// A distribution truncated to a fixed physical range [phys_lo, phys_hi], with everything that does
// not depend on u (the bounds, their standardised values, the tail probabilities or table CDF
// values at them) worked out once: sample(u) is Distribution::sample(u, phys_lo, phys_hi) bit
// for bit (which is computed through it), without the per-call logs and erfc's. For the many
// histories of one group. Keeps a pointer to `d`, which must outlive it.
class TruncatedDistribution {
 public:
  TruncatedDistribution(const Distribution& d, double phys_lo, double phys_hi);
  double sample(double u) const;

 private:
  const Distribution* d_;
  double lo_, hi_;     // the truncation: explicit bounds within the physical range
  StdNormalCut cut_;   // normal, lognormal: in standardised units
  double f_lo_ = 0.0;  // table: CDF at lo_ and hi_
  double f_hi_ = 0.0;
};

// Mott's distribution with scale mu (> 0): the survival function S(x) = exp(-sqrt(x / mu)) (x >= 0,
// 1 for x <= 0), and the variate for uniform u in [0, 1) restricted to [lo, hi] (0 <= lo < hi <=
// inf) by inversion, x = mu (sqrt(lo / mu) - ln(1 - u (1 - S(hi) / S(lo))))^2: exact, no
// rejection, accurate near u = 0 (log1p / expm1).
double mott_survival(double x, double mu);
double mott_quantile(double u, double mu, double lo, double hi);

// Standard normal CDF and its inverse (Wichura 1988, AS 241, relative accuracy ~1e-16).
double normal_cdf(double x);
double normal_quantile(double p);

}  // namespace fragsim::fragments
