#pragma once
/// @file
/// Part of the mapping engine (MapEngine, map_engine.h): what it counts and times. EngineStats
/// is what MapEngine::stats() returns; EngineStatsRecorder keeps it, the recent timings of the
/// two stages and the order of the frames' stamps behind one mutex.

#include "mlmap/awareness/awareness_stage.h"
#include "mlmap/local/local_map.h"
#include "mlmap/planning/planning_layers.h"

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

namespace mlmap {

/// Median, 99th percentile, mean and maximum of the recent samples of a stage, in ms.
struct TimingSummary {
  double median_ms = 0.0;   ///< median [ms]
  double p99_ms = 0.0;      ///< 99th percentile [ms]
  double mean_ms = 0.0;     ///< mean [ms]
  double max_ms = 0.0;      ///< maximum [ms]
  std::size_t samples = 0;  ///< samples summarised
};

/// The q-quantile (0..1) of ascending, non-empty `sorted` values, by nearest rank: the one rule
/// behind every median and p99 mlmap reports.
double sortedQuantile(const std::vector<double>& sorted, double q);
/// Median, p99, mean and maximum of `values_ms` (any order).
TimingSummary summarizeTimings(std::vector<double> values_ms);

/// Memory in bytes by layer.
struct MemoryUsage {
  std::size_t awareness_bytes = 0;  ///< cylindrical grid, per-frame scratch and batch
  std::size_t local_bytes = 0;      ///< active-area voxels
  std::size_t global_bytes = 0;     ///< retired submaps' occupied voxels
  std::size_t planning_bytes = 0;   ///< snapshots (window copies, 2D grids) and ESDF buffers
  /// Sum of the layers' bytes.
  [[nodiscard]] std::size_t total() const {
    return awareness_bytes + local_bytes + global_bytes + planning_bytes;
  }
};

/// Everything the engine counts. Frames: in = accepted + rejected_*; dropped counts accepted
/// frames that were discarded because the input queue was full (threaded mode only).
struct EngineStats {
  std::uint64_t frames_in = 0;              ///< frames submitted
  std::uint64_t frames_mapped = 0;          ///< frames through both stages
  std::uint64_t frames_dropped = 0;         ///< accepted, dropped from a full input queue
  std::uint64_t rejected_invalid_pose = 0;  ///< FrameStatus::kInvalidPose
  std::uint64_t rejected_out_of_order = 0;  ///< FrameStatus::kOutOfOrder
  /// First frames after restoreState() older than the loaded map's last stamp (another time
  /// base: a map saved on wall-clock time, a sensor on sim time): accepted, the stamp order
  /// restarted from them (at most one per load).
  std::uint64_t stamp_order_restarts = 0;
  std::uint64_t rejected_empty = 0;      ///< FrameStatus::kEmpty
  std::uint64_t rejected_bad_image = 0;  ///< FrameStatus::kBadImage
  PointCounters points;                  ///< the awareness stage's points
  LocalMapCounters local;                ///< the local map's counters
  TimingSummary awareness;               ///< points -> awareness map + measurements
  TimingSummary local_global;            ///< re-centring + log-odds updates
  TimingSummary total;                   ///< both stages of one frame
  MemoryUsage memory;                    ///< bytes by layer
  std::size_t global_voxels = 0;         ///< occupied voxels in the global map
  std::size_t global_submaps = 0;        ///< submaps in the global map
  /// Hit voxel updates beyond the local window (its hits_outside_window and the points'
  /// hits_beyond_local_map, one per voxel and frame) applied to the global map instead.
  std::uint64_t hits_to_global = 0;
  /// Hits in range that no layer could hold (beyond the global map's submap index range).
  std::uint64_t hits_lost = 0;
  /// Voxels of other vehicles added as prior knowledge (addPrior()), and the submaps still
  /// waiting because they lie in the local window.
  std::uint64_t prior_voxels_added = 0;
  std::size_t prior_submaps_waiting = 0;
  PlanningStats planning;  ///< snapshots, 2D grid and ESDF (not part of `total`)
};

/// The last `capacity` samples of a stage's time [ms], oldest overwritten first.
class TimingWindow {
 public:
  /// Frames kept for the median and p99 of MapEngine::stats().
  static constexpr std::size_t kCapacity = 2000;
  /// Adds a sample [ms], replacing the oldest once kCapacity are held.
  void add(double ms);
  /// Median, p99, mean and maximum of the samples held.
  [[nodiscard]] TimingSummary summary() const { return summarizeTimings(values_ms_); }

 private:
  std::vector<double> values_ms_;
  std::size_t next_ = 0;  ///< where the next sample goes once full
};

/// The order of the frames' stamps (MapEngine::submit()): the last accepted stamp.
struct StampOrder {
  double last_stamp_s = -1e300;  ///< stamp of the last accepted frame [s]
  bool have_stamp = false;       ///< a frame was accepted, or a map with a stamp restored
  bool from_load = false;        ///< last_stamp_s came from restoreState(), no frame since
};

/// What the engine records, all behind one mutex: a frame's admission, its counters and its
/// timings change together, so that stats() sees them consistent. Any thread.
class EngineStatsRecorder {
 public:
  /// The recorded state, handed to update()'s function under the lock.
  struct Record {
    EngineStats stats;          ///< counters and memory (the timing summaries left empty)
    StampOrder stamps;          ///< the order frames are admitted in
    TimingWindow awareness_ms;  ///< the awareness stage's time per frame
    TimingWindow local_ms;      ///< the local-global stage's
    TimingWindow total_ms;      ///< both stages' of one frame
  };

  /// Runs `f(record)` under the lock and returns what it returns.
  template <typename F>
  decltype(auto) update(F&& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    return f(record_);
  }
  /// The counters with the timing summaries of the samples held (planning left empty).
  [[nodiscard]] EngineStats stats() const;

 private:
  mutable std::mutex mutex_;
  Record record_;
};

}  // namespace mlmap
