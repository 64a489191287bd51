// The stack switch of core/run/lane_context.h for x86-64 System V (ELF).
#include "core/run/lane_context.h"

#include <cstdint>
#include <cstdlib>

#if FRAGSIM_LANE_CONTEXT

extern "C" {
// Saves rbp, rbx, r12-r15 and the return address on the current stack, stores the stack pointer
// in *save_sp, then loads load_sp and restores the same registers from the stack it points at
// and jumps to its return address. A stack that was never switched from is laid out by
// LaneContext::start() so that this lands in fragsim_lane_entry with r12 = the context and
// r13 = LaneContext::entry.
void fragsim_switch_stack(void** save_sp, void* load_sp);
// A new lane's first frame: calls r13(r12); never returns (the entry switches away for good).
// Its CFI marks the return address undefined, so a backtrace ends there.
void fragsim_lane_entry();
}

// The return address is popped and jumped to, as Boost.Context does; a `ret` would do the same
// (either way the CPU's return-stack buffer holds the other stack's calls and misses once).
asm(R"(
        .text
        .globl  fragsim_switch_stack
        .type   fragsim_switch_stack, @function
        .p2align 4
fragsim_switch_stack:
        .cfi_startproc
        pushq   %rbp
        pushq   %rbx
        pushq   %r12
        pushq   %r13
        pushq   %r14
        pushq   %r15
        movq    %rsp, (%rdi)
        movq    %rsi, %rsp
        popq    %r15
        popq    %r14
        popq    %r13
        popq    %r12
        popq    %rbx
        popq    %rbp
        popq    %rcx
        jmpq    *%rcx
        .cfi_endproc
        .size   fragsim_switch_stack, .-fragsim_switch_stack

        .globl  fragsim_lane_entry
        .type   fragsim_lane_entry, @function
        .p2align 4
fragsim_lane_entry:
        .cfi_startproc
        .cfi_undefined rip
        movq    %r12, %rdi
        callq   *%r13
        ud2
        .cfi_endproc
        .size   fragsim_lane_entry, .-fragsim_lane_entry
)");

namespace fragsim::run {

void LaneContext::start(void* stack_top, Body body, void* arg) {
  if (!finished_) std::abort();  // a running lane's stack would be reused under it
  body_ = body;
  arg_ = arg;
  finished_ = false;
  // The frame fragsim_switch_stack pops: r15, r14, r13, r12, rbx, rbp, return address. After
  // those seven pops rsp must be 16-byte aligned (the entry's `call` then leaves the callee at
  // 8 mod 16, as the ABI has it): top - 72 + 56 = top - 16.
  const auto top = reinterpret_cast<std::uintptr_t>(stack_top) & ~std::uintptr_t{15};
  void** frame = reinterpret_cast<void**>(top - 72);
  frame[0] = nullptr;                                       // r15
  frame[1] = nullptr;                                       // r14
  frame[2] = reinterpret_cast<void*>(&LaneContext::entry);  // r13
  frame[3] = this;                                          // r12
  frame[4] = nullptr;                                       // rbx
  frame[5] = nullptr;                                       // rbp: ends frame-pointer walks
  frame[6] = reinterpret_cast<void*>(&fragsim_lane_entry);  // return address
  lane_sp_ = frame;
}

void LaneContext::resume() {
  fragsim_switch_stack(&sched_sp_, lane_sp_);
}

void LaneContext::suspend() {
  fragsim_switch_stack(&lane_sp_, sched_sp_);
}

void LaneContext::entry(void* self) noexcept {
  auto* c = static_cast<LaneContext*>(self);
  c->body_(c->arg_);
  c->finished_ = true;
  fragsim_switch_stack(&c->lane_sp_, c->sched_sp_);
  std::abort();  // a finished lane is never resumed
}

}  // namespace fragsim::run

#else

namespace fragsim::run {

// Not built on this target (kLaneContextBuilt is false): histories run one at a time and nothing
// calls these.
void LaneContext::start(void*, Body, void*) {
  std::abort();
}
void LaneContext::resume() {
  std::abort();
}
void LaneContext::suspend() {
  std::abort();
}
void LaneContext::entry(void*) noexcept {
  std::abort();
}

}  // namespace fragsim::run

#endif
