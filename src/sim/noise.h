#pragma once
// Deterministic noise shared by the simulated sensors (private to src/sim): a sample is a pure
// function of (key, index), identical on every platform, so rendering the same time twice gives
// the same data.

#include <cmath>
#include <cstdint>
#include <cstring>

namespace mlmap::sim::detail {

/// SplitMix64 finaliser: a good 64-bit mixing function, identical on every platform.
inline std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// Uniform double in (0, 1] from the top 53 bits of a 64-bit word.
inline double unitOpenZero(std::uint64_t bits) {
  return (static_cast<double>(bits >> 11) + 1.0) * (1.0 / 9007199254740992.0);
}

/// Standard normal sample number `index` of the frame keyed by `frame_key` (Box-Muller).
inline double standardNormal(std::uint64_t frame_key, std::uint64_t index) {
  const std::uint64_t a = splitMix64(frame_key ^ splitMix64(2 * index));
  const std::uint64_t b = splitMix64(frame_key ^ splitMix64(2 * index + 1));
  const double u1 = unitOpenZero(a);
  const double u2 = unitOpenZero(b);
  constexpr double kTwoPi = 6.283185307179586476925286766559;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(kTwoPi * u2);
}

/// Key of one frame: the sensor's seed mixed with the bits of its time stamp.
inline std::uint64_t frameKey(std::uint32_t seed, double time_s) {
  std::uint64_t time_bits = 0;
  static_assert(sizeof(time_bits) == sizeof(time_s));
  std::memcpy(&time_bits, &time_s, sizeof(time_bits));
  return splitMix64(splitMix64(seed) ^ time_bits);
}

}  // namespace mlmap::sim::detail
