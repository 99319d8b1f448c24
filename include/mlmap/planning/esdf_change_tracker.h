#pragma once
/// @file
/// Part of the ESDF (EsdfMap, esdf.h): what changed since the last frame and where EsdfMap's
/// incremental update() must work again. EsdfChangeTracker keeps the box states of the last
/// frame, compares a new box with them (collectChangedStates()), shifts them when the box
/// moves, and holds the marks of the lines whose inputs changed (EsdfLineMarks), with the range
/// along each line where they did. All positions are in voxels, in box coordinates (from the
/// box's min_index).

#include "mlmap/core/types.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace mlmap {

/// A part of a box, voxels [lo, hi) in box coordinates (from the box's min_index); the type of
/// EsdfMap::Region.
struct EsdfRegion {
  Eigen::Vector3i lo;  ///< first voxel, inclusive
  Eigen::Vector3i hi;  ///< one past the last voxel
};

/// A y line (across = z) or z line (across = y) of x slab x that update() transforms again, and
/// the range [lo, hi] along it where its inputs changed.
struct EsdfMarkedLine {
  int x;       ///< x slab
  int across;  ///< z of a y line, y of a z line
  int lo;      ///< first changed input along the line
  int hi;      ///< last changed input (inclusive)
};

/// The part of a line that changed inputs over [lo, hi] reach: the outputs
/// [out_begin, out_end), within `reach` of them, and the inputs those depend on,
/// [in_begin, in_end), within twice that (see EsdfMap::update()).
struct ReachedPart {
  int in_begin;   ///< first input to transform
  int in_end;     ///< one past the last input
  int out_begin;  ///< first output that may change
  int out_end;    ///< one past the last
};

/// reachedPart(lo, hi, reach, length): see ReachedPart; clipped to the line's `length`.
inline ReachedPart reachedPart(int lo, int hi, int reach, int length) {
  return {std::max(0, lo - 2 * reach), std::min(length, hi + 2 * reach + 1),
          std::max(0, lo - reach), std::min(length, hi + reach + 1)};
}

/// Shifts a box-shaped array (x-major, z fastest) of `size` voxels so that new voxel v holds
/// old voxel v + delta (voxels); voxels with no old counterpart get `unseen`. In place: each
/// position is read (as the source of position p - offset) before it is written.
template <typename T>
void shiftBox(std::vector<T>* values, const Eigen::Vector3i& size, const VoxelIndex& delta,
              T unseen) {
  const std::ptrdiff_t nx = size.x();
  const std::ptrdiff_t ny = size.y();
  const std::ptrdiff_t nz = size.z();
  const std::ptrdiff_t offset = (delta.x() * ny + delta.y()) * nz + delta.z();
  if (offset == 0) return;
  T* v = values->data();
  const std::ptrdiff_t z_lo = std::max<std::ptrdiff_t>(0, -delta.z());
  const std::ptrdiff_t z_hi = std::min<std::ptrdiff_t>(nz, nz - delta.z());
  const auto run = [&](std::ptrdiff_t x, std::ptrdiff_t y) {
    T* dst = v + (x * ny + y) * nz;
    const std::ptrdiff_t sx = x + delta.x();
    const std::ptrdiff_t sy = y + delta.y();
    if (sx < 0 || sx >= nx || sy < 0 || sy >= ny || z_lo >= z_hi) {
      std::fill(dst, dst + nz, unseen);
      return;
    }
    std::memmove(dst + z_lo, dst + z_lo + offset,
                 static_cast<std::size_t>(z_hi - z_lo) * sizeof(T));
    std::fill(dst, dst + z_lo, unseen);
    std::fill(dst + z_hi, dst + nz, unseen);
  };
  if (offset > 0) {
    for (std::ptrdiff_t x = 0; x < nx; ++x)
      for (std::ptrdiff_t y = 0; y < ny; ++y) run(x, y);
  } else {
    for (std::ptrdiff_t x = nx - 1; x >= 0; --x)
      for (std::ptrdiff_t y = ny - 1; y >= 0; --y) run(x, y);
  }
}

/// Marks of the lines of one direction (y lines, indexed x * nz + z, or z lines, indexed
/// x * ny + y) that a pass transforms again: per line the range [lo, hi] of positions along it
/// where its inputs changed. A line is unmarked at lo = length, hi = -1.
class EsdfLineMarks {
 public:
  /// `lines` lines of `length` positions, all unmarked.
  void reset(std::size_t lines, int length) {
    length_ = length;
    lo_.assign(lines, length);
    hi_.assign(lines, -1);
  }
  /// Positions along each line.
  [[nodiscard]] int length() const { return length_; }
  /// Lowest changed positions, from line `first` on (to read and write in place).
  [[nodiscard]] int* lo(std::size_t first) { return lo_.data() + first; }
  /// Highest changed positions, from line `first` on.
  [[nodiscard]] int* hi(std::size_t first) { return hi_.data() + first; }
  /// Widens the range of every line to hold `position` (a face of the box that moved).
  void markAll(int position) {
    for (std::size_t i = 0; i < lo_.size(); ++i) {
      lo_[i] = std::min(lo_[i], position);
      hi_[i] = std::max(hi_[i], position);
    }
  }
  /// Takes the marked lines (per x slab of `nx`, `per_slab` lines), leaving them unmarked, and
  /// orders them by the start of their range into `sorted` (a counting sort, stable; `marked`
  /// and `starts` are its scratch): lines taken 16 at a time then share most of their ranges.
  void take(int nx, int per_slab, std::vector<EsdfMarkedLine>* marked,
            std::vector<EsdfMarkedLine>* sorted, std::vector<int>* starts);
  /// Bytes held.
  [[nodiscard]] std::size_t memoryBytes() const {
    return (lo_.capacity() + hi_.capacity()) * sizeof(int);
  }

 private:
  int length_ = 0;
  std::vector<int> lo_;
  std::vector<int> hi_;
};

/// What changed since the last frame (the kept box states, the changed voxels) and the lines
/// the passes transform again (their marks). Not thread-safe; EsdfMap::update() uses it from
/// one thread.
class EsdfChangeTracker {
 public:
  /// Kept-state value of a voxel that was not in the kept box (differs from every state).
  static constexpr std::uint8_t kUnseenState = 0xFF;

  /// x and z range of a y row's changed states that pass 1 sweeps again.
  struct RowSpan {
    int z_lo;  ///< lowest z of a changed state (nz: none)
    int z_hi;  ///< highest z (-1: none)
    int x_lo;  ///< lowest x
    int x_hi;  ///< highest x
  };

  /// Sizes for a box of `size` voxels: the kept states (contents left to the caller) and the
  /// line marks (all unmarked). Allocates.
  void reset(const Eigen::Vector3i& size);
  /// The kept box states (OccupancyBox order, as bytes), to be written by the caller.
  [[nodiscard]] std::uint8_t* keptStates() { return kept_states_.data(); }
  /// Shifts the kept states by `delta` voxels (new min_index - old); the voxels that were not in
  /// the kept box become kUnseenState.
  void shiftKept(const VoxelIndex& delta) { shiftBox(&kept_states_, size_, delta, kUnseenState); }

  /// Lists in changedStates() the voxels of `now` (a box of the reset() size, OccupancyBox
  /// order, as bytes) whose state differs from the kept one, inside `regions` (clipped to the
  /// box; overlaps allowed) or everywhere (null); false once more than `budget` did.
  [[nodiscard]] bool collectChangedStates(const std::uint8_t* now, std::size_t budget,
                                          const std::vector<EsdfRegion>* regions);
  /// Box offsets of the states collectChangedStates() found changed, each once.
  [[nodiscard]] const std::vector<std::uint32_t>& changedStates() const { return changed_states_; }

  /// Empties the row spans for a frame: every row gets no z range and the x range [x_face,
  /// x_face] (a face the move removed), or none when x_face < 0.
  void clearRowSpans(int x_face) {
    const int nx = size_.x();
    rows_.assign(static_cast<std::size_t>(size_.y()),
                 RowSpan{size_.z(), -1, x_face >= 0 ? x_face : nx, x_face >= 0 ? x_face : -1});
  }
  /// Widens the span of row y to hold a changed voxel at (x, z).
  void addRowChange(int x, std::size_t y, int z) {
    RowSpan& r = rows_[y];
    r.z_lo = std::min(r.z_lo, z);
    r.z_hi = std::max(r.z_hi, z);
    r.x_lo = std::min(r.x_lo, x);
    r.x_hi = std::max(r.x_hi, x);
  }
  /// The span of row y.
  [[nodiscard]] const RowSpan& rowSpan(int y) const { return rows_[static_cast<std::size_t>(y)]; }

  /// The marks of the y lines (x * nz + z; along y).
  [[nodiscard]] EsdfLineMarks& yMarks() { return y_marks_; }
  /// The marks of the z lines (x * ny + y; along z).
  [[nodiscard]] EsdfLineMarks& zMarks() { return z_marks_; }
  /// Takes the marked y lines, ordered by the start of their range (see EsdfLineMarks::take()).
  const std::vector<EsdfMarkedLine>& takeYLines() {
    y_marks_.take(size_.x(), size_.z(), &marked_, &sorted_, &starts_);
    return sorted_;
  }
  /// The same for the z lines.
  const std::vector<EsdfMarkedLine>& takeZLines() {
    z_marks_.take(size_.x(), size_.y(), &marked_, &sorted_, &starts_);
    return sorted_;
  }

  /// Bytes held.
  [[nodiscard]] std::size_t memoryBytes() const;

 private:
  Eigen::Vector3i size_ = Eigen::Vector3i::Zero();
  /// The box states of the last compute() / update() (what update() compares with).
  std::vector<std::uint8_t> kept_states_;
  std::vector<std::uint32_t> changed_states_;  ///< offsets of the states found changed
  std::vector<EsdfRegion> merged_regions_;     ///< the regions clipped and merged
  std::vector<RowSpan> rows_;                  ///< per y row: its changed states' span
  EsdfLineMarks y_marks_;
  EsdfLineMarks z_marks_;
  std::vector<EsdfMarkedLine> marked_;  ///< takeYLines() / takeZLines(): the lines taken ...
  std::vector<EsdfMarkedLine> sorted_;  ///< ... ordered by the start of their range
  std::vector<int> starts_;             ///< ... and the counting sort's buckets
};

}  // namespace mlmap
