#include "mlmap/planning/esdf_window_kernel.h"

#include <algorithm>
#include <cstddef>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace mlmap::esdf_kernel {
namespace {

/// Grows `v` to at least n elements.
inline __attribute__((always_inline)) void ensure(std::vector<std::int16_t>* v, std::size_t n) {
  if (v->size() < n) v->resize(n);
}

/// One step of relaxWindow().
inline __attribute__((always_inline)) void relax(std::int16_t* __restrict best,
                                                 const std::int16_t* __restrict m,
                                                 std::ptrdiff_t offset, std::size_t n,
                                                 std::int16_t k2) {
  const std::int16_t* below = m - offset;
  const std::int16_t* above = m + offset;
  for (std::size_t i = 0; i < n; ++i) {
    const std::int16_t nearer = std::min(below[i], above[i]);
    const auto candidate = static_cast<std::int16_t>(nearer + k2);
    best[i] = std::min(best[i], candidate);
  }
}

/// Values per block of relaxWindow().
constexpr std::size_t kBlock = 64;

/// best[i] = min(best[i], min(m[i - k step], m[i + k step]) + k^2) over [0, n) for
/// k = 1 .. cap_d: the window, both sides at distance k. Blocks of kBlock values stay in
/// registers over the whole window (two loads per step, one store per block). A block is
/// skipped when no value of m within its window's reach is below inf (`finite_before[b]`: how
/// many blocks of m, counted from m - pad, before block b hold one: no candidate can be below
/// inf then), and its window stops at the first k with k^2 >= every value of the block (every
/// further candidate is at least k^2).
inline __attribute__((always_inline)) void relaxWindow(std::int16_t* __restrict best,
                                                       const std::int16_t* __restrict m,
                                                       std::ptrdiff_t step, std::size_t n,
                                                       std::int32_t cap_d, std::size_t pad,
                                                       const std::int32_t* finite_before) {
  std::size_t i0 = 0;
  for (; i0 + kBlock <= n; i0 += kBlock) {
    // Blocks of m (from m - pad) that the window of [i0, i0 + kBlock) reads.
    const std::size_t reach = static_cast<std::size_t>(cap_d) * static_cast<std::size_t>(step);
    const std::size_t first_block = (pad + i0 - reach) / kBlock;
    const std::size_t last_block = (pad + i0 + kBlock - 1 + reach) / kBlock;
    if (finite_before[last_block + 1] == finite_before[first_block]) continue;
    std::int16_t acc[kBlock];
    std::int16_t largest = 0;
    for (std::size_t j = 0; j < kBlock; ++j) {
      acc[j] = best[i0 + j];
      largest = std::max(largest, acc[j]);
    }
    for (std::int32_t k = 1; k <= cap_d; ++k) {
      if (k * k >= largest) break;
      const std::int16_t* below = m + i0 - step * k;
      const std::int16_t* above = m + i0 + step * k;
      const auto k2 = static_cast<std::int16_t>(k * k);
      for (std::size_t j = 0; j < kBlock; ++j) {
        const auto candidate = static_cast<std::int16_t>(std::min(below[j], above[j]) + k2);
        acc[j] = std::min(acc[j], candidate);
      }
      if ((k & 3) == 0) {
        largest = 0;
        for (std::size_t j = 0; j < kBlock; ++j) largest = std::max(largest, acc[j]);
      }
    }
    for (std::size_t j = 0; j < kBlock; ++j) best[i0 + j] = acc[j];
  }
  for (std::int32_t k = 1; k <= cap_d; ++k) {
    relax(best + i0, m + i0, step * k, n - i0, static_cast<std::int16_t>(k * k));
  }
}

/// Fills buffers->finite_before for relaxWindow() from the magnitude buffer `m_padded`
/// (`total` values from its padded start, inf = cap_sq + 1).
inline __attribute__((always_inline)) void countFiniteBlocks(const std::int16_t* m_padded,
                                                             std::size_t total, std::int16_t inf,
                                                             WindowBuffers* buffers) {
  const std::size_t blocks = (total + kBlock - 1) / kBlock;
  if (buffers->finite_before.size() < blocks + 2) buffers->finite_before.resize(blocks + 2);
  std::int32_t* before = buffers->finite_before.data();
  before[0] = 0;
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t begin = b * kBlock;
    const std::size_t end = std::min(total, begin + kBlock);
    std::int16_t lowest = inf;
    for (std::size_t i = begin; i < end; ++i) lowest = std::min(lowest, m_padded[i]);
    before[b + 1] = before[b] + (lowest < inf ? 1 : 0);
  }
  before[blocks + 1] = before[blocks];
}

/// Forward sweep of one line position y across `lanes` lines: left[l] = distance to the last
/// voxel of the other kind before y (at most far); updates the last positions of each kind.
inline __attribute__((always_inline)) void sweepLeft(const std::int16_t* __restrict s,
                                                     std::int16_t* __restrict left,
                                                     std::int16_t* __restrict near_free,
                                                     std::int16_t* __restrict near_obstacle,
                                                     int lanes, std::int16_t y, std::int16_t far) {
  for (int l = 0; l < lanes; ++l) {
    const bool obstacle = s[l] < 0;
    const std::int16_t f = near_free[l];
    const std::int16_t o = near_obstacle[l];
    const auto d = static_cast<std::int16_t>(y - (obstacle ? f : o));
    left[l] = std::min(d, far);
    near_free[l] = obstacle ? f : y;
    near_obstacle[l] = obstacle ? y : o;
  }
}

/// Backward sweep of one line position y: best[l] = min(r^2, own[l]) with r the nearer of
/// left[l] (in best on entry) and the next voxel of the other kind after y.
inline __attribute__((always_inline)) void sweepRight(const std::int16_t* __restrict s,
                                                      const std::int16_t* __restrict own,
                                                      std::int16_t* __restrict best,
                                                      std::int16_t* __restrict near_free,
                                                      std::int16_t* __restrict near_obstacle,
                                                      int lanes, std::int16_t y, std::int16_t far) {
  for (int l = 0; l < lanes; ++l) {
    const bool obstacle = s[l] < 0;
    const std::int16_t f = near_free[l];
    const std::int16_t o = near_obstacle[l];
    const auto right = static_cast<std::int16_t>((obstacle ? f : o) - y);
    const std::int16_t r = std::min(best[l], std::min(right, far));
    best[l] = std::min(static_cast<std::int16_t>(r * r), own[l]);
    near_free[l] = obstacle ? f : y;
    near_obstacle[l] = obstacle ? y : o;
  }
}

/// The 1D pass along the outer index of `values` (n lines of `lanes` values, lanes fastest;
/// signed squared distances or +-inf), in place, written at positions [out_begin, out_end)
/// only (the others keep their input). `m` is buffers->magnitude laid out with pad = cap_d *
/// lanes values of inf before and after, already holding |values|. kLanes > 0: `lanes` is
/// kLanes, known here, and the sweeps keep their last / next positions in registers.
template <int kLanes>
inline __attribute__((always_inline)) void windowPass(std::int16_t* values, std::int16_t* m, int n,
                                                      int lanes_in, int out_begin, int out_end,
                                                      std::int32_t cap_sq, std::int32_t cap_d,
                                                      WindowBuffers* buffers) {
  const int lanes = kLanes > 0 ? kLanes : lanes_in;
  const auto inf = static_cast<std::int16_t>(cap_sq + 1);
  const std::size_t row = static_cast<std::size_t>(lanes);
  const std::size_t cells = static_cast<std::size_t>(n) * row;
  std::int16_t* best = buffers->best.data();
  std::int16_t fixed_free[kLanes > 0 ? kLanes : 1];
  std::int16_t fixed_obstacle[kLanes > 0 ? kLanes : 1];
  std::int16_t* near_free = kLanes > 0 ? fixed_free : buffers->near_free.data();
  std::int16_t* near_obstacle = kLanes > 0 ? fixed_obstacle : buffers->near_obstacle.data();
  // r: distance along the line to the nearest voxel of the other kind (cap_d + 1 when beyond),
  // two sweeps with the last / next position of each kind per lane.
  const auto far = static_cast<std::int16_t>(cap_d + 1);
  std::fill(near_free, near_free + row, static_cast<std::int16_t>(-far));
  std::fill(near_obstacle, near_obstacle + row, static_cast<std::int16_t>(-far));
  for (int y = 0; y < n; ++y) {
    const std::size_t first = static_cast<std::size_t>(y) * row;
    sweepLeft(values + first, best + first, near_free, near_obstacle, lanes,
              static_cast<std::int16_t>(y), far);
  }
  std::fill(near_free, near_free + row, static_cast<std::int16_t>(n - 1 + far));
  std::fill(near_obstacle, near_obstacle + row, static_cast<std::int16_t>(n - 1 + far));
  for (int y = n - 1; y >= 0; --y) {
    const std::size_t first = static_cast<std::size_t>(y) * row;
    sweepRight(values + first, m + first, best + first, near_free, near_obstacle, lanes,
               static_cast<std::int16_t>(y), far);
  }
  const std::size_t pad = static_cast<std::size_t>(cap_d) * row;
  countFiniteBlocks(m - pad, cells + 2 * pad, inf, buffers);
  // The window, the costly part, over the output positions only.
  const std::size_t first = static_cast<std::size_t>(out_begin) * row;
  const std::size_t last = static_cast<std::size_t>(out_end) * row;
  relaxWindow(best + first, m + first, lanes, last - first, cap_d, pad + first,
              buffers->finite_before.data());
  for (std::size_t i = first; i < last; ++i) {
    const std::int16_t v = best[i] <= cap_sq ? best[i] : inf;
    values[i] = values[i] < 0 ? static_cast<std::int16_t>(-v) : v;
  }
}

/// Sizes the buffers for a pass over n lines of `lanes` values; returns the magnitude buffer's
/// start after its padding (inf written to both paddings).
inline __attribute__((always_inline)) std::int16_t* prepareBuffers(int n, int lanes,
                                                                   std::int32_t cap_d,
                                                                   std::int16_t inf,
                                                                   WindowBuffers* buffers) {
  const std::size_t row = static_cast<std::size_t>(lanes);
  const std::size_t cells = static_cast<std::size_t>(n) * row;
  const std::size_t pad = static_cast<std::size_t>(cap_d) * row;
  ensure(&buffers->magnitude, cells + 2 * pad);
  ensure(&buffers->best, cells);
  ensure(&buffers->near_free, row);
  ensure(&buffers->near_obstacle, row);
  std::int16_t* m = buffers->magnitude.data() + pad;
  std::fill(m - pad, m, inf);
  std::fill(m + cells, m + cells + pad, inf);
  return m;
}

/// dst[c * dst_stride + r] = src[r * src_stride + c] for r < rows, c < cols (16-bit values):
/// 8 x 8 blocks through SSE2 registers where there are, the rest one value at a time.
inline __attribute__((always_inline)) void transpose(const std::int16_t* __restrict src,
                                                     std::size_t src_stride,
                                                     std::int16_t* __restrict dst,
                                                     std::size_t dst_stride, int rows, int cols) {
  int r0 = 0;
#if defined(__SSE2__)
  for (; r0 + 8 <= rows; r0 += 8) {
    int c0 = 0;
    for (; c0 + 8 <= cols; c0 += 8) {
      const std::int16_t* s = src + static_cast<std::size_t>(r0) * src_stride + c0;
      __m128i a[8];
      for (std::size_t i = 0; i < 8; ++i) {
        a[i] = _mm_loadu_si128(reinterpret_cast<const __m128i*>(s + i * src_stride));
      }
      // Interleave 16-, 32-, then 64-bit pieces: row i of the result is column i of the block.
      const __m128i b0 = _mm_unpacklo_epi16(a[0], a[1]);
      const __m128i b1 = _mm_unpackhi_epi16(a[0], a[1]);
      const __m128i b2 = _mm_unpacklo_epi16(a[2], a[3]);
      const __m128i b3 = _mm_unpackhi_epi16(a[2], a[3]);
      const __m128i b4 = _mm_unpacklo_epi16(a[4], a[5]);
      const __m128i b5 = _mm_unpackhi_epi16(a[4], a[5]);
      const __m128i b6 = _mm_unpacklo_epi16(a[6], a[7]);
      const __m128i b7 = _mm_unpackhi_epi16(a[6], a[7]);
      const __m128i c0v = _mm_unpacklo_epi32(b0, b2);
      const __m128i c1v = _mm_unpackhi_epi32(b0, b2);
      const __m128i c2v = _mm_unpacklo_epi32(b1, b3);
      const __m128i c3v = _mm_unpackhi_epi32(b1, b3);
      const __m128i c4v = _mm_unpacklo_epi32(b4, b6);
      const __m128i c5v = _mm_unpackhi_epi32(b4, b6);
      const __m128i c6v = _mm_unpacklo_epi32(b5, b7);
      const __m128i c7v = _mm_unpackhi_epi32(b5, b7);
      const __m128i out[8] = {_mm_unpacklo_epi64(c0v, c4v), _mm_unpackhi_epi64(c0v, c4v),
                              _mm_unpacklo_epi64(c1v, c5v), _mm_unpackhi_epi64(c1v, c5v),
                              _mm_unpacklo_epi64(c2v, c6v), _mm_unpackhi_epi64(c2v, c6v),
                              _mm_unpacklo_epi64(c3v, c7v), _mm_unpackhi_epi64(c3v, c7v)};
      std::int16_t* d = dst + static_cast<std::size_t>(c0) * dst_stride + r0;
      for (std::size_t i = 0; i < 8; ++i) {
        _mm_storeu_si128(reinterpret_cast<__m128i*>(d + i * dst_stride), out[i]);
      }
    }
    for (; c0 < cols; ++c0) {
      for (int r = r0; r < r0 + 8; ++r) {
        dst[static_cast<std::size_t>(c0) * dst_stride + r] =
            src[static_cast<std::size_t>(r) * src_stride + c0];
      }
    }
  }
#endif
  for (int r = r0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      dst[static_cast<std::size_t>(c) * dst_stride + r] =
          src[static_cast<std::size_t>(r) * src_stride + c];
    }
  }
}

}  // namespace

void transpose16(const std::int16_t* src, std::size_t src_stride, std::int16_t* dst,
                 std::size_t dst_stride, int rows, int cols) {
  transpose(src, src_stride, dst, dst_stride, rows, cols);
}

bool windowFits(std::int32_t cap_sq, std::int32_t cap_d) {
  // inf + k^2 <= 2 cap_sq + 1 and (cap_d + 1)^2 must fit 16 bits.
  return cap_d >= 1 && cap_d <= kMaxWindowCapCells && 2 * cap_sq + 1 < 32767;
}

MLMAP_ESDF_CLONES
void transformSlabY(const std::int8_t* pass1, int ny, int nz, std::int32_t cap_sq,
                    std::int32_t cap_d, std::int16_t* pass2, WindowBuffers* buffers) {
  const auto inf = static_cast<std::int16_t>(cap_sq + 1);
  // The y lines across paddedLanes(nz) lanes, the z lines across paddedLanes(ny).
  const int z_lanes = paddedLanes(nz);
  const int y_lanes = paddedLanes(ny);
  const std::size_t z_row = static_cast<std::size_t>(z_lanes);
  const std::size_t y_row = static_cast<std::size_t>(y_lanes);
  ensure(&buffers->signed_sq, static_cast<std::size_t>(nz) * y_row);
  ensure(&buffers->transposed, static_cast<std::size_t>(ny) * z_row);
  std::int16_t* m = prepareBuffers(ny, z_lanes, cap_d, inf, buffers);
  std::int16_t* values = buffers->transposed.data();
  // The x pass's distance squared (it is at most cap_d, or inf), signed; +inf in the extra
  // lanes.
  for (int y = 0; y < ny; ++y) {
    const std::int8_t* in = pass1 + static_cast<std::size_t>(y) * static_cast<std::size_t>(nz);
    std::int16_t* m_row = m + static_cast<std::size_t>(y) * z_row;
    std::int16_t* v_row = values + static_cast<std::size_t>(y) * z_row;
    for (int z = 0; z < nz; ++z) {
      const std::int32_t v = in[z];
      const std::int32_t sq = squaredAlongX(v, cap_d, inf);
      m_row[z] = static_cast<std::int16_t>(sq);
      v_row[z] = static_cast<std::int16_t>(v < 0 ? -sq : sq);
    }
    std::fill(m_row + nz, m_row + z_lanes, inf);
    std::fill(v_row + nz, v_row + z_lanes, inf);
  }
  windowPass<0>(values, m, ny, z_lanes, 0, ny, cap_sq, cap_d, buffers);
  // Out to pass 2 (y-major) and, transposed, to the z pass's lines (z-major, +inf in the extra
  // lanes).
  std::int16_t* out = buffers->signed_sq.data();
  for (int y = 0; y < ny; ++y) {
    const std::int16_t* v = values + static_cast<std::size_t>(y) * z_row;
    std::copy(v, v + nz, pass2 + static_cast<std::size_t>(y) * static_cast<std::size_t>(nz));
  }
  transpose(values, z_row, out, y_row, ny, nz);
  for (int z = 0; z < nz; ++z) {
    std::int16_t* row = out + static_cast<std::size_t>(z) * y_row;
    std::fill(row + ny, row + y_lanes, inf);
  }
}

MLMAP_ESDF_CLONES
void transformLines(std::int16_t* values, int n, int lanes, int out_begin, int out_end,
                    std::int32_t cap_sq, std::int32_t cap_d, WindowBuffers* buffers) {
  const auto inf = static_cast<std::int16_t>(cap_sq + 1);
  const std::size_t cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(lanes);
  std::int16_t* m = prepareBuffers(n, lanes, cap_d, inf, buffers);
  for (std::size_t i = 0; i < cells; ++i) {
    m[i] = static_cast<std::int16_t>(values[i] < 0 ? -values[i] : values[i]);
  }
  if (lanes == kGroupLanes) {
    windowPass<kGroupLanes>(values, m, n, lanes, out_begin, out_end, cap_sq, cap_d, buffers);
  } else {
    windowPass<0>(values, m, n, lanes, out_begin, out_end, cap_sq, cap_d, buffers);
  }
}

void transformSlabZ(int ny, int nz, std::int32_t cap_sq, std::int32_t cap_d,
                    WindowBuffers* buffers) {
  // z-major: the z lines across the y lanes.
  transformLines(buffers->signed_sq.data(), nz, paddedLanes(ny), 0, nz, cap_sq, cap_d, buffers);
}

}  // namespace mlmap::esdf_kernel
