#pragma once
/// @file
/// What the engine's threads hand to the node's publishing thread: copies of the awareness and
/// global layers (made at their publishing rates), and the news that a snapshot is out.

#include "mlmap/awareness/awareness_map.h"
#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/fleet/submap_share.h"
#include "mlmap/global/global_map.h"
#include "mlmap/planning/map_snapshot.h"

#include <Eigen/Core>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace mlmap::dds::node {

/// Publishes at most at `rate_hz` (0: never).
class RateGate {
 public:
  explicit RateGate(double rate_hz);
  /// Enabled and the period ran out since mark() (or never marked).
  [[nodiscard]] bool due() const;
  void mark();

 private:
  using Clock = std::chrono::steady_clock;
  double period_s_ = 0.0;
  bool enabled_ = false;
  Clock::time_point last_ = Clock::time_point::min();
};

/// A layer's occupied points, copied on an engine thread for the publishing thread.
struct LayerCopy {
  std::vector<Eigen::Vector3f> points_W;  ///< cell / voxel centres in the world frame
  double stamp_s = 0.0;
  bool fresh = false;  ///< not taken yet
};

/// What the fleet output needs of one collection: the global map's changes since the previous
/// collection, the snapshot (its window) and the priors taken (MapEngine::priors()) of the same
/// frame.
struct FleetCopy {
  fleet::GlobalMapDelta delta;
  std::shared_ptr<const MapSnapshot> snap;
  std::shared_ptr<const PriorVoxels> priors;
  bool fresh = false;  ///< not taken yet
};

/// The hand-over from the engine's threads (copyAwareness, copyGlobal, announceSnapshot: a copy
/// and a notify, so mapping never waits for publishing) to the publishing thread (take()).
/// Thread-safe.
class LayerMailbox {
 public:
  /// `fleet_rate_hz`: how often copyFleet() collects (0: never).
  explicit LayerMailbox(const PublishRates& rates, double fleet_rate_hz = 0.0);

  /// Copies the awareness map's occupied cells when awareness_hz allows.
  void copyAwareness(const AwarenessMap& map, double stamp_s);
  /// Copies the global map's voxels when it changed (`version`) and global_map_hz allows (or
  /// `force`).
  void copyGlobal(const GlobalMap& map, double stamp_s, std::uint64_t version, bool force = false);
  /// Collects the global map's changes since the last collection, with `snap` (the snapshot of
  /// the frame `map` is at) and `priors` (the engine's priors as `map` holds them), when
  /// fleet_rate_hz allows (or `force`). Earlier collections not taken yet are merged with it.
  void copyFleet(const GlobalMap& map, std::shared_ptr<const MapSnapshot> snap,
                 std::shared_ptr<const PriorVoxels> priors, bool force = false);
  /// A frame's snapshot is out.
  void announceSnapshot();
  /// The publishing thread is to publish once more and end.
  void close();

  /// What take() hands over.
  struct News {
    LayerCopy awareness;
    LayerCopy global;
    FleetCopy fleet;
    bool last = false;  ///< closed: publish the final state and end
  };
  /// Waits up to `poll` for news and takes it.
  News take(std::chrono::milliseconds poll);

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  LayerCopy awareness_;
  LayerCopy global_;
  RateGate awareness_gate_;
  RateGate global_gate_;
  std::uint64_t global_version_ = ~std::uint64_t{0};
  FleetCopy fleet_;
  RateGate fleet_gate_;
  std::uint64_t fleet_version_ = 0;  ///< the global map's version at the last collection
  bool snapshot_fresh_ = false;
  bool closed_ = false;
};

}  // namespace mlmap::dds::node
