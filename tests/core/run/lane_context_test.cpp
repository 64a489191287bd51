// The lanes' stack switch (core/run/lane_context.h): a body runs across suspends and ends
// finished; every value the compiler keeps in a callee-saved register across a switch survives
// it, on both sides; the body's stack is aligned as the ABI requires; exceptions are thrown and
// caught inside a body; a context is reused after its body returns; two lanes interleave.
#include "core/run/lane_context.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/run/lane_runner.h"

namespace fragsim::run {
namespace {

// Sanitizer builds do not follow the switch (lane_runner.h); other targets do not build it.
bool skip() {
  return !kHistoryLanesBuilt || !kLaneContextBuilt;
}

// A lane's stack for the tests: 256 KiB of heap (no guard page; the bodies here are small).
struct TestStack {
  std::vector<char> bytes = std::vector<char>(std::size_t{1} << 18);
  void* top() { return bytes.data() + bytes.size(); }
};

struct Trace {
  LaneContext* context = nullptr;
  std::vector<int>* events = nullptr;
  int id = 0;
  int suspends = 0;
};

void traced_body(void* arg) noexcept {
  auto& t = *static_cast<Trace*>(arg);
  for (int k = 0; k < t.suspends; ++k) {
    t.events->push_back(100 * t.id + k);
    t.context->suspend();
  }
  t.events->push_back(100 * t.id + 99);
}

TEST(LaneContext, RunsABodyAcrossSuspendsAndEndsFinished) {
  if (skip()) GTEST_SKIP() << "histories run one at a time in this build";
  TestStack stack;
  LaneContext c;
  EXPECT_TRUE(c.finished());
  std::vector<int> events;
  Trace t{&c, &events, 1, 3};
  c.start(stack.top(), &traced_body, &t);
  EXPECT_FALSE(c.finished());
  int resumes = 0;
  while (!c.finished()) {
    events.push_back(-resumes);
    c.resume();
    ++resumes;
  }
  EXPECT_EQ(resumes, 4);
  EXPECT_EQ(events, (std::vector<int>{0, 100, -1, 101, -2, 102, -3, 199}));
}

TEST(LaneContext, TwoLanesInterleaveAndAContextIsReusedAfterItsBodyReturns) {
  if (skip()) GTEST_SKIP() << "histories run one at a time in this build";
  TestStack sa, sb;
  LaneContext a, b;
  for (int round = 0; round < 3; ++round) {  // the same contexts and stacks each round
    std::vector<int> events;
    Trace ta{&a, &events, 1, 2}, tb{&b, &events, 2, 4};
    a.start(sa.top(), &traced_body, &ta);
    b.start(sb.top(), &traced_body, &tb);
    while (!a.finished() || !b.finished()) {
      if (!a.finished()) a.resume();
      if (!b.finished()) b.resume();
    }
    EXPECT_EQ(events, (std::vector<int>{100, 200, 101, 201, 199, 202, 203, 299})) << round;
  }
}

// Six integers live across every switch, on both sides: more than the caller-saved registers
// the compiler could keep them in without spilling, so callee-saved ones carry them (a swapped
// or lost register in the switch changes the sums).
struct Mixer {
  LaneContext* context = nullptr;
  int rounds = 0;
  std::uint64_t out = 0;
};

std::uint64_t mix_rounds(int rounds, LaneContext* context, bool in_lane) {
  std::uint64_t a = 1, b = 2, c = 3, d = 5, e = 7, f = 11;
  for (int k = 0; k < rounds; ++k) {
    a = a * 6364136223846793005ULL + b;
    b ^= c << 7;
    c += d * 3;
    d = (d >> 3) ^ e;
    e += f ^ a;
    f = f * 31 + static_cast<std::uint64_t>(k);
    if (context != nullptr) {
      if (in_lane)
        context->suspend();
      else
        context->resume();
    }
  }
  return a ^ (b * 3) ^ (c * 5) ^ (d * 7) ^ (e * 11) ^ (f * 13);
}

void mixer_body(void* arg) noexcept {
  auto& m = *static_cast<Mixer*>(arg);
  m.out = mix_rounds(m.rounds, m.context, true);
}

TEST(LaneContext, KeepsEveryCalleeSavedValueOnBothSides) {
  if (skip()) GTEST_SKIP() << "histories run one at a time in this build";
  constexpr int kRounds = 1000;
  const std::uint64_t expected = mix_rounds(kRounds, nullptr, false);
  TestStack stack;
  LaneContext c;
  Mixer m{&c, kRounds, 0};
  c.start(stack.top(), &mixer_body, &m);
  // The scheduler's own mix resumes the lane once per round (the first resume starts it): the
  // lane then waits at its last suspend, and one more resume lets its body return.
  const std::uint64_t scheduler = mix_rounds(kRounds, &c, false);
  EXPECT_FALSE(c.finished());
  c.resume();
  EXPECT_TRUE(c.finished());
  EXPECT_EQ(m.out, expected);
  EXPECT_EQ(scheduler, expected);
}

// The frame address of a function that is not inlined: 16-byte aligned when the stack it runs
// on was 16-byte aligned at its call, as the System V ABI requires.
[[gnu::noinline]] std::uintptr_t frame_address() {
  return reinterpret_cast<std::uintptr_t>(__builtin_frame_address(0));
}

struct Alignment {
  std::uintptr_t frame = 0;
  std::string printed;
};

void alignment_body(void* arg) noexcept {
  auto& a = *static_cast<Alignment*>(arg);
  a.frame = frame_address();
  // glibc's printf of a double stores vector registers with aligned moves: a misaligned stack
  // faults here.
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f %.1e", 3.14159, 2.5e-7);
  a.printed = buf;
}

TEST(LaneContext, GivesTheBodyAnAlignedStack) {
  if (skip()) GTEST_SKIP() << "histories run one at a time in this build";
  for (const std::size_t offset : {0, 1, 8, 15}) {  // any stack top: start() aligns it
    TestStack stack;
    LaneContext c;
    Alignment a;
    c.start(static_cast<char*>(stack.top()) - offset, &alignment_body, &a);
    c.resume();
    ASSERT_TRUE(c.finished());
    EXPECT_EQ(a.frame % 16, 0u) << offset;
    EXPECT_EQ(a.printed, "3.142 2.5e-07");
  }
}

[[gnu::noinline]] int throws_below(int depth) {
  if (depth == 0) throw std::runtime_error("deep");
  return throws_below(depth - 1) + 1;
}

struct Catcher {
  LaneContext* context = nullptr;
  std::vector<std::string> caught;
};

void catching_body(void* arg) noexcept {
  auto& c = *static_cast<Catcher*>(arg);
  for (int k = 0; k < 3; ++k) {
    try {
      throws_below(5 + k);
    } catch (const std::runtime_error& e) {
      c.caught.push_back(e.what());
    }
    c.context->suspend();
  }
}

TEST(LaneContext, LetsAnExceptionBeThrownAndCaughtInsideTheBody) {
  if (skip()) GTEST_SKIP() << "histories run one at a time in this build";
  TestStack stack;
  LaneContext c;
  Catcher k{&c, {}};
  c.start(stack.top(), &catching_body, &k);
  int resumes = 0;
  while (!c.finished()) {
    c.resume();
    ++resumes;
    // The scheduler throws and catches on its own stack between resumes as well.
    EXPECT_THROW(throws_below(3), std::runtime_error);
  }
  EXPECT_EQ(resumes, 4);
  EXPECT_EQ(k.caught, (std::vector<std::string>{"deep", "deep", "deep"}));
}

}  // namespace
}  // namespace fragsim::run
