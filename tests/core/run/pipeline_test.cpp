#include "core/run/pipeline.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <thread>
#include <vector>

namespace fragsim::run {
namespace {

struct Scratch {
  int uses = 0;  // one per worker: counts the items it produced
};

using Pipeline = OrderedPipeline<std::int64_t, Scratch>;

// Items produced out of order (later indices first, by sleeping less) are folded 0, 1, 2, ...
// whatever the thread count, each once; every item is counted as submitted.
TEST(OrderedPipeline, FoldsEveryItemOnceInIndexOrderWhateverTheThreads) {
  for (const int threads : {1, 2, 4, 7}) {
    SCOPED_TRACE(threads);
    constexpr std::int64_t kTotal = 200;
    std::vector<std::int64_t> folded;
    std::atomic<std::int64_t> submitted{0};
    Pipeline::Stages s;
    s.produce = [](std::int64_t k, Scratch& scratch, std::int64_t& out) {
      ++scratch.uses;
      std::this_thread::sleep_for(std::chrono::microseconds((kTotal - k) % 7 * 20));
      out = k * k;
      return true;
    };
    s.fold = [&](std::int64_t& item) { folded.push_back(item); };
    s.submitted = [&](std::int64_t) { ++submitted; };
    Pipeline p(kTotal, threads, s);
    p.run();
    ASSERT_EQ(folded.size(), static_cast<std::size_t>(kTotal));
    for (std::int64_t k = 0; k < kTotal; ++k) EXPECT_EQ(folded[k], k * k) << k;
    EXPECT_EQ(submitted.load(), kTotal);
    EXPECT_FALSE(p.finished());
    EXPECT_FALSE(p.stopped());
  }
}

// finish() from the fold ends the run there: no later item is folded, even one already made.
TEST(OrderedPipeline, FinishFromTheFoldDropsEveryLaterItem) {
  for (const int threads : {1, 3}) {
    std::vector<std::int64_t> folded;
    Pipeline* self = nullptr;
    Pipeline::Stages s;
    s.produce = [](std::int64_t k, Scratch&, std::int64_t& out) {
      out = k;
      return true;
    };
    s.fold = [&](std::int64_t& item) {
      folded.push_back(item);
      if (item == 41) self->finish();
    };
    Pipeline p(1000, threads, s);
    self = &p;
    p.run();
    ASSERT_EQ(folded.size(), 42u) << threads;
    EXPECT_EQ(folded.back(), 41);
    EXPECT_TRUE(p.finished());
  }
}

// A worker's exception stops the others, calls on_error once and comes out of run(); the items
// folded before it form a prefix.
TEST(OrderedPipeline, AWorkersExceptionStopsTheRunAndIsRethrown) {
  std::vector<std::int64_t> folded;
  std::atomic<int> errors{0};
  Pipeline::Stages s;
  s.produce = [](std::int64_t k, Scratch&, std::int64_t& out) {
    if (k == 17) throw std::runtime_error("item 17 failed");
    out = k;
    return true;
  };
  s.fold = [&](std::int64_t& item) { folded.push_back(item); };
  s.on_error = [&] { ++errors; };
  Pipeline p(100000, 2, s);
  try {
    p.run();
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "item 17 failed");
  }
  EXPECT_EQ(errors.load(), 1);
  EXPECT_TRUE(p.stopped());
  ASSERT_LE(folded.size(), 17u);
  for (std::size_t k = 0; k < folded.size(); ++k)
    EXPECT_EQ(folded[k], static_cast<std::int64_t>(k));
}

// produce() answering false (the domain stopped the run) ends that worker; stop() ends the others.
TEST(OrderedPipeline, AProduceThatStopsEndsTheRunWithAFoldedPrefix) {
  std::vector<std::int64_t> folded;
  Pipeline* self = nullptr;
  Pipeline::Stages s;
  s.produce = [&](std::int64_t k, Scratch&, std::int64_t& out) {
    if (k >= 50) {
      self->stop();
      return false;
    }
    out = k;
    return true;
  };
  s.fold = [&](std::int64_t& item) { folded.push_back(item); };
  Pipeline p(1000, 4, s);
  self = &p;
  p.run();
  EXPECT_TRUE(p.stopped());
  ASSERT_EQ(folded.size(), 50u);
  for (std::size_t k = 0; k < folded.size(); ++k)
    EXPECT_EQ(folded[k], static_cast<std::int64_t>(k));
}

}  // namespace
}  // namespace fragsim::run
