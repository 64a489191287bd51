#pragma once
// Mean and standard error of per-bin totals from per-history contributions, with strata, kept as
// exact sums (tally/exact_sum.h) so that a tally split in any way - threads, chunks, shards,
// MPI ranks - and merged in any order gives the same bits (docs/cluster.md, "Exact sums").
// Resolution: squares are kept to 2^-160, so a bin's standard error is exact to 1e-12 for
// contributions down to 1e-18 (and loses its meaning below ~1e-22); means far below that.
//
// Within stratum j (n_j histories), history i adds x_i (already multiplied by its weight) to a
// bin; the stratum's total S_j = sum_i x_i is an unbiased estimate of its expected total, with
// variance estimated by
//   n_j/(n_j - 1) * (Q_j - S_j^2 / n_j),   Q_j = sum_i x_i^2.
// Totals over strata add means and variances. A history that touches a bin more than once must
// add its contributions together first (x_i is the history's whole contribution).
//
// Strata are named by a StratumKey and have a known size. A piece of a stratum (the histories of
// one chunk in it) is folded into a PieceBuilder (tally/stratum_pieces.h: this tally's own, or a
// run's worker's, added by add_piece()), then either closed at once (the piece is the whole
// stratum) or kept open, as exact per-bin sums S and Q, until pieces of the stratum from other
// chunks, threads or shards have brought it to its size (merge). S_j and Q_j are thus exact
// whatever the split, and each stratum's variance term is computed once from them.
//
// Stratified launch sampling (settings.stratified_launch) estimates the variance on two
// partitions of the histories into strata, offset by half a stratum, and reports the larger of
// the two (docs/precision.md, "Stratified launch sampling"); the mean is the same sum either way.
#include <compare>
#include <cstdint>
#include <map>
#include <vector>

#include "core/tally/exact_sum.h"
#include "core/tally/stratum_pieces.h"

namespace fragsim::tally {

// Sparse exact per-bin sums: memory in proportion to the bins touched.
class ExactBins {
 public:
  explicit ExactBins(std::size_t bins = 0) : slot_(bins, kNone) {}
  std::size_t size() const { return slot_.size(); }
  void add(std::size_t bin, double x) { at(bin).add(x); }
  void add(std::size_t bin, const ExactSum& s) { at(bin).add(s); }
  bool touched(std::size_t bin) const { return slot_[bin] != kNone; }
  double value(std::size_t bin) const {
    const std::uint32_t k = slot_[bin];
    return k == kNone ? 0.0 : sums_[k].value();
  }
  void merge(const ExactBins& o) {
    for (std::size_t k = 0; k < o.bins_.size(); ++k) add(o.bins_[k], o.sums_[k]);
  }
  void clear() {  // visits only the touched bins
    for (const std::uint32_t b : bins_) slot_[b] = kNone;
    bins_.clear();
    sums_.clear();
  }
  // The touched bins and their sums, in the order they were first touched.
  const std::vector<std::uint32_t>& bins() const { return bins_; }
  const std::vector<ExactSum>& sums() const { return sums_; }

 private:
  static constexpr std::uint32_t kNone = 0xffffffffu;
  ExactSum& at(std::size_t bin) {
    std::uint32_t& k = slot_[bin];
    if (k == kNone) {
      k = static_cast<std::uint32_t>(sums_.size());
      bins_.push_back(static_cast<std::uint32_t>(bin));
      sums_.emplace_back();
    }
    return sums_[k];
  }
  std::vector<std::uint32_t> slot_;  // per bin: index into bins_/sums_, or kNone
  std::vector<std::uint32_t> bins_;
  std::vector<ExactSum> sums_;
};

class StratifiedTally {
 public:
  // `partitions`: 1, or 2 for two partitions into strata closed independently.
  explicit StratifiedTally(std::size_t bins = 0, int partitions = 1);
  std::size_t size() const { return mean_.size(); }
  std::size_t partitions() const { return var_.size(); }

  // Folding: start(k, key, size) names partition k's current stratum (key.partition is set to
  // k); add() feeds every partition's current stratum; history_done() counts one history in
  // each (after its add()s); flush(k) ends the piece of partition k's stratum folded since
  // start(). A start() without the flush() of the piece before, or add()s not followed by
  // history_done(), throw std::logic_error.
  // The pieces are built by a PieceBuilder (tally/stratum_pieces.h) and added by add_piece().
  void start(std::size_t partition, const StratumKey& key, std::int64_t size) {
    builder_.start(partition, key, size);
  }
  void add(std::size_t bin, double x) { builder_.add(bin, x); }
  // Adds v to the bin's sum of squares alone, raising its variance term by about v: a floor
  // for a unit whose add() to the bin came just before (so the bin is touched in both sums).
  void add_square(std::size_t bin, double v) { builder_.add_square(bin, v); }
  void history_done() { builder_.history_done(); }
  void flush(std::size_t partition);
  // A piece built elsewhere (a worker's PieceBuilder): closed at once when it is the whole
  // stratum, else merged into the open stratum, which closes when its pieces are complete. The
  // same bits as folding its histories here.
  void add_piece(StratumPiece&& piece);

  // Adds another tally's closed and open strata (exact: any order gives the same bits).
  void merge(const StratifiedTally& o);
  // Closes every open stratum with the histories it has (a cancelled run's partial strata).
  void close_open_strata();
  // Forgets every sum and open stratum, keeping the shape (visits only the touched bins).
  void clear();
  // The open strata, each with its entries sorted by bin (built on demand: for a partial
  // result's file and for tests).
  std::map<StratumKey, OpenStratum> open_strata() const;

  double mean(std::size_t bin) const { return mean_.value(bin); }
  double std_error(std::size_t bin) const;
  // Means and standard errors of bins [first, first + count).
  std::vector<double> means(std::size_t first, std::size_t count) const;
  std::vector<double> std_errors(std::size_t first, std::size_t count) const;

  // The exact sums, for a partial result's file (formats/partial_file.h).
  const ExactBins& mean_sums() const { return mean_; }
  const ExactBins& variance_sums(std::size_t partition) const { return var_[partition]; }
  void restore(ExactBins mean, std::vector<ExactBins> var, std::map<StratumKey, OpenStratum> open);

 private:
  // An open stratum: its pieces so far, summed per bin in a hash index (adding a piece costs in
  // proportion to the piece, not to the stratum).
  struct Open {
    std::int64_t size = 0;
    std::int64_t n = 0;
    PieceSums sums;
  };
  void close(const OpenStratum& st, std::size_t partition);
  void close(const Open& st, std::size_t partition);
  void close_entry(std::uint32_t bin, const ExactSum& s, const ExactSum& q, std::int64_t n,
                   std::size_t partition);
  void merge_open(const StratumKey& key, const OpenStratum& piece);
  PieceBuilder builder_;
  std::vector<StratumPiece> flushed_;  // builder_'s pieces, added at once
  ExactBins mean_;
  std::vector<ExactBins> var_;  // per partition
  std::map<StratumKey, Open> open_;
};

}  // namespace fragsim::tally
