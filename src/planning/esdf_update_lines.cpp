// EsdfMap, the incremental update()'s passes 2 (y) and 3 (z): only the lines that pass 1 (or
// pass 2) marked in the EsdfChangeTracker, each over the part its changed range reaches, line
// by line with the envelope code or, where the windowed passes apply, 16 lines side by side
// through esdf_kernel::transformLines(). Finding what changed and pass 1 are in esdf_update.cpp.

#include "mlmap/planning/esdf.h"

#include "mlmap/planning/esdf_window_kernel.h"

#include <array>

namespace mlmap {
namespace {

/// update()'s windowed passes take their marked lines kGroupLanes at a time.
constexpr auto kGroupWidth = static_cast<std::size_t>(esdf_kernel::kGroupLanes);

/// Floats in a 64-byte cache line (the step of the z pass's prefetches).
constexpr int kFloatsPerCacheLine = 16;

/// Where a group of marked lines (sorted by start) is transformed along a line of `length`:
/// the part the union of their changed ranges reaches.
ReachedPart groupSpan(const EsdfMarkedLine* group, std::size_t count, int reach, int length) {
  int hi = -1;
  for (std::size_t l = 0; l < count; ++l) hi = std::max(hi, group[l].hi);
  return reachedPart(group[0].lo, hi, reach, length);  // sorted by start
}

/// The part one marked line's changed range reaches.
ReachedPart linePart(const EsdfMarkedLine& line, int reach, int length) {
  return reachedPart(line.lo, line.hi, reach, length);
}

}  // namespace

void EsdfMap::updateLinesEnvelope(int reach, Scratch* scratch) {
  const int nx = field_.size().x();
  const int ny = field_.size().y();
  const int nz = field_.size().z();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  EsdfLineMarks& y_marks = tracker_.yMarks();
  EsdfLineMarks& z_marks = tracker_.zMarks();
  // Pass 2, the marked y lines; changed results mark their z lines.
  UpdateStats& u = last_update_;
  std::int32_t* line = scratch->line.data();
  for (int x = 0; x < nx; ++x) {
    int* dirty_lo = y_marks.lo(static_cast<std::size_t>(x) * nz);
    int* dirty_hi = y_marks.hi(static_cast<std::size_t>(x) * nz);
    std::int32_t* slab_values = pass2_.data() + static_cast<std::size_t>(x) * slab;
    int* mark_lo = z_marks.lo(static_cast<std::size_t>(x) * ny);
    int* mark_hi = z_marks.hi(static_cast<std::size_t>(x) * ny);
    for (int z = 0; z < nz; ++z) {
      if (dirty_hi[z] < dirty_lo[z]) continue;
      const int lo = dirty_lo[z];
      const int hi = dirty_hi[z];
      dirty_lo[z] = ny;  // the marks are left clear (see EsdfLineMarks)
      dirty_hi[z] = -1;
      ++u.y_lines;
      const ReachedPart part = reachedPart(lo, hi, reach, ny);
      transformYLine(x, z, part.in_begin, part.in_end, line, scratch);
      for (int y = part.out_begin; y < part.out_end; ++y) {
        std::int32_t& old = slab_values[static_cast<std::size_t>(y) * nz + z];
        const std::int32_t fresh = line[y - part.in_begin];
        if (fresh != old) {
          old = fresh;
          mark_lo[y] = std::min(mark_lo[y], z);
          mark_hi[y] = std::max(mark_hi[y], z);
        }
      }
    }
  }

  // Pass 3, the marked z lines, into the field.
  for (int x = 0; x < nx; ++x) {
    int* mark_lo = z_marks.lo(static_cast<std::size_t>(x) * ny);
    int* mark_hi = z_marks.hi(static_cast<std::size_t>(x) * ny);
    for (int y = 0; y < ny; ++y) {
      if (mark_hi[y] < mark_lo[y]) continue;
      const int lo = mark_lo[y];
      const int hi = mark_hi[y];
      mark_lo[y] = nz;
      mark_hi[y] = -1;
      ++u.z_lines;
      const ReachedPart part = reachedPart(lo, hi, reach, nz);
      transformZLine(x, y, part.in_begin, part.in_end, line, scratch);
      const std::size_t first =
          static_cast<std::size_t>(x) * slab + static_cast<std::size_t>(y) * nz;
      float* field = field_.mutableValues_m().data() + first;
      for (int z = part.out_begin; z < part.out_end; ++z) {
        const float m = metres(line[z - part.in_begin]);
        if (m != field[z]) {
          field[z] = m;
          changed_cells_.push_back(static_cast<std::uint32_t>(first + static_cast<std::size_t>(z)));
        }
      }
    }
  }
}

void EsdfMap::updateLinesWindowed(int reach, Scratch* scratch) {
  // The marked lines of the whole box, ordered by the start of their changed range and taken
  // kGroupWidth at a time, side by side (one lane each) over the union of the group's ranges:
  // a group's lines come from any slab, so that few lanes are idle and the union stays close to
  // each line's own range. Each line's outputs within its own range are exact (a part of a
  // line, see updateChanged()).
  updateYLinesWindowed(reach, scratch);
  updateZLinesWindowed(reach, scratch);
}

void EsdfMap::updateYLinesWindowed(int reach, Scratch* scratch) {
  const int ny = field_.size().y();
  const auto nz = static_cast<std::size_t>(field_.size().z());
  const std::size_t slab = static_cast<std::size_t>(ny) * nz;
  const std::vector<EsdfMarkedLine>& sorted = tracker_.takeYLines();
  EsdfLineMarks& z_marks = tracker_.zMarks();
  last_update_.y_lines = sorted.size();
  // The x pass's signed distance (8 bits, indexed by its byte) -> the y pass's signed input.
  std::array<std::int16_t, 256> square{};
  for (std::size_t byte = 0; byte < square.size(); ++byte) {
    const std::int32_t v = static_cast<std::int8_t>(static_cast<std::uint8_t>(byte));
    const std::int32_t sq = esdf_kernel::squaredAlongX(v, cap_d_, inf_);
    square[byte] = static_cast<std::int16_t>(v < 0 ? -sq : sq);
  }
  esdf_kernel::WindowBuffers* buffers = &scratch->window;
  const auto keptY = [&](const EsdfMarkedLine& line) {  // the line's kept y pass results, nz apart
    return pass2_narrow_.data() + static_cast<std::size_t>(line.x) * slab +
           static_cast<std::size_t>(line.across);
  };
  for (std::size_t g = 0; g < sorted.size(); g += kGroupWidth) {
    const std::size_t count = std::min(kGroupWidth, sorted.size() - g);
    const EsdfMarkedLine* group = sorted.data() + g;
    const ReachedPart span = groupSpan(group, count, reach, ny);
    const auto n = static_cast<std::size_t>(span.in_end - span.in_begin);
    if (buffers->lines.size() < n * kGroupWidth) buffers->lines.resize(n * kGroupWidth);
    std::int16_t* values = buffers->lines.data();
    // A y line is strided (nz apart): gathered value by value into its lane; idle lanes +inf.
    for (std::size_t l = 0; l < kGroupWidth; ++l) {
      if (l >= count) {
        for (std::size_t i = 0; i < n; ++i) {
          values[i * kGroupWidth + l] = static_cast<std::int16_t>(inf_);
        }
        continue;
      }
      const std::int8_t* in = pass1_narrow_.data() + static_cast<std::size_t>(group[l].x) * slab +
                              static_cast<std::size_t>(span.in_begin) * nz +
                              static_cast<std::size_t>(group[l].across);
      for (std::size_t i = 0; i < n; ++i) {
        values[i * kGroupWidth + l] = square[static_cast<std::uint8_t>(in[i * nz])];
      }
      // The kept results this line's outputs are compared with lie a line apart (a cache line
      // each): fetched now, while the group is transformed.
      const std::int16_t* kept = keptY(group[l]);
      const ReachedPart part = linePart(group[l], reach, ny);
      for (int y = part.out_begin; y < part.out_end; ++y) {
        __builtin_prefetch(kept + static_cast<std::size_t>(y) * nz, 1);
      }
    }
    esdf_kernel::transformLines(values, static_cast<int>(n), esdf_kernel::kGroupLanes,
                                span.out_begin - span.in_begin, span.out_end - span.in_begin,
                                cap_sq_, cap_d_, buffers);
    // Changed results are kept and mark their z lines.
    for (std::size_t l = 0; l < count; ++l) {
      const EsdfMarkedLine& line = group[l];
      const auto x = static_cast<std::size_t>(line.x);
      std::int16_t* kept = keptY(line);
      int* mark_lo = z_marks.lo(x * static_cast<std::size_t>(ny));
      int* mark_hi = z_marks.hi(x * static_cast<std::size_t>(ny));
      const ReachedPart part = linePart(line, reach, ny);
      for (int y = part.out_begin; y < part.out_end; ++y) {
        std::int16_t& old = kept[static_cast<std::size_t>(y) * nz];
        const auto i = static_cast<std::size_t>(y - span.in_begin);
        const std::int16_t fresh = values[i * kGroupWidth + l];
        if (fresh != old) {
          old = fresh;
          mark_lo[y] = std::min(mark_lo[y], line.across);
          mark_hi[y] = std::max(mark_hi[y], line.across);
        }
      }
    }
  }
}

void EsdfMap::updateZLinesWindowed(int reach, Scratch* scratch) {
  const int nz = field_.size().z();
  const std::size_t slab =
      static_cast<std::size_t>(field_.size().y()) * static_cast<std::size_t>(nz);
  const std::vector<EsdfMarkedLine>& sorted = tracker_.takeZLines();
  last_update_.z_lines = sorted.size();
  // The metres table is there: windowFits() keeps 2 inf_ + 1 below its limit.
  const float* table = metres_table_.data() + inf_;
  esdf_kernel::WindowBuffers* buffers = &scratch->window;
  std::vector<std::int16_t>& gathered = scratch->gathered;
  const auto first = [&](const EsdfMarkedLine& line) {
    return static_cast<std::size_t>(line.x) * slab +
           static_cast<std::size_t>(line.across) * static_cast<std::size_t>(nz);
  };
  for (std::size_t g = 0; g < sorted.size(); g += kGroupWidth) {
    const std::size_t count = std::min(kGroupWidth, sorted.size() - g);
    const EsdfMarkedLine* group = sorted.data() + g;
    const ReachedPart span = groupSpan(group, count, reach, nz);
    const int rows = span.in_end - span.in_begin;
    const auto n = static_cast<std::size_t>(rows);
    if (buffers->lines.size() < n * kGroupWidth) buffers->lines.resize(n * kGroupWidth);
    if (gathered.size() < n * kGroupWidth) gathered.resize(n * kGroupWidth);
    std::int16_t* values = buffers->lines.data();
    // A z line is contiguous: the group's lines are copied one after another (idle lanes +inf),
    // then transposed to lie side by side (and back).
    for (std::size_t l = 0; l < kGroupWidth; ++l) {
      std::int16_t* to = gathered.data() + l * n;
      if (l < count) {
        const std::int16_t* in =
            pass2_narrow_.data() + first(group[l]) + static_cast<std::size_t>(span.in_begin);
        std::copy(in, in + n, to);
        // The field cells this line writes (a few cache lines anywhere in the box): fetched
        // now, while the group is transformed.
        const float* field = field_.mutableValues_m().data() + first(group[l]);
        const ReachedPart part = linePart(group[l], reach, nz);
        for (int z = part.out_begin; z < part.out_end; z += kFloatsPerCacheLine) {
          __builtin_prefetch(field + z, 1);
        }
        __builtin_prefetch(field + part.out_end - 1, 1);
      } else {
        std::fill(to, to + n, static_cast<std::int16_t>(inf_));
      }
    }
    esdf_kernel::transpose16(gathered.data(), n, values, kGroupWidth, esdf_kernel::kGroupLanes,
                             rows);
    esdf_kernel::transformLines(values, rows, esdf_kernel::kGroupLanes,
                                span.out_begin - span.in_begin, span.out_end - span.in_begin,
                                cap_sq_, cap_d_, buffers);
    esdf_kernel::transpose16(values, kGroupWidth, gathered.data(), n, rows,
                             static_cast<int>(count));
    // Into the field, branch-free: every cell written and listed, the list advanced past the
    // changed ones.
    for (std::size_t l = 0; l < count; ++l) {
      const EsdfMarkedLine& line = group[l];
      const std::size_t row = first(line);
      float* field = field_.mutableValues_m().data() + row;
      const std::int16_t* fresh = gathered.data() + l * n;
      const ReachedPart part = linePart(line, reach, nz);
      const std::size_t listed = changed_cells_.size();
      changed_cells_.resize(listed + static_cast<std::size_t>(part.out_end - part.out_begin));
      std::uint32_t* next = changed_cells_.data() + listed;
      for (int z = part.out_begin; z < part.out_end; ++z) {
        const float m = table[fresh[z - span.in_begin]];
        const bool changed = m != field[z];
        field[z] = m;
        *next = static_cast<std::uint32_t>(row + static_cast<std::size_t>(z));
        next += changed ? 1 : 0;
      }
      changed_cells_.resize(static_cast<std::size_t>(next - changed_cells_.data()));
    }
  }
}

}  // namespace mlmap
