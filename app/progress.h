#pragma once
// Progress of a run: a line on stderr (ProgressLine) and a JSON file for batch systems and
// fragsimd's cluster backends (ProgressFile).
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>

#include "core/run/run.h"

namespace fragsim::app {

// " batch 4: 7 of 9 targets met, ETA 35 s" (settings.precision).
std::string precision_progress(const run::PrecisionReport& r);

// Progress on stderr, rewritten in place; only when stderr is a terminal.
class ProgressLine {
 public:
  // `enabled`: a line rewritten in place (a terminal). `batch_lines`: otherwise, one line per
  // batch boundary of a settings.precision run, at most one per progress interval (logs of
  // overnight runs show the way to the targets).
  ProgressLine(bool enabled, bool batch_lines) : enabled_(enabled), batch_lines_(batch_lines) {}
  ~ProgressLine() { finish(); }
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  void update(const run::Progress& p);
  void finish();

 private:
  bool enabled_;
  bool batch_lines_;
  std::int64_t last_batch_ = 0;
  bool shown_ = false;
  std::mutex mutex_;
};

// `--progress-file FILE`: {"state", "histories_done", "histories_total", "elapsed_s"}, rewritten
// whole (temporary + rename, so a reader never sees half a file) at most every 0.5 s while
// running, and once at the end with the state "done", "failed" or "cancelled". Does nothing
// without a path. Write errors are ignored: progress must never stop a run.
class ProgressFile {
 public:
  explicit ProgressFile(std::string path) : path_(std::move(path)) {}
  void update(const run::Progress& p);
  void finish(const char* state);

 private:
  void write(const char* state);
  std::string path_;
  std::mutex mutex_;
  std::int64_t done_ = 0, total_ = 0;
  double elapsed_s_ = 0.0;
  std::chrono::steady_clock::time_point last_{};
  bool finished_ = false;
};

}  // namespace fragsim::app
