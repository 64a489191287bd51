#pragma once
// Jobs' threads run at a lower priority than the daemon's (--job-nice), so that requests are
// answered promptly while a job keeps the cores busy.
namespace fragsim::server {

// Lowers the calling thread's priority to `nice` (nothing when nice <= 0; a failure is logged).
// Linux keeps a nice value per thread, and a new thread (or process) starts with its creator's.
void lower_thread_priority(int nice);

}  // namespace fragsim::server
