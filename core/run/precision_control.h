#pragma once
// The stop decision of a settings.precision run: at each batch boundary (under the fold's lock)
// the estimates of the batches so far are checked against the targets (core/run/precision.h)
// and the run stops there or goes on (docs/precision.md, "Targets and the stop").
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "core/run/hfd.h"
#include "core/run/partial.h"
#include "core/run/precision.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::run {

class PrecisionControl {
 public:
  // `tallies`: the tally and counts the decisions read (a divided run's: every shard's).
  PrecisionControl(const Scenario& sc, const scene::Site& site, const PartialRun& tallies);

  // After batch `batches` (1-based) has been folded, `tallied` of them into the estimates (all
  // but an importance-sampling pilot): true when the run stops here.
  // `elapsed`: seconds since the run's start (of divided shards: the longest's).
  bool batch_done(std::int64_t batches, std::int64_t tallied, std::int64_t histories_run,
                  double elapsed);

  std::shared_ptr<const PrecisionReport> report() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return report_;
  }
  StopReason reason() const { return reason_; }
  double hfd_m() const { return hfd_m_; }  // at the last boundary (0 unless computed)
  // ring_participation at the last boundary (1 unless computed)
  double ring_triangles() const { return ring_triangles_; }
  // Under direction importance sampling with the HFD ring among the learnt figures: the pilot's
  // terrain density is folded (Reducer::fold_pilot) and read at its boundary for the first ring.
  bool wants_pilot_density() const;
  const std::vector<double>& distances() const {
    static const std::vector<double> none;
    return geometry_ ? geometry_->distances() : none;
  }

 private:
  PrecisionSnapshot snapshot(std::int64_t batches) const;
  void hfd_snapshot(double scale, PrecisionSnapshot& s) const;
  void pilot_ring();

  const Scenario& sc_;
  const scene::Site& site_;
  const PartialRun& tallies_;
  const TallyBins bins_;
  const PrecisionSettings* p_ = nullptr;
  std::optional<HfdGeometry> geometry_;
  PrecisionTracker tracker_;
  StopReason reason_ = StopReason::kSamples;
  double hfd_m_ = 0.0;
  double ring_triangles_ = 1.0;
  mutable std::mutex mutex_;
  std::shared_ptr<const PrecisionReport> report_;
};

}  // namespace fragsim::run
