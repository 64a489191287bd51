#pragma once
// Folds the outputs of chunks computed in parallel, strictly in chunk-index order.
//
// Workers compute chunks in any order on any thread; each calls submit(k, output). The outputs are
// consumed by `fold` in order 0, 1, 2, ... by whichever thread completes the gap, under a mutex.
// Since every floating-point accumulation then happens in (group, history) order, results are
// bit-identical for any number of threads. Chunk boundaries do not matter either as long as the
// fold treats each history separately (it does: chunk outputs are lists of per-history records).
#include <cstdint>
#include <map>
#include <mutex>

namespace fragsim::run {

template <class T, class Fold>
class OrderedSequencer {
 public:
  explicit OrderedSequencer(Fold fold) : fold_(std::move(fold)) {}

  void submit(std::int64_t index, T&& output) {
    std::lock_guard<std::mutex> lock(mu_);
    pending_.emplace(index, std::move(output));
    for (auto it = pending_.begin(); it != pending_.end() && it->first == next_;
         it = pending_.begin()) {
      fold_(it->second);
      pending_.erase(it);
      ++next_;
    }
  }

  std::int64_t folded() const {
    std::lock_guard<std::mutex> lock(mu_);
    return next_;
  }
  std::size_t pending() const {
    std::lock_guard<std::mutex> lock(mu_);
    return pending_.size();
  }

 private:
  Fold fold_;
  mutable std::mutex mu_;
  std::map<std::int64_t, T> pending_;
  std::int64_t next_ = 0;
};

}  // namespace fragsim::run
