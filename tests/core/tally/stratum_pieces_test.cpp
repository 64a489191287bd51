// Pieces of strata (core/tally/stratum_pieces.h): the hash index from bin to entry, and pieces
// built apart from the tally - as a run's workers build them - giving the bits of the tally's
// own fold.
#include "core/tally/stratum_pieces.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/tally/stratified_tally.h"

namespace fragsim::tally {
namespace {

// Bins of three kinds: random 32-bit, consecutive, and multiples of a large power of two (the
// keys a weak hash would pile into one slot).
std::vector<std::uint32_t> bins_to_index(std::mt19937_64& g, std::size_t n) {
  std::vector<std::uint32_t> out;
  std::uniform_int_distribution<std::uint32_t> any;
  for (std::size_t k = 0; k < n; ++k) {
    switch (k % 3) {
      case 0: out.push_back(any(g)); break;
      case 1: out.push_back(static_cast<std::uint32_t>(k % 4093)); break;
      default: out.push_back(static_cast<std::uint32_t>((k % 1021) << 20)); break;
    }
  }
  return out;
}

TEST(BinIndex, GivesEachBinItsIndexOfFirstUseThroughGrowthAndClears) {
  std::mt19937_64 g(5);
  BinIndex index;
  // Rounds of very different sizes: a large one grows the table, the small ones after it are
  // cleared slot by slot, a full one by filling.
  for (const std::size_t n : {60000u, 30u, 1u, 0u, 700u, 5000u, 2u}) {
    std::map<std::uint32_t, std::uint32_t> want;
    std::vector<std::uint32_t> order;
    for (const std::uint32_t bin : bins_to_index(g, n)) {
      const auto [it, added] = want.try_emplace(bin, static_cast<std::uint32_t>(want.size()));
      if (added) order.push_back(bin);
      ASSERT_EQ(index.find_or_add(bin), it->second) << "round of " << n;
    }
    ASSERT_EQ(index.size(), want.size());
    ASSERT_EQ(index.bins(), order);
    index.clear();
    ASSERT_EQ(index.size(), 0u);
  }
}

// Contributions of a few histories to a few bins, in pieces of one stratum, some split.
struct Term {
  std::size_t bin;
  double x;
};
using History = std::vector<Term>;

// Folds histories [i0, i1) of a stratum of `size` into `t` (a StratifiedTally or a builder).
template <class Fold, class Flush>
void fold_piece(Fold& t, Flush flush, const std::vector<History>& hist, StratumKey key,
                std::int64_t i0, std::int64_t i1) {
  for (std::size_t k = 0; k < t.partitions(); ++k) {
    key.partition = static_cast<std::uint32_t>(k);
    t.start(k, key, static_cast<std::int64_t>(hist.size()));
  }
  for (std::int64_t i = i0; i < i1; ++i) {
    for (const Term& c : hist[static_cast<std::size_t>(i)]) t.add(c.bin, c.x);
    if (i % 4 == 0) t.add_square(hist[static_cast<std::size_t>(i)].front().bin, 0.5);
    t.history_done();
  }
  for (std::size_t k = 0; k < t.partitions(); ++k) flush(k);
}

TEST(PieceBuilder, PiecesAddedToATallyGiveTheBitsOfItsOwnFold) {
  std::mt19937_64 g(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<std::size_t> bin(0, 49);
  for (const int partitions : {1, 2}) {
    for (int trial = 0; trial < 20; ++trial) {
      // Two strata of 30 histories, each cut into pieces at random points.
      std::vector<std::vector<History>> strata(2);
      for (auto& hist : strata)
        for (int i = 0; i < 30; ++i) {
          History h;
          std::map<std::size_t, double> distinct;
          for (int k = 0; k < 4; ++k) distinct[bin(g)] = u(g) * std::pow(10.0, 6.0 * u(g));
          for (const auto& [b, x] : distinct) h.push_back({b, x});
          hist.push_back(h);
        }
      StratifiedTally own(50, partitions), added(50, partitions);
      PieceBuilder builder(partitions);
      for (std::size_t s = 0; s < strata.size(); ++s) {
        const StratumKey key{0, 0, 0, static_cast<std::int64_t>(s)};
        std::int64_t i0 = 0;
        while (i0 < 30) {
          const std::int64_t i1 =
              std::min<std::int64_t>(30, i0 + std::uniform_int_distribution<int>(1, 12)(g));
          fold_piece(
              own, [&](std::size_t k) { own.flush(k); }, strata[s], key, i0, i1);
          std::vector<StratumPiece> pieces;
          fold_piece(
              builder, [&](std::size_t k) { builder.flush(k, pieces); }, strata[s], key, i0, i1);
          ASSERT_EQ(pieces.size(), static_cast<std::size_t>(partitions));
          for (StratumPiece& p : pieces) added.add_piece(std::move(p));
          i0 = i1;
        }
      }
      ASSERT_TRUE(own.open_strata().empty());
      ASSERT_TRUE(added.open_strata().empty());
      // The same exact sums, touched in the same order (a partial file's bytes follow it).
      EXPECT_EQ(added.mean_sums().bins(), own.mean_sums().bins());
      EXPECT_EQ(added.mean_sums().sums(), own.mean_sums().sums());
      for (std::size_t k = 0; k < own.partitions(); ++k) {
        EXPECT_EQ(added.variance_sums(k).bins(), own.variance_sums(k).bins());
        EXPECT_EQ(added.variance_sums(k).sums(), own.variance_sums(k).sums());
      }
      ASSERT_FALSE(::testing::Test::HasFailure())
          << "partitions " << partitions << ", trial " << trial;
    }
  }
}

TEST(PieceBuilder, APieceKeepsTheOrderOfFirstTouch) {
  PieceBuilder b;
  std::vector<StratumPiece> pieces;
  b.start(0, StratumKey{0, 0, 0, 0}, 2);
  b.add(7, 1.0);
  b.add(3, 2.0);
  b.add(5, 0.0);  // changes neither sum: not an entry
  b.history_done();
  b.flush(0, pieces);  // one of two histories: a part
  b.start(0, StratumKey{0, 0, 0, 1}, 1);
  b.add(9, 1.0);
  b.add(2, 4.0);
  b.history_done();
  b.flush(0, pieces);  // the whole stratum
  b.flush(0, pieces);  // nothing since: no piece
  ASSERT_EQ(pieces.size(), 2u);
  ASSERT_EQ(pieces[0].st.entries.size(), 2u);
  EXPECT_EQ(pieces[0].st.entries[0].bin, 7u);
  EXPECT_EQ(pieces[0].st.entries[1].bin, 3u);
  EXPECT_EQ(pieces[0].st.n, 1);
  EXPECT_EQ(pieces[0].st.size, 2);
  ASSERT_EQ(pieces[1].st.entries.size(), 2u);
  EXPECT_EQ(pieces[1].st.entries[0].bin, 9u);
  EXPECT_EQ(pieces[1].st.entries[1].bin, 2u);
  EXPECT_EQ(pieces[1].st.entries[1].q.value(), 16.0);
  // Misuse is refused as by the tally's own fold.
  b.start(0, StratumKey{0, 0, 0, 2}, 3);
  b.add(1, 1.0);
  EXPECT_THROW(b.flush(0, pieces), std::logic_error);
  EXPECT_THROW(b.start(0, StratumKey{0, 0, 0, 3}, 3), std::logic_error);
  b.clear();
  EXPECT_NO_THROW(b.start(0, StratumKey{0, 0, 0, 3}, 3));
}

}  // namespace
}  // namespace fragsim::tally
