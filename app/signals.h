#pragma once
// SIGINT/SIGTERM as a cancel request (fragsim and fragsim-mpi): the first signal sets the flag
// (a run then returns a partial result, which is discarded, and the output directory is cleaned
// up); the second takes the default action, i.e. terminates at once.
#include <atomic>

namespace fragsim::app {

std::atomic<bool>& cancel_flag();
void install_cancel_handlers();

}  // namespace fragsim::app
