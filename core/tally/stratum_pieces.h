#pragma once
// Pieces of strata (tally/stratified_tally.h): the exact sums S and Q per bin of the histories of
// one stratum that one chunk holds. A run builds a chunk's pieces on the worker that computed it,
// in parallel with the other chunks, and adds them to its tally in chunk order (core/run/
// reducer.h): the serial part of the fold is then one merge per touched bin, not two exact sums
// per term. A piece's memory is in proportion to the bins it touches (a hash index on the bin),
// not to the tally's size, so a worker's scratch stays small on a large terrain.
#include <compare>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "core/tally/exact_sum.h"

namespace fragsim::tally {

struct StratumKey {
  std::uint32_t partition = 0;
  std::uint32_t group = 0;
  std::int64_t batch = 0;
  std::int64_t index = 0;
  auto operator<=>(const StratumKey&) const = default;
};

// A stratum's histories folded so far and their exact S and Q per bin: a piece of it
// (StratumPiece), or an open stratum as StratifiedTally::open_strata() and partial files show it
// (entries sorted by bin).
struct OpenStratum {
  struct Entry {
    std::uint32_t bin = 0;
    ExactSum s, q;
  };
  std::int64_t size = 0;  // histories in the whole stratum
  std::int64_t n = 0;     // histories folded so far
  std::vector<Entry> entries;
};

// A piece of stratum `key`: the whole stratum (st.n == st.size) or a part of it; its entries in
// the order their bins were first touched.
struct StratumPiece {
  StratumKey key;
  OpenStratum st;
};

// Bin -> index in the order of first use: open addressing (linear probing) on a multiplicative
// hash of the bin, at most half full.
class BinIndex {
 public:
  // The index of `bin`; a bin not seen since clear() gets the next one (size() before the call).
  std::uint32_t find_or_add(std::uint32_t bin) {
    if (2 * (bins_.size() + 1) > slot_.size()) grow();
    const std::size_t mask = slot_.size() - 1;
    for (std::size_t s = hash(bin);; s = (s + 1) & mask) {
      const std::uint32_t k = slot_[s];
      if (k == 0) {
        bins_.push_back(bin);
        slot_[s] = static_cast<std::uint32_t>(bins_.size());
        return static_cast<std::uint32_t>(bins_.size() - 1);
      }
      if (bins_[k - 1] == bin) return k - 1;
    }
  }
  std::size_t size() const { return bins_.size(); }
  const std::vector<std::uint32_t>& bins() const { return bins_; }  // by index
  void clear();  // keeps the capacity; visits only the used slots when few are

 private:
  std::size_t hash(std::uint32_t bin) const {
    return static_cast<std::size_t>((bin * 0x9E3779B97F4A7C15ull) >> shift_);
  }
  void grow();
  std::vector<std::uint32_t> slot_;  // index + 1, or 0 when empty; a power of 2 in size
  std::vector<std::uint32_t> bins_;
  int shift_ = 64;
};

// The exact S and Q per bin of one piece, in the order the bins were first touched.
class PieceSums {
 public:
  void add(std::uint32_t bin, double x) {
    const std::uint32_t k = at(bin);
    s_[k].add(x);
    q_[k].add(x * x);
  }
  void add_square(std::uint32_t bin, double v) { q_[at(bin)].add(v); }
  // Another piece's sums for the bin (exact: throws std::overflow_error out of range). A bin not
  // touched before takes them as they are.
  void add_sums(std::uint32_t bin, const ExactSum& s, const ExactSum& q) {
    const std::uint32_t k = index_.find_or_add(bin);
    if (k == s_.size()) {
      s_.push_back(s);
      q_.push_back(q);
      return;
    }
    s_[k].add(s);
    q_[k].add(q);
  }
  bool empty() const { return index_.size() == 0; }
  std::size_t size() const { return index_.size(); }
  // Entry k (in the order first touched): its bin and sums.
  std::uint32_t bin(std::size_t k) const { return index_.bins()[k]; }
  const ExactSum& s(std::size_t k) const { return s_[k]; }
  const ExactSum& q(std::size_t k) const { return q_[k]; }
  // The entries' indices in the order of their bins.
  std::vector<std::uint32_t> order_by_bin() const;
  // Appends the entries to `out` (first touched first) and clears.
  void move_to(std::vector<OpenStratum::Entry>& out);
  void clear();  // keeps the capacity

 private:
  std::uint32_t at(std::uint32_t bin) {
    const std::uint32_t k = index_.find_or_add(bin);
    if (k == s_.size()) {
      s_.emplace_back();
      q_.emplace_back();
    }
    return k;
  }
  BinIndex index_;
  std::vector<ExactSum> s_, q_;  // by index
};

// Builds the pieces of a fold: per partition, the current stratum's piece, flushed into a list.
// The fold's calls are those of StratifiedTally (start, add, add_square, history_done, flush).
class PieceBuilder {
 public:
  // `partitions`: 1, or 2 for two partitions into strata closed independently.
  explicit PieceBuilder(int partitions = 1) : parts_(partitions > 1 ? 2 : 1) {}
  std::size_t partitions() const { return parts_.size(); }

  // Names partition k's current stratum (key.partition is set to k). A start() without the
  // flush() of the piece before throws std::logic_error.
  void start(std::size_t partition, const StratumKey& key, std::int64_t size);
  void add(std::size_t bin, double x) {
    if (x == 0.0) return;  // changes neither sum
    for (Part& p : parts_) p.sums.add(static_cast<std::uint32_t>(bin), x);
  }
  // Adds v to the bin's sum of squares alone (StratifiedTally::add_square).
  void add_square(std::size_t bin, double v) {
    for (Part& p : parts_) p.sums.add_square(static_cast<std::uint32_t>(bin), v);
  }
  void history_done() {
    for (Part& p : parts_) ++p.n;
  }
  // Ends the piece of partition k's stratum folded since start() and appends it to `out`, unless
  // it holds no history. Contributions without history_done() throw std::logic_error.
  void flush(std::size_t partition, std::vector<StratumPiece>& out);
  // Forgets every piece in progress.
  void clear();

 private:
  struct Part {
    StratumKey key;
    std::int64_t size = 0;
    std::int64_t n = 0;  // histories since start()
    PieceSums sums;
  };
  std::vector<Part> parts_;
};

}  // namespace fragsim::tally
