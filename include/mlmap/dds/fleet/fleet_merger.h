#pragma once
/// @file
/// mlmap_fleet's node: reads each vehicle's mlmap_msgs/Submap samples on its own topic
/// rt/<vehicle>/mlmap/submaps (the listed vehicles', or every one discovery finds; SubmapReaders)
/// (TRANSIENT_LOCAL: a merger that starts late or comes back gets each writer's latest state of
/// every submap), fuses them in a fleet::FleetMap, and publishes the merged map as standard ROS 2
/// topics: the occupied voxels as sensor_msgs/PointCloud2 (x, y, z, rgb by the first vehicle
/// holding the voxel, and `vehicles`: a bit per vehicle), a 2D nav_msgs/OccupancyGrid of a height
/// band (both TRANSIENT_LOCAL, only when the map changed) and mlmap_msgs/FleetStatus (each
/// vehicle's last sample, bytes, submaps, voxels, stale or not).

#include "mlmap/core/config.h"
#include "mlmap/core/log_odds.h"
#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/dds/fleet/fleet_intake.h"
#include "mlmap/fleet/fleet_map.h"
#include "mlmap/pipeline/rate_limited_log.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace mlmap::dds {

/// What mlmap_fleet does.
struct FleetMergerConfig {
  DdsConfig dds;  ///< domain, discovery, world_frame, ns of outputs
  /// Input: vehicle V's submaps on /V/<submaps_topic> (vehicleSubmapTopic()).
  std::string submaps_topic = "mlmap/submaps";
  std::string cloud_topic = "mlmap/fleet/occupied";  ///< output PointCloud2 (under dds.ns)
  std::string grid_topic = "mlmap/fleet/grid";       ///< output OccupancyGrid (under dds.ns)
  std::string status_topic = "mlmap/fleet/status";   ///< output FleetStatus (under dds.ns)
  double publish_hz = 1.0;      ///< outputs at most this often (when changed), status always
  double stale_after_s = 10.0;  ///< a vehicle silent this long is stale (its voxels kept)
  double grid_min_z_m = 0.2;    ///< the grid's band of voxel centre heights [m]
  double grid_max_z_m = 2.0;
  LogOddsConfig log_odds;  ///< clamping bounds and threshold of the fused log-odds
  /// The grid, the known vehicles and the memory budgets (docs/fleet.md#trust).
  FleetTrustConfig trust;
};

/// One vehicle as the status reports it.
struct FleetVehicleStatus {
  fleet::FleetVehicle info;
  double seconds_since_seen = 0.0;
  bool stale = false;
};

/// What the merger has done.
struct FleetMergerStats {
  std::vector<FleetVehicleStatus> vehicles;
  std::size_t merged_voxels = 0;
  std::size_t submaps = 0;
  std::size_t memory_bytes = 0;
  std::uint64_t samples_received = 0;
  /// Samples refused or dropped, for any reason (the sum of `refused`).
  std::uint64_t samples_rejected = 0;
  /// Refused and dropped samples by reason (index: SubmapRefusal).
  SubmapRefusalCounts refused{};
  /// Times a vehicle's samples came from a new writer (a restart), all vehicles.
  std::uint64_t restarts = 0;
  /// Submap writers (vehicles) the merger's reader is matched with now, whether or not they
  /// have sent anything yet. A vehicle that leaves before its writer matched the merger's
  /// reader is never heard: discovery takes a moment, longer on a busy machine.
  int publishers_matched = 0;
  /// Vehicle topics found by discovery but not read (SubmapReaders::topicsIgnored()).
  std::uint64_t topics_ignored = 0;
  std::uint64_t clouds_published = 0;
  std::uint64_t grids_published = 0;
};

/// The merger. Thread-safe.
class FleetMerger {
 public:
  /// Joins the domain, creates the reader and the writers. Throws std::runtime_error (or
  /// std::invalid_argument for a bad config) with the reason.
  explicit FleetMerger(const FleetMergerConfig& config, LogSink log = {});
  ~FleetMerger();
  FleetMerger(const FleetMerger&) = delete;
  FleetMerger& operator=(const FleetMerger&) = delete;

  /// Starts the publishing thread.
  void start();
  /// Publishes the final state, ends the thread, leaves the domain. Idempotent.
  void stop();

  [[nodiscard]] FleetMergerStats stats() const;
  /// The merged map's occupied voxels with their vehicle bits.
  [[nodiscard]] std::vector<std::pair<VoxelIndex, std::uint64_t>> occupiedVoxels() const;
  /// The merged map as a map file holds it (fleet::fleetMapState(); throws as it does, and
  /// std::runtime_error when no vehicle's sample was applied: nothing to save).
  [[nodiscard]] MapState mapState() const;
  /// One line: vehicles (name, last seen, kB, submaps, voxels, restarts, stale), merged voxels,
  /// memory, refused samples by reason.
  [[nodiscard]] std::string statusLine() const;
  [[nodiscard]] int domainId() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlmap::dds
