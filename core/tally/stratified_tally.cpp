#include "core/tally/stratified_tally.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace fragsim::tally {

namespace {

// One stratum's variance term from its exact sums, rounded once (the formula of the header).
double variance_term(const ExactSum& s, const ExactSum& q, std::int64_t n) {
  if (n <= 1) return 0.0;
  const double dn = static_cast<double>(n), sv = s.value(), qv = q.value();
  return std::max(0.0, dn / (dn - 1.0) * (qv - sv * sv / dn));
}

}  // namespace

StratifiedTally::StratifiedTally(std::size_t bins, int partitions)
    : builder_(partitions), mean_(bins), var_(partitions > 1 ? 2 : 1, ExactBins(bins)) {}

void StratifiedTally::flush(std::size_t partition) {
  builder_.flush(partition, flushed_);
  for (StratumPiece& piece : flushed_) add_piece(std::move(piece));
  flushed_.clear();
}

void StratifiedTally::add_piece(StratumPiece&& piece) {
  if (piece.st.n >= piece.st.size) {
    close(piece.st, piece.key.partition);  // the whole stratum is here: no need to keep it
    return;
  }
  merge_open(piece.key, piece.st);
}

// One bin of a complete stratum: its sum into the mean (once: partition 0's) and its variance
// term, computed once from the exact S and Q, into the partition's variance.
void StratifiedTally::close_entry(std::uint32_t bin, const ExactSum& s, const ExactSum& q,
                                  std::int64_t n, std::size_t partition) {
  if (partition == 0) mean_.add(bin, s);
  const double v = variance_term(s, q, n);
  if (v > 0.0) var_[partition].add(bin, v);
}

void StratifiedTally::close(const OpenStratum& st, std::size_t partition) {
  for (const OpenStratum::Entry& e : st.entries) close_entry(e.bin, e.s, e.q, st.n, partition);
}

// In the order of the bins, so that the tally's sums are touched in the same order however the
// stratum's pieces arrived.
void StratifiedTally::close(const Open& st, std::size_t partition) {
  for (const std::uint32_t k : st.sums.order_by_bin())
    close_entry(st.sums.bin(k), st.sums.s(k), st.sums.q(k), st.n, partition);
}

// Adds a piece to the open stratum `key`, closing it when it is complete. The sum of two pieces
// is exact, so the order of pieces does not matter.
void StratifiedTally::merge_open(const StratumKey& key, const OpenStratum& piece) {
  auto [it, inserted] = open_.try_emplace(key);
  Open& st = it->second;
  if (inserted) {
    st.size = piece.size;
  } else if (piece.size != st.size || piece.n < 0 || piece.n > st.size - st.n) {
    // Pieces of one stratum agree on its size and together hold at most its histories; pieces
    // that do not (a damaged or forged partial file) are refused before anything changes.
    throw std::overflow_error("open strata whose pieces do not add up to the stratum");
  }
  for (const OpenStratum::Entry& e : piece.entries) st.sums.add_sums(e.bin, e.s, e.q);
  st.n += piece.n;
  if (st.n >= st.size) {
    close(st, key.partition);
    open_.erase(it);
  }
}

void StratifiedTally::merge(const StratifiedTally& o) {
  mean_.merge(o.mean_);
  for (std::size_t k = 0; k < var_.size() && k < o.var_.size(); ++k) var_[k].merge(o.var_[k]);
  for (const auto& [key, st] : o.open_strata()) merge_open(key, st);
}

std::map<StratumKey, OpenStratum> StratifiedTally::open_strata() const {
  std::map<StratumKey, OpenStratum> out;
  for (const auto& [key, st] : open_) {
    OpenStratum& o = out[key];
    o.size = st.size;
    o.n = st.n;
    o.entries.reserve(st.sums.size());
    for (const std::uint32_t k : st.sums.order_by_bin())
      o.entries.push_back({st.sums.bin(k), st.sums.s(k), st.sums.q(k)});
  }
  return out;
}

void StratifiedTally::close_open_strata() {
  for (const auto& [key, st] : open_) close(st, key.partition);
  open_.clear();
}

void StratifiedTally::clear() {
  mean_.clear();
  for (ExactBins& v : var_) v.clear();
  open_.clear();
  builder_.clear();
}

double StratifiedTally::std_error(std::size_t bin) const {
  double v = 0.0;
  for (const ExactBins& p : var_) v = std::max(v, p.value(bin));
  return std::sqrt(v);
}

std::vector<double> StratifiedTally::means(std::size_t first, std::size_t count) const {
  std::vector<double> m(count, 0.0);
  for (std::size_t k = 0; k < mean_.bins().size(); ++k) {
    const std::size_t b = mean_.bins()[k];
    if (b >= first && b < first + count) m[b - first] = mean_.sums()[k].value();
  }
  return m;
}

std::vector<double> StratifiedTally::std_errors(std::size_t first, std::size_t count) const {
  std::vector<double> v(count, 0.0);
  for (const ExactBins& p : var_)
    for (std::size_t k = 0; k < p.bins().size(); ++k) {
      const std::size_t b = p.bins()[k];
      if (b >= first && b < first + count)
        v[b - first] = std::max(v[b - first], p.sums()[k].value());
    }
  for (double& x : v) x = std::sqrt(x);
  return v;
}

void StratifiedTally::restore(ExactBins mean, std::vector<ExactBins> var,
                              std::map<StratumKey, OpenStratum> open) {
  mean_ = std::move(mean);
  var_ = std::move(var);
  open_.clear();
  for (const auto& [key, st] : open) {
    Open& o = open_[key];
    o.size = st.size;
    o.n = st.n;
    for (const OpenStratum::Entry& e : st.entries) o.sums.add_sums(e.bin, e.s, e.q);
  }
}

}  // namespace fragsim::tally
