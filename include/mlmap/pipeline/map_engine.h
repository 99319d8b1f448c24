#pragma once
/// @file
/// The mapping engine (paper V-A, Figure 5): input validation, the awareness stage and the
/// local-global stage, either synchronously on the caller's thread (deterministic; tests,
/// benchmarks, replay) or on two threads joined by bounded queues.

#include "mlmap/awareness/awareness_stage.h"
#include "mlmap/core/config.h"
#include "mlmap/global/global_map.h"
#include "mlmap/local/local_map.h"
#include "mlmap/local/map_state.h"
#include "mlmap/planning/planning_layers.h"
#include "mlmap/pipeline/rate_limited_log.h"

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <variant>
#include <vector>

namespace mlmap {

/// Why a frame was not mapped.
enum class FrameStatus {
  kAccepted,         ///< mapped (synchronous) or queued (threaded)
  kInvalidPose,      ///< T_W_B or T_B_S not finite or not a rotation, or absurdly far away
  kOutOfOrder,       ///< stamp not newer than the last accepted frame, or not finite
  kEmpty,            ///< no points / no valid pixels
  kBadImage,         ///< depth image size disagrees with its intrinsics
  kStopped,          ///< engine shutting down
};
const char* toString(FrameStatus status);

/// Median, 99th percentile, mean and maximum of the recent samples of a stage, in ms.
struct TimingSummary {
  double median_ms = 0.0;
  double p99_ms = 0.0;
  double mean_ms = 0.0;
  double max_ms = 0.0;
  std::size_t samples = 0;
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
  [[nodiscard]] std::size_t total() const {
    return awareness_bytes + local_bytes + global_bytes + planning_bytes;
  }
};

/// Everything the engine counts. Frames: in = accepted + rejected_*; dropped counts accepted
/// frames that were discarded because the input queue was full (threaded mode only).
struct EngineStats {
  std::uint64_t frames_in = 0;
  std::uint64_t frames_mapped = 0;
  std::uint64_t frames_dropped = 0;
  std::uint64_t rejected_invalid_pose = 0;
  std::uint64_t rejected_out_of_order = 0;
  /// First frames after restoreState() older than the loaded map's last stamp (another time
  /// base: a map saved on wall-clock time, a sensor on sim time): accepted, the stamp order
  /// restarted from them (at most one per load).
  std::uint64_t stamp_order_restarts = 0;
  std::uint64_t rejected_empty = 0;
  std::uint64_t rejected_bad_image = 0;
  PointCounters points;
  LocalMapCounters local;
  TimingSummary awareness;     ///< points -> awareness map + measurements
  TimingSummary local_global;  ///< re-centring + log-odds updates
  TimingSummary total;         ///< both stages of one frame
  MemoryUsage memory;
  std::size_t global_voxels = 0;
  std::size_t global_submaps = 0;
  /// Hit voxel updates beyond the local window (its hits_outside_window and the points'
  /// hits_beyond_local_map, one per voxel and frame) applied to the global map instead.
  std::uint64_t hits_to_global = 0;
  /// Hits in range that no layer could hold (beyond the global map's submap index range).
  std::uint64_t hits_lost = 0;
  /// Voxels of other vehicles added as prior knowledge (addPrior()), and the submaps still
  /// waiting because they lie in the local window.
  std::uint64_t prior_voxels_added = 0;
  std::size_t prior_submaps_waiting = 0;
  PlanningStats planning;      ///< snapshots, 2D grid and ESDF (not part of `total`)
};


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

/// Optional observers of the layers the snapshot does not carry, and of each new snapshot,
/// called on the engine's own threads (the caller's in synchronous mode) while that layer is not
/// being written. They run inside the mapping loop: copy what you need and return (e.g. a
/// publisher's hand-over).
struct EngineObservers {
  /// After the awareness update of every frame (awareness thread).
  std::function<void(const AwarenessMap& map, double stamp_s, const Transform& T_W_B)> awareness;
  /// After the local-global update of every frame (local-global thread). `version` is the
  /// global map's modifications() (submap moves between the local and the global map, hits
  /// beyond the window): the global map changed exactly when it differs from the previous
  /// call's.
  std::function<void(const GlobalMap& map, double stamp_s, std::uint64_t version)> global;
  /// After the snapshot of every mapped frame is published (local-global thread, before
  /// `global`): from then on snapshot() returns it or a newer one. `frame` is its
  /// MapSnapshot::frame(). Lets a publisher wake as soon as there is something new instead of
  /// polling. (A snapshot the planning thread republishes with a new ESDF is not announced.)
  /// Never called when pipeline.planning_layers is false: no snapshot is made.
  std::function<void(std::uint64_t frame, double stamp_s)> snapshot;
};

/// Owns the three layers. Submit frames from one thread; read the layers after flush().
class MapEngine {
 public:
  /// Throws std::invalid_argument listing every problem when `config` is not valid.
  explicit MapEngine(const MapConfig& config, LogSink log = {}, EngineObservers observers = {});
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

  [[nodiscard]] EngineStats stats() const;
  [[nodiscard]] const MapConfig& config() const { return config_; }

  /// Layers, valid to read after flush() while no frame is being submitted.
  [[nodiscard]] const AwarenessMap& awareness() const { return awareness_.map(); }
  [[nodiscard]] const LocalMap& localMap() const { return local_; }
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
  /// records below occupancy, another vehicle's free evidence, are left out) as prior knowledge: before the next frame the local-global stage adds each of them that the
  /// map does not hold (GlobalMap::addPrior(): the vehicle's own evidence wins), so when the
  /// vehicle enters that submap its window is restored with them before its own sensor sees
  /// them; its measurements then update them as any voxel. A prior's log-odds is kept below
  /// clamp_max (at most clamp_max - 0.001), so the first own hit changes it and priors() no
  /// longer marks it. A submap of the local window waits
  /// until it leaves the window (the vehicle observes it itself meanwhile); a later prior of the
  /// same submap is merged with a waiting one (the higher log-odds per voxel). Any thread.
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
  using Input = std::variant<PointCloudFrame, DepthFrame>;
  FrameStatus admit(double stamp_s, const Transform& T_W_B, const Transform& T_B_S);
  void process(Input& input, MeasurementBatch* batch);
  void awarenessStep(Input& input, MeasurementBatch* batch);
  void localStep(const MeasurementBatch& batch);
  void applyPriors();
  void awarenessLoop();
  void localLoop();
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
  std::uint64_t frames_integrated_ = 0;  // local-global stage only (written under layers_mutex_)
  std::uint64_t hits_to_global_ = 0;     // EngineStats::hits_to_global (same stage)
  std::uint64_t hits_lost_ = 0;          // EngineStats::hits_lost (same stage)
  std::uint64_t prior_voxels_added_ = 0; // EngineStats::prior_voxels_added (same stage)
  std::size_t priors_waiting_ = 0;       // EngineStats::prior_submaps_waiting (same stage)

  // Priors handed over by addPrior() (any thread), by packed submap index, and those added
  // (published like a snapshot: a pointer swapped under prior_mutex_).
  mutable std::mutex prior_mutex_;
  std::shared_ptr<const PriorVoxels> prior_voxels_ = std::make_shared<const PriorVoxels>();
  std::unordered_map<std::uint64_t, std::pair<SubmapIndex, std::vector<VoxelRecord>>> priors_;

  // Guards local_ and global_ against exportState() while the local-global stage writes them,
  // and the state of the last mapped frame.
  mutable std::mutex layers_mutex_;
  bool has_mapped_stamp_ = false;
  double last_mapped_stamp_s_ = 0.0;
  Transform last_T_W_B_ = Transform::Identity();
  std::uint64_t frames_restored_ = 0;  // frames mapped before the state restored last

  // Statistics, guarded by stats_mutex_.
  mutable std::mutex stats_mutex_;
  EngineStats stats_;
  struct Samples {
    std::vector<double> values;
    std::size_t next = 0;
    void add(double v);
    [[nodiscard]] TimingSummary summary() const;
  };
  Samples awareness_ms_, local_ms_, total_ms_;
  double last_stamp_s_ = -1e300;
  bool have_stamp_ = false;
  bool stamp_from_load_ = false;  ///< last_stamp_s_ came from restoreState(), no frame since

  // Threaded mode.
  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<Input> inputs_;
  std::deque<std::unique_ptr<MeasurementBatch>> batches_;
  std::vector<std::unique_ptr<MeasurementBatch>> batch_pool_;
  std::size_t in_flight_ = 0;  // frames taken from the input queue, not yet mapped
  bool stopping_ = false;
  std::thread awareness_thread_;
  std::thread local_thread_;
  MeasurementBatch sync_batch_;
};

}  // namespace mlmap
