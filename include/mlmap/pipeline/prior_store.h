#pragma once
/// @file
/// Part of the mapping engine (MapEngine, map_engine.h): the fleet's priors. PriorStore holds
/// other vehicles' submaps handed over as prior knowledge (MapEngine::addPrior()) until the
/// local-global stage adds them to the map, and publishes the voxels added (PriorVoxels) the way
/// a snapshot is published.

#include "mlmap/core/log_odds.h"
#include "mlmap/core/types.h"
#include "mlmap/global/global_map.h"
#include "mlmap/local/local_map.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <utility>
#include <vector>

namespace mlmap {

/// The voxels other vehicles' submaps added as prior knowledge (MapEngine::addPrior()), with the
/// log-odds each came with, for planners to tell them apart (read it next to a snapshot:
/// MapEngine::priors()) and for the fleet's share to send the vehicle's own evidence only
/// (fleet::SubmapShare: its value minus the prior's). A voxel counts as prior while it holds the
/// value it came with; the vehicle's own measurements change it (a prior is kept below
/// clamp_max, so even the first own hit does). Immutable.
class PriorVoxels {
 public:
  PriorVoxels() = default;
  /// A copy of `earlier` with `added` on top: per submap, the voxels added (ascending offsets
  /// inside the submap, with the log-odds each came with); `submap_cells`: voxels per submap and
  /// axis (the engine's).
  PriorVoxels(const PriorVoxels& earlier, const Eigen::Vector3i& submap_cells,
              const std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>>& added);
  /// True when `g` came from another vehicle and `window` (a snapshot's) still holds it with
  /// the value it came with. False outside the window.
  [[nodiscard]] bool isPrior(const VoxelIndex& g, const LocalWindow& window) const;
  /// The voxels of submap `m` added as priors (ascending offsets, the log-odds each came with);
  /// null when there are none.
  [[nodiscard]] const std::vector<VoxelRecord>* inSubmap(const SubmapIndex& m) const;
  /// Voxels ever added as priors.
  [[nodiscard]] std::size_t size() const { return size_; }

 private:
  Eigen::Vector3i submap_cells_ = Eigen::Vector3i::Ones();
  std::unordered_map<std::uint64_t, std::vector<VoxelRecord>> submaps_;  ///< by packed index
  std::size_t size_ = 0;
};

/// The priors waiting to be added to the map and the voxels added (PriorVoxels). add() and
/// published() may be called from any thread; apply() and forgetAdded() from one thread at a
/// time (the engine's local-global stage, or a caller holding the engine's layers).
class PriorStore {
 public:
  /// What apply() did.
  struct Applied {
    std::uint64_t voxels_added = 0;   ///< voxels the global map took (GlobalMap::addPrior())
    std::size_t submaps_waiting = 0;  ///< priors left waiting: their submap is in the window
  };

  /// `log_odds` is the engine's model: which records are occupied, and the clamp a prior stays
  /// below.
  explicit PriorStore(const LogOddsModel& log_odds) : log_odds_(log_odds) {}

  /// Takes another vehicle's records of submap `m` (see MapEngine::addPrior()): the occupied
  /// ones wait for apply(), merged with a prior of the same submap already waiting (the higher
  /// log-odds per voxel). Submap indices beyond GlobalMap's limit are ignored. Any thread.
  void add(const SubmapIndex& m, std::vector<VoxelRecord> records);
  /// Adds to `global` the waiting priors of the submaps `local`'s window does not hold (each
  /// log-odds kept below clamp_max), leaving the others waiting, and publishes the voxels
  /// `global` did not hold before.
  Applied apply(const LocalMap& local, GlobalMap* global);
  /// The voxels added since forgetAdded() (never null). Any thread.
  [[nodiscard]] std::shared_ptr<const PriorVoxels> published() const;
  /// Forgets the voxels added (the map they went into was emptied or replaced); the priors
  /// still waiting stay.
  void forgetAdded();

 private:
  LogOddsModel log_odds_;
  mutable std::mutex mutex_;  ///< guards the two below
  std::shared_ptr<const PriorVoxels> added_ = std::make_shared<const PriorVoxels>();
  /// By packed submap index: the submap and its records (ascending offsets).
  std::unordered_map<std::uint64_t, std::pair<SubmapIndex, std::vector<VoxelRecord>>> waiting_;
};

}  // namespace mlmap
