// SplitMix64's finaliser: a well-mixed 64-bit hash. The simulator's noise and
// its thread-to-thread variation are pure functions of it, so they depend on
// the seed alone, not on the standard library or the thread count.
#pragma once

#include <cstdint>

namespace scanbench::sim_internal {

inline constexpr uint64_t kSplitMixGamma = 0x9E3779B97F4A7C15ULL;

inline uint64_t Mix64(uint64_t z) {
  z += kSplitMixGamma;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

}  // namespace scanbench::sim_internal
