#include "app/progress.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/run/precision.h"

namespace fragsim::app {

// " batch 4: 7 of 9 targets met, ETA 35 s" (settings.precision).
std::string precision_progress(const run::PrecisionReport& r) {
  const auto met = std::count_if(r.targets.begin(), r.targets.end(),
                                 [](const run::TargetStatus& t) { return t.met; });
  std::string s = " batch " + std::to_string(r.batches) + ": " + std::to_string(met) + " of " +
                  std::to_string(r.targets.size()) + " targets met";
  if (!r.all_met) {
    char eta[64];
    if (std::isfinite(r.eta_s))
      std::snprintf(eta, sizeof eta, ", ETA %.0f s", r.eta_s);
    else
      std::snprintf(eta, sizeof eta, ", ETA unknown");
    s += eta;
  }
  return s;
}

void ProgressLine::update(const run::Progress& p) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!enabled_) {
    if (batch_lines_ && p.precision && p.precision->batches != last_batch_) {
      last_batch_ = p.precision->batches;
      std::fprintf(stderr, "%lld histories, %.1f s:%s\n",
                   static_cast<long long>(p.precision->histories), p.elapsed_s,
                   precision_progress(*p.precision).c_str());
    }
    return;
  }
  const double pct = p.histories_total > 0 ? 100.0 * static_cast<double>(p.histories_done) /
                                                 static_cast<double>(p.histories_total)
                                           : 0.0;
  std::fprintf(stderr, "\r%5.1f%%  %lld / %lld histories  %.1f s ", pct,
               static_cast<long long>(p.histories_done), static_cast<long long>(p.histories_total),
               p.elapsed_s);
  if (p.precision) std::fputs((precision_progress(*p.precision) + "      ").c_str(), stderr);
  std::fflush(stderr);
  shown_ = true;
}

void ProgressLine::finish() {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (shown_) std::fputc('\n', stderr);
  shown_ = false;
}

void ProgressFile::update(const run::Progress& p) {
  if (path_.empty()) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  done_ = p.histories_done;
  total_ = p.histories_total;
  elapsed_s_ = p.elapsed_s;
  const auto now = std::chrono::steady_clock::now();
  if (finished_ || now - last_ < std::chrono::milliseconds(500)) return;
  last_ = now;
  write("running");
}

void ProgressFile::finish(const char* state) {
  if (path_.empty()) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) return;
  finished_ = true;
  write(state);
}

void ProgressFile::write(const char* state) {
  char text[256];
  std::snprintf(text, sizeof text,
                "{\"state\":\"%s\",\"histories_done\":%lld,\"histories_total\":%lld,"
                "\"elapsed_s\":%.3f}\n",
                state, static_cast<long long>(done_), static_cast<long long>(total_), elapsed_s_);
  const std::string tmp = path_ + ".tmp";
  {
    std::ofstream f(tmp, std::ios::trunc);
    f << text;
    if (!f) return;
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path_, ec);
}

}  // namespace fragsim::app
