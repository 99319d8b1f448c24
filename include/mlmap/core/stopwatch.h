#pragma once
/// @file
/// Elapsed wall time in milliseconds on the steady clock: the one way mlmap's stages, programs
/// and benchmarks time themselves. Header-only, standard library only.

#include <chrono>

namespace mlmap {

/// The clock every mlmap timing uses: monotonic, never adjusted.
using SteadyClock = std::chrono::steady_clock;

/// Milliseconds from `start` to `end` [ms].
inline double msBetween(SteadyClock::time_point start, SteadyClock::time_point end) {
  return std::chrono::duration<double, std::milli>(end - start).count();
}

/// Milliseconds from `start` to now [ms].
inline double msSince(SteadyClock::time_point start) {
  return msBetween(start, SteadyClock::now());
}

/// Seconds from `start` to `end` [s].
inline double secondsBetween(SteadyClock::time_point start, SteadyClock::time_point end) {
  return std::chrono::duration<double>(end - start).count();
}

}  // namespace mlmap
