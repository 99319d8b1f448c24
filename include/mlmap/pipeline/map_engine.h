#pragma once
/// @file
/// The mapping engine (paper V-A, Figure 5): input validation, the awareness stage and the
/// local-global stage, either synchronously on the caller's thread (deterministic; tests,
/// benchmarks, replay) or on two threads joined by bounded queues.
///
/// The parts: the threads and the hand-over between them are StageThreads (stage_threads.h),
/// the fleet's priors PriorStore (prior_store.h), the counters, timings and stamp order
/// EngineStatsRecorder (engine_stats.h); MapEngine validates frames, runs the two stages on the
/// layers and saves, restores and clears them.

#include "mlmap/awareness/awareness_stage.h"
#include "mlmap/core/config.h"
#include "mlmap/global/global_map.h"
#include "mlmap/local/local_map.h"
#include "mlmap/local/map_state.h"
#include "mlmap/planning/planning_layers.h"
#include "mlmap/pipeline/engine_stats.h"
#include "mlmap/pipeline/prior_store.h"
#include "mlmap/pipeline/rate_limited_log.h"
#include "mlmap/pipeline/stage_threads.h"

#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <variant>
#include <vector>

namespace mlmap {

/// Why a frame was not mapped.
enum class FrameStatus {
  kAccepted,     ///< mapped (synchronous) or queued (threaded)
  kInvalidPose,  ///< T_W_B or T_B_S not finite or not a rotation, or absurdly far away
  kOutOfOrder,   ///< stamp not newer than the last accepted frame, or not finite
  kEmpty,        ///< no points / no valid pixels
  kBadImage,     ///< depth image size disagrees with its intrinsics
  kStopped,      ///< engine shutting down
};
/// The status's name, for logs.
const char* toString(FrameStatus status);

/// Optional observers of the layers the snapshot does not carry, and of each new snapshot,
/// called on the engine's own threads (the caller's in synchronous mode) while that layer is not
/// being written. They run inside the mapping loop: copy what you need and return (e.g. a
/// publisher's hand-over).
struct EngineObservers {
  /// After the awareness update of every frame (the local-global thread in threaded mode, where
  /// the awareness map is updated beside the carving).
  std::function<void(const AwarenessMap& map, double stamp_s, const Transform& T_W_B)> awareness;
  /// After the local-global update of every frame (local-global thread). `version` is the
  /// global map's modifications() (submap moves between the local and the global map, hits
  /// beyond the window): the global map changed exactly when it differs from the previous
  /// call's.
  std::function<void(const GlobalMap& map, double stamp_s, std::uint64_t version)> global;
  /// After the snapshot of every mapped frame is published (local-global thread, before
  /// `global`): from then on snapshot() returns it or a newer one. `frame` is its
  /// MapSnapshot::frame(). Lets a publisher wake as soon as there is something new instead of
  /// polling (a snapshot the planning thread republishes with a new ESDF: `esdf`).
  /// Never called when pipeline.planning_layers is false: no snapshot is made.
  std::function<void(std::uint64_t frame, double stamp_s)> snapshot;
  /// After the planning thread (pipeline.threaded) republished the latest snapshot with a new
  /// ESDF (planning thread); `frame` and `stamp_s` are that snapshot's. Without it a publisher
  /// woken by `snapshot` finds the ESDF only when it looks again.
  std::function<void(std::uint64_t frame, double stamp_s)> esdf;
};

/// Owns the three layers. Submit frames from one thread; read the layers after flush().
class MapEngine {
 public:
  /// Throws std::invalid_argument listing every problem when `config` is not valid.
  explicit MapEngine(const MapConfig& config, LogSink log = {}, EngineObservers observers = {});
  /// Stops the threads (threaded mode): frames still queued are not mapped.
  ~MapEngine();
  MapEngine(const MapEngine&) = delete;
  MapEngine& operator=(const MapEngine&) = delete;

  /// Validates and maps (synchronous) or queues (threaded) a point cloud in the sensor frame.
  FrameStatus submit(PointCloudFrame frame);
  /// The same for a depth image; it is back-projected on the awareness stage.
  FrameStatus submit(DepthFrame frame);
  /// Waits until every queued frame is mapped and its planning layers are published (no-op in
  /// synchronous mode).
  void flush();

  /// What planners read: the latest snapshot of the local window, 2D grid and ESDF. Safe to call
  /// from any thread at any time; keep the pointer for a planning cycle (see MapSnapshot). With
  /// pipeline.planning_layers false it stays the empty snapshot of a new engine.
  [[nodiscard]] std::shared_ptr<const MapSnapshot> snapshot() const { return planning_.snapshot(); }

  /// What the engine counted and timed so far (any thread).
  [[nodiscard]] EngineStats stats() const;
  /// The configuration in use.
  [[nodiscard]] const MapConfig& config() const { return config_; }

  /// Layers, valid to read after flush() while no frame is being submitted: the awareness map,
  [[nodiscard]] const AwarenessMap& awareness() const { return awareness_.map(); }
  /// the local map,
  [[nodiscard]] const LocalMap& localMap() const { return local_; }
  /// the global map.
  [[nodiscard]] const GlobalMap& globalMap() const { return global_; }
  /// State of a world voxel: the local map inside the window, the global map outside it
  /// (occupied if stored there, unknown otherwise).
  [[nodiscard]] Occupancy state(const VoxelIndex& index) const;
  /// Every occupied voxel, local and global, with its log-odds (after flush()).
  [[nodiscard]] std::vector<VoxelIndex> occupiedVoxels() const;

  /// The local and global layers as they are between two frames (what a map file saves). Safe to
  /// call from any thread at any time: it waits for the frame being integrated, if any. Frames
  /// still queued are not in it; call flush() first to include them (e.g. at shutdown).
  [[nodiscard]] MapState exportState() const;
  /// Replaces the local and global layers by `state` (a loaded map) and publishes a snapshot of
  /// it. Later frames must be newer than its last stamp, except the first one: when that one is
  /// older (the map was saved on another time base), the stamp order restarts from it, counted
  /// (stamp_order_restarts) and logged with both stamps. Call before submitting frames, or after
  /// flush() with no frame in flight. Throws std::invalid_argument, changing nothing, when the
  /// state does not fit this engine (voxel size, window size or log-odds model differ from the
  /// configuration, or its data is inconsistent); the message names what differs.
  void restoreState(const MapState& state);
  /// Takes another vehicle's occupied voxels of submap `m` (ascending offsets inside the submap,
  /// with their log-odds, as GlobalMap holds them; e.g. from the fleet's mlmap_msgs/Submap; the
  /// records below occupancy, another vehicle's free evidence, are left out) as prior knowledge:
  /// before the next frame the local-global stage adds each of them that the map does not hold
  /// (GlobalMap::addPrior(): the vehicle's own evidence wins), so when the vehicle enters that
  /// submap its window is restored with them before its own sensor sees them; its measurements then
  /// update them as any voxel. A prior's log-odds is kept below clamp_max (at most clamp_max -
  /// 0.001), so the first own hit changes it and priors() no longer marks it. A submap of the local
  /// window waits until it leaves the window (the vehicle observes it itself meanwhile); a later
  /// prior of the same submap is merged with a waiting one (the higher log-odds per voxel). Any
  /// thread.
  void addPrior(const SubmapIndex& m, std::vector<VoxelRecord> records);
  /// The voxels added as priors since the map was last emptied (clear(), restoreState()); see
  /// PriorVoxels: never null, safe from any thread.
  [[nodiscard]] std::shared_ptr<const PriorVoxels> priors() const;

  /// Empties the local and the global map (what planners, the 2D grid, the ESDF and a map file
  /// hold): the window is unplaced, so the next mapped frame places it around the body again and
  /// maps from nothing. Frames queued before the call are mapped first, then cleared (threaded
  /// mode: it waits until the engine is idle, holding off new frames meanwhile; synchronous mode:
  /// call it between two submit() calls). Then publishes an empty snapshot and calls the
  /// `global` observer with a new version. The awareness map (the sensor's view of the last
  /// frames, rebuilt with each frame) is kept, and so are the stamp order (later frames must
  /// still be newer than the last one mapped) and the counters. Any thread.
  void clear();

 private:
  using Input = EngineInput;
  FrameStatus admit(double stamp_s, const Transform& T_W_B, const Transform& T_B_S);
  void process(Input& input, MeasurementBatch* batch);
  /// The awareness stage of a frame: all of it (synchronous), or its first half (threaded:
  /// AwarenessStage::collect(), the carving is left to carveStep() on the local-global thread).
  void awarenessStep(Input& input, MeasurementBatch* batch);
  /// Threaded: the awareness stage's second half (AwarenessStage::carve()), on the local-global
  /// thread before localStep(): the two threads then carry about equal shares of a frame.
  /// Returns the milliseconds of the awareness map's update, where it was done there.
  double carveStep(MeasurementBatch* batch);
  void localStep(const MeasurementBatch& batch);
  void applyPriors();
  FrameStatus enqueue(Input input);

  MapConfig config_;
  RateLimitedLog log_;  // one line per reason and second
  EngineObservers observers_;
  AwarenessStage awareness_;
  LocalMap local_;
  GlobalMap global_;
  LogOddsModel log_odds_model_;
  std::vector<VoxelIndex> beyond_window_;  // a frame's hits outside the window (scratch)
  PlanningLayers planning_;
  std::uint64_t frames_integrated_ = 0;   // local-global stage only (written under layers_mutex_)
  std::uint64_t hits_to_global_ = 0;      // EngineStats::hits_to_global (same stage)
  std::uint64_t hits_lost_ = 0;           // EngineStats::hits_lost (same stage)
  std::uint64_t prior_voxels_added_ = 0;  // EngineStats::prior_voxels_added (same stage)
  std::size_t priors_waiting_ = 0;        // EngineStats::prior_submaps_waiting (same stage)

  // Priors handed over by addPrior() (any thread) and those added (published like a snapshot).
  PriorStore priors_;

  // Guards local_ and global_ against exportState() while the local-global stage writes them,
  // and the state of the last mapped frame.
  mutable std::mutex layers_mutex_;
  bool has_mapped_stamp_ = false;
  double last_mapped_stamp_s_ = 0.0;
  Transform last_T_W_B_ = Transform::Identity();
  std::uint64_t frames_restored_ = 0;  // frames mapped before the state restored last

  // Counters, stage timings and the stamp order (its own mutex).
  EngineStatsRecorder stats_;

  MeasurementBatch sync_batch_;  // synchronous mode's one batch
  // Threaded mode: the free set of every batch, lent to each in turn by the local-global thread
  // (the only one that writes or reads a free set there): its pages stay mapped and in that
  // core's cache, where each batch of the pool had a set of its own to fault in and bring over.
  VoxelBitset carve_free_;
  std::atomic<std::size_t> carve_free_bytes_{0};  // carve_free_'s memoryBytes(), for the stats
  /// The shortest of a thread's last four frames [ms]: a frame's window move or fresh pages do
  /// not decide where the awareness map goes.
  struct RecentMinimum {
    std::array<double, 4> ms{};
    std::size_t count = 0;
    /// Adds a frame's milliseconds; returns the shortest of the last four.
    double add(double frame_ms);
    /// Whether four frames were added (the shortest is of a full window).
    [[nodiscard]] bool full() const { return count >= ms.size(); }
  };
  // Threaded: each thread's milliseconds per frame without the awareness map and the cone
  // listing (the shortest of the last few), which decide the half that updates the map
  // (AwarenessStage::placeAwarenessMap()) and how far the first half takes the cone listing
  // (AwarenessStage::placeConeListing()).
  RecentMinimum awareness_recent_;              // the awareness thread's
  RecentMinimum local_recent_;                  // the local-global thread's
  double awareness_half_ms_ = -1.0;             // the awareness thread's (-1: none yet)
  std::atomic<double> local_half_ms_{-1.0};     // the local-global thread's (-1: none yet)
  std::atomic<double> map_half_ms_{-1.0};       // the awareness map's update, on either thread
  bool map_in_carve_ = true;                    // the place last chosen (the awareness thread's)
  std::atomic<double> bins_half_ms_{-1.0};      // the listing's bin entry, on either thread
  std::atomic<double> cones_half_ms_{-1.0};     // the rest of the listing, on either thread
  std::atomic<bool> local_recent_full_{false};  // local_recent_.full(), for the awareness thread
  // How far the awareness thread takes the cone listing, last chosen (the awareness thread's).
  AwarenessStage::ConeListingStep listing_in_awareness_ = AwarenessStage::ConeListingStep::kNothing;
  // Threaded mode: the two stage threads and their queues (null in synchronous mode; last, so
  // that the threads stop before anything they use is destroyed).
  std::unique_ptr<StageThreads> stages_;
};

}  // namespace mlmap
