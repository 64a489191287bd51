#pragma once
// Chi-square goodness-of-fit machinery for the sampler tests: the regularised upper incomplete
// gamma function Q(a, x) (the chi-square survival function is Q(k/2, x/2)) and an
// equal-probability-bin test. Header-only, test code only.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace fragsim::fragments::testing {

// Regularised upper incomplete gamma Q(a, x) = Gamma(a, x) / Gamma(a), a > 0, x >= 0.
// For x < a + 1 the power series of the lower function P converges fast (Abramowitz & Stegun
// 6.5.29) and Q = 1 - P loses nothing that matters for p-values near 1; otherwise Q comes
// directly from its continued fraction (A&S 6.5.31), evaluated by the modified Lentz method, so
// tiny p-values (1e-100) keep full relative accuracy.
inline double gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  const double log_prefactor = a * std::log(x) - x - std::lgamma(a);  // x^a e^-x / Gamma(a)
  constexpr double eps = 1e-16;
  if (x < a + 1.0) {
    // P(a, x) = x^a e^-x / Gamma(a+1) * sum_n x^n / ((a+1)...(a+n))
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::fabs(term) < eps * std::fabs(sum)) break;
    }
    return 1.0 - sum * std::exp(log_prefactor);
  }
  // Q(a, x) = x^a e^-x / Gamma(a) * 1/(x+1-a- 1(1-a)/(x+3-a- 2(2-a)/(x+5-a- ...)))
  constexpr double tiny = 1e-300;
  double b = x + 1.0 - a;
  double c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < eps) break;
  }
  return std::exp(log_prefactor) * h;
}

inline double chi_square_p_value(double statistic, int dof) {
  return gamma_q(0.5 * dof, 0.5 * statistic);
}

struct ChiSquareResult {
  double statistic = 0.0;
  int dof = 0;
  double p_value = 0.0;
};

// Pearson's statistic for counts in bins of equal expected probability.
inline ChiSquareResult equal_probability_test(const std::vector<std::int64_t>& counts) {
  std::int64_t n = 0;
  for (auto c : counts) n += c;
  const double expected = static_cast<double>(n) / static_cast<double>(counts.size());
  ChiSquareResult r;
  for (auto c : counts) {
    const double diff = static_cast<double>(c) - expected;
    r.statistic += diff * diff / expected;
  }
  r.dof = static_cast<int>(counts.size()) - 1;
  r.p_value = chi_square_p_value(r.statistic, r.dof);
  return r;
}

// Bins samples by their value under the reference CDF: F(x) in [0, 1] falls in bin
// floor(F * nbins), so each bin has probability 1/nbins under the reference distribution.
class EqualProbabilityBins {
 public:
  explicit EqualProbabilityBins(std::size_t nbins) : counts_(nbins, 0) {}
  void add_cdf(double f) {
    const double nb = static_cast<double>(counts_.size());
    double idx = std::floor(f * nb);
    if (!(idx >= 0.0)) idx = 0.0;  // also catches NaN, which then shows up as a misfit
    if (idx > nb - 1.0) idx = nb - 1.0;
    ++counts_[static_cast<std::size_t>(idx)];
  }
  void add_bin(std::size_t k) { ++counts_[k]; }
  ChiSquareResult test() const { return equal_probability_test(counts_); }
  const std::vector<std::int64_t>& counts() const { return counts_; }

 private:
  std::vector<std::int64_t> counts_;
};

}  // namespace fragsim::fragments::testing
