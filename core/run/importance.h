#pragma once
// Learning the launch-direction importance densities (settings.precision.direction_importance,
// docs/precision.md "Importance sampling"). Every folded history adds, for its group and launch
// cell, what it contributed to the figures the targets look at: a hit of each building, and its
// PTN density contributions by distance from the HFD origin. At a batch boundary, each group's
// density for the next batch is
//   q_c = delta' / N + (1 - delta') * s_c / sum_c' s_c',   s_c = sqrt(a_c) spread to neighbours,
//   a_c = sum_f E[x_f^2 | c] / E[x_f]^2,
// the piecewise-constant density that minimises the sum over the figures f of their relative
// variances (q_c proportional to p_c sqrt(a_c), p_c = 1/N), mixed with the group's own density
// (defensive share delta' >= delta, larger while few histories have touched a figure) so that no
// likelihood ratio exceeds 1/delta.
#include <cstdint>
#include <utility>
#include <vector>

#include "core/fragments/direction_cells.h"
#include "core/run/history.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::run {

// What the learner takes from a sequence of histories, reduced to what it adds up: replayed in
// the histories' order (DirectionLearner::replay) it gives the learner the same bits as add()ing
// them. A shard of a divided settings.precision run hands its batch's over at the batch boundary
// (core/run/partial.h, BatchState), and every shard replays all of them in shard order: for each
// group, the order of its histories in one process.
struct LearnerInput {
  std::vector<std::uint32_t> group, cell;  // per history
  std::vector<double> likelihood_ratio;    // per history
  std::vector<std::int32_t> building;      // per history: the building hit, or -1
  std::vector<std::uint8_t> contributed;   // per history: 1 when it had PTN contributions
  std::vector<std::uint32_t> entries_end;  // per history: end of its entries in bin and x
  std::vector<std::uint16_t> bin;          // per entry: a distance bin
  std::vector<double> x;                   // per entry: its x (without the likelihood ratio)
  std::size_t size() const { return group.size(); }
  void clear();
};

class DirectionLearner {
 public:
  // `distance_m`: horizontal distance of each terrain triangle's centroid from the HFD origin.
  DirectionLearner(const Scenario& sc, const scene::Site& site, std::vector<double> distance_m);

  // One folded history of `group`: its launch cell, likelihood ratio, the building it hit (-1:
  // none) and its PTN contributions [begin, end) (values include the likelihood ratio).
  void add(std::uint32_t group, std::uint32_t cell, double likelihood_ratio, std::int32_t building,
           const PtnContribution* begin, const PtnContribution* end);
  // The same history appended to `out` instead (to be replayed, here or on another shard).
  void observe(std::uint32_t group, std::uint32_t cell, double likelihood_ratio,
               std::int32_t building, const PtnContribution* begin, const PtnContribution* end,
               LearnerInput& out);
  // add()s the histories of `in`, in order. Throws InputError for input of another shape (a
  // group, cell, building or bin out of range: a damaged exchange).
  void replay(const LearnerInput& in);

  // The densities for the next batch, per group; `hfd_m` places the ring of triangles whose
  // density decides the HFD ([kRingInner, kRingOuter] HFD, core/run/precision.h; none when 0),
  // `ring_triangles` is how many triangles share the ring's density (ring_participation in
  // core/run/precision.h): the ring's figure is the relative variance of one triangle's density, as
  // the HFD targets read it, not of the ring's total, which is about that many times smaller.
  std::vector<fragments::DirectionCells> plan(double hfd_m, double ring_triangles) const;

  // Bytes of the learning tables for `groups` groups of `cells` cells each with `buildings`
  // buildings (per cell: histories, hits per building, squared ring contributions per distance
  // bin, whether it faces each building, the neighbour list). The api layer bounds it
  // (docs/scenario.md, "Limits").
  static double table_bytes(double groups, double cells, double buildings) {
    return groups * cells * (8.0 * (1.0 + buildings + kDistanceBins) + buildings + 4.0 * 81.0);
  }

  // Uniform cells (groups with nothing learnt): the plain draw, cells reported.
  std::vector<fragments::DirectionCells> uniform() const;

  // The densities of the pilot (batch 0), from the site alone: a fragment without wind keeps
  // the azimuth of its launch velocity until its first impact, so it can reach a building
  // directly only from the cells whose site azimuths overlap the building's azimuth span as
  // seen from the launch origin. Every building a target names gets an equal share of the
  // learnt part, spread evenly over its cells (and the HFD ring, when a target needs it, a
  // share over all cells), mixed with the group's own density as in plan().
  std::vector<fragments::DirectionCells> pilot() const;

 private:
  static constexpr int kDistanceBins = 300;  // ln-spaced by 5 %: 1 m ... 2e6 m
  // One history's x per PTN contribution with its distance bin, into `entries` (in the order
  // add() sums them).
  void reduce(double likelihood_ratio, const PtnContribution* begin, const PtnContribution* end,
              std::vector<std::pair<std::uint16_t, double>>& entries);
  void apply(std::uint32_t group, std::uint32_t cell, double likelihood_ratio,
             std::int32_t building, bool contributed, const std::pair<std::uint16_t, double>* begin,
             const std::pair<std::uint16_t, double>* end);
  static int distance_bin(double d_m);
  static constexpr int kEvidence = 5;  // histories of evidence for half the learnt share
  static constexpr double kNeighbourTrust = 20.0;  // histories of a cell that halve the floor
  // Histories of prior weight on a cell's hit rate, centred on its neighbourhood's rate.
  static constexpr double kPriorHistories = 20.0;
  // A building's hits that earn its learnt hit rates half of its share; the rest stays spread
  // evenly over the cells facing it (its wedge, as in the pilot). See building_rates(); 5
  // measured better than 20 on the demo (docs/benchmarks.md §8).
  static constexpr double kBuildingEvidence = 5.0;
  // delta / N + (1 - delta) s_c / sum s (the defensive mixture), or uniform cells when s holds
  // nothing to follow.
  fragments::DirectionCells mixture(const std::vector<double>& s, double delta) const;
  // The pilot's learnt part per cell; fills `wedges` (per building and direction cell: 1 when
  // the cell faces the building, 0 else; empty for buildings no target names).
  std::vector<double> site_prior(const fragments::FragmentGroupSpec& group, const scene::Site& site,
                                 std::vector<std::vector<char>>& wedges) const;
  struct GroupStats;
  std::vector<std::vector<std::uint32_t>> neighbour_lists(bool wraps) const;
  std::vector<double> spread_to_neighbours(const std::vector<double>& s, const GroupStats& g) const;
  std::vector<double> smoothed_hit_rates(const GroupStats& g, std::size_t building) const;
  std::vector<double> ring_second_moments(const GroupStats& g, int lo, int hi) const;
  std::vector<double> shrunk_to_neighbourhood(const GroupStats& g,
                                              const std::vector<double>& own) const;
  std::vector<double> building_rates(const GroupStats& g, std::size_t building, double mean) const;
  struct GroupStats {
    std::vector<std::int64_t> n;        // per cell: histories
    std::vector<std::int64_t> hits;     // per cell x building: hits
    std::vector<double> ring_sq;        // per cell x distance bin: sum of x^2 (x without p/q)
    std::vector<double> building_mean;  // per building: sum of p/q * hit (-> E under p)
    std::vector<double> bin_mean;       // per distance bin: sum of p/q * x
    std::int64_t histories = 0;
    bool wraps = false;  // the group's azimuth range is the full circle
    std::vector<std::vector<std::uint32_t>> neighbours;  // per cell: itself and its neighbours
    std::int64_t touching = 0;  // histories that hit a used building or have PTN contributions
    std::vector<std::vector<char>> wedge;  // per building and direction cell: faces it
  };
  std::vector<std::pair<std::uint16_t, double>> entries_;  // reduce()'s output, reused
  const DirectionImportanceSettings settings_;
  int cells_;
  std::size_t buildings_;
  std::vector<char> building_used_;  // a figure of the targets (all when no building target)
  bool ring_used_;
  std::vector<double> distance_m_;
  std::vector<GroupStats> groups_;
  std::vector<std::vector<double>> prior_;  // per group and cell: the pilot's learnt part
};

}  // namespace fragsim::run
