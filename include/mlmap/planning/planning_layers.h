#pragma once
/// @file
/// Builds what planners read (local window copy, projected 2D grid, ESDF) after each mapped frame
/// and publishes it as MapSnapshot objects. Owned by the engine; update() runs on the local-global
/// stage, snapshot() on any thread.
///
/// The ESDF is updated only when a voxel state changed inside its box or the box moved, and
/// at most at esdf.max_rate_hz (stamps of the frames); the update is incremental
/// (EsdfMap::update(): only what the changed voxels can affect; a box moved along x or y keeps
/// its kept part and computes the new slabs and what they and the removed faces reach, one
/// moved along z is computed whole), and a planner gets a copy of the field that
/// is brought up to date cell by cell. With `own_thread` it is computed on a planning
/// thread of its own so that mapping never waits for it; a frame that finds the thread busy
/// replaces the one waiting (latest only, counted). Otherwise it runs inside update().

#include "mlmap/core/config.h"
#include "mlmap/global/global_map.h"
#include "mlmap/local/local_map.h"
#include "mlmap/planning/map_snapshot.h"

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace mlmap {

/// Costs and counts of the planning layers. Times in ms per update.
struct PlanningStats {
  std::uint64_t snapshots = 0;          ///< snapshots published
  std::uint64_t grid_updates = 0;       ///< 2D grid changed (rebuilt or updated in part)
  std::uint64_t grid_rebuilds = 0;      ///< of those, rebuilt whole (window or band moved)
  std::uint64_t esdf_updates = 0;       ///< ESDF updated (incrementally or whole)
  std::uint64_t esdf_full = 0;          ///< of those, computed whole (first, load, many
                                        ///< changes, a box moved along z; see
                                        ///< EsdfMap::update())
  std::uint64_t esdf_unchanged = 0;     ///< skipped: no state change in the box, box still
  std::uint64_t esdf_rate_limited = 0;  ///< skipped: sooner than 1 / esdf.max_rate_hz
  std::uint64_t esdf_superseded = 0;    ///< planning thread busy: a newer frame took its place
  double last_snapshot_ms = 0.0;        ///< copying the window and publishing
  double last_grid_ms = 0.0;
  double last_esdf_ms = 0.0;
  double max_snapshot_ms = 0.0;
  double max_grid_ms = 0.0;
  double max_esdf_ms = 0.0;
  std::uint64_t esdf_frame = 0;    ///< frame the published ESDF was computed from
  std::size_t snapshot_bytes = 0;  ///< window copies and grids, pooled
  std::size_t esdf_bytes = 0;      ///< fields and work buffers, pooled
};

/// See the file comment.
class PlanningLayers {
 public:
  /// `esdf_published`, when given, is called on the planning thread each time it has published
  /// a snapshot with a new ESDF (`frame`, `stamp_s`: that snapshot's), so that a reader can
  /// wake then instead of polling.
  PlanningLayers(const MapConfig& config, bool own_thread,
                 std::function<void(std::uint64_t frame, double stamp_s)> esdf_published = {});
  ~PlanningLayers();
  PlanningLayers(const PlanningLayers&) = delete;
  PlanningLayers& operator=(const PlanningLayers&) = delete;

  /// After frame `frame` was integrated: copy, rebuild what is due, publish.
  void update(const LocalMap& local, const GlobalMap& global, std::uint64_t frame, double stamp_s,
              const Transform& T_W_B);
  /// The latest snapshot (never null). Thread-safe; cheap (a shared-pointer copy under a mutex).
  [[nodiscard]] std::shared_ptr<const MapSnapshot> snapshot() const;
  /// Waits until an ESDF handed to the planning thread is published.
  void flush();
  [[nodiscard]] PlanningStats stats() const;
  /// Bytes held by the published layers and the reusable buffers.
  [[nodiscard]] std::size_t memoryBytes() const;

 private:
  struct EsdfJob {
    std::shared_ptr<const LocalWindow> window;
    Eigen::Vector3d body_W = Eigen::Vector3d::Zero();
    std::uint64_t frame = 0;
    /// The local map's change clock and its submaps' state stamps (x-major, z fastest, over
    /// the window's submaps) when the window was copied: which parts of the box to refill.
    std::uint64_t clock = 0;
    std::vector<std::uint64_t> submap_stamps;
  };
  /// Fills esdf_box_ from the job's window: only the submaps whose states changed since the
  /// last fill when the window and the box are where they were (returns true, and lists their
  /// parts of the box in esdf_refilled_), else all of it (returns false).
  bool fillEsdfBox(const EsdfJob& job);
  /// A published field and its query copy (nullptr unless esdf.query_grid).
  struct PublishedEsdf {
    std::shared_ptr<const EsdfMap> map;
    std::shared_ptr<const EsdfQueryGrid> query_grid;
  };
  PublishedEsdf computeEsdf(const EsdfJob& job);
  /// Whether this frame's ESDF is computed, and why not.
  struct EsdfDecision {
    bool due = false;           ///< compute it (the box's state changed and the rate allows)
    bool unchanged = false;     ///< the box is where it was and nothing in it changed
    bool rate_limited = false;  ///< changed, but esdf.max_rate_hz says not yet
  };
  /// Rebuilds or patches the 2D grid (grid_) from `window`; its time [ms], -1 when unchanged.
  double updateGrid(const LocalMap& local, const GlobalMap& global, const LocalWindow& window,
                    const Eigen::Vector3d& body_W);
  /// Projects again the grid columns of the band's submaps that changed since the last grid;
  /// false when none did (grid_ unchanged).
  bool patchGridColumns(const LocalMap& local, const LocalWindow& window, int band_k0, int band_k1);
  /// Decides this frame's ESDF (and, when due, records the box and clock it is computed for).
  EsdfDecision decideEsdf(const LocalMap& local, const LocalWindow& window,
                          const Eigen::Vector3d& body_W, double stamp_s);
  /// The statistics of one update().
  void recordUpdate(double snapshot_ms, double grid_ms, double esdf_ms, std::uint64_t frame,
                    const EsdfDecision& decision, bool superseded);
  void publish(std::shared_ptr<const LocalWindow> window, std::shared_ptr<const ProjectedGrid> grid,
               PublishedEsdf esdf, bool keep_esdf, std::uint64_t frame, double stamp_s,
               const Transform& T_W_B);
  void planningLoop();
  [[nodiscard]] VoxelIndex esdfBoxMin(const LocalWindow& window, const Eigen::Vector3d& body_W,
                                      Eigen::Vector3i* size) const;
  template <typename T, typename... Args>
  static std::shared_ptr<T> reuse(std::vector<std::shared_ptr<T>>* pool, const Args&... args);

  MapConfig config_;
  bool own_thread_;

  mutable std::mutex snapshot_mutex_;  // guards snapshot_ (pointer swap only)
  std::shared_ptr<const MapSnapshot> snapshot_;

  // Local-global stage only.
  std::vector<std::shared_ptr<LocalWindow>> window_pool_;
  std::vector<std::shared_ptr<ProjectedGrid>> grid_pool_;
  std::shared_ptr<const ProjectedGrid> grid_;
  std::uint64_t grid_clock_ = 0;  // the local map's change clock when grid_ was made
  std::uint64_t grid_rebuilds_ = 0;
  std::uint64_t grid_global_ = 0;  // the global map's modifications() when grid_ was made
  VoxelIndex grid_window_min_ = VoxelIndex::Zero();
  int grid_band_k0_ = 0;
  int grid_band_k1_ = 0;
  std::uint64_t esdf_clock_ = 0;  // the local map's change clock when the last ESDF was due
  VoxelIndex esdf_box_min_ = VoxelIndex::Zero();
  Eigen::Vector3i esdf_box_size_ = Eigen::Vector3i::Zero();  // zero: no ESDF yet
  double esdf_stamp_s_ = -1e300;

  // ESDF computation (planning thread, or the local-global stage without one). The field is
  // updated incrementally in esdf_ (never published); snapshots get pooled copies of it, each
  // brought up to date by copying the cells changed since it was last filled.
  /// Whether a published copy is still held by a snapshot. The last holder's release clears
  /// `held` under the mutex, so the planning thread's next write to the copy happens after
  /// every read of it (a plain use_count() check gives no such order).
  struct EsdfLease {
    std::mutex mutex;
    bool held = false;
  };
  struct EsdfCopy {
    std::shared_ptr<EsdfMap> map;
    std::shared_ptr<EsdfLease> lease = std::make_shared<EsdfLease>();
    std::shared_ptr<EsdfQueryGrid> query_grid;  // map's query copy (esdf.query_grid)
    std::vector<std::uint32_t> pending;         // cells esdf_ changed since map was filled
    bool stale = true;                          // map must be copied whole
  };
  /// The published copy of esdf_ after an update (reusing a copy no snapshot holds), with its
  /// query copy brought up to date by the same cells.
  PublishedEsdf publishEsdfCopy();
  EsdfMap esdf_;
  std::vector<EsdfCopy> esdf_copies_;
  OccupancyBox esdf_box_;
  bool esdf_box_filled_ = false;                     // esdf_box_ holds a window's states
  VoxelIndex esdf_box_window_ = VoxelIndex::Zero();  // min_index of the window it was filled from
  std::uint64_t esdf_box_clock_ = 0;                 // that window's change clock
  std::vector<EsdfMap::Region> esdf_refilled_;       // parts of the box the last fill rewrote

  mutable std::mutex stats_mutex_;
  PlanningStats stats_;

  std::mutex job_mutex_;
  std::condition_variable job_cv_;
  bool has_job_ = false;
  bool busy_ = false;
  bool stopping_ = false;
  EsdfJob job_;
  std::function<void(std::uint64_t frame, double stamp_s)> esdf_published_;
  std::thread thread_;
};

}  // namespace mlmap
