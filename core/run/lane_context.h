#pragma once
// A lane's execution context (core/run/lane_runner.h): a stack of its own and a switch between it
// and the scheduler's, written for x86-64 System V (Linux) in lane_context.cpp.
//
// Why not a fiber library: Boost.Context, used before (issue 27, stop 49), saves and reloads the
// SSE and x87 control words (MXCSR, FPU control word) at every switch. Reloading them stalls the
// pipeline until the work before it retires: 7.3 % of a one-thread run of the demo without bounce
// went to its switch, 1.3 % once the reloads were left out (docs/benchmarks.md, stop 49). A lane
// shares its thread's floating-point environment with the scheduler (fragsim never changes the
// rounding mode or the exception masks), so this switch keeps only what the ABI asks a call to
// keep: rsp and the callee-saved rbx, rbp, r12-r15.
//
// Limits, by design:
// * a lane's body must not let an exception out (it is noexcept: std::terminate);
// * a lane that is suspended when its owner goes away is not unwound: the objects on its stack
//   are not destroyed. The lane runner resumes every lane until its body has returned before it
//   leaves run(), and nothing in its scheduling loop throws;
// * on other targets kLaneContextBuilt is false and histories run one at a time (the path the
//   sanitizer builds take too, bit for bit the same results). So also with Intel CET
//   (-fcf-protection defines __CET__): a shadow stack would refuse the switch's returns into the
//   other stack, and indirect-branch tracking its jumps to return addresses.

#if defined(__x86_64__) && defined(__ELF__) && !defined(__CET__)
#define FRAGSIM_LANE_CONTEXT 1
#else
#define FRAGSIM_LANE_CONTEXT 0
#endif

namespace fragsim::run {

inline constexpr bool kLaneContextBuilt = FRAGSIM_LANE_CONTEXT != 0;

class LaneContext {
 public:
  using Body = void (*)(void* arg) noexcept;

  // Prepare the lane to run body(arg) on the stack that ends at stack_top (exclusive; the
  // caller keeps the memory below it, at least a few pages, for as long as the lane runs). The
  // body starts at the first resume(). Only when finished() (a new context, or its body returned).
  void start(void* stack_top, Body body, void* arg);
  // Scheduler: run the lane until it calls suspend() or its body returns.
  void resume();
  // Lane (inside body): return to the scheduler's resume(); continue at the next resume().
  void suspend();
  bool finished() const { return finished_; }

 private:
  static void entry(void* self) noexcept;

  void* lane_sp_ = nullptr;   // the lane's stack pointer while it is suspended
  void* sched_sp_ = nullptr;  // the scheduler's while the lane runs
  Body body_ = nullptr;
  void* arg_ = nullptr;
  bool finished_ = true;
};

}  // namespace fragsim::run
