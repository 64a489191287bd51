#pragma once
// Counter-based random numbers (Philox4x32-10, Salmon et al. 2011, via Random123).
//
// Every fragment history owns a stream keyed by (seed, group, history). Each random variable of a
// history has a fixed *slot* (see fragments/sampling.h): the variate is a pure function of
// (seed, group, history, slot, k), so a history's result never depends on which thread ran it,
// on the batch split, or on how many variates other code drew before it. New variables get new
// slots, so adding one never changes the values of the existing ones.
#include <Random123/philox.h>

#include <array>
#include <cstdint>

namespace fragsim {

class RandomStream {
 public:
  RandomStream(std::uint64_t seed, std::uint32_t group, std::uint64_t history)
      : group_(group), history_(history) {
    key_ = {{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)}};
  }

  // Uniform double in the open interval (0, 1), 53 random bits; `slot` selects the variable and
  // `k` (0..1) its index within the slot's block of two variates.
  double uniform(std::uint32_t slot, std::uint32_t k = 0) const {
    const auto r = block(slot);
    return to_unit(r[2 * (k & 1)], r[2 * (k & 1) + 1]);
  }
  // Both variates of `slot` from one block: {uniform(slot, 0), uniform(slot, 1)}.
  std::array<double, 2> uniform_pair(std::uint32_t slot) const {
    const auto r = block(slot);
    return {to_unit(r[0], r[1]), to_unit(r[2], r[3])};
  }

  // Raw 128-bit block for `slot` (four 32-bit words).
  r123::Philox4x32::ctr_type block(std::uint32_t slot) const {
    r123::Philox4x32::ctr_type ctr = {{group_, static_cast<std::uint32_t>(history_),
                                       static_cast<std::uint32_t>(history_ >> 32), slot}};
    return r123::Philox4x32()(ctr, key_);
  }

 private:
  static double to_unit(std::uint64_t hi, std::uint64_t lo) {
    const std::uint64_t bits = ((hi << 32) | lo) >> 11;  // 53 bits
    return (static_cast<double>(bits) + 0.5) * 0x1.0p-53;
  }
  std::uint32_t group_;
  std::uint64_t history_;
  r123::Philox4x32::key_type key_;
};

}  // namespace fragsim
