#include "mlmap/planning/esdf_window_kernel.h"

#include <algorithm>
#include <cstddef>

/// On x86-64 the passes are also built for AVX2 and AVX-512 (16 and 32 lanes of 16 bits), one
/// chosen at load time for the CPU (GCC function multiversioning); elsewhere the baseline build.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define MLMAP_WINDOW_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define MLMAP_WINDOW_CLONES
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

/// best[i] = min(best[i], min(m[i - k step], m[i + k step]) + k^2) over [0, n) for
/// k = 1 .. cap_d: the window, both sides at distance k. Blocks of kBlock values stay in
/// registers over the whole window (two loads per step, one store per block).
inline __attribute__((always_inline)) void relaxWindow(std::int16_t* __restrict best,
                                                       const std::int16_t* __restrict m,
                                                       std::ptrdiff_t step, std::size_t n,
                                                       std::int32_t cap_d) {
  constexpr std::size_t kBlock = 64;
  std::size_t i0 = 0;
  for (; i0 + kBlock <= n; i0 += kBlock) {
    std::int16_t acc[kBlock];
    for (std::size_t j = 0; j < kBlock; ++j) acc[j] = best[i0 + j];
    for (std::int32_t k = 1; k <= cap_d; ++k) {
      const std::int16_t* below = m + i0 - step * k;
      const std::int16_t* above = m + i0 + step * k;
      const auto k2 = static_cast<std::int16_t>(k * k);
      for (std::size_t j = 0; j < kBlock; ++j) {
        const auto candidate = static_cast<std::int16_t>(std::min(below[j], above[j]) + k2);
        acc[j] = std::min(acc[j], candidate);
      }
    }
    for (std::size_t j = 0; j < kBlock; ++j) best[i0 + j] = acc[j];
  }
  for (std::int32_t k = 1; k <= cap_d; ++k) {
    relax(best + i0, m + i0, step * k, n - i0, static_cast<std::int16_t>(k * k));
  }
}

/// The 1D pass along the outer index of `values` (n lines of `lanes` values, lanes fastest;
/// signed squared distances or +-inf), in place. `m` is buffers->magnitude laid out with pad
/// = cap_d * lanes values of inf before and after, already holding |values|.
inline __attribute__((always_inline)) void windowPass(std::int16_t* values, std::int16_t* m,
                                                      int n, int lanes, std::int32_t cap_sq,
                                                      std::int32_t cap_d,
                                                      WindowBuffers* buffers) {
  const auto inf = static_cast<std::int16_t>(cap_sq + 1);
  const std::size_t row = static_cast<std::size_t>(lanes);
  const std::size_t cells = static_cast<std::size_t>(n) * row;
  std::int16_t* best = buffers->best.data();
  std::int16_t* near_free = buffers->near_free.data();
  std::int16_t* near_obstacle = buffers->near_obstacle.data();
  // r: distance along the line to the nearest voxel of the other kind (cap_d + 1 when beyond),
  // two sweeps with the last / next position of each kind per lane.
  const std::int32_t far = cap_d + 1;
  std::fill(near_free, near_free + row, static_cast<std::int16_t>(-far));
  std::fill(near_obstacle, near_obstacle + row, static_cast<std::int16_t>(-far));
  for (int y = 0; y < n; ++y) {
    const std::int16_t* s = values + static_cast<std::size_t>(y) * row;
    std::int16_t* b = best + static_cast<std::size_t>(y) * row;
    for (int z = 0; z < lanes; ++z) {
      const bool obstacle = s[z] < 0;
      const std::int32_t last = obstacle ? near_free[z] : near_obstacle[z];
      b[z] = static_cast<std::int16_t>(std::min(y - last, far));
      near_free[z] = obstacle ? near_free[z] : static_cast<std::int16_t>(y);
      near_obstacle[z] = obstacle ? static_cast<std::int16_t>(y) : near_obstacle[z];
    }
  }
  std::fill(near_free, near_free + row, static_cast<std::int16_t>(n - 1 + far));
  std::fill(near_obstacle, near_obstacle + row, static_cast<std::int16_t>(n - 1 + far));
  for (int y = n - 1; y >= 0; --y) {
    const std::size_t first = static_cast<std::size_t>(y) * row;
    const std::int16_t* s = values + first;
    std::int16_t* b = best + first;
    const std::int16_t* own = m + first;
    for (int z = 0; z < lanes; ++z) {
      const bool obstacle = s[z] < 0;
      const std::int32_t next = obstacle ? near_free[z] : near_obstacle[z];
      const std::int32_t r = std::min<std::int32_t>(b[z], std::min(next - y, far));
      b[z] = static_cast<std::int16_t>(std::min<std::int32_t>(r * r, own[z]));
      near_free[z] = obstacle ? near_free[z] : static_cast<std::int16_t>(y);
      near_obstacle[z] = obstacle ? static_cast<std::int16_t>(y) : near_obstacle[z];
    }
  }
  relaxWindow(best, m, lanes, cells, cap_d);
  for (std::size_t i = 0; i < cells; ++i) {
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

}  // namespace

bool windowFits(std::int32_t cap_sq, std::int32_t cap_d) {
  // inf + k^2 <= 2 cap_sq + 1 and (cap_d + 1)^2 must fit 16 bits.
  return cap_d >= 1 && cap_d <= kMaxWindowCapCells && 2 * cap_sq + 1 < 32767;
}

MLMAP_WINDOW_CLONES
void transformSlabY(const std::int32_t* pass1, int ny, int nz, std::int32_t cap_sq,
                    std::int32_t cap_d, std::int32_t* pass2, WindowBuffers* buffers) {
  const auto inf = static_cast<std::int16_t>(cap_sq + 1);
  const std::size_t cells = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  ensure(&buffers->signed_sq, cells);
  ensure(&buffers->transposed, cells);
  std::int16_t* m = prepareBuffers(ny, nz, cap_d, inf, buffers);
  std::int16_t* values = buffers->transposed.data();
  // The x pass's distance squared (it is at most cap_d, or inf), signed.
  for (std::size_t i = 0; i < cells; ++i) {
    const std::int32_t v = pass1[i];
    const std::int32_t a = v < 0 ? -v : v;
    const std::int32_t sq = a <= cap_d ? a * a : std::int32_t{inf};
    m[i] = static_cast<std::int16_t>(sq);
    values[i] = static_cast<std::int16_t>(v < 0 ? -sq : sq);
  }
  windowPass(values, m, ny, nz, cap_sq, cap_d, buffers);
  // Out to pass 2 (y-major) and, transposed, to the z pass's lines (z-major).
  std::int16_t* out = buffers->signed_sq.data();
  for (std::size_t i = 0; i < cells; ++i) pass2[i] = values[i];
  for (int y = 0; y < ny; ++y) {
    const std::int16_t* v = values + static_cast<std::size_t>(y) * static_cast<std::size_t>(nz);
    for (int z = 0; z < nz; ++z) out[static_cast<std::size_t>(z) * ny + y] = v[z];
  }
}

MLMAP_WINDOW_CLONES
void transformLines(std::int16_t* values, int n, int lanes, std::int32_t cap_sq,
                    std::int32_t cap_d, WindowBuffers* buffers) {
  const auto inf = static_cast<std::int16_t>(cap_sq + 1);
  const std::size_t cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(lanes);
  std::int16_t* m = prepareBuffers(n, lanes, cap_d, inf, buffers);
  for (std::size_t i = 0; i < cells; ++i) {
    m[i] = static_cast<std::int16_t>(values[i] < 0 ? -values[i] : values[i]);
  }
  windowPass(values, m, n, lanes, cap_sq, cap_d, buffers);
}

void transformSlabZ(int ny, int nz, std::int32_t cap_sq, std::int32_t cap_d,
                    WindowBuffers* buffers) {
  // z-major: the z lines across the y lanes.
  transformLines(buffers->signed_sq.data(), nz, ny, cap_sq, cap_d, buffers);
}

}  // namespace mlmap::esdf_kernel
