#pragma once
/// @file
/// The local map (paper IV-B, IV-C): probabilistic voxels of the active area around the body,
/// cut into 5 x 5 x 5 submaps that slide with the vehicle.
///
/// Storage is a torus: world voxel g lives at (g mod N) on each axis, N = 5 submaps. Submap m
/// therefore always occupies the same slot (m mod 5), so sliding by one submap touches only the
/// 25 slots that change owner: their old submap is retired to the global map and the slot is
/// reset to unknown, then filled from the global map if the new submap was mapped before. No
/// voxel is copied on a shift and a recycled slot never shows old values at new positions.

#include "mlmap/core/measurement_batch.h"
#include "mlmap/core/config.h"
#include "mlmap/core/log_odds.h"
#include "mlmap/global/global_map.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace mlmap {

/// Counters of the local map's updates.
struct LocalMapCounters {
  std::uint64_t hits_applied = 0;         ///< occupied updates inside the window
  std::uint64_t misses_applied = 0;       ///< free updates inside the window
  std::uint64_t outside_window = 0;       ///< measurements outside the window (dropped)
  std::uint64_t hits_outside_window = 0;  ///< of them, hits (MapEngine: to the global map)
  std::uint64_t shifts = 0;               ///< one-submap re-centrings
  std::uint64_t resets = 0;               ///< jumps too far for a shift: whole window retired
  std::uint64_t submaps_retired = 0;      ///< submaps handed to the global map
  std::uint64_t submaps_restored = 0;     ///< submaps taken back from the global map
};

/// A copy of the local map's window in box order, for readers on other threads (planning
/// snapshots). Voxel (x, y, z) of the window, world index min_index + (x, y, z), is
/// log_odds[(x * size.y() + y) * size.z() + z]: x-major, z fastest.
struct LocalWindow {
  VoxelIndex min_index = VoxelIndex::Zero();       ///< first voxel (world index)
  Eigen::Vector3i size = Eigen::Vector3i::Zero();  ///< voxels per axis (0: map not placed yet)
  double resolution_m = 0.2;                       ///< voxel edge
  LogOddsModel model{LogOddsConfig{}};             ///< thresholds of the map it was copied from
  std::vector<LogOddsQ> log_odds;                  ///< stored log-odds, see above
  /// LocalMap::changeClock() of the map when it was copied (what LocalMap::updateWindowCopy()
  /// builds on); 0 for a window that is not such a copy.
  std::uint64_t change_clock = 0;

  /// True when the world voxel lies in the window.
  [[nodiscard]] bool contains(const VoxelIndex& g) const { return boxContains(min_index, size, g); }
  /// Stored value of a world voxel in the window.
  [[nodiscard]] LogOddsQ at(const VoxelIndex& g) const {
    return log_odds[boxOffset(min_index, size, g)];
  }
  /// State of a world voxel; unknown outside the window.
  [[nodiscard]] Occupancy state(const VoxelIndex& g) const {
    return contains(g) ? model.state(at(g)) : Occupancy::kUnknown;
  }
};

/// Largest |voxel index| a window corner may have: keeps every index sum far from int overflow.
inline constexpr int kMaxAbsWindowVoxelIndex = 1 << 30;

/// What makes `window` unfit for a local map of `size` voxels with `submap_cells` voxels per
/// submap and `model`'s clamping bounds, or "" when it fits (an empty window always fits): a
/// size or value count that differs, a first voxel off the submap grid or beyond
/// kMaxAbsWindowVoxelIndex, a value outside the clamping bounds.
[[nodiscard]] std::string windowProblem(const LocalWindow& window, const Eigen::Vector3i& size,
                                        const Eigen::Vector3i& submap_cells,
                                        const LogOddsModel& model);

/// Dense sliding voxel window. Not thread-safe: owned by the local-global stage.
class LocalMap {
 public:
  LocalMap(const LocalMapConfig& config, const LogOddsConfig& log_odds);

  /// Re-centres on the body (paper Algorithm 3 line 1-3): while the body is outside the centre
  /// submap, move the centre to the one of its 26 neighbours whose centre is closest to the body.
  /// A jump of more than two submaps retires the whole window instead. The first call places the
  /// window. Retired submaps go to `global`; entering ones are restored from it.
  void recenter(const Eigen::Vector3d& body_W, GlobalMap* global);

  /// Applies a frame's measurements: +hit for occupied voxels, +miss for free ones (Eq. 8-9),
  /// each voxel once. Measurements outside the window are counted and dropped.
  void integrate(const MeasurementBatch& batch);

  /// Copies the window into `out` in box order (reusing its memory). An unplaced map gives an
  /// empty window.
  void copyWindow(LocalWindow* out) const;
  /// The same result as copyWindow(), for an `out` that holds an earlier copy of this map's
  /// window (from copyWindow() or updateWindowCopy(), e.g. a pooled snapshot buffer): when the
  /// window has not moved since, only the voxel columns (all of z at one x, y) changed after
  /// `out->change_clock` are copied: a few percent of the window per frame, where a 360-degree
  /// scan changes some voxels in nearly every submap. Any other `out` gets a full copy. Returns
  /// the number of columns copied.
  int updateWindowCopy(LocalWindow* out) const;

  /// Retires every submap to `global` (e.g. before saving a complete map); the window stays.
  void retireAll(GlobalMap* global);

  /// Replaces the whole window by `window` (as copyWindow() gives it; an empty window unplaces
  /// the map), e.g. when a saved map is loaded. Its size must equal the configured size, its
  /// first voxel must lie on the submap grid and every value must be unknown or within the
  /// clamping bounds; otherwise std::invalid_argument says what is wrong and nothing changes.
  /// Stamps every submap (see submapChangedAt()), so that derived layers are rebuilt.
  void restoreWindow(const LocalWindow& window);
  /// What restoreWindow() would refuse in `window`, or "" when it fits (mlmap::windowProblem()
  /// with this map's size, submaps and model).
  [[nodiscard]] std::string windowProblem(const LocalWindow& window) const;

  /// True when the window has been placed and holds `index`.
  [[nodiscard]] bool contains(const VoxelIndex& index) const;
  /// State of a voxel; unknown outside the window.
  [[nodiscard]] Occupancy state(const VoxelIndex& index) const;
  /// Log-odds of a voxel; false when unknown or outside the window.
  [[nodiscard]] bool logOdds(const VoxelIndex& index, double* log_odds) const;

  /// Calls f(world voxel index, log-odds) for every occupied voxel of the window, in the order
  /// of x, then y, then z from minIndex().
  template <typename F>
  void forEachOccupied(F&& f) const {
    if (!placed_) return;
    // slot() walked column by column: one wrap-around per column instead of three modulos per
    // voxel (a 750 x 750 x 75 LiDAR window is 42 million voxels); only the columns that ever
    // took a hit or a restored voxel are read (a LiDAR in a room reaches a few percent of them).
    const auto ny = static_cast<std::size_t>(size_.y());
    const auto nz = static_cast<std::size_t>(size_.z());
    const auto z0 = static_cast<std::size_t>(floorMod(min_index_.z(), size_.z()));
    const auto sy0 = static_cast<std::size_t>(floorMod(min_index_.y(), size_.y()));
    for (int x = 0; x < size_.x(); ++x) {
      const std::size_t row =
          static_cast<std::size_t>(floorMod(min_index_.x() + x, size_.x())) * ny;
      // Window y 0, 1, ... are torus y sy0 .. ny - 1, then 0 .. sy0 - 1.
      auto listColumn = [&](std::size_t torus_column, int y) {
        const std::size_t column = torus_column * nz;
        if (!anyOccupied(cells_.get() + column)) return;
        std::size_t sz = z0;
        for (int z = 0; z < size_.z(); ++z) {
          const LogOddsQ v = flipUnknown(cells_[column + sz]);
          if (model_.isOccupied(v)) f(min_index_ + VoxelIndex(x, y, z), dequantizeLogOdds(v));
          if (++sz == nz) sz = 0;
        }
      };
      forEachMarkedColumn(row + sy0, row + ny,
                          [&](std::size_t c) { listColumn(c, static_cast<int>(c - row - sy0)); });
      forEachMarkedColumn(row, row + sy0, [&](std::size_t c) {
        listColumn(c, static_cast<int>(c - row + ny - sy0));
      });
    }
  }

  /// First voxel of the window (inclusive) and one past the last.
  [[nodiscard]] const VoxelIndex& minIndex() const { return min_index_; }
  [[nodiscard]] VoxelIndex maxIndex() const { return min_index_ + size_; }
  [[nodiscard]] const SubmapIndex& centerSubmap() const { return center_; }
  [[nodiscard]] SubmapIndex submapOf(const VoxelIndex& index) const;
  [[nodiscard]] bool placed() const { return placed_; }
  [[nodiscard]] const LocalMapConfig& config() const { return config_; }
  [[nodiscard]] const LocalMapCounters& counters() const { return counters_; }

  /// The change clock: advanced by every call that can change voxel values (integrate(),
  /// re-centring, restoreWindow()). A reader that built something from the window when the clock
  /// read `c` needs to redo the submaps m with submapChangedAt(m) > c, and only those.
  [[nodiscard]] std::uint64_t changeClock() const { return change_clock_; }
  /// The change clock at the last change of a stored value (log-odds, not only state) of submap
  /// `m`, or at its entry into the window; `m` must be a submap of the window.
  [[nodiscard]] std::uint64_t submapChangedAt(const SubmapIndex& m) const {
    return submap_changed_at_[submapSlot(m)];
  }
  /// The same for changes of a voxel's state (unknown / free / occupied), for readers derived
  /// from states only (the ESDF): never later than submapChangedAt(m).
  [[nodiscard]] std::uint64_t submapStateChangedAt(const SubmapIndex& m) const {
    return submap_state_changed_at_[submapSlot(m)];
  }
  /// Columns (x, y) of the window that the occupied listing reads: every column holding an
  /// occupied voxel is among them, and a column that a window move emptied of occupied voxels
  /// is not.
  [[nodiscard]] std::size_t markedColumns() const {
    std::size_t n = 0;
    for (const std::uint64_t word : may_hold_occupied_)
      n += static_cast<std::size_t>(__builtin_popcountll(word));
    return n;
  }
  /// Bytes held by the voxel storage (2 bytes per voxel) and the change stamps of its columns.
  [[nodiscard]] std::size_t memoryBytes() const {
    return cell_count_ * sizeof(LogOddsQ) + column_changed_at_.capacity() * sizeof(std::uint64_t) +
           may_hold_occupied_.capacity() * sizeof(std::uint64_t);
  }
  /// Bytes per voxel of the active area.
  static constexpr std::size_t kBytesPerVoxel = sizeof(LogOddsQ);

 private:
  [[nodiscard]] static int floorMod(int v, int n) {
    const int r = v % n;
    return r < 0 ? r + n : r;
  }
  [[nodiscard]] std::size_t slot(const VoxelIndex& g) const {
    return (static_cast<std::size_t>(floorMod(g.x(), size_.x())) *
                static_cast<std::size_t>(size_.y()) +
            static_cast<std::size_t>(floorMod(g.y(), size_.y()))) *
               static_cast<std::size_t>(size_.z()) +
           static_cast<std::size_t>(floorMod(g.z(), size_.z()));
  }
  /// A log-odds value as the window stores it, and back (the same operation): the sign bit
  /// flipped, so that unknown (the smallest value) is stored as 0. The window then starts as
  /// zeroed memory from calloc, whose pages the system provides only where a voxel is written
  /// (a 750 x 750 x 75 LiDAR window is 84 MB, of which a scan in a room reaches a few percent).
  [[nodiscard]] static LogOddsQ flipUnknown(LogOddsQ v) {
    return static_cast<LogOddsQ>(v ^ kUnknownLogOdds);
  }
  /// Frees the window's calloc'd storage.
  struct FreeCells {
    void operator()(LogOddsQ* p) const { std::free(p); }
  };
  /// Calls f(torus column) for every column in [first, end) marked by markMayHoldOccupied(), in
  /// increasing order, 64 columns per step.
  template <typename F>
  void forEachMarkedColumn(std::size_t first, std::size_t end, F&& f) const {
    while (first < end) {
      const std::size_t word_end = std::min(end, (first | 63) + 1);
      std::uint64_t bits = may_hold_occupied_[first >> 6] >> (first & 63);
      if (word_end - first < 64) bits &= (std::uint64_t{1} << (word_end - first)) - 1;
      while (bits != 0) {
        f(first + static_cast<std::size_t>(__builtin_ctzll(bits)));
        bits &= bits - 1;
      }
      first = word_end;
    }
  }
  /// True when markMayHoldOccupied() marked the torus column (and no retire unmarked it since).
  [[nodiscard]] bool columnMarked(std::size_t torus_column) const {
    return ((may_hold_occupied_[torus_column >> 6] >> (torus_column & 63)) & 1U) != 0;
  }
  /// Marks the torus column (x * size_cells.y + y) as possibly holding occupied voxels: it took
  /// a hit that made a voxel occupied, or a restored value. An unmarked column holds none.
  void markMayHoldOccupied(std::size_t torus_column) {
    may_hold_occupied_[torus_column >> 6] |= std::uint64_t{1} << (torus_column & 63);
  }
  /// Slot of submap m in submap_changed_at_ (its torus position, m mod 5 per axis).
  [[nodiscard]] static std::size_t submapSlot(const SubmapIndex& m) {
    constexpr int kN = LocalMapConfig::kSubmapsPerAxis;
    const auto slot = [](int v) { return static_cast<std::size_t>(floorMod(v, kN)); };
    constexpr auto kStride = static_cast<std::size_t>(kN);
    return (slot(m.x()) * kStride + slot(m.y())) * kStride + slot(m.z());
  }
  /// Stamps submap slot `slot` (values and states) with `clock`; every slot with a new clock.
  void stampSubmap(std::size_t slot, std::uint64_t clock);
  void stampAllSubmaps();
  /// Copies into `out` (placed and sized like the window) every column of the window, or with
  /// `all` false those changed after `changed_after`. Returns the number of columns copied.
  int copyColumns(LocalWindow* out, bool all, std::uint64_t changed_after) const;
  /// Whether any of the size_cells.z voxels of the torus column starting at `column` (stored
  /// values) is occupied.
  [[nodiscard]] bool anyOccupied(const LogOddsQ* column) const;
  /// Applies a miss to column[base + k] (stored values) for each set bit k of `bits` (all within
  /// the column), stamping the submaps (`changed_at`, `state_changed_at`: the column's stamps)
  /// whose values or states changed. Returns whether any value changed.
  bool missRun(LogOddsQ* column, int base, std::uint64_t bits, std::uint64_t now,
               std::uint64_t* changed_at, std::uint64_t* state_changed_at) const;
  /// Before integrate() reads cells [first, first + count) to update them: writes (an atomic add
  /// of 0, values unchanged) to each of their pages not written yet, so that a page never
  /// touched is mapped by that write. Read first, it would be mapped to the zero page and then
  /// copied on the write, whose change of mapping interrupts the other core (a TLB shootdown)
  /// when the engine's other thread runs.
  void writeFirst(std::size_t first, std::size_t count);
  void moveCenter(const SubmapIndex& new_center, GlobalMap* global);
  void retireSubmap(const SubmapIndex& m, GlobalMap* global);
  void restoreSubmap(const SubmapIndex& m, GlobalMap* global);

  LocalMapConfig config_;
  LogOddsModel model_;
  Eigen::Vector3i size_;
  Eigen::Vector3i submap_;
  std::size_t cell_count_;                        // size_cells.x * y * z
  std::unique_ptr<LogOddsQ[], FreeCells> cells_;  // stored values, see flipUnknown()
  bool placed_ = false;
  SubmapIndex center_ = SubmapIndex::Zero();
  VoxelIndex min_index_ = VoxelIndex::Zero();
  LocalMapCounters counters_;
  std::vector<VoxelRecord> scratch_;
  std::uint64_t change_clock_ = 0;
  std::vector<std::uint64_t> submap_changed_at_;        // per torus submap slot, see submapSlot()
  std::vector<std::uint64_t> submap_state_changed_at_;  // the same for state changes
  // Per torus submap slot: 1 when a cell of it may be other than unknown (written by a change
  // since the slot was last cleared), 0 when all its cells are unknown: retiring such a slot
  // reads none of its cells (a fresh window's pages are never touched; reading them would map
  // them).
  std::vector<std::uint8_t> submap_written_;
  std::vector<std::uint64_t> column_changed_at_;  // per torus column x, y: last value change
  std::vector<std::uint8_t> submap_of_torus_x_;   // torus x -> submap slot x (no division per hit)
  std::vector<std::uint8_t> submap_of_torus_y_;   // torus y -> submap slot y
  std::vector<std::uint8_t> submap_of_torus_z_;  // torus z -> submap slot z (no division per voxel)
  std::vector<std::uint64_t>
      may_hold_occupied_;  // a bit per torus column, see markMayHoldOccupied()
  // A bit per 4 kB page of cells_: set once integrate() has written to it (see writeFirst()).
  std::vector<std::uint64_t> page_written_;
};

}  // namespace mlmap
