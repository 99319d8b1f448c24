// EsdfMap, the incremental update(): the changed states found (EsdfChangeTracker), a moved box
// brought to its new place, and pass 1 run again over the rows the changes reach, marking the
// lines that passes 2 and 3 then transform again (esdf_update_lines.cpp); see the file comment
// of esdf.h. Each part goes through the same kernels as compute() (esdf.cpp), so the field is
// bit-identical to a full compute.

#include "mlmap/planning/esdf.h"

#include "esdf_line_kernels.h"
#include <cstring>
#include <limits>
#include <type_traits>

namespace mlmap {
namespace {

using esdf_kernel::isObstacle;
using esdf_kernel::sweepBlock;

/// Pass-buffer value of a voxel that was not in the kept box (no pass produces it).
constexpr std::int32_t kUnseenPass = std::numeric_limits<std::int32_t>::min();
/// Field value of a voxel that was not in the kept box (beyond any clamp).
constexpr float kUnseenField = std::numeric_limits<float>::lowest();
/// The same for the x pass's 8-bit results (at most cap_d + 1 <= 49 in magnitude) ...
constexpr std::int8_t kUnseenNarrow1 = std::numeric_limits<std::int8_t>::min();
/// ... and the y pass's 16-bit ones (at most cap_sq + 1 < 16384 in magnitude).
constexpr std::int16_t kUnseenNarrow2 = std::numeric_limits<std::int16_t>::min();
/// update() recomputes the whole field when more than 1 / kFullFraction of the voxels changed.
constexpr std::size_t kFullFraction = 16;

}  // namespace

bool EsdfMap::update(const OccupancyBox& box) { return updateWithin(box, nullptr); }

bool EsdfMap::update(const OccupancyBox& box, const std::vector<Region>& may_have_changed) {
  return updateWithin(box, &may_have_changed);
}

bool EsdfMap::updateWithin(const OccupancyBox& box, const std::vector<Region>* regions) {
  const Eigen::Vector3i& size = field_.size();
  if (!kept_ || !wellFormed(box) || box.size != size || box.resolution_m != field_.resolution_m()) {
    return compute(box);
  }
  const VoxelIndex delta = box.min_index - field_.minIndex();
  for (int a = 0; a < 3; ++a) {
    if (std::abs(delta[a]) >= size[a]) return compute(box);
  }
  last_update_ = UpdateStats{};
  last_update_.full = false;
  // A moved box, where the windowed passes apply: moved along z, every z line reaches a new
  // or a removed face within the clamp (the box is shallow), so it is computed whole. Moved
  // along x or y, the kept box is first brought to the new place with its kept states (see
  // moveWindowed()), then the states that changed there go through the unmoved path below.
  const bool moved_windowed = !delta.isZero() && window_kernel_;
  if (moved_windowed && delta.z() != 0) return compute(box);
  // Until this update is through, the kept state is not the box's: were it cut short (an
  // allocation failing), the next update computes the field whole.
  kept_ = false;
  if (moved_windowed) {
    moveWindowed(box, delta);
  } else if (!delta.isZero()) {
    shiftKept(delta);
    field_.setMinIndex(box.min_index);
    last_update_.shifted = true;
  }
  // The changed voxels; many of them (unmoved box): the full compute is cheaper (and uses
  // every thread).
  const std::size_t cells = box.states.size();
  const std::size_t budget = last_update_.shifted ? cells : cells / kFullFraction;
  const auto* states = reinterpret_cast<const std::uint8_t*>(box.states.data());
  if (!tracker_.collectChangedStates(states, budget, delta.isZero() ? regions : nullptr)) {
    return compute(box);
  }
  updateChanged(box, moved_windowed ? VoxelIndex::Zero() : delta);
  if (moved_windowed) {  // every cell may have moved: a copy must take the field whole
    last_update_.shifted = true;
    last_update_.changed_cells = cells;
    changed_cells_.clear();
  }
  kept_ = true;
  return true;
}

void EsdfMap::shiftKept(const VoxelIndex& delta) {
  const Eigen::Vector3i& size = field_.size();
  tracker_.shiftKept(delta);
  shiftBox(&pass1_, size, delta, kUnseenPass);
  shiftBox(&pass2_, size, delta, kUnseenPass);
  shiftBox(&field_.mutableValues_m(), size, delta, kUnseenField);
}

void EsdfMap::moveWindowed(const OccupancyBox& box, const VoxelIndex& delta) {
  // The kept box brought to B' (see moveKeptSlabs()); its x pass where it may differ from the
  // moved results, marking the y lines where it does (sweepMovedRows()). The new slabs are
  // transformed whole, and the removed y face marks every kept y line (its neighbours there are
  // gone, with no changed input). updateChanged() then transforms the marked lines.
  moveKeptSlabs(box, delta);
  Scratch* scratch = &scratch_[0];
  sweepMovedRows(delta, scratch);
  const int nx = field_.size().x();
  const int ny = field_.size().y();
  const int nz = field_.size().z();
  const int dx = delta.x();
  const int dy = delta.y();
  const int face = dy > 0 ? 0 : ny - 1;
  const std::uint8_t* kept = tracker_.keptStates();
  EsdfLineMarks& y_marks = tracker_.yMarks();
  for (int x = 0; x < nx; ++x) {
    if (x + dx < 0 || x + dx >= nx) {  // a new slab
      transformSlabs(kept, x, x + 1, scratch);
      last_update_.y_lines += static_cast<std::size_t>(nz);
      last_update_.z_lines += static_cast<std::size_t>(ny);
      continue;
    }
    if (dy == 0) continue;
    int* lo = y_marks.lo(static_cast<std::size_t>(x) * nz);
    int* hi = y_marks.hi(static_cast<std::size_t>(x) * nz);
    for (int z = 0; z < nz; ++z) {
      lo[z] = std::min(lo[z], face);
      hi[z] = std::max(hi[z], face);
    }
  }
}

void EsdfMap::moveKeptSlabs(const OccupancyBox& box, const VoxelIndex& delta) {
  const int nx = field_.size().x();
  const int ny = field_.size().y();
  const int nz = field_.size().z();
  const int dx = delta.x();
  const int dy = delta.y();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  const auto* now = reinterpret_cast<const std::uint8_t*>(box.states.data());
  const auto kept_slab = [&](int x) { return x + dx >= 0 && x + dx < nx; };
  // The kept slabs' states and results (x pass, y pass, field) moved to their new place, in the
  // order that reads each source slab before it is overwritten; the new rows of a kept slab
  // get the new box's states and values no pass produces, so that they differ from the fresh
  // ones below. The new slabs take the new box's states after that (their place may have been
  // a source). This box of states, B', differs from the new one only where the kept part
  // changed, which update() then handles as for an unmoved box. The unknown bits move with the
  // slabs where the rows do not move, and are written again where they do.
  std::uint8_t* kept = tracker_.keptStates();
  const int row_lo = std::max(0, -dy);
  const int row_hi = std::min(ny, ny - dy);
  const auto kept_rows = static_cast<std::size_t>(row_hi - row_lo) * static_cast<std::size_t>(nz);
  const auto moveSlab = [&](auto* values, int x, auto unseen) {
    auto* slab_values = values + static_cast<std::size_t>(x) * slab;
    std::memmove(slab_values + static_cast<std::size_t>(row_lo) * nz,
                 values + static_cast<std::size_t>(x + dx) * slab +
                     static_cast<std::size_t>(row_lo + dy) * nz,
                 kept_rows * sizeof(*values));
    std::fill(slab_values, slab_values + static_cast<std::size_t>(row_lo) * nz, unseen);
    std::fill(slab_values + static_cast<std::size_t>(row_hi) * nz, slab_values + slab, unseen);
  };
  for (int i = 0; i < nx; ++i) {
    const int x = dx >= 0 ? i : nx - 1 - i;
    if (!kept_slab(x)) continue;
    const std::size_t first = static_cast<std::size_t>(x) * slab;
    std::memmove(
        kept + first + static_cast<std::size_t>(row_lo) * nz,
        kept + static_cast<std::size_t>(x + dx) * slab + static_cast<std::size_t>(row_lo + dy) * nz,
        kept_rows);
    std::memcpy(kept + first, now + first, static_cast<std::size_t>(row_lo) * nz);
    const std::size_t high = static_cast<std::size_t>(row_hi) * nz;
    std::memcpy(kept + first + high, now + first + high, slab - high);
    moveSlab(pass1_narrow_.data(), x, kUnseenNarrow1);
    moveSlab(pass2_narrow_.data(), x, kUnseenNarrow2);
    moveSlab(field_.mutableValues_m().data(), x, kUnseenField);
    if (dy == 0) {
      field_.copyUnknownSlab(x + dx, x);
    } else {
      field_.writeUnknownBits(kept, x);
    }
  }
  for (int x = 0; x < nx; ++x) {
    if (kept_slab(x)) continue;
    const std::size_t first = static_cast<std::size_t>(x) * slab;
    std::memcpy(kept + first, now + first, slab);
  }
  field_.setMinIndex(box.min_index);
}

void EsdfMap::sweepMovedRows(const VoxelIndex& delta, Scratch* scratch) {
  const int nx = field_.size().x();
  const int ny = field_.size().y();
  const int nz = field_.size().z();
  const int dx = delta.x();
  const int dy = delta.y();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  const auto kept_slab = [&](int x) { return x + dx >= 0 && x + dx < nx; };
  const std::uint8_t* kept = tracker_.keptStates();
  EsdfLineMarks& y_marks = tracker_.yMarks();
  const int row_lo = std::max(0, -dy);
  const int row_hi = std::min(ny, ny - dy);
  // The x pass of B', a block of rows at a time. In the kept slabs, a result that differs from
  // the moved one (next to a new or removed x face, or in a new row) marks its y line, as a
  // changed state's would. The new slabs are swept whole.
  const std::int32_t unknown_is_obstacle = unknownIsObstacle();
  std::vector<std::int8_t>& narrow_rows = scratch->narrow_rows;
  narrow_rows.resize(static_cast<std::size_t>(std::min(kNarrowRowBlock, ny)) * nz);
  std::int8_t* narrow = narrow_rows.data();
  // In a kept row, the x pass changed only within the clamp of a new or removed x face: the
  // bands [0, low_end) and [high_begin, nx), each swept over a part that reaches cap_d + 1
  // beyond it (its results there are then exact: a voxel farther than cap_d is beyond the cap).
  const int reach = cap_d_ + 1;
  const int low_end = dx == 0 ? 0 : std::min(nx, (dx < 0 ? -dx : 0) + reach);
  const int high_begin = dx == 0 ? nx : std::max(0, nx - (dx > 0 ? dx : 0) - reach);
  const bool split = low_end + reach < high_begin - reach;
  // Writes the fresh results of slab x (`from`, n values of the row block at y0) over the kept
  // ones, marking the y lines where a kept slab's differ.
  const auto merge = [&](int x, const std::int32_t* from, int y0, int n) {
    for (int i = 0; i < n; ++i) narrow[i] = static_cast<std::int8_t>(from[i]);
    std::int8_t* to = pass1_narrow_.data() + static_cast<std::size_t>(x) * slab +
                      static_cast<std::size_t>(y0) * nz;
    if (kept_slab(x) && std::memcmp(to, narrow, static_cast<std::size_t>(n)) != 0) {
      int* lo = y_marks.lo(static_cast<std::size_t>(x) * nz);
      int* hi = y_marks.hi(static_cast<std::size_t>(x) * nz);
      for (int i = 0; i < n; ++i) {
        if (narrow[i] == to[i]) continue;
        const int y = y0 + i / nz;
        const int z = i % nz;
        lo[z] = std::min(lo[z], y);
        hi[z] = std::max(hi[z], y);
      }
    }
    std::memcpy(to, narrow, static_cast<std::size_t>(n));
  };
  // Sweeps the x range [b, e) of the row block at y0 and merges the results of [out_b, out_e).
  const auto sweepPart = [&](int y0, int n, int b, int e, int out_b, int out_e) {
    std::int32_t* fresh = scratch->sweep.data();
    sweepBlock(kept + static_cast<std::size_t>(b) * slab + static_cast<std::size_t>(y0) * nz, slab,
               fresh, static_cast<std::size_t>(n), e - b, n, scratch->near_free.data(),
               scratch->near_obstacle.data(), unknown_is_obstacle, cap_d_, pass1Inf());
    for (int x = out_b; x < out_e; ++x) {
      merge(x, fresh + static_cast<std::size_t>(x - b) * static_cast<std::size_t>(n), y0, n);
    }
  };
  for (int y0 = 0; y0 < ny; y0 += kNarrowRowBlock) {
    const int rows = std::min(kNarrowRowBlock, ny - y0);
    const int n = rows * nz;
    const bool new_rows = y0 < row_lo || y0 + rows > row_hi;
    if (new_rows || !split) {
      sweepPart(y0, n, 0, nx, 0, nx);
      last_update_.rows_swept += static_cast<std::size_t>(rows);
      continue;
    }
    if (low_end > 0 || high_begin < nx) last_update_.rows_swept += static_cast<std::size_t>(rows);
    if (low_end > 0) sweepPart(y0, n, 0, low_end + reach, 0, low_end);
    if (high_begin < nx) sweepPart(y0, n, high_begin - reach, nx, high_begin, nx);
  }
}

void EsdfMap::updateChanged(const OccupancyBox& box, const VoxelIndex& shift) {
  const int ny = field_.size().y();
  const int nz = field_.size().z();
  const auto* states = reinterpret_cast<const std::uint8_t*>(box.states.data());
  Scratch* scratch = &scratch_[0];
  changed_cells_.clear();
  // A changed input at i changes outputs within reach = cap_d_ + 1 of it (a site's parabola
  // within the cap, or a run boundary next to it); those outputs depend on inputs within reach
  // of them. So lines are transformed again over [lo - 2 reach, hi + 2 reach] and compared over
  // [lo - reach, hi + reach]: the parabolas cut off at the ends lie beyond the cap there.
  const int reach = cap_d_ + 1;
  // After a shift along y (z), the voxels removed on one side change the y (z) pass's results
  // next to that face, with no changed input there: that face counts as changed.
  if (shift.y() != 0) tracker_.yMarks().markAll(shift.y() > 0 ? 0 : ny - 1);
  if (shift.z() != 0) tracker_.zMarks().markAll(shift.z() > 0 ? 0 : nz - 1);
  row_buffer_.resize(static_cast<std::size_t>(field_.size().x()) * static_cast<std::size_t>(nz));
  applyChangedStates(states, shift);
  resweepChangedRows(states, reach, scratch);
  if (window_kernel_) {
    updateLinesWindowed(reach, scratch);
  } else {
    updateLinesEnvelope(reach, scratch);
  }
  last_update_.changed_cells = last_update_.shifted ? box.states.size() : changed_cells_.size();
}

void EsdfMap::applyChangedStates(const std::uint8_t* states, const VoxelIndex& shift) {
  const int nx = field_.size().x();
  const int nz = field_.size().z();
  const std::size_t slab =
      static_cast<std::size_t>(field_.size().y()) * static_cast<std::size_t>(nz);
  constexpr auto kUnknown = static_cast<std::uint8_t>(Occupancy::kUnknown);
  UpdateStats& u = last_update_;
  // Changed states: the rows of those whose kind changed (obstacle or not: all pass 1 reads) are
  // swept again over the z range of the row's changes; their unknown bits follow (all of them
  // after a shift, whose bits were not shifted). Most of a frame's changes are unknown voxels
  // seen free: with unknown as free, no kind changes there, and no row is swept for them.
  const std::int32_t unknown_is_obstacle = unknownIsObstacle();
  // A kept voxel a shift left unseen (kUnseenState) has no pass 1 result yet: always swept.
  const auto kind_changed = [&](std::uint8_t now, std::uint8_t before) {
    return before == EsdfChangeTracker::kUnseenState ||
           isObstacle(now, unknown_is_obstacle) != isObstacle(before, unknown_is_obstacle);
  };
  std::uint8_t* kept = tracker_.keptStates();
  // x range of a row's changes; after a shift along x the face it removed counts as changed.
  tracker_.clearRowSpans(shift.x() == 0 ? -1 : shift.x() > 0 ? 0 : nx - 1);
  const std::vector<std::uint32_t>& changed_states = tracker_.changedStates();
  for (const std::uint32_t c : changed_states) {
    const std::size_t i = c;
    const std::size_t x = i / slab;
    const std::size_t r = i - x * slab;
    const std::size_t y = r / static_cast<std::size_t>(nz);
    const int z = static_cast<int>(r - y * static_cast<std::size_t>(nz));
    if (kind_changed(states[i], kept[i])) tracker_.addRowChange(static_cast<int>(x), y, z);
    if (!u.shifted && (states[i] == kUnknown) != (kept[i] == kUnknown)) {
      field_.flipUnknownBit(x, r);
      changed_cells_.push_back(c);
    }
    kept[i] = states[i];
  }
  u.changed_states = changed_states.size();
  if (u.shifted) {
    for (int x = 0; x < nx; ++x) field_.writeUnknownBits(states, x);
  }
}

void EsdfMap::resweepChangedRows(const std::uint8_t* states, int reach, Scratch* scratch) {
  const int nx = field_.size().x();
  const int ny = field_.size().y();
  const int nz = field_.size().z();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  const std::int32_t unknown_is_obstacle = unknownIsObstacle();
  EsdfLineMarks& y_marks = tracker_.yMarks();
  // Pass 1, row by row over the changed z range and the x range the changes reach (as for the
  // lines); changed results mark their y lines.
  for (int y = 0; y < ny; ++y) {
    const EsdfChangeTracker::RowSpan& span = tracker_.rowSpan(y);
    const int z_lo = span.z_lo;
    const int z_hi = span.z_hi;
    if (z_hi < z_lo) continue;
    ++last_update_.rows_swept;
    const int n = z_hi - z_lo + 1;
    const std::size_t row = static_cast<std::size_t>(y) * nz + static_cast<std::size_t>(z_lo);
    const ReachedPart xs = reachedPart(span.x_lo, span.x_hi, reach, nx);
    const int x_begin = xs.in_begin;
    sweepBlock(states + static_cast<std::size_t>(x_begin) * slab + row, slab, row_buffer_.data(),
               static_cast<std::size_t>(n), xs.in_end - x_begin, n, scratch->near_free.data(),
               scratch->near_obstacle.data(), unknown_is_obstacle, cap_d_, pass1Inf());
    // Writes the fresh results over the kept ones (32 or 8 bits), marking the changed ones.
    const auto merge = [&](auto* kept_pass1, int x) {
      const std::int32_t* fresh =
          row_buffer_.data() + static_cast<std::size_t>(x - x_begin) * static_cast<std::size_t>(n);
      auto* old = kept_pass1 + static_cast<std::size_t>(x) * slab + row;
      int* lo = y_marks.lo(static_cast<std::size_t>(x) * nz + z_lo);
      int* hi = y_marks.hi(static_cast<std::size_t>(x) * nz + z_lo);
      // Most of the row's results are unchanged: checked first without a branch (it vectorises).
      int differ = 0;
      for (int z = 0; z < n; ++z) differ |= static_cast<int>(fresh[z] != old[z]);
      if (differ == 0) return;
      for (int z = 0; z < n; ++z) {
        if (fresh[z] != old[z]) {
          old[z] = static_cast<std::remove_reference_t<decltype(old[z])>>(fresh[z]);
          lo[z] = std::min(lo[z], y);
          hi[z] = std::max(hi[z], y);
        }
      }
    };
    for (int x = xs.out_begin; x < xs.out_end; ++x) {
      if (window_kernel_) {
        merge(pass1_narrow_.data(), x);
      } else {
        merge(pass1_.data(), x);
      }
    }
  }
}

}  // namespace mlmap
