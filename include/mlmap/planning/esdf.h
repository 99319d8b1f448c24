#pragma once
/// @file
/// Exact signed Euclidean distance field (ESDF) over a dense box of the world voxel grid, for
/// planners: distance to the nearest obstacle and its gradient at any point of the box.
///
/// Definition. A voxel is an *obstacle* when it is occupied, or unknown under
/// `UnknownAs::kOccupied`; every other voxel is *non-obstacle*. With centre(v) the centre of
/// voxel v in metres (see voxelCenter()):
/// - for a non-obstacle voxel c: d(c) = + min over obstacle voxels o in the box of
///   |centre(c) - centre(o)|;
/// - for an obstacle voxel c: d(c) = - min over non-obstacle voxels f in the box of
///   |centre(c) - centre(f)|.
/// d is then clamped to [-max_distance_m, +max_distance_m]; a box with no obstacle voxel gives
/// +max_distance_m everywhere and a box with no non-obstacle voxel gives -max_distance_m
/// everywhere. Only voxels inside the box count: space outside the box is not seen, so it is
/// neither obstacle nor free. An obstacle voxel next to a non-obstacle one has d = -resolution_m
/// and that neighbour d = +resolution_m, so the interpolated field (below) crosses zero on the
/// face between them.
///
/// Between cell centres the field is the trilinear interpolation of the 8 surrounding cell
/// values; EsdfMap::query() returns it with its analytic gradient.
///
/// Algorithm: exact separable Euclidean distance transform on integer squared distances
/// (Felzenszwalb & Huttenlocher, "Distance Transforms of Sampled Functions", 2012): a two-sweep
/// 1D distance along x, then the lower envelope of parabolas along y and along z. The outside
/// (distance to obstacles) and inside (distance to free space) transforms run in the same
/// passes on one signed buffer, each evaluated only where it is needed. Squared distances beyond
/// (max_distance_m / resolution_m)^2 are treated as infinite, which keeps the clamped result
/// exact. Linear in the number of voxels; one sqrt (a table lookup) per voxel; no allocation
/// after the first compute() of the largest box. Where that clamp is at most
/// esdf_kernel::kMaxWindowCapCells voxels (20 at 0.1 m with the default 2 m), the y and z
/// passes instead take, at each voxel, the minimum over the 2 cap_d + 1 voxels of its line
/// within the clamp (see esdf_window_kernel.h): 16-bit values, many lines side by side, no
/// branch on the data, so the compiler vectorises it (AVX2 / AVX-512 builds on x86-64, chosen
/// at load time); the result is the same, bit for bit.
///
/// Incremental updates (update()): the map keeps the box it was computed from and the results
/// of the x pass and of the y pass. A new box of the same size and resolution is compared with
/// the kept one; only the x lines (swept a y row at a time) holding a changed voxel are swept
/// again, only the y lines where the x pass's result changed are transformed again, and only
/// the z lines where the y pass's result changed. A changed input reaches outputs within
/// cap_d + 1 voxels of it (a parabola within the cap, or a run boundary next to it), so each
/// line is transformed only over twice that around its changed inputs, and its results are kept
/// within once that, where the parabolas cut off at the part's ends lie beyond the cap. Each
/// part goes through the same code as in compute() (exact integer arithmetic, invariant under
/// translation), so the field is bit-identical to a full recompute. Through the windowed passes,
/// the lines to transform again are taken from the whole box in order of where their changes
/// start, 16 side by side (one vector of 16-bit values), each group over the union of its
/// lines' parts. With the envelope code (large
/// clamps), a box that moved (the window slid) by less than its size is shifted first: the kept
/// part stays, the new slabs count as changed, and so does the face the move removed (its
/// neighbours there are gone). Where the windowed passes apply, a box moved along x or y is
/// first brought to B' (moveWindowed()), its new place with the kept states: the new x slabs
/// are computed whole; in the kept slabs the kept results are moved, the x pass runs again
/// only within the clamp of a new or removed x face and over the new rows, and the y lines
/// where its results differ, or next to a removed y face, are marked. The states that changed
/// in the kept part then go through the unmoved path, which transforms those lines with its
/// own. A box moved along z (every z line of a shallow box reaches a face within the clamp) is
/// computed whole. More than 1/16 of the box changed
/// (e.g. a map load) is computed whole. The cost follows what changed:
/// a depth frame's few thousand changed voxels touch a part of the lines.
///
/// For many queries, EsdfQueryGrid (esdf_query_grid.h) keeps a 16-bit copy of the field that
/// answers within a documented bound of query() at about 1.6x its rate.
///
/// The parts: the field's storage and queries are EsdfField (esdf_field.h); the kept states,
/// the changed voxels and the marks of the lines to transform again are EsdfChangeTracker
/// (esdf_change_tracker.h); the line kernels are free functions (esdf_window_kernel.h and,
/// inside the library, esdf_line_kernels.h). EsdfMap runs the passes: src/planning/esdf.cpp the
/// full compute(), esdf_update.cpp the incremental update() up to pass 1 and
/// esdf_update_lines.cpp its passes 2 and 3.

#include "mlmap/core/config.h"
#include "mlmap/core/types.h"
#include "mlmap/planning/esdf_change_tracker.h"
#include "mlmap/planning/esdf_field.h"
#include "mlmap/planning/esdf_window_kernel.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mlmap {

/// Dense box of occupancy states on the world voxel grid (voxel i spans [i * res, (i + 1) * res)
/// per axis). `states[(x * size.y() + y) * size.z() + z]` holds box-relative voxel (x, y, z),
/// i.e. world voxel min_index + (x, y, z): x-major, z fastest (the local map's iteration order).
struct OccupancyBox {
  VoxelIndex min_index = VoxelIndex::Zero();       ///< world index of the first voxel
  Eigen::Vector3i size = Eigen::Vector3i::Zero();  ///< voxels per axis
  double resolution_m = 0.2;                       ///< voxel edge length [m]
  std::vector<Occupancy> states;                   ///< size.prod() states, see above

  /// Sets the box geometry and fills every voxel with `fill`.
  void reset(const VoxelIndex& min_index_in, const Eigen::Vector3i& size_in, double resolution_m_in,
             Occupancy fill = Occupancy::kUnknown) {
    min_index = min_index_in;
    size = size_in;
    resolution_m = resolution_m_in;
    states.assign(static_cast<std::size_t>(std::max(0, size.x())) *
                      static_cast<std::size_t>(std::max(0, size.y())) *
                      static_cast<std::size_t>(std::max(0, size.z())),
                  fill);
  }
  /// True when the world voxel lies inside the box.
  [[nodiscard]] bool contains(const VoxelIndex& world_index) const {
    return boxContains(min_index, size, world_index);
  }
  /// Position in `states` of a world voxel inside the box.
  [[nodiscard]] std::size_t offsetOf(const VoxelIndex& world_index) const {
    return boxOffset(min_index, size, world_index);
  }
  /// State of a world voxel inside the box.
  [[nodiscard]] Occupancy& at(const VoxelIndex& world_index) {
    return states[offsetOf(world_index)];
  }
  /// State of a world voxel inside the box.
  [[nodiscard]] Occupancy at(const VoxelIndex& world_index) const {
    return states[offsetOf(world_index)];
  }
};

/// The signed distance field of one OccupancyBox (see the file comment for the definition).
///
/// compute() rebuilds the whole field; the const accessors may then be called concurrently from
/// any number of threads. compute() itself must not run concurrently with anything else on the
/// same object.
class EsdfMap {
 public:
  /// Largest accepted box edge in voxels (keeps every squared distance in 32 bits).
  static constexpr int kMaxCellsPerAxis = 16384;
  /// Largest accepted box in voxels (about 2.3 GB of buffers at 9 bytes per voxel).
  static constexpr std::int64_t kMaxCells = std::int64_t{1} << 28;

  /// Result of query(): distance, gradient and whether they may be trusted (see EsdfQuery).
  using Query = EsdfQuery;

  /// Throws std::invalid_argument listing every problem when `config` is not valid.
  explicit EsdfMap(const EsdfConfig& config);

  /// Recomputes the whole field from `box` (exact, linear time). Buffers are reused across calls.
  /// Returns false, leaving the map empty (every query invalid), when the box is malformed:
  /// a size below 1 or above kMaxCellsPerAxis, more than kMaxCells voxels, states.size() not
  /// size.prod(), a resolution that is not finite and positive, or indices beyond +-2^30.
  /// With num_threads > 1 the work is split over that many threads (created per call); the
  /// result is bit-identical to one thread. std::bad_alloc propagates, leaving the map empty.
  [[nodiscard]] bool compute(const OccupancyBox& box);

  /// Makes compute() run its y and z passes with the envelope code even where the windowed
  /// 16-bit passes apply (see the file comment); both give the same field. For tests and the
  /// benchmark; takes effect at the next compute().
  void setEnvelopeOnly(bool envelope_only) { envelope_only_ = envelope_only; }
  /// True when the last compute() ran the windowed 16-bit y and z passes (the clamp is at most
  /// esdf_kernel::kMaxWindowCapCells voxels and setEnvelopeOnly() was not set).
  [[nodiscard]] bool windowedPasses() const { return window_kernel_; }

  /// What the last compute() or update() did.
  struct UpdateStats {
    bool full = true;                ///< the whole field was computed (compute(), or update()
                                     ///< without a kept box of the same size and resolution)
    bool shifted = false;            ///< the kept box was shifted to the new one's place
    std::size_t changed_states = 0;  ///< voxels whose state differed from the kept box
    std::size_t rows_swept = 0;      ///< y rows swept again by the x pass
    std::size_t y_lines = 0;         ///< y lines transformed again
    std::size_t z_lines = 0;         ///< z lines transformed again
    std::size_t changed_cells = 0;   ///< cells whose value or unknown bit changed
  };

  /// Brings the field to `box`, exactly as compute(box) would, doing only the work the changes
  /// since the last compute() or update() need (see the file comment). Falls back to compute()
  /// when there is no kept box (first call, after a failed call, after copyFrom()), when the
  /// size or resolution differs, when the box moved by its size or more, when it moved along z
  /// and windowedPasses() applies, or when more than 1/16 of the kept part changed (the full
  /// compute is then cheaper). After a move, lastUpdate().shifted is set (changedCells() does
  /// not list the moved cells). Same return value and failure behaviour as compute().
  /// Single-threaded except in the fallback.
  [[nodiscard]] bool update(const OccupancyBox& box);
  /// A part of a box, voxels [lo, hi) in box coordinates (from the box's min_index).
  using Region = EsdfRegion;
  /// As update(box), where the caller knows where states may have changed since the last
  /// compute() or update(): only inside `may_have_changed` (clipped to the box; overlaps are
  /// allowed). A map engine knows this from its submaps' change stamps, and the box is then
  /// compared with the kept one only there instead of whole (at 0.1 m, 5 MB of memory read per
  /// frame). States that changed elsewhere would be missed: the promise is the caller's. When
  /// the box moved, the whole box is compared (the hint speaks of the old place).
  [[nodiscard]] bool update(const OccupancyBox& box, const std::vector<Region>& may_have_changed);
  /// What the last compute() or update() did.
  [[nodiscard]] const UpdateStats& lastUpdate() const { return last_update_; }
  /// Box offsets (OccupancyBox order) of the cells whose value or unknown bit the last update()
  /// changed; meaningful only when lastUpdate().full and lastUpdate().shifted are both false.
  [[nodiscard]] const std::vector<std::uint32_t>& changedCells() const { return changed_cells_; }
  /// Makes this map a copy of `source`'s field (geometry, values, unknown bits, configuration)
  /// without its kept box: a following update() on this map is a full compute. For publishing
  /// a field while `source` goes on updating.
  void copyFrom(const EsdfMap& source);
  /// Copies from `source` the cells at `offsets` (value and unknown bit). Both maps must have
  /// the same geometry (checked: false and nothing copied otherwise); offsets beyond the box are
  /// ignored. Brings a copy made by copyFrom() up to date after source.update() by its
  /// changedCells().
  bool copyCells(const EsdfMap& source, const std::vector<std::uint32_t>& offsets);

  /// Trilinear distance and its analytic gradient at a world point (metres). The 8-cell stencil
  /// is clamped at the box border so any point inside the box works: within half a voxel of a
  /// box face the value is held constant across that face (gradient component 0 along its
  /// normal). The value therefore always lies between the values of the 8 cells used.
  /// valid = false outside the box or when the point's voxel is unknown. Allocation-free.
  [[nodiscard]] Query query(const Eigen::Vector3d& p_W) const;

  /// query() at `count` points: out[i] = query(points_W[i]), bit for bit. Faster than a loop of
  /// query() when the points are scattered over a box larger than the CPU's caches: the memory
  /// each query reads (four cache lines of the field and one of the unknown mask) is prefetched
  /// kQueryPrefetchAhead points ahead, so the memory latencies of many queries overlap.
  /// Allocation-free; `out` must hold `count` results.
  void queryBatch(const Eigen::Vector3d* points_W, std::size_t count, Query* out) const;
  /// How many points ahead queryBatch() prefetches.
  static constexpr std::size_t kQueryPrefetchAhead = EsdfField::kQueryPrefetchAhead;

  /// Cell value of a world voxel [m] (the value at its centre); NaN outside the box.
  [[nodiscard]] float distanceAt(const VoxelIndex& world_index) const;
  /// True when the world voxel lies inside the box of the last successful compute().
  [[nodiscard]] bool contains(const VoxelIndex& world_index) const {
    return field_.contains(world_index);
  }
  /// True when box-relative voxel (x, y, z) (inside the box, unchecked) was unknown in the box
  /// given to compute() / update().
  [[nodiscard]] bool isUnknownCell(int x, int y, int z) const {
    return field_.isUnknownCell(x, y, z);
  }
  /// True when the world voxel is inside the box and was unknown in the box given to compute().
  [[nodiscard]] bool isUnknown(const VoxelIndex& world_index) const {
    return field_.isUnknown(world_index);
  }

  /// True until the first successful compute() (and after a failed one).
  [[nodiscard]] bool empty() const { return field_.empty(); }
  /// First voxel of the box (world index, inclusive).
  [[nodiscard]] const VoxelIndex& minIndex() const { return field_.minIndex(); }
  /// One past the last voxel of the box (world index).
  [[nodiscard]] VoxelIndex maxIndex() const { return field_.maxIndex(); }
  /// Box size in voxels.
  [[nodiscard]] const Eigen::Vector3i& size() const { return field_.size(); }
  /// Voxel edge length of the last successful compute() [m].
  [[nodiscard]] double resolution_m() const { return field_.resolution_m(); }
  /// Lower corner of the box in W [m].
  [[nodiscard]] Eigen::Vector3d minCorner_W() const {
    return minIndex().cast<double>() * resolution_m();
  }
  /// Upper corner of the box in W [m].
  [[nodiscard]] Eigen::Vector3d maxCorner_W() const {
    return maxIndex().cast<double>() * resolution_m();
  }
  /// Cell values [m] in OccupancyBox order (x-major, z fastest), e.g. for publishing; empty
  /// after a failed compute().
  [[nodiscard]] const std::vector<float>& distances() const { return field_.values_m(); }
  /// The configuration in use.
  [[nodiscard]] const EsdfConfig& config() const { return config_; }
  /// Bytes held by the field (4 per voxel), the unknown mask (1 bit per voxel), the kept box and
  /// the x and y passes' results (9 per voxel, 4 with the windowed passes, which keep them in 8
  /// and 16 bits; none in a copy) and a little per thread.
  [[nodiscard]] std::size_t memoryBytes() const;

 private:
  /// Per-thread scratch (envelopes sized for the longest y or z line + 1).
  struct Scratch {
    std::vector<std::int32_t> runs;           ///< starts of the same-sign runs of a line
    std::vector<std::int32_t> out_sites;      ///< outside-transform envelope: positions
    std::vector<std::int32_t> in_sites;       ///< inside-transform envelope: positions
    std::vector<std::int32_t> out_keys32;     ///< f(q) + q^2 when it fits 32-bit arithmetic
    std::vector<std::int32_t> in_keys32;      ///< (inside envelope)
    std::vector<std::int64_t> out_keys64;     ///< f(q) + q^2 otherwise
    std::vector<std::int64_t> in_keys64;      ///< (inside envelope)
    std::vector<std::int32_t> near_free;      ///< x pass: nearest non-obstacle x per (y, z)
    std::vector<std::int32_t> near_obstacle;  ///< x pass: nearest obstacle x per (y, z)
    std::vector<std::int32_t> line;           ///< one y or z line being transformed
    std::vector<std::int32_t> sweep;          ///< x pass: 32-bit results before the 8-bit copy
    esdf_kernel::WindowBuffers window;        ///< the windowed passes' slab buffers
    std::vector<std::int16_t> gathered;       ///< update(): z lines one after another
    std::vector<std::int8_t> narrow_rows;     ///< update() after a move: x pass rows in 8 bits
  };

  /// Rows (y) swept together by the x pass.
  static constexpr int kRowBlock = 32;
  /// The same where the x pass's results are kept in 8 bits (the windowed passes): its 32-bit
  /// work buffer over the whole x extent of that many rows stays in the L2 cache.
  static constexpr int kNarrowRowBlock = 8;

  // ---- The full compute (esdf.cpp) ----

  /// True when compute() accepts the box (see compute()).
  [[nodiscard]] static bool wellFormed(const OccupancyBox& box);

  /// Empties the map (size 0, every query invalid); keeps the buffers' capacity.
  void clear();
  /// Sets the geometry and the size-dependent constants (clamp, metres table) for the box and
  /// sizes the buffers (setClamp(), sizeBuffers()); allocates.
  void prepare(const OccupancyBox& box);
  /// The clamp constants (cap_sq_, inf_, cap_d_, narrow_keys_, window_kernel_) and the metres
  /// table for the field's geometry.
  void setClamp();
  /// Sizes the pass buffers, the tracker and the per-thread scratch for the field's geometry
  /// (grown only).
  void sizeBuffers();
  /// Pass 1 (x, two sweeps) over the y rows [y_begin, y_end): 1D distances into pass1_.
  void sweepRows(const std::uint8_t* states, int y_begin, int y_end, Scratch* scratch);
  /// Pass 2 (y, into pass2_) and pass 3 (z) over the x slabs [x_begin, x_end), writing the field
  /// in metres and the unknown mask.
  void transformSlabs(const std::uint8_t* states, int x_begin, int x_end, Scratch* scratch);
  /// Pass 2 and 3 of x slab x with the envelope code (transformSlabs() without the windowed
  /// passes); `table` is the metres table at [inf_] or null.
  void transformSlabEnvelope(int x, const float* table, Scratch* scratch);
  /// Transforms the part [begin, end) of one y line (pass1_ at (x, z)) as a line of its own,
  /// into `line` (end - begin values).
  void transformYLine(int x, int z, int begin, int end, std::int32_t* line, Scratch* scratch) const;
  /// The same for the part [begin, end) of one z line (pass2_ at (x, y)).
  void transformZLine(int x, int y, int begin, int end, std::int32_t* line, Scratch* scratch) const;
  /// Signed squared voxel distance (or +-inf_) -> clamped signed metres (table when there).
  [[nodiscard]] float metres(std::int32_t value) const {
    return metres_table_.empty() ? slowMetres(value) : metres_table_[value + inf_];
  }
  /// What pass 1 writes for "beyond the cap": inf_, or cap_d_ + 1 where its results are kept in
  /// 8 bits (the windowed passes read any distance above cap_d_ as beyond).
  [[nodiscard]] std::int32_t pass1Inf() const { return window_kernel_ ? cap_d_ + 1 : inf_; }
  /// Signed squared voxel distance (or +-inf_) -> clamped signed metres, without the table.
  /// Needs cap_sq_, inf_ and the field's resolution of the current compute().
  [[nodiscard]] float slowMetres(std::int32_t value) const;
  /// 1 where unknown voxels are obstacles (UnknownAs::kOccupied), else 0: what pass 1 reads.
  [[nodiscard]] std::int32_t unknownIsObstacle() const {
    return config_.unknown_as == UnknownAs::kOccupied ? 1 : 0;
  }

  // ---- The incremental update (esdf_update.cpp) ----

  /// update()'s common part; `regions` null: the whole box may have changed.
  [[nodiscard]] bool updateWithin(const OccupancyBox& box, const std::vector<Region>* regions);
  /// Shifts the kept state by `delta` voxels (new min - old min); new voxels are marked unseen.
  void shiftKept(const VoxelIndex& delta);
  /// update() for a box moved by `delta` (delta.z() == 0) where the windowed passes apply:
  /// brings the map to B', the new box's geometry with the kept states where the boxes overlap
  /// and the new box's states elsewhere. The new x slabs are computed whole; in the kept ones
  /// the results are moved, the x pass runs again and the y lines where its results differ
  /// (next to a new or removed x face, in the new rows) or next to a removed y face are marked
  /// for updateChanged(), which transforms them with the frame's own changes.
  void moveWindowed(const OccupancyBox& box, const VoxelIndex& delta);
  /// moveWindowed()'s first step: the kept slabs' states and results moved to their new place,
  /// the new rows and slabs given the new box's states.
  void moveKeptSlabs(const OccupancyBox& box, const VoxelIndex& delta);
  /// moveWindowed()'s second step: pass 1 of B' where it may differ from the moved results,
  /// marking the y lines where it does.
  void sweepMovedRows(const VoxelIndex& delta, Scratch* scratch);
  /// The incremental part of update(): box has the kept geometry after a shift by `shift`
  /// voxels (zero: none).
  void updateChanged(const OccupancyBox& box, const VoxelIndex& shift);
  /// updateChanged()'s first step: the changed states into the kept ones, the unknown bits and
  /// the row spans of those whose kind changed.
  void applyChangedStates(const std::uint8_t* states, const VoxelIndex& shift);
  /// updateChanged()'s second step: pass 1 again over the row spans, marking the y lines whose
  /// results changed.
  void resweepChangedRows(const std::uint8_t* states, int reach, Scratch* scratch);
  // ---- The incremental update's passes 2 and 3 (esdf_update_lines.cpp) ----

  /// The y and z passes of updateChanged() over the lines its x pass marked, `reach` = cap_d_ + 1:
  /// line by line with the envelope code ...
  void updateLinesEnvelope(int reach, Scratch* scratch);
  /// ... or, where the windowed passes apply, the marked lines side by side through them, in
  /// groups across the box:
  void updateLinesWindowed(int reach, Scratch* scratch);
  /// the y pass (into pass2_narrow_), marking the z lines whose input changed, ...
  void updateYLinesWindowed(int reach, Scratch* scratch);
  /// ... then the z pass, into the field.
  void updateZLinesWindowed(int reach, Scratch* scratch);

  EsdfConfig config_;
  EsdfField field_;  ///< the field and its geometry

  std::int32_t cap_sq_ = 0;     ///< squared voxel distances above this clamp to max_distance_m
  std::int32_t inf_ = 1;        ///< cap_sq_ + 1: "farther than the cap" in the work buffer
  std::int32_t cap_d_ = 0;      ///< largest d with d * d <= cap_sq_
  bool narrow_keys_ = true;     ///< the envelope arithmetic of every line fits 32 bits
  bool envelope_only_ = false;  ///< see setEnvelopeOnly()
  bool window_kernel_ = false;  ///< compute() runs the windowed y and z passes
  /// Pass 1's result: +d (non-obstacle) / -d (obstacle) along x, in voxels, or +-inf_.
  std::vector<std::int32_t> pass1_;
  /// The same in 8 bits, where the windowed passes apply (pass1_ is then empty), with
  /// +-(cap_d_ + 1) for beyond the cap: see pass1Inf().
  std::vector<std::int8_t> pass1_narrow_;
  /// Pass 2's result: +d^2 / -d^2 over the y-x plane, in voxels, or +-inf_.
  std::vector<std::int32_t> pass2_;
  /// The same in 16 bits, where the windowed passes apply (pass2_ is then empty).
  std::vector<std::int16_t> pass2_narrow_;
  EsdfChangeTracker tracker_;  ///< the kept states, what changed, the lines to transform again
  bool kept_ = false;  ///< the passes' results and the tracker's kept states hold the current box
  UpdateStats last_update_;
  std::vector<std::uint32_t> changed_cells_;
  std::vector<std::int32_t> row_buffer_;  ///< one y row of pass 1 (nx * nz)
  std::vector<float> metres_table_;       ///< slowMetres(v) at [v + inf_] (when the cap is small)
  std::vector<Scratch> scratch_;          ///< one per thread
};

inline EsdfMap::Query EsdfMap::query(const Eigen::Vector3d& p_W) const { return field_.query(p_W); }

inline void EsdfMap::queryBatch(const Eigen::Vector3d* points_W, std::size_t count,
                                Query* out) const {
  field_.queryBatch(points_W, count, out);
}

}  // namespace mlmap
