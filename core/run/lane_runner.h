#pragma once
// Histories in lanes (docs/architecture.md, "Histories in lanes"): a worker thread runs up to
// flight::kLanes histories at once, each on its own stack (LaneContext). A history runs as it
// would alone until its flight integrator needs a step attempt; the integrator posts it here
// (flight::thread_attempt_lanes) and the lane yields. When every live lane waits, one call of
// the lane kernel (core/flight/lanes.h) computes all their attempts, in path length or in time,
// kLanes at a time, and the lanes resume. Each lane's arithmetic is the scalar attempt's, bit for
// bit, so a history's results do not depend on which histories shared its lanes; the caller gets
// each history's end in history order (`done`), so a chunk's output is the same as one history
// at a time. Attempts that a lane cannot take (a flight without drag, a truncated step, the
// ground phase's integrator) are computed by the history itself, as before.
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>

#include "core/flight/lanes.h"
#include "core/run/lane_context.h"

namespace fragsim::run {

// Sanitizer builds run one history at a time: ASan and TSan do not follow the lanes' stack
// switches (docs/testing.md); so do targets without a LaneContext. Release builds check the lanes
// against that path bit for bit.
#if !FRAGSIM_LANE_CONTEXT
inline constexpr bool kHistoryLanesBuilt = false;
#elif defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kHistoryLanesBuilt = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
inline constexpr bool kHistoryLanesBuilt = false;
#else
inline constexpr bool kHistoryLanesBuilt = true;
#endif
#else
inline constexpr bool kHistoryLanesBuilt = true;
#endif

class LaneRunner final : public flight::AttemptLanes {
 public:
  LaneRunner();
  ~LaneRunner();
  LaneRunner(const LaneRunner&) = delete;
  LaneRunner& operator=(const LaneRunner&) = delete;

  // Jobs start at most this far ahead of the oldest unfinished one: a caller's per-job slots can
  // be a ring of kWindow (slot i % kWindow), whatever n is.
  static constexpr std::int64_t kWindow = 64;

  // job(i, lane) for i = 0, 1, ... n - 1, up to kLanes at once (lane in [0, kLanes): the lane's
  // own scratch), job i never before job i - kWindow has been reported; a job returning false
  // stops the taking of new ones. done(i) for every finished job in increasing i, each once
  // job(i) and every earlier job have finished. An exception thrown by a job stops the taking of
  // new jobs and is rethrown here when the others end.
  void run(std::int64_t n, const std::function<bool(std::int64_t, int)>& job,
           const std::function<void(std::int64_t)>& done);

  bool attempt(const flight::FlightModel& model, int n, const double* y0, const double* f0,
               double h, double rtol, double atol, flight::LaneOut out, double& err) override;

  // Diagnostics (lifetime): kernel calls, and lanes that carried an attempt in them.
  long kernel_calls() const { return kernel_calls_; }
  long lane_attempts() const { return lane_attempts_; }

 private:
  struct Lane {
    LaneContext context;
    LaneRunner* runner = nullptr;
    int index = 0;
    bool waiting = false;  // an attempt posted, not yet computed
    flight::LaneIO io{};
    double rtol = 0.0, atol = 0.0;
  };
  class Stacks;  // the lanes' stacks, mapped once with a guard page each
  static void lane_entry(void* lane) noexcept;
  void lane_body(int lane);
  void compute_waiting() noexcept;
  void finish_job(std::int64_t i);

  std::unique_ptr<Stacks> stacks_;
  Lane lanes_[flight::kLanes];
  int current_ = -1;  // the lane running, -1 in the scheduler
  // The run in progress.
  std::int64_t n_ = 0, next_ = 0, flushed_ = 0;
  bool stop_ = false;
  bool finished_[kWindow] = {};  // job i's end, at i % kWindow, until it is reported
  const std::function<bool(std::int64_t, int)>* job_ = nullptr;
  const std::function<void(std::int64_t)>* done_ = nullptr;
  std::exception_ptr error_;
  long kernel_calls_ = 0, lane_attempts_ = 0;
};

}  // namespace fragsim::run
