#include "core/run/lane_runner.h"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <iterator>
#include <new>
#include <utility>

namespace fragsim::run {

// One stack per lane, mapped once for the runner's life (a thread's), with an inaccessible page
// below it: an overflow faults instead of writing over the heap. A history needs a few tens of
// kB (Embree's traversal stack is the largest user); 1 MiB is reserved, and only touched pages
// take memory.
class LaneRunner::Stacks {
 public:
  static constexpr std::size_t kStackBytes = std::size_t{1} << 20;
  Stacks() {
    page_ = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
    for (void*& m : maps_) {
      m = mmap(nullptr, page_ + kStackBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS,
               -1, 0);
      if (m == MAP_FAILED) {
        m = nullptr;
        throw std::bad_alloc();
      }
      mprotect(m, page_, PROT_NONE);
    }
  }
  ~Stacks() {
    for (void* m : maps_)
      if (m != nullptr) munmap(m, page_ + kStackBytes);
  }
  Stacks(const Stacks&) = delete;
  Stacks& operator=(const Stacks&) = delete;
  // The top (highest address, exclusive) of lane l's stack.
  void* top(int lane) const { return static_cast<char*>(maps_[lane]) + page_ + kStackBytes; }

 private:
  std::size_t page_ = 4096;
  void* maps_[flight::kLanes] = {};
};

LaneRunner::LaneRunner() : stacks_(std::make_unique<Stacks>()) {}
LaneRunner::~LaneRunner() = default;

// Called by a history's integrator on its lane's stack: post the attempt, yield to the
// scheduler, and return once the kernel has written the stages and the error.
bool LaneRunner::attempt(const flight::FlightModel& model, int n, const double* y0,
                         const double* f0, double h, double rtol, double atol, flight::LaneOut out,
                         double& err) {
  if (current_ < 0 || !flight::lane_ready(model)) return false;
  const int me = current_;
  Lane& lane = lanes_[me];
  lane.io = {&model, y0, f0, h, out, &err, n == 6};
  lane.rtol = rtol;
  lane.atol = atol;
  lane.waiting = true;
  lane.context.suspend();
  current_ = me;
  return true;
}

// One kernel call per set of waiting lanes that share an atmosphere and tolerances (in a run:
// all of them). Idle lanes repeat the first waiting lane's inputs into scratch outputs.
void LaneRunner::compute_waiting() noexcept {
  double scratch[4][7], scratch_err;
  for (;;) {
    int first = -1;
    for (int l = 0; l < flight::kLanes && first < 0; ++l)
      if (lanes_[l].waiting) first = l;
    if (first < 0) return;
    const Lane& key = lanes_[first];
    flight::LaneIO io[flight::kLanes];
    int taken[flight::kLanes], k = 0;
    for (int l = 0; l < flight::kLanes; ++l) {
      const Lane& lane = lanes_[l];
      if (lane.waiting && lane.io.model->atmosphere == key.io.model->atmosphere &&
          lane.rtol == key.rtol && lane.atol == key.atol)
        taken[k++] = l;
    }
    for (int j = 0; j < flight::kLanes; ++j) {
      io[j] = lanes_[taken[j < k ? j : 0]].io;
      if (j >= k) {
        io[j].out = {scratch[0], scratch[1], scratch[2], scratch[3]};
        io[j].err = &scratch_err;
      }
    }
    flight::attempt_lanes(io, key.rtol, key.atol);
    ++kernel_calls_;
    lane_attempts_ += k;
    for (int j = 0; j < k; ++j) lanes_[taken[j]].waiting = false;
  }
}

void LaneRunner::finish_job(std::int64_t i) {
  finished_[i % kWindow] = true;
  while (flushed_ < n_ && finished_[flushed_ % kWindow]) {
    finished_[flushed_ % kWindow] = false;
    (*done_)(flushed_++);
  }
}

void LaneRunner::lane_entry(void* lane) noexcept {
  const Lane& l = *static_cast<const Lane*>(lane);
  l.runner->lane_body(l.index);
}

// A lane's body: jobs until none is left or the run stops. An exception (from a job or from
// `done`) ends the lane's work and is kept for run(): nothing leaves the lane's stack.
void LaneRunner::lane_body(int lane) {
  for (;;) {
    // The next job would be kWindow ahead of the oldest unreported one, which another lane is
    // still running: let the others go on first.
    while (!stop_ && next_ < n_ && next_ >= flushed_ + kWindow) {
      lanes_[lane].context.suspend();
      current_ = lane;
    }
    if (stop_ || next_ >= n_) return;
    const std::int64_t i = next_++;
    try {
      if (!(*job_)(i, lane)) stop_ = true;
      current_ = lane;
      finish_job(i);  // `done` may throw too (e.g. out of memory): never out of the lane
    } catch (...) {
      if (!error_) error_ = std::current_exception();
      stop_ = true;
      return;
    }
  }
}

void LaneRunner::run(std::int64_t n, const std::function<bool(std::int64_t, int)>& job,
                     const std::function<void(std::int64_t)>& done) {
  n_ = n;
  next_ = flushed_ = 0;
  stop_ = false;
  error_ = nullptr;
  std::fill(std::begin(finished_), std::end(finished_), false);
  job_ = &job;
  done_ = &done;
  flight::AttemptLanes* const outer = flight::thread_attempt_lanes;
  flight::thread_attempt_lanes = this;
  for (int l = 0; l < flight::kLanes; ++l) {
    Lane& lane = lanes_[l];
    lane.waiting = false;
    lane.runner = this;
    lane.index = l;
    lane.context.start(stacks_->top(l), &LaneRunner::lane_entry, &lane);
  }
  // Every lane is resumed until its body has returned: none is left suspended when run() leaves
  // (a suspended lane's stack is not unwound, lane_context.h), and nothing here throws.
  for (;;) {
    bool live = false;
    for (int l = 0; l < flight::kLanes; ++l) {
      Lane& lane = lanes_[l];
      if (!lane.context.finished() && !lane.waiting) {
        current_ = l;
        lane.context.resume();
        current_ = -1;
      }
      live = live || !lane.context.finished();
    }
    if (!live) break;
    compute_waiting();
  }
  flight::thread_attempt_lanes = outer;
  job_ = nullptr;
  done_ = nullptr;
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

}  // namespace fragsim::run
