#include "core/tally/stratum_pieces.h"

#include <algorithm>
#include <bit>
#include <numeric>

namespace fragsim::tally {

void BinIndex::clear() {
  if (slot_.size() <= 8 * bins_.size()) {
    std::fill(slot_.begin(), slot_.end(), 0u);
  } else {  // each bin's slot holds its index + 1: found along its probe sequence
    const std::size_t mask = slot_.size() - 1;
    for (std::size_t k = 0; k < bins_.size(); ++k) {
      std::size_t s = hash(bins_[k]);
      while (slot_[s] != k + 1) s = (s + 1) & mask;
      slot_[s] = 0;
    }
  }
  bins_.clear();
}

void BinIndex::grow() {
  const std::size_t slots = std::max<std::size_t>(1024, 2 * slot_.size());
  slot_.assign(slots, 0u);
  shift_ = 64 - std::countr_zero(slots);
  const std::size_t mask = slots - 1;
  for (std::size_t k = 0; k < bins_.size(); ++k) {
    std::size_t s = hash(bins_[k]);
    while (slot_[s] != 0) s = (s + 1) & mask;
    slot_[s] = static_cast<std::uint32_t>(k + 1);
  }
}

void PieceSums::move_to(std::vector<OpenStratum::Entry>& out) {
  out.reserve(out.size() + s_.size());
  for (std::size_t k = 0; k < s_.size(); ++k) out.push_back({index_.bins()[k], s_[k], q_[k]});
  clear();
}

void PieceSums::clear() {
  index_.clear();
  s_.clear();
  q_.clear();
}

std::vector<std::uint32_t> PieceSums::order_by_bin() const {
  std::vector<std::uint32_t> order(size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return bin(a) < bin(b); });
  return order;
}

void PieceBuilder::start(std::size_t partition, const StratumKey& key, std::int64_t size) {
  Part& p = parts_[partition];
  if (p.n != 0 || !p.sums.empty()) throw std::logic_error("start() before flush()");
  p.key = key;
  p.key.partition = static_cast<std::uint32_t>(partition);
  p.size = size;
}

void PieceBuilder::flush(std::size_t partition, std::vector<StratumPiece>& out) {
  Part& p = parts_[partition];
  if (p.n == 0) {
    if (!p.sums.empty()) throw std::logic_error("contributions without history_done()");
    return;
  }
  StratumPiece& piece = out.emplace_back();
  piece.key = p.key;
  piece.st.size = p.size;
  piece.st.n = p.n;
  p.sums.move_to(piece.st.entries);
  p.n = 0;
}

void PieceBuilder::clear() {
  for (Part& p : parts_) {
    p.sums.clear();
    p.n = 0;
  }
}

}  // namespace fragsim::tally
