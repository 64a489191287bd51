#pragma once
// Folds the outputs of chunks computed in parallel, strictly in chunk-index order.
//
// Workers compute chunks in any order on any thread; each calls submit(k, output). The outputs are
// consumed by `fold` in order 0, 1, 2, ... by whichever thread completes the gap, under a mutex.
// The tallies are exact sums and would not need the order (tally/exact_sum.h); the importance-
// sampling learner (its sums are doubles) and the batch boundaries of settings.precision do: a
// boundary's decision reads exactly the batches before it.
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
