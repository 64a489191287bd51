// StratifiedTally (core/tally/stratified_tally.h): per-bin means and standard errors from exact
// per-stratum sums. The expected figures are the header's formulas applied to every bin, with
// each stratum's S and Q taken from the reference exact sum (reference_sum.h), each stratum's
// variance term computed once from them, and the terms summed exactly: so the checks are bit for
// bit, whatever the split of the strata into pieces and the order of the merges.
#include "core/tally/stratified_tally.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "reference_sum.h"

namespace fragsim::tally {
namespace {

using testing::ReferenceSum;

std::uint64_t bits(double x) {
  return std::bit_cast<std::uint64_t>(x);
}

struct Contribution {
  std::size_t bin;
  double x;
};
using History = std::vector<Contribution>;  // a history's whole contribution per bin (distinct)
using Stratum = std::vector<std::size_t>;   // ids of histories

struct Figures {
  std::vector<double> mean, se;
};

// The header's formulas over every bin: strata[k] are partition k's strata (n_j = the histories
// listed); the mean is the sum over partition 0's, the standard error the larger partition's.
Figures formulas(const std::vector<History>& hist, const std::vector<std::vector<Stratum>>& strata,
                 std::size_t bins) {
  std::vector<ReferenceSum> mean(bins);
  std::vector<double> var(bins, 0.0);
  for (std::size_t k = 0; k < strata.size(); ++k) {
    std::vector<ReferenceSum> v(bins);
    for (const Stratum& st : strata[k]) {
      std::vector<ReferenceSum> s(bins), q(bins);
      for (const std::size_t id : st)
        for (const Contribution& c : hist[id]) {
          s[c.bin].add(c.x);
          q[c.bin].add(c.x * c.x);
          if (k == 0) mean[c.bin].add(c.x);
        }
      if (st.size() <= 1) continue;
      const double dn = static_cast<double>(st.size());
      for (std::size_t b = 0; b < bins; ++b) {
        const double sv = s[b].rounded(), qv = q[b].rounded();
        v[b].add(std::max(0.0, dn / (dn - 1.0) * (qv - sv * sv / dn)));
      }
    }
    for (std::size_t b = 0; b < bins; ++b) var[b] = std::max(var[b], v[b].rounded());
  }
  Figures f{std::vector<double>(bins), std::vector<double>(bins)};
  for (std::size_t b = 0; b < bins; ++b) {
    f.mean[b] = mean[b].rounded();
    f.se[b] = std::sqrt(var[b]);
  }
  return f;
}

Figures figures(const StratifiedTally& t) {
  Figures f;
  for (std::size_t b = 0; b < t.size(); ++b) {
    f.mean.push_back(t.mean(b));
    f.se.push_back(t.std_error(b));
  }
  return f;
}

void expect_same_bits(const Figures& got, const Figures& want, const char* what) {
  ASSERT_EQ(got.mean.size(), want.mean.size()) << what;
  for (std::size_t b = 0; b < want.mean.size(); ++b) {
    EXPECT_EQ(bits(got.mean[b]), bits(want.mean[b])) << what << ": mean of bin " << b;
    EXPECT_EQ(bits(got.se[b]), bits(want.se[b])) << what << ": standard error of bin " << b;
  }
}

// --- the old StratifiedEstimator's tests -----------------------------------------------------

TEST(StratifiedTally, ManySmallStrataGiveTheFormulasOverEveryBin) {
  constexpr std::size_t kBins = 50;
  std::mt19937_64 gen(7);
  std::uniform_int_distribution<std::size_t> bin(0, kBins - 1);
  std::uniform_real_distribution<double> value(-1.0, 3.0);
  StratifiedTally t(kBins);
  std::vector<History> hist;
  std::vector<Stratum> strata;
  for (int stratum = 0; stratum < 300; ++stratum) {
    const int n = 2 + stratum % 4;
    t.start(0, StratumKey{0, 0, 0, stratum}, n);
    strata.emplace_back();
    for (int h = 0; h < n; ++h) {
      // Each history touches a few distinct bins once (its whole contribution), some with 0.
      History c;
      const std::size_t b0 = bin(gen);
      for (std::size_t k = 0; k < 3; ++k) {
        const std::size_t b = (b0 + k * 17) % kBins;
        const double x = (stratum + h + static_cast<int>(k)) % 5 == 0 ? 0.0 : value(gen);
        t.add(b, x);
        c.push_back({b, x});
      }
      t.history_done();
      strata.back().push_back(hist.size());
      hist.push_back(c);
    }
    t.flush(0);
  }
  EXPECT_TRUE(t.open_strata().empty());
  const Figures want = formulas(hist, {strata}, kBins);
  expect_same_bits(figures(t), want, "one piece per stratum");
  // As the old test had it, against plain double sums over every bin.
  std::vector<double> mean(kBins, 0.0), var(kBins, 0.0);
  for (const Stratum& st : strata) {
    const double n = static_cast<double>(st.size());
    std::vector<double> s(kBins, 0.0), q(kBins, 0.0);
    for (const std::size_t id : st)
      for (const Contribution& c : hist[id]) {
        s[c.bin] += c.x;
        q[c.bin] += c.x * c.x;
      }
    for (std::size_t b = 0; b < kBins; ++b) {
      mean[b] += s[b];
      var[b] += std::max(0.0, n / (n - 1.0) * (q[b] - s[b] * s[b] / n));
    }
  }
  for (std::size_t b = 0; b < kBins; ++b) {
    EXPECT_NEAR(t.mean(b), mean[b], 1e-12 * (1.0 + std::abs(mean[b]))) << b;
    EXPECT_NEAR(t.std_error(b), std::sqrt(var[b]), 1e-12 * (1.0 + std::sqrt(var[b]))) << b;
  }
}

TEST(StratifiedTally, AStratumOfOneHistoryAddsItsMeanAndNoVariance) {
  StratifiedTally t(2);
  t.start(0, StratumKey{0, 0, 0, 0}, 1);
  t.add(0, 2.0);
  t.history_done();
  t.flush(0);
  t.start(0, StratumKey{0, 0, 0, 1}, 2);
  t.add(0, 1.0);  // two histories of the next stratum in the same bin: 2 (1 + 9 - 16/2) = 4
  t.history_done();
  t.add(0, 3.0);
  t.history_done();
  t.flush(0);
  EXPECT_TRUE(t.open_strata().empty());
  EXPECT_EQ(t.mean(0), 6.0);
  EXPECT_DOUBLE_EQ(t.std_error(0), 2.0);
  EXPECT_EQ(t.mean(1), 0.0);
  EXPECT_EQ(t.std_error(1), 0.0);
}

// Two partitions into strata, closed independently: the mean is the plain sum, the standard
// error the larger of the two partitions' (the stratified launch sampling's conservative
// estimate, docs/precision.md).
TEST(StratifiedTally, TwoPartitionsReportTheLargerVariance) {
  StratifiedTally t(1, 2);
  ASSERT_EQ(t.partitions(), 2u);
  // Histories 1, 1, 3, 3: partition 0 strata {1, 1} {3, 3} (variance 0); partition 1 strata
  // {1} {1, 3} {3}: 2 (1 + 9 - 16/2) = 4.
  t.start(0, StratumKey{0, 0, 0, 0}, 2);
  t.start(1, StratumKey{1, 0, 0, 0}, 1);
  t.add(0, 1.0);
  t.history_done();
  t.flush(1);
  t.start(1, StratumKey{1, 0, 0, 1}, 2);
  t.add(0, 1.0);
  t.history_done();
  t.flush(0);
  t.start(0, StratumKey{0, 0, 0, 1}, 2);
  t.add(0, 3.0);
  t.history_done();
  t.flush(1);
  t.start(1, StratumKey{1, 0, 0, 2}, 1);
  t.add(0, 3.0);
  t.history_done();
  t.flush(0);  // {3, 3}
  t.flush(1);  // {3}
  EXPECT_TRUE(t.open_strata().empty());
  EXPECT_EQ(t.mean(0), 8.0);
  EXPECT_DOUBLE_EQ(t.std_error(0), 2.0);
  EXPECT_EQ(t.variance_sums(0).value(0), 0.0);
  EXPECT_EQ(t.variance_sums(1).value(0), 4.0);

  // The other way round: histories 1, 3, 3, 1; partition 0 {1, 3} {3, 1}: 4 + 4 = 8, the
  // larger; partition 1 {1} {3, 3} {1}: 0.
  StratifiedTally u(1, 2);
  const double x[] = {1.0, 3.0, 3.0, 1.0};
  for (std::int64_t i = 0; i < 4; ++i) {
    if (i % 2 == 0) {
      u.flush(0);
      u.start(0, StratumKey{0, 0, 0, i / 2}, 2);
    }
    if (i % 2 == 1 || i == 0) {
      u.flush(1);
      u.start(1, StratumKey{1, 0, 0, (i + 1) / 2}, i == 1 ? 2 : 1);
    }
    u.add(0, x[i]);
    u.history_done();
  }
  u.flush(0);
  u.flush(1);
  EXPECT_TRUE(u.open_strata().empty());
  EXPECT_EQ(u.mean(0), 8.0);
  EXPECT_DOUBLE_EQ(u.std_error(0), std::sqrt(8.0));
  EXPECT_EQ(u.variance_sums(1).value(0), 0.0);
}

// From the old ptn_prisms_test.
TEST(StratifiedTally, MeanAndStandardErrorOfTwoStrata) {
  StratifiedTally t(1);
  // Group A: 4 histories, contributions 1, 0, 3, 0 (zeros need no add()).
  t.start(0, StratumKey{0, 0, 0, 0}, 4);
  t.add(0, 1.0);
  t.history_done();
  t.history_done();
  t.add(0, 3.0);
  t.history_done();
  t.history_done();
  t.flush(0);
  // Group B: 2 histories: 2, 2.
  t.start(0, StratumKey{0, 1, 0, 0}, 2);
  t.add(0, 2.0);
  t.history_done();
  t.add(0, 2.0);
  t.history_done();
  t.flush(0);
  // Means add: 4 + 4. Var A = 4/3 (10 - 16/4) = 8; var B = 2 (8 - 16/2) = 0.
  EXPECT_EQ(t.mean(0), 8.0);
  EXPECT_DOUBLE_EQ(t.std_error(0), std::sqrt(8.0));
}

// --- pieces, merges and open strata ----------------------------------------------------------

// A run in the shape of core/run/run.cpp's Reducer: streams of histories (a group's batch);
// partition 0's strata are runs of kSize histories, partition 1's the same offset by half a
// stratum (the first and last shorter).
constexpr std::int64_t kSize = 6;

struct Stream {
  std::uint32_t group;
  std::int64_t batch;
  std::vector<std::size_t> ids;  // its histories, in order
};

struct Span {
  std::int64_t index, first, size;
};
Span stratum_of(std::int64_t i, std::int64_t n, std::size_t partition) {
  const std::int64_t offset = partition == 0 ? 0 : kSize / 2;
  const std::int64_t j = (i + offset) / kSize;
  const std::int64_t lo = std::max<std::int64_t>(0, j * kSize - offset);
  const std::int64_t hi = std::min(n, (j + 1) * kSize - offset);
  return {j, lo, hi - lo};
}
StratumKey key_of(const Stream& s, std::int64_t i, std::size_t partition) {
  return StratumKey{static_cast<std::uint32_t>(partition), s.group, s.batch,
                    stratum_of(i, static_cast<std::int64_t>(s.ids.size()), partition).index};
}

// Folds histories [i0, i1) of a stream as one chunk, as the Reducer does.
void fold(StratifiedTally& t, const std::vector<History>& hist, const Stream& s, std::int64_t i0,
          std::int64_t i1) {
  const auto n = static_cast<std::int64_t>(s.ids.size());
  for (std::int64_t i = i0; i < i1; ++i) {
    for (std::size_t k = 0; k < t.partitions(); ++k) {
      const Span v = stratum_of(i, n, k);
      if (i != i0 && v.first != i) continue;
      t.flush(k);
      t.start(k, key_of(s, i, k), v.size);
    }
    for (const Contribution& c : hist[s.ids[static_cast<std::size_t>(i)]]) t.add(c.bin, c.x);
    t.history_done();
  }
  for (std::size_t k = 0; k < t.partitions(); ++k) t.flush(k);
}

struct Chunk {
  std::size_t stream;
  std::int64_t i0, i1;
};

struct RunData {
  std::size_t bins = 40;
  std::vector<History> hist;
  std::vector<Stream> streams;

  explicit RunData(std::uint64_t seed) {
    std::mt19937_64 g(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0), decade(-6.0, 3.0);
    std::uniform_int_distribution<int> touched(0, 4);
    std::vector<std::size_t> all(bins);
    std::iota(all.begin(), all.end(), std::size_t{0});
    for (std::uint32_t group = 0; group < 2; ++group)
      for (std::int64_t batch = 0; batch < 2; ++batch) {
        Stream s{group, batch, {}};
        const int n = group == 0 ? 37 : 23;
        for (int i = 0; i < n; ++i) {
          History h;
          std::shuffle(all.begin() + 2, all.end() - 2, g);  // the last two bins: never touched
          for (int k = 0, m = touched(g); k < m; ++k)
            h.push_back({all[static_cast<std::size_t>(k) + 2], u(g) * std::pow(10.0, decade(g))});
          // Bin 0: large and nearly equal (the variance is a difference of close numbers);
          // bin 1: most histories, small.
          h.push_back({0, 1e3 + u(g)});
          if (i % 3 != 0) h.push_back({1, 1e-3 * u(g)});
          s.ids.push_back(hist.size());
          hist.push_back(h);
        }
        streams.push_back(s);
      }
  }

  StratifiedTally one_piece() const {
    StratifiedTally t(bins, 2);
    for (const Stream& s : streams) fold(t, hist, s, 0, static_cast<std::int64_t>(s.ids.size()));
    return t;
  }

  // The strata of each partition, as lists of the histories of `seen` (per stream, per history)
  // in them; only the complete ones if `complete_only`.
  std::vector<std::vector<Stratum>> strata(const std::vector<std::vector<bool>>& seen,
                                           bool complete_only) const {
    std::vector<std::vector<Stratum>> out(2);
    for (std::size_t k = 0; k < 2; ++k)
      for (std::size_t si = 0; si < streams.size(); ++si) {
        const Stream& s = streams[si];
        const auto n = static_cast<std::int64_t>(s.ids.size());
        std::map<std::int64_t, Stratum> by_index;
        std::map<std::int64_t, std::int64_t> sizes;
        for (std::int64_t i = 0; i < n; ++i) {
          const Span v = stratum_of(i, n, k);
          sizes[v.index] = v.size;
          if (seen[si][static_cast<std::size_t>(i)])
            by_index[v.index].push_back(s.ids[static_cast<std::size_t>(i)]);
        }
        for (auto& [index, st] : by_index)
          if (!complete_only || static_cast<std::int64_t>(st.size()) == sizes[index])
            out[k].push_back(st);
      }
    return out;
  }
  std::vector<std::vector<bool>> all_seen() const {
    std::vector<std::vector<bool>> seen;
    for (const Stream& s : streams) seen.emplace_back(s.ids.size(), true);
    return seen;
  }

  // Each stream cut at random points into chunks (so that chunks cut strata in the middle).
  std::vector<Chunk> random_chunks(std::mt19937_64& g) const {
    std::vector<Chunk> chunks;
    for (std::size_t si = 0; si < streams.size(); ++si) {
      const auto n = static_cast<std::int64_t>(streams[si].ids.size());
      std::set<std::int64_t> cuts{0, n};
      const int count = std::uniform_int_distribution<int>(0, static_cast<int>(n) - 1)(g);
      for (int c = 0; c < count; ++c)
        cuts.insert(std::uniform_int_distribution<std::int64_t>(1, n - 1)(g));
      for (auto it = cuts.begin(); std::next(it) != cuts.end(); ++it)
        chunks.push_back({si, *it, *std::next(it)});
    }
    return chunks;
  }
};

// Chunks dealt at random to `tallies` tallies (threads, shards), each folding its chunks in a
// random order: one tally may fold two pieces of a stratum with others in between.
std::vector<StratifiedTally> fold_dealt(const RunData& run, std::vector<Chunk> chunks,
                                        std::size_t tallies, std::mt19937_64& g,
                                        std::vector<std::vector<Chunk>>* dealt = nullptr) {
  std::vector<std::vector<Chunk>> own(tallies);
  for (const Chunk& c : chunks)
    own[std::uniform_int_distribution<std::size_t>(0, tallies - 1)(g)].push_back(c);
  std::vector<StratifiedTally> out(tallies, StratifiedTally(run.bins, 2));
  for (std::size_t k = 0; k < tallies; ++k) {
    std::shuffle(own[k].begin(), own[k].end(), g);
    for (const Chunk& c : own[k]) fold(out[k], run.hist, run.streams[c.stream], c.i0, c.i1);
  }
  if (dealt != nullptr) *dealt = own;
  return out;
}

TEST(StratifiedTally, PiecesMergedInAnyOrderGiveTheBitsOfOnePiece) {
  const RunData run(11);
  const StratifiedTally one = run.one_piece();
  EXPECT_TRUE(one.open_strata().empty());
  const Figures want = formulas(run.hist, run.strata(run.all_seen(), false), run.bins);
  expect_same_bits(figures(one), want, "one piece");
  ASSERT_GT(want.se[0], 0.0);  // bin 0: a variance from a difference of close numbers

  std::mt19937_64 g(12);
  for (int trial = 0; trial < 30; ++trial) {
    const std::size_t tallies = std::uniform_int_distribution<std::size_t>(1, 6)(g);
    std::vector<StratifiedTally> parts = fold_dealt(run, run.random_chunks(g), tallies, g);
    // Merged in a random order into an empty tally...
    std::vector<std::size_t> order(parts.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::shuffle(order.begin(), order.end(), g);
    StratifiedTally flat(run.bins, 2);
    for (const std::size_t k : order) flat.merge(parts[k]);
    EXPECT_TRUE(flat.open_strata().empty()) << trial;
    expect_same_bits(figures(flat), want, "flat merge");
    EXPECT_EQ(flat.means(0, run.bins), want.mean) << trial;
    EXPECT_EQ(flat.std_errors(0, run.bins), want.se) << trial;
    // ... and pairwise, as a random tree.
    while (parts.size() > 1) {
      const std::size_t i = std::uniform_int_distribution<std::size_t>(0, parts.size() - 1)(g);
      std::size_t j = std::uniform_int_distribution<std::size_t>(0, parts.size() - 2)(g);
      if (j >= i) ++j;
      parts[i].merge(parts[j]);
      parts.erase(parts.begin() + static_cast<std::ptrdiff_t>(j));
    }
    EXPECT_TRUE(parts[0].open_strata().empty()) << trial;
    expect_same_bits(figures(parts[0]), want, "tree merge");
    if (::testing::Test::HasFailure()) break;
  }
}

// A stratum folded in pieces by one tally: flushed after some histories, started again later
// (with other strata in between), split in the middle; one partition and two.
TEST(StratifiedTally, AStratumStartedAgainLaterInTheSameTallyGivesTheBitsOfOnePiece) {
  for (const int partitions : {1, 2}) {
    StratifiedTally one(3, partitions), split(3, partitions);
    const StratumKey a{0, 0, 0, 0}, b{0, 0, 0, 1};
    const double xa[] = {0.1, 0.7, 1e8, -1e8 + 0.3, 2.0};
    const double xb[] = {5.0, -1e-3, 0.2};
    const auto history = [](StratifiedTally& t, double x) {
      t.add(0, x);
      t.add(1, x * x);
      if (x > 0.15) t.add(2, -x);
      t.history_done();
    };
    const auto start = [](StratifiedTally& t, StratumKey key, std::int64_t size) {
      for (std::size_t k = 0; k < t.partitions(); ++k) {
        key.partition = static_cast<std::uint32_t>(k);
        t.start(k, key, size);
      }
    };
    const auto flush = [](StratifiedTally& t) {
      for (std::size_t k = 0; k < t.partitions(); ++k) t.flush(k);
    };
    start(one, a, 5);
    for (const double x : xa) history(one, x);
    flush(one);
    start(one, b, 3);
    for (const double x : xb) history(one, x);
    flush(one);

    start(split, a, 5);
    history(split, xa[0]);
    history(split, xa[1]);
    flush(split);
    ASSERT_EQ(split.open_strata().size(), split.partitions());
    start(split, b, 3);
    history(split, xb[0]);
    flush(split);
    start(split, a, 5);
    history(split, xa[2]);
    flush(split);
    start(split, b, 3);
    history(split, xb[1]);
    history(split, xb[2]);
    flush(split);  // b complete
    start(split, a, 5);
    history(split, xa[3]);
    history(split, xa[4]);
    flush(split);  // a complete
    EXPECT_TRUE(split.open_strata().empty());
    expect_same_bits(figures(split), figures(one), "split in one tally");

    // The formulas: S and Q exact, so 1e8 and -1e8 + 0.3 cancel exactly.
    std::vector<History> hist;
    Stratum sa, sb;
    for (const double x : xa) {
      sa.push_back(hist.size());
      hist.push_back(x > 0.15 ? History{{0, x}, {1, x * x}, {2, -x}} : History{{0, x}, {1, x * x}});
    }
    for (const double x : xb) {
      sb.push_back(hist.size());
      hist.push_back(x > 0.15 ? History{{0, x}, {1, x * x}, {2, -x}} : History{{0, x}, {1, x * x}});
    }
    std::vector<std::vector<Stratum>> strata(static_cast<std::size_t>(partitions), {sa, sb});
    expect_same_bits(figures(one), formulas(hist, strata, 3), "one piece vs formulas");
  }
}

TEST(StratifiedTally, OpenStrataHoldTheHistoriesSeenUntilTheirPiecesAreAllThere) {
  // One stratum of 4 histories: 1 | 2 in bin 1 | 3 in bin 0 and 5 in bin 2 | nothing.
  const StratumKey key{0, 0, 0, 0};
  const auto piece = [&](std::int64_t first, std::int64_t count) {
    StratifiedTally t(3);
    t.start(0, key, 4);
    for (std::int64_t i = first; i < first + count; ++i) {
      if (i == 0) t.add(0, 1.0);
      if (i == 1) t.add(1, 2.0);
      if (i == 2) {
        t.add(2, 5.0);
        t.add(0, 3.0);
      }
      t.history_done();
    }
    t.flush(0);
    return t;
  };
  const StratifiedTally a = piece(0, 1), b = piece(1, 2), c = piece(3, 1);
  ASSERT_EQ(a.open_strata().size(), 1u);
  EXPECT_EQ(a.open_strata().begin()->first, key);
  EXPECT_EQ(a.open_strata().begin()->second.size, 4);
  EXPECT_EQ(a.open_strata().begin()->second.n, 1);
  EXPECT_EQ(a.mean(0), 0.0);  // not closed yet
  EXPECT_EQ(c.open_strata().begin()->second.n, 1);
  EXPECT_TRUE(c.open_strata().begin()->second.entries.empty());

  StratifiedTally ab(3);
  ab.merge(b);
  ab.merge(a);
  ASSERT_EQ(ab.open_strata().size(), 1u);
  const auto ab_open = ab.open_strata();
  const OpenStratum& st = ab_open.at(key);
  EXPECT_EQ(st.size, 4);
  EXPECT_EQ(st.n, 3);
  ASSERT_EQ(st.entries.size(), 3u);  // sorted by bin
  const double s[] = {4.0, 2.0, 5.0}, q[] = {10.0, 4.0, 25.0};
  for (std::uint32_t k = 0; k < 3; ++k) {
    EXPECT_EQ(st.entries[k].bin, k);
    EXPECT_EQ(st.entries[k].s.value(), s[k]) << k;
    EXPECT_EQ(st.entries[k].q.value(), q[k]) << k;
  }
  for (std::size_t bin = 0; bin < 3; ++bin) {
    EXPECT_EQ(ab.mean(bin), 0.0);
    EXPECT_EQ(ab.std_error(bin), 0.0);
  }

  // A cancelled run: closed with the 3 histories seen, n/(n - 1) (Q - S^2/n) with n = 3.
  StratifiedTally cut = ab;
  cut.close_open_strata();
  EXPECT_TRUE(cut.open_strata().empty());
  const auto term = [](double sv, double qv, double n) {
    return std::max(0.0, n / (n - 1.0) * (qv - sv * sv / n));
  };
  for (std::size_t bin = 0; bin < 3; ++bin) {
    EXPECT_EQ(cut.mean(bin), s[bin]) << bin;
    EXPECT_EQ(bits(cut.std_error(bin)), bits(std::sqrt(term(s[bin], q[bin], 3.0)))) << bin;
  }
  EXPECT_DOUBLE_EQ(cut.std_error(0), std::sqrt(7.0));  // 3/2 (10 - 16/3)

  // The last piece closes it, with n = 4, in any order of the pieces.
  const StratifiedTally* pieces[] = {&a, &b, &c};
  std::vector<int> order{0, 1, 2};
  do {
    StratifiedTally t(3);
    for (const int k : order) t.merge(*pieces[k]);
    EXPECT_TRUE(t.open_strata().empty());
    for (std::size_t bin = 0; bin < 3; ++bin) {
      EXPECT_EQ(t.mean(bin), s[bin]) << bin;
      EXPECT_EQ(bits(t.std_error(bin)), bits(std::sqrt(term(s[bin], q[bin], 4.0)))) << bin;
    }
    EXPECT_DOUBLE_EQ(t.std_error(0), std::sqrt(8.0));  // 4/3 (10 - 16/4)
  } while (std::next_permutation(order.begin(), order.end()));
}

// Some of the pieces of a run merged: the strata they complete are closed, the others listed
// open with the histories seen; closing those gives the formulas over the histories seen.
TEST(StratifiedTally, MergingSomePiecesLeavesTheRestOpenAndClosingUsesTheHistoriesSeen) {
  const RunData run(21);
  std::mt19937_64 g(22);
  int open_seen = 0;
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<std::vector<Chunk>> dealt;
    const std::size_t tallies = std::uniform_int_distribution<std::size_t>(2, 6)(g);
    const std::vector<StratifiedTally> parts =
        fold_dealt(run, run.random_chunks(g), tallies, g, &dealt);
    // A random nonempty subset, not all of them.
    std::vector<std::size_t> subset(tallies);
    std::iota(subset.begin(), subset.end(), std::size_t{0});
    std::shuffle(subset.begin(), subset.end(), g);
    subset.resize(std::uniform_int_distribution<std::size_t>(1, tallies - 1)(g));
    std::vector<std::vector<bool>> seen;
    for (const Stream& s : run.streams) seen.emplace_back(s.ids.size(), false);
    StratifiedTally t(run.bins, 2);
    for (const std::size_t k : subset) {
      t.merge(parts[k]);
      for (const Chunk& c : dealt[k])
        for (std::int64_t i = c.i0; i < c.i1; ++i)
          seen[c.stream][static_cast<std::size_t>(i)] = true;
    }
    // The open strata: exactly those with some but not all of their histories seen.
    std::map<StratumKey, std::pair<std::int64_t, std::int64_t>> want_open;  // size, n
    std::map<StratumKey, std::map<std::uint32_t, ReferenceSum>> want_s;
    for (std::size_t si = 0; si < run.streams.size(); ++si) {
      const Stream& s = run.streams[si];
      const auto n = static_cast<std::int64_t>(s.ids.size());
      for (std::size_t k = 0; k < 2; ++k)
        for (std::int64_t i = 0; i < n; ++i) {
          if (!seen[si][static_cast<std::size_t>(i)]) continue;
          const StratumKey key = key_of(s, i, k);
          auto& [size, count] = want_open[key];
          size = stratum_of(i, n, k).size;
          ++count;
          for (const Contribution& c : run.hist[s.ids[static_cast<std::size_t>(i)]])
            want_s[key][static_cast<std::uint32_t>(c.bin)].add(c.x);
        }
    }
    std::erase_if(want_open, [](const auto& e) { return e.second.second == e.second.first; });
    ASSERT_EQ(t.open_strata().size(), want_open.size()) << trial;
    for (const auto& [key, st] : t.open_strata()) {
      ASSERT_TRUE(want_open.count(key)) << trial;
      EXPECT_EQ(st.size, want_open[key].first);
      EXPECT_EQ(st.n, want_open[key].second);
      EXPECT_LT(st.n, st.size);
      ASSERT_EQ(st.entries.size(), want_s[key].size());
      auto w = want_s[key].begin();
      for (const OpenStratum::Entry& e : st.entries) {
        EXPECT_EQ(e.bin, w->first);  // sorted by bin
        EXPECT_EQ(bits(e.s.value()), bits(w->second.rounded()));
        ++w;
      }
    }
    open_seen += static_cast<int>(want_open.size());
    // Only the complete strata count so far.
    expect_same_bits(figures(t), formulas(run.hist, run.strata(seen, true), run.bins), "partial");
    // Closed with the histories seen (a cancelled run).
    t.close_open_strata();
    EXPECT_TRUE(t.open_strata().empty());
    expect_same_bits(figures(t), formulas(run.hist, run.strata(seen, false), run.bins),
                     "closed with the histories seen");
    if (::testing::Test::HasFailure()) break;
  }
  EXPECT_GT(open_seen, 0);  // the trials did leave strata open
}

// A partial result's file keeps the exact sums and the open strata (formats/partial_file.h): a
// tally restored from them gives the same bits and merges on like the original.
TEST(StratifiedTally, ARestoredTallyGivesTheSameBitsAndMergesOn) {
  const RunData run(31);
  const Figures want = formulas(run.hist, run.strata(run.all_seen(), false), run.bins);
  std::mt19937_64 g(32);
  std::vector<StratifiedTally> parts = fold_dealt(run, run.random_chunks(g), 3, g);
  StratifiedTally r(run.bins, 2);
  r.restore(parts[0].mean_sums(), {parts[0].variance_sums(0), parts[0].variance_sums(1)},
            parts[0].open_strata());
  expect_same_bits(figures(r), figures(parts[0]), "restored");
  EXPECT_EQ(r.open_strata().size(), parts[0].open_strata().size());
  r.merge(parts[2]);
  r.merge(parts[1]);
  EXPECT_TRUE(r.open_strata().empty());
  expect_same_bits(figures(r), want, "restored and merged");
}

// Pieces of a stratum read from files may be forged: they must agree on its size and hold no
// more than its histories together (a count near 2^63 once overflowed in the sum, found by
// fuzz_partial). Such a merge throws and leaves the stratum as it was.
TEST(StratifiedTally, PiecesThatDoNotAddUpToTheirStratumAreRefused) {
  const std::int64_t big = std::numeric_limits<std::int64_t>::max() - 1;
  auto one_open = [](std::int64_t size, std::int64_t n) {
    OpenStratum st;
    st.size = size;
    st.n = n;
    OpenStratum::Entry e;
    e.bin = 3;
    e.s.add(1.0);
    e.q.add(1.0);
    st.entries.push_back(e);
    StratifiedTally t(8, 1);
    t.restore(ExactBins(8), {ExactBins(8)}, {{StratumKey{0, 0, 0, 0}, st}});
    return t;
  };
  struct Case {
    std::int64_t size_a, n_a, size_b, n_b;
    const char* what;
  };
  for (const Case& c : {Case{big + 1, big, big + 1, big, "two pieces near 2^63"},
                        Case{10, 6, 10, 5, "more histories than the stratum"},
                        Case{10, 4, 12, 4, "different sizes"}}) {
    StratifiedTally a = one_open(c.size_a, c.n_a);
    const StratifiedTally b = one_open(c.size_b, c.n_b);
    EXPECT_THROW(a.merge(b), std::overflow_error) << c.what;
    ASSERT_EQ(a.open_strata().size(), 1u) << c.what;
    const auto a_open = a.open_strata();
    const OpenStratum& st = a_open.begin()->second;
    EXPECT_EQ(st.size, c.size_a) << c.what;
    EXPECT_EQ(st.n, c.n_a) << c.what;
    EXPECT_EQ(st.entries.size(), 1u) << c.what;
  }
  // Pieces that do add up close the stratum.
  StratifiedTally a = one_open(10, 6);
  a.merge(one_open(10, 4));
  EXPECT_TRUE(a.open_strata().empty());
  EXPECT_EQ(a.means(3, 1)[0], 2.0);
}

TEST(StratifiedTally, MeansAndStdErrorsOfARangeAreThePerBinFigures) {
  const RunData run(41);
  std::mt19937_64 g(42);
  std::vector<StratifiedTally> parts = fold_dealt(run, run.random_chunks(g), 2, g);
  StratifiedTally t = parts[1];
  t.merge(parts[0]);
  // Both partitions are the larger in some bins, and some bins are never touched.
  int p0 = 0, p1 = 0;
  for (std::size_t b = 0; b < run.bins; ++b) {
    const double v0 = t.variance_sums(0).value(b), v1 = t.variance_sums(1).value(b);
    p0 += v0 > v1;
    p1 += v1 > v0;
  }
  ASSERT_GT(p0, 0);
  ASSERT_GT(p1, 0);
  ASSERT_EQ(t.mean(run.bins - 1), 0.0);
  for (const StratifiedTally* x : {&t, &parts[0]}) {  // merged, and with strata still open
    std::vector<std::pair<std::size_t, std::size_t>> ranges{
        {0, run.bins}, {0, 0}, {5, 10}, {run.bins - 1, 1}, {run.bins, 0}, {0, 1}};
    for (int k = 0; k < 20; ++k) {
      const std::size_t first = std::uniform_int_distribution<std::size_t>(0, run.bins)(g);
      ranges.push_back({first, std::uniform_int_distribution<std::size_t>(0, run.bins - first)(g)});
    }
    for (const auto& [first, count] : ranges) {
      const std::vector<double> m = x->means(first, count), se = x->std_errors(first, count);
      ASSERT_EQ(m.size(), count);
      ASSERT_EQ(se.size(), count);
      for (std::size_t i = 0; i < count; ++i) {
        EXPECT_EQ(bits(m[i]), bits(x->mean(first + i))) << first << "+" << i;
        EXPECT_EQ(bits(se[i]), bits(x->std_error(first + i))) << first << "+" << i;
      }
    }
  }
}

// Known limitation, disabled (run with --gtest_also_run_disabled_tests): Q sums the squares x^2
// in an ExactSum, whose terms below 2^-107 are rounded to multiples of 2^-160 (exact_sum.h). So
// Q is exact only for contributions |x| >= 2^-53.5 (about 7.7e-17); the standard error is off by
// about 1e-9 at x ~ 1e-20, by 7.5 % at 1e-24 and is 0 from about 1e-25 down (the old
// double-precision estimator had no such floor). Weights with likelihood ratios can be that small.
// The documented resolution (docs/cluster.md, "Exact sums"): squares are kept to 2^-160, so the
// standard error is exact to 1e-12 for contributions down to 1e-18 (a weight of 1e-9 over a
// triangle of 10^9 m^2), and means stay exact far below that.
TEST(StratifiedTally, SmallContributionsKeepTheirStandardErrorDownTo1eMinus18) {
  for (const double scale : {1e-12, 1e-16, 1e-18}) {
    StratifiedTally t(1);
    t.start(0, StratumKey{}, 2);
    t.add(0, 1.0 * scale);
    t.history_done();
    t.add(0, 3.0 * scale);
    t.history_done();
    t.flush(0);
    // 2 (1 + 9 - 16/2) scale^2 = 4 scale^2.
    EXPECT_NEAR(t.std_error(0), 2.0 * scale, 1e-12 * scale) << scale;
    EXPECT_DOUBLE_EQ(t.mean(0), 4.0 * scale) << scale;
  }
  StratifiedTally t(1);
  t.start(0, StratumKey{}, 2);
  t.add(0, 1e-30);
  t.history_done();
  t.add(0, 3e-30);
  t.history_done();
  t.flush(0);
  EXPECT_DOUBLE_EQ(t.mean(0), 4e-30);
}

}  // namespace
}  // namespace fragsim::tally
