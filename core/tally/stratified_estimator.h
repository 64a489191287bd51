#pragma once
// Mean and standard error of per-bin totals from per-history contributions, with fragment groups
// as independent strata. Within group g (n_g histories), history i adds x_i (already multiplied by
// its weight count_g/samples_g) to a bin; the group's total is S_g = sum_i x_i, an unbiased
// estimate of the group's expected total, with variance estimated by
//   n_g/(n_g - 1) * (Q_g - S_g^2 / n_g),   Q_g = sum_i x_i^2.
// Totals over groups add means and variances. A history that touches a bin more than once must
// add its contributions together before calling add() (x_i is the history's whole contribution).
//
// Stratified launch sampling (settings.stratified_launch) closes strata far more often. There the
// variance is estimated on two partitions of the histories into collapsed strata, offset by half
// a stratum, and the larger of the two is reported (docs/precision.md, "Stratified launch
// sampling"); the mean is the same sum either way.
//
// Contributions are added in a fixed (group, history) order by the run's ordered reducer, so the
// floating-point sums are identical whatever the thread count or chunking.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace fragsim::tally {

class StratifiedEstimator {
 public:
  // `partitions`: 1, or 2 for two partitions into strata closed independently (end_stratum).
  explicit StratifiedEstimator(std::size_t bins = 0, int partitions = 1) {
    parts_.resize(partitions > 1 ? 2 : 1);
    resize(bins);
  }
  void resize(std::size_t bins) {
    for (Partition& p : parts_) p.resize(bins);
    mean_.assign(bins, 0.0);
  }
  std::size_t size() const { return mean_.size(); }
  std::size_t partitions() const { return parts_.size(); }

  void add(std::size_t bin, double x) {
    if (x == 0.0) return;  // changes neither sum
    for (Partition& p : parts_) p.add(bin, x);
  }

  // Closes the current group (stratum) of n histories of every partition (their strata must
  // hold the same n histories; otherwise close each with end_stratum).
  void end_group(std::int64_t n) {
    for (std::size_t k = 0; k < parts_.size(); ++k) end_stratum(k, n);
  }
  // Closes the current stratum of n histories of one partition. Visits only the bins the stratum
  // touched, so a run may close many small strata; each bin's update reads only that bin, so the
  // order of the visit cannot change a result.
  void end_stratum(std::size_t partition, std::int64_t n) {
    parts_[partition].close(n, partition == 0 ? &mean_ : nullptr);
  }

  double mean(std::size_t bin) const { return mean_[bin]; }
  double std_error(std::size_t bin) const { return std::sqrt(variance(bin)); }
  const std::vector<double>& means() const { return mean_; }
  std::vector<double> std_errors() const {
    std::vector<double> se(mean_.size());
    for (std::size_t b = 0; b < se.size(); ++b) se[b] = std_error(b);
    return se;
  }

 private:
  double variance(std::size_t bin) const {
    double v = 0.0;
    for (const Partition& p : parts_) v = std::max(v, p.var[bin]);
    return v;
  }

  struct Partition {
    std::vector<double> s, q;          // current stratum
    std::vector<double> var;           // closed strata
    std::vector<std::size_t> touched;  // bins with q > 0 in the current stratum
    void resize(std::size_t bins) {
      touched.clear();
      s.assign(bins, 0.0);
      q.assign(bins, 0.0);
      var.assign(bins, 0.0);
    }
    void add(std::size_t bin, double x) {
      if (q[bin] == 0.0) touched.push_back(bin);
      s[bin] += x;
      q[bin] += x * x;
    }
    void close(std::int64_t n, std::vector<double>* mean) {
      const double dn = static_cast<double>(n);
      for (const std::size_t b : touched) {
        if (s[b] == 0.0 && q[b] == 0.0) continue;
        if (mean != nullptr) (*mean)[b] += s[b];
        if (n > 1) var[b] += std::max(0.0, dn / (dn - 1.0) * (q[b] - s[b] * s[b] / dn));
        s[b] = 0.0;
        q[b] = 0.0;
      }
      touched.clear();
    }
  };
  std::vector<Partition> parts_;
  std::vector<double> mean_;  // closed strata of partition 0
};

}  // namespace fragsim::tally
