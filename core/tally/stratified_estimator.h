#pragma once
// Mean and standard error of per-bin totals from per-history contributions, with fragment groups
// as independent strata. Within group g (n_g histories), history i adds x_i (already multiplied by
// its weight count_g/samples_g) to a bin; the group's total is S_g = sum_i x_i, an unbiased
// estimate of the group's expected total, with variance estimated by
//   n_g/(n_g - 1) * (Q_g - S_g^2 / n_g),   Q_g = sum_i x_i^2.
// Totals over groups add means and variances. A history that touches a bin more than once must
// add its contributions together before calling add() (x_i is the history's whole contribution).
//
// Contributions are added in a fixed (group, history) order by the run's ordered reducer, so the
// floating-point sums are identical whatever the thread count or chunking.
#include <cmath>
#include <cstdint>
#include <vector>

namespace fragsim::tally {

class StratifiedEstimator {
 public:
  explicit StratifiedEstimator(std::size_t bins = 0) { resize(bins); }
  void resize(std::size_t bins) {
    touched_.clear();
    s_.assign(bins, 0.0);
    q_.assign(bins, 0.0);
    mean_.assign(bins, 0.0);
    var_.assign(bins, 0.0);
  }
  std::size_t size() const { return s_.size(); }

  void add(std::size_t bin, double x) {
    if (x == 0.0) return;  // changes neither sum
    if (q_[bin] == 0.0) touched_.push_back(bin);
    s_[bin] += x;
    q_[bin] += x * x;
  }

  // Closes the current group (stratum) of n histories. Visits only the bins the stratum touched,
  // so a run may close many small strata (settings.stratified_launch); each bin's update reads
  // only that bin, so the order of the visit cannot change a result.
  void end_group(std::int64_t n) {
    const double dn = static_cast<double>(n);
    for (const std::size_t b : touched_) {
      if (s_[b] == 0.0 && q_[b] == 0.0) continue;
      mean_[b] += s_[b];
      if (n > 1) var_[b] += std::max(0.0, dn / (dn - 1.0) * (q_[b] - s_[b] * s_[b] / dn));
      s_[b] = 0.0;
      q_[b] = 0.0;
    }
    touched_.clear();
  }

  double mean(std::size_t bin) const { return mean_[bin]; }
  double std_error(std::size_t bin) const { return std::sqrt(var_[bin]); }
  const std::vector<double>& means() const { return mean_; }
  std::vector<double> std_errors() const {
    std::vector<double> se(var_.size());
    for (std::size_t b = 0; b < se.size(); ++b) se[b] = std::sqrt(var_[b]);
    return se;
  }

 private:
  std::vector<double> s_, q_;         // current group
  std::vector<std::size_t> touched_;  // bins with q_ > 0 in the current group
  std::vector<double> mean_, var_;    // closed groups
};

}  // namespace fragsim::tally
