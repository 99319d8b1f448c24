#pragma once
/// @file
/// Quantised log-odds (paper Eq. 7-9). A voxel stores its natural-log odds as a 16-bit integer
/// in units of 0.001, so a voxel costs 2 bytes and updates are integer additions with
/// saturation. The smallest value means "never observed" (unknown).

#include "mlmap/core/config.h"
#include "mlmap/core/types.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace mlmap {

/// Stored log-odds value of one voxel.
using LogOddsQ = std::int16_t;
/// Value of a never-observed voxel.
inline constexpr LogOddsQ kUnknownLogOdds = std::numeric_limits<LogOddsQ>::min();
/// Log-odds units per stored unit.
inline constexpr double kLogOddsQuantum = 0.001;

/// Converts a log-odds value to its stored form (rounded to the quantum).
inline LogOddsQ quantizeLogOdds(double log_odds) {
  return static_cast<LogOddsQ>(std::lround(log_odds / kLogOddsQuantum));
}
/// Converts a stored value (not kUnknownLogOdds) back to log-odds.
inline double dequantizeLogOdds(LogOddsQ q) { return q * kLogOddsQuantum; }
/// Probability of a log-odds value: 1 / (1 + exp(-l)).
inline double probabilityFromLogOdds(double log_odds) { return 1.0 / (1.0 + std::exp(-log_odds)); }

/// The sensor model of LogOddsConfig in stored units, with the update rule of Eq. 8-9.
class LogOddsModel {
 public:
  explicit LogOddsModel(const LogOddsConfig& c)
      : hit_(quantizeLogOdds(c.hit)),
        miss_(quantizeLogOdds(c.miss)),
        min_(quantizeLogOdds(c.clamp_min)),
        max_(quantizeLogOdds(c.clamp_max)),
        occupied_(quantizeLogOdds(c.occupied_threshold)) {}

  /// Applies a hit (Eq. 8 then the saturation of Eq. 9). Unknown starts at 0 (P = 0.5).
  void hit(LogOddsQ& v) const { v = saturate((v == kUnknownLogOdds ? 0 : v) + hit_); }
  /// Applies a miss.
  void miss(LogOddsQ& v) const { v = saturate((v == kUnknownLogOdds ? 0 : v) + miss_); }
  /// Three-state reading of a stored value.
  [[nodiscard]] Occupancy state(LogOddsQ v) const {
    if (v == kUnknownLogOdds) return Occupancy::kUnknown;
    return v > occupied_ ? Occupancy::kOccupied : Occupancy::kFree;
  }
  [[nodiscard]] bool isOccupied(LogOddsQ v) const { return v != kUnknownLogOdds && v > occupied_; }
  /// The stored change of a miss, and the occupied threshold (a stored value above it is
  /// occupied): for updates that apply the rule to many voxels at once.
  [[nodiscard]] LogOddsQ missStep() const { return miss_; }
  [[nodiscard]] LogOddsQ occupiedThreshold() const { return occupied_; }
  [[nodiscard]] LogOddsQ clampMin() const { return min_; }
  [[nodiscard]] LogOddsQ clampMax() const { return max_; }

 private:
  [[nodiscard]] LogOddsQ saturate(int v) const {
    return static_cast<LogOddsQ>(std::clamp<int>(v, min_, max_));
  }
  LogOddsQ hit_, miss_, min_, max_, occupied_;
};

}  // namespace mlmap
