#pragma once
/// @file
/// The awareness stage (paper Algorithm 2): turns one frame into the awareness map update and the
/// occupied / free measurements for the local map.

#include "mlmap/awareness/awareness_map.h"
#include "mlmap/awareness/cone_carver.h"
#include "mlmap/awareness/point_kernel.h"
#include "mlmap/core/measurement_batch.h"
#include "mlmap/core/config.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <random>
#include <vector>

namespace mlmap {

class TaskThreads;

/// What happened to the points of frames (summed over frames by the engine).
struct PointCounters {
  std::uint64_t points_in = 0;            ///< points received
  std::uint64_t rejected_non_finite = 0;  ///< NaN / Inf coordinates
  std::uint64_t rejected_too_close = 0;   ///< closer than awareness.min_range_m (incl. zero range)
  std::uint64_t beyond_max_range = 0;     ///< cut at max_range_m: clear their ray, are no hit
  /// Within range but farther from the sensor than the local map can hold (3 submaps beyond the
  /// body's): they mark the awareness map and clear their ray, and their voxels get a hit in the
  /// global map (MeasurementBatch::far_hits).
  std::uint64_t hits_beyond_local_map = 0;
  /// Of them, the points within the local map's horizontal reach but above or below it (a
  /// LiDAR's upper and lower beams): a taller local_map.size_cells z holds them.
  std::uint64_t hits_above_or_below_local_map = 0;
  std::uint64_t sampled_out = 0;  ///< left out by sample_count
  std::uint64_t hit_voxels = 0;   ///< occupied measurements (unique voxels)
  std::uint64_t free_voxels = 0;  ///< free measurements (unique voxels)

  PointCounters& operator+=(const PointCounters& o);
};

/// Runs the awareness map and produces measurement batches. Not thread-safe: one owner thread.
class AwarenessStage {
 public:
  /// Points are classified in blocks of this many (structure of arrays, vectorised).
  static constexpr std::size_t kPointBlock = 1024;

  /// `config` must be valid (MapConfig::validate() empty). With awareness.num_threads > 1 it
  /// starts that many - 1 threads, kept until it is destroyed.
  explicit AwarenessStage(const MapConfig& config);
  ~AwarenessStage();
  AwarenessStage(const AwarenessStage&) = delete;
  AwarenessStage& operator=(const AwarenessStage&) = delete;

  /// Processes a frame whose poses were validated. Fills `batch` (reusing its memory) and adds
  /// to `counters`.
  void process(const PointCloudFrame& frame, MeasurementBatch* batch, PointCounters* counters);
  /// The same for a depth image: every pixel is a point on the ray through its centre (as
  /// backProject() makes it), pixels without data count as non-finite points. Returns false,
  /// touching nothing, when the image size or intrinsics are inconsistent.
  bool process(const DepthFrame& frame, MeasurementBatch* batch, PointCounters* counters);

  /// The first half of process(), for a pipeline that runs the halves on two threads: the
  /// frame's points into end voxels, the hits (batch->hits, batch->far_hits) and the awareness
  /// map, unless that is left to carve() (placeAwarenessMap()), and as much of the cone listing
  /// as placeConeListing() asks for; the frame's ends wait for carve()
  /// (batch->free is carve()'s). Each collect() must be followed by one carve() of the
  /// same batch, in the same order; a collect() may run while carve() of an earlier frame runs
  /// on another thread (each half on one thread at a time). Adds to `counters` all but
  /// free_voxels.
  void collect(const PointCloudFrame& frame, MeasurementBatch* batch, PointCounters* counters);
  /// The same for a depth image (returns false, touching nothing, where process() does).
  bool collect(const DepthFrame& frame, MeasurementBatch* batch, PointCounters* counters);
  /// The second half of process(): the oldest frame collected and not yet carved: its awareness
  /// map where collect() left it here, then the rest of its cone listing and its cones, carved into
  /// its batch's free set (sets batch->free_count and adds free_voxels to `counters`), split over
  /// the kept threads as process() splits it when no collect() holds them (TaskThreads::run()). The
  /// batch then holds what process() would have filled it with, bit for bit. Where it updated the
  /// awareness map, calls `on_map` with it (if set) before the next collect() may update it, and
  /// returns the milliseconds the update took; otherwise returns 0.
  double carve(MeasurementBatch* batch, PointCounters* counters,
               const std::function<void(const AwarenessMap&)>& on_map = {});

  /// Which half updates the awareness map of the frames collected from now on (collect()'s
  /// thread): collect() (false, the default), or carve() (true) beside the carving, for when
  /// the first half is the longer one. The maps are the same either way: the frames' updates
  /// stay in order, collect() waiting for the carve() of the earlier frames whose map waits
  /// there (at most 100 ms, then it leaves its own there too).
  void placeAwarenessMap(bool in_carve) { map_in_carve_ = in_carve; }
  /// Whether the last collect() updated the awareness map, and the milliseconds it took (0 when
  /// it left it to carve()); collect()'s thread.
  [[nodiscard]] bool lastCollectUpdatedMap() const { return collect_map_ms_ >= 0.0; }
  [[nodiscard]] double lastCollectMapMs() const { return std::max(collect_map_ms_, 0.0); }

  /// How far a frame's cone listing has come, in its two steps.
  enum class ConeListingStep : std::uint8_t {
    kNothing,      ///< not begun
    kBinsEntered,  ///< the ends entered into their direction bins (each end's finest bin and
                   ///< distance, each bin's nearest member and parent)
    kConesListed,  ///< the cones listed from the bins and the ends: only the carving is left
  };
  /// How far collect() takes the cone listing of the frames collected from now on, after the
  /// awareness map (collect()'s thread): nowhere (kNothing, the default: carve() lists the
  /// cones), the bin entry, or the whole listing, for when the second half is the longer one.
  /// The cones are the same either way: each half lists into scratch of its own, and the
  /// frame's listing goes to carve() with its ends.
  void placeConeListing(ConeListingStep in_collect) { listing_in_collect_ = in_collect; }
  /// The milliseconds of the cone listing's two steps on one half (0 for a step not done there).
  struct ListingMs {
    double bins = 0.0;   ///< the bin entry
    double cones = 0.0;  ///< the cones listed from the bins
  };
  /// The last collect()'s listing steps; collect()'s thread.
  [[nodiscard]] ListingMs lastCollectListingMs() const { return collect_listing_ms_; }
  /// The last carve()'s listing steps (those collect() left); carve()'s thread.
  [[nodiscard]] ListingMs lastCarveListingMs() const { return carve_listing_ms_; }
  /// The cones the last process() or carve() carved (its direction bins' and its ends');
  /// carve()'s thread.
  [[nodiscard]] std::size_t lastConeCount() const { return carve_listing_.cones.size(); }

  /// The awareness map after the last frame (after its collect() or carve(), whichever updated
  /// it).
  [[nodiscard]] const AwarenessMap& map() const { return map_; }
  /// Bytes held by the stage (awareness grid and per-frame scratch). May be called by
  /// collect()'s thread while carve() runs (the second half's part as of its last frame).
  [[nodiscard]] std::size_t memoryBytes() const;

 private:
  /// Where a frame's points come from: a cloud (optionally sub-sampled) or the pixels of a
  /// depth image, read in blocks into structure-of-arrays form.
  struct Source {
    std::size_t count = 0;
    const Eigen::Vector3f* points = nullptr;    // cloud
    const std::uint32_t* indices = nullptr;     // sub-sampled cloud: the chosen points
    const DepthFrame* depth = nullptr;          // or a depth image
    const std::vector<float>* ray_x = nullptr;  // (u - cx) / fx per column
    float inv_fy = 0.0f;
    float cy = 0.0f;
    /// Points first .. first + len - 1, less the depth pixels without data: returns how many it
    /// wrote.
    std::size_t fill(std::size_t first, std::size_t len, float* xs, float* ys, float* zs) const;
  };
  /// One frame: the scratch box, its points grouped into end voxels, the hits, the awareness
  /// map, the free space (process()), or only its first half (collect(): `split`).
  void processSource(const Source& source, double stamp_s, const Transform& T_W_B,
                     const Transform& T_B_S, MeasurementBatch* batch, PointCounters* counters,
                     bool split);
  /// The depth image as a Source (process() and collect()); false when it is inconsistent.
  bool processDepth(const DepthFrame& frame, MeasurementBatch* batch, PointCounters* counters,
                    bool split);
  /// The cloud as a Source (process() and collect()).
  void processCloud(const PointCloudFrame& frame, MeasurementBatch* batch, PointCounters* counters,
                    bool split);
  /// A frame's scratch box around the sensor (everything within range that the local map can
  /// hold) and the sensor pose.
  struct FrameGeometry {
    Transform T_W_S = Transform::Identity();
    VoxelIndex box_origin = VoxelIndex::Zero();      ///< world voxel index of the box's corner
    Eigen::Vector3i dims = Eigen::Vector3i::Zero();  ///< box size [voxels]
    Eigen::Vector3d origin_vox = Eigen::Vector3d::Zero();  ///< the sensor, box voxel units
  };
  /// Sizes the scratch box and resets the batch (but its free set) and the per-frame tables.
  FrameGeometry beginFrame(double stamp_s, const Transform& T_W_B, const Transform& T_B_S,
                           MeasurementBatch* batch);
  /// Turns every point into its end voxel (ends_, one per box voxel) or an end beyond the box
  /// (outside_, per point), counting the points rejected or cut at the maximum range. With
  /// threads the points are split into consecutive parts, each grouped by a thread of its own
  /// (collectPart()), and the parts merged in order: the same ends in the same order.
  void collectEnds(const Source& source, const FrameGeometry& g, PointCounters* counters);
  /// A voxel where rays end in this frame: the box of its points and the first point.
  struct End {
    Eigen::Vector3d p_W = Eigen::Vector3d::Zero();    // first point
    Eigen::Vector3i voxel = Eigen::Vector3i::Zero();  // box-relative
    VoxelSpaceBox points{};  // bounding box of the frame's points in it (voxel units)
    bool cut = false;        // rays cut at max_range_m (free end) rather than hits
  };
  static_assert(sizeof(End) <= 64, "an end is 64 bytes at most (the listing reads them all)");
  /// The awareness map of this frame: carried obstacles, hits, then the 2D rho-z ray walks, from
  /// the frame's ends (those beyond the box included). Reads only the ends' points and `cut`.
  /// Returns the milliseconds it took.
  double updateAwarenessMap(const Eigen::Vector3d& body_W, const std::vector<End>& ends);
  /// Rays bundled by direction (a cube-map bin of one level): the shared part of their cones.
  struct Bin {
    std::uint32_t index = 0;     // on its level: binKey() of its direction (its parent's: >> 2)
    std::uint32_t parent = 0;    // its parent's place in the next level
    std::uint32_t children = 0;  // bins of the level below in it (ends on the finest level)
    double near = 0.0;           // nearest member distance (voxel units)
    double start = 0.0;          // where its members' cones start (listCones(); voxel units)
    // Hull of its members' point boxes less the sensor, each divided by its distance
    // (listCones()): its box at distance r is sensor + r [dir_lo, dir_hi]; a parent's directions
    // are the hull of its children's.
    Eigen::Vector3d dir_lo = Eigen::Vector3d::Zero();
    Eigen::Vector3d dir_hi = Eigen::Vector3d::Zero();
  };
  /// Open-addressing table: linear box index (+ cut flag) -> index in ends, valid when stamped.
  struct Slot {
    std::uint32_t stamp = 0;
    std::uint32_t key = 0;
    std::uint32_t end = 0;
  };
  /// An end of this frame met lately: its key and index in the part's ends.
  struct RecentEnd {
    std::uint32_t key = 0;
    std::uint32_t end = 0;
  };
  /// Size of the direct-mapped cache of recent ends (8 kB: in L1, where the table is not).
  static constexpr std::size_t kRecentEnds = 1024;
  /// One thread's part of the point loop: the end voxels of its points in the order first met,
  /// the ends beyond the box, its counters and scratch space.
  struct PointPart {
    /// Recent ends by their key's hash: most runs of points continue an end voxel of the image
    /// rows just before, found here without the table's cache miss.
    std::array<RecentEnd, kRecentEnds> recent{};
    std::vector<Slot> table = std::vector<Slot>(1u << 15);
    std::uint32_t stamp = 0;  // this frame's, in table
    std::vector<End> ends;
    std::vector<End> outside;
    PointCounters counters;
    // Per point of a block: box voxel key (or why it has none), box-relative coordinates and 0
    // (padded as groupPointRuns() reads them); the block's runs of equal keys.
    std::vector<std::uint32_t> keys = std::vector<std::uint32_t>(kPointBlock + PointRuns::kPadding);
    std::vector<std::array<float, 4>> box_coords =
        std::vector<std::array<float, 4>>(kPointBlock + PointRuns::kPadding);
    std::vector<float> block_xyz = std::vector<float>(3 * kPointBlock);  // one block, x | y | z
    PointRuns runs{kPointBlock};
  };
  /// Points first .. end - 1 of the frame into `part` (collectEnds() on one part).
  void collectPart(const Source& source, const FrameGeometry& g, std::size_t first, std::size_t end,
                   PointPart* part) const;
  /// The entry in part->ends of a box key (voxel index | kCutFlag), added when new.
  std::uint32_t findOrAddEnd(PointPart* part, std::uint32_t key) const;
  /// A cone to carve: the part s in [s_min, 1] of the cone from the sensor to `box`.
  struct Cone {
    VoxelSpaceBox box{};
    double s_min = 0.0;
  };
  /// A frame's cone listing and its scratch. Each half lists into its own (so that the two
  /// halves can list frames at once); a frame that collect() listed carries its listing to
  /// carve(), swapped, so that the memory goes round.
  struct ConeListing {
    // Level 0: bins about bin_width_voxels wide at the maximum range; level L: 2^L times wider,
    // covering the distances where they are still about that wide. Per level, the frame's bins
    // with members, in the order of their index (a bin's children are consecutive there), so
    // the levels are built and read in order, with no table over all the bins of a level.
    std::vector<std::vector<Bin>> bins;
    // The ends by finest bin: (bin index << 32 | end), radix-sorted, and the sort's scratch.
    std::vector<std::uint64_t> order;
    std::vector<std::uint64_t> order_scratch;
    // Per end (in the frame's order): its distance from the sensor to its points (voxel units)
    // and its finest bin (its place in bins[0]); beside the ends, not in them, so that the
    // bins' building reads its members' distances from a small array (the ends are 64 bytes
    // each) and the listing writes nothing the awareness map reads.
    std::vector<double> end_near;
    std::vector<std::uint32_t> end_bin;
    std::vector<Cone> cones;  // the frame's cones, ends first, then bins (fine to coarse)
    /// The bytes it holds.
    [[nodiscard]] std::size_t bytes() const;
  };
  /// The cone listing's first step: enters every end of `ends` (ends_ with outside_ appended)
  /// into its finest direction bin (sets listing->end_near and end_bin) and the bins' ancestors
  /// into listing->bins (one vector per level, finest first, rebuilt), each bin with its nearest
  /// member and its parent.
  void enterBins(const Eigen::Vector3d& origin_vox, const std::vector<End>& ends,
                 ConeListing* listing) const;
  /// The second step: lists the cones of the direction bins and of the ends into
  /// listing->cones, from the bins enterBins() entered `ends` into.
  void listCones(const Eigen::Vector3d& origin_vox, const std::vector<End>& ends,
                 ConeListing* listing) const;
  /// The steps of the cone listing after `from` up to `to`, into `listing`, each timed into `ms`
  /// (the steps not done here 0).
  void advanceListing(const Eigen::Vector3d& origin_vox, const std::vector<End>& ends,
                      ConeListingStep from, ConeListingStep to, ConeListing* listing,
                      ListingMs* ms) const;
  /// updateAwarenessMap() and the rest of the cone listing after `from` (into carve_listing_),
  /// of one frame, side by side on the kept threads when there are any and the listing is not
  /// done. Returns the map's milliseconds.
  double mapAndListCones(const Eigen::Vector3d& body_W, const Eigen::Vector3d& origin_vox,
                         const std::vector<End>& ends, ConeListingStep from);
  /// Carves carve_listing_'s cones into batch->free, clears the hits and counts the free voxels
  /// (sets batch->free_count): on the calling thread, or split by box x over awareness.num_threads
  /// threads (the same bits either way).
  void carveCones(const Eigen::Vector3d& origin_vox, MeasurementBatch* batch);
  /// The bytes of the second half's scratch (bins, cones), for memoryBytes().
  [[nodiscard]] std::size_t carveBytes() const;
  /// The part of carveCones() with box x in [x_begin, x_end): marks the cones' voxels there,
  /// clears the hits there and counts the free voxels there into `free_count`. Writes only the
  /// bitset's rows of that range and their rowsInUse() words.
  void carveRange(const Eigen::Vector3d& origin_vox, int x_begin, int x_end,
                  MeasurementBatch* batch, std::size_t* free_count) const;

  MapConfig config_;
  AwarenessMap map_;
  Eigen::Vector3i box_dims_ = Eigen::Vector3i::Zero();  // scratch box of the current frame
  std::vector<End> ends_;                               // inside the scratch box, one per voxel
  std::vector<End> outside_;  // beyond the box (the local map cannot hold them), per point
  // The second half's (carveCones()): with collect() and carve(), carve()'s thread's.
  std::vector<double> range_scratch_;  // the cones' work per box x, for splitting it over threads
  std::vector<PointPart> parts_;       // one per thread; ends_ and outside_ merge them
  std::unique_ptr<TaskThreads> threads_;  // with awareness.num_threads > 1
  /// A frame between collect() and carve(): its ends (ends_ and outside_), its cone listing as
  /// far as collect() took it, its body and sensor (for the awareness map and the cones)
  /// and the box of its free set (which carve() clears).
  struct CollectedFrame {
    std::vector<End> ends;
    ConeListing listing;  // as far as `listed` (spare memory at kNothing)
    ConeListingStep listed = ConeListingStep::kNothing;
    Eigen::Vector3d body_W = Eigen::Vector3d::Zero();
    bool map_in_carve = false;  // its awareness map is carve()'s to update
    Eigen::Vector3d origin_vox = Eigen::Vector3d::Zero();
    VoxelIndex box_origin = VoxelIndex::Zero();
    Eigen::Vector3i dims = Eigen::Vector3i::Zero();
  };
  mutable std::mutex collected_mutex_;  // guards the two below (collect() and carve() share them)
  std::deque<std::unique_ptr<CollectedFrame>> collected_;  // waiting for carve(), oldest first
  std::vector<std::unique_ptr<CollectedFrame>> spare_;     // their memory, for reuse
  std::atomic<std::size_t> carve_bytes_{0};                // carveBytes() as of the last carving
  std::atomic<std::size_t> map_bytes_{0};  // map_.memoryBytes() as of the last awareness update
  // Frames collected whose awareness map waits for carve() (under collected_mutex_): collect()
  // updates the map only at 0, waiting for it on maps_carved_.
  int maps_in_carve_ = 0;
  std::condition_variable maps_carved_;
  bool map_in_carve_ = false;    // placeAwarenessMap() (collect()'s thread)
  double collect_map_ms_ = 0.0;  // the last collect()'s map update, -1 when none (its thread)
  // placeConeListing(), the last collect()'s listing steps and its listing, swapped into its
  // frame (collect()'s thread).
  ConeListingStep listing_in_collect_ = ConeListingStep::kNothing;
  ListingMs collect_listing_ms_;
  ConeListing collect_listing_;
  // The second half's listing, and its steps of the last frame (process(); with collect() and
  // carve(), carve()'s thread's).
  ConeListing carve_listing_;
  ListingMs carve_listing_ms_;
  int bins_per_face_side_ = 0;  // at level 0, a power of two
  std::vector<std::uint32_t> sample_indices_;
  std::vector<float> ray_x_;                   // depth images: (u - cx) / fx per column
  std::vector<Eigen::Vector3f> depth_points_;  // depth images with sub-sampling: the cloud
  std::mt19937 rng_;
};

}  // namespace mlmap
