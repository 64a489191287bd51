#pragma once
// A generic ordered parallel pipeline: items 0, 1, ..., total - 1 are produced by worker threads
// in any order and folded strictly in index order, one at a time, by whichever thread completes
// the gap (core/run/ordered_sequencer.h). It knows nothing of histories or tallies: the run's
// domain fold (core/run/shard_runner.h) gives it `produce` and `fold`.
//
//   worker:  k = next index -> produce(k, scratch, item) -> submit(k, item) -> submitted(k)
//   fold:    fold(item k) in order k = 0, 1, 2, ... (may call finish() to end the run there)
//
// The first exception a worker throws stops the others (`on_error` wakes any that wait on the
// domain's side) and is rethrown by run().
#include <atomic>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "core/run/ordered_sequencer.h"

namespace fragsim::run {

template <class Item, class Scratch>
class OrderedPipeline {
 public:
  struct Stages {
    // On a worker: item k into `out`. False: this worker stops (the domain called stop()).
    std::function<bool(std::int64_t k, Scratch& scratch, Item& out)> produce;
    // Under the fold's lock, in index order.
    std::function<void(Item& item)> fold;
    // On the worker, after item k was handed to the fold (e.g. to count and report progress).
    std::function<void(std::int64_t k)> submitted;
    // Once, when a worker throws: wakes workers that wait on the domain's side.
    std::function<void()> on_error;
  };

  OrderedPipeline(std::int64_t total, int threads, Stages stages)
      : total_(total), threads_(threads), stages_(std::move(stages)) {}

  // Runs `threads` workers (this thread one of them) until every item is folded, finish() or
  // stop() is called, or a worker throws (rethrown here).
  void run() {
    std::vector<std::thread> pool;
    for (int i = 1; i < threads_; ++i) pool.emplace_back([this] { work_guarded(); });
    work_guarded();
    for (auto& th : pool) th.join();
    if (error_) std::rethrow_exception(error_);
  }

  // From the fold: the items after this one are not needed (they are dropped unfolded).
  void finish() { finished_.store(true); }
  // From anywhere: the workers stop after their current item.
  void stop() { stopped_.store(true); }
  bool finished() const { return finished_.load(); }
  bool stopped() const { return stopped_.load(); }
  int threads() const { return threads_; }

 private:
  struct Fold {
    OrderedPipeline* pipeline;
    void operator()(Item& item) const {
      if (!pipeline->finished_.load(std::memory_order_relaxed)) pipeline->stages_.fold(item);
    }
  };

  void work_guarded() {
    try {
      work();
    } catch (...) {
      {
        const std::lock_guard<std::mutex> lock(error_mutex_);
        if (!error_) error_ = std::current_exception();
      }
      stopped_.store(true);
      if (stages_.on_error) stages_.on_error();
    }
  }

  void work() {
    Scratch scratch;
    while (!stopped_.load(std::memory_order_relaxed) &&
           !finished_.load(std::memory_order_relaxed)) {
      const std::int64_t k = next_.fetch_add(1);
      if (k >= total_) break;
      Item item;
      if (!stages_.produce(k, scratch, item)) return;
      sequencer_.submit(k, std::move(item));
      if (stages_.submitted) stages_.submitted(k);
    }
  }

  const std::int64_t total_;
  const int threads_;
  const Stages stages_;
  OrderedSequencer<Item, Fold> sequencer_{Fold{this}};
  std::atomic<bool> finished_{false};
  std::atomic<bool> stopped_{false};
  std::atomic<std::int64_t> next_{0};
  std::mutex error_mutex_;
  std::exception_ptr error_;
};

}  // namespace fragsim::run
