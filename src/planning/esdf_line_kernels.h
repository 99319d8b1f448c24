#pragma once
/// @file
/// Part of the ESDF (EsdfMap, esdf.h): the kernels that transform one line, or a block of
/// lines, with no state of their own: pass 1's two sweeps along x (sweepBlock()) and the exact
/// 1D transform of passes 2 and 3 by lower envelopes of parabolas (transformLine()). The
/// windowed 16-bit passes are in esdf_window_kernel.h. Distances are in voxels throughout.

#include "mlmap/core/types.h"
#include "mlmap/planning/esdf_window_kernel.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace mlmap::esdf_kernel {

// ---- Pass 1 (x): two sweeps of the 1D distance to the nearest voxel of the other kind ----

/// A voxel's kind, all that pass 1 reads of its state: an obstacle when occupied, or unknown
/// with `unknown_is_obstacle` (1: unknown as occupied, 0: as free). Branch-free, so that the
/// sweeps vectorise.
inline __attribute__((always_inline)) bool isObstacle(std::int32_t state,
                                                      std::int32_t unknown_is_obstacle) {
  constexpr auto kUnknown = static_cast<std::int32_t>(Occupancy::kUnknown);
  constexpr auto kOccupied = static_cast<std::int32_t>(Occupancy::kOccupied);
  return ((state == kOccupied ? 1 : 0) | ((state == kUnknown ? 1 : 0) & unknown_is_obstacle)) != 0;
}

/// Pass 1 over a block of `n` consecutive voxels of every x slab (one or more y rows, z
/// fastest): states at states + x * state_stride, results at out + x * out_stride: the signed
/// distance along x to the nearest voxel of the other kind (+d non-obstacle, -d obstacle), or
/// +-inf beyond cap_d; with `narrow`, each x's results are also written there in 8 bits
/// (narrow + x * narrow_stride; inf must then fit). `near_free` and `near_obstacle` are
/// scratch of n values. Built for AVX2 / AVX-512 too (MLMAP_ESDF_CLONES): its sweeps
/// vectorise.
void sweepBlock(const std::uint8_t* states, std::size_t state_stride, std::int32_t* out,
                std::size_t out_stride, int nx, int n, std::int32_t* near_free,
                std::int32_t* near_obstacle, std::int32_t unknown_is_obstacle, std::int32_t cap_d,
                std::int32_t inf, std::int8_t* narrow = nullptr, std::size_t narrow_stride = 0);

// ---- Passes 2 (y) and 3 (z): exact 1D transforms by lower envelopes of parabolas ----

/// One line of the work buffer with a stride between its voxels (the y pass).
struct StridedLine {
  std::int32_t* base;
  std::ptrdiff_t stride;
  std::int32_t& operator[](std::ptrdiff_t i) const { return base[i * stride]; }
};

/// One thread's envelope buffers, each at least one longer than the longest line.
template <typename Key>
struct LineBuffers {
  std::int32_t* runs;       ///< starts of the same-sign runs of the line
  std::int32_t* out_sites;  ///< outside-transform envelope: positions ...
  Key* out_keys;            ///< ... and f(q) + q^2
  std::int32_t* in_sites;   ///< inside-transform envelope
  Key* in_keys;
};

/// Adds the parabola (x - q)^2 + f, stored as key = f + q^2, to a lower envelope whose sites
/// are increasing and < q, dropping the parabolas it hides (Felzenszwalb & Huttenlocher, with
/// the intersection test cross-multiplied so that it needs no division).
template <typename Key>
inline void pushParabola(std::int32_t* sites, Key* keys, int* count, std::int32_t q, Key key) {
  int m = *count;
  while (m >= 2) {
    const Key top = keys[m - 1];
    // intersection(q, top) <= intersection(below, top): `top` is nowhere the lowest.
    if ((key - top) * static_cast<Key>(sites[m - 1] - sites[m - 2]) <=
        (top - keys[m - 2]) * static_cast<Key>(q - sites[m - 1])) {
      --m;
    } else {
      break;
    }
  }
  sites[m] = q;
  keys[m] = key;
  *count = m + 1;
}

/// Writes the envelope's minimum at the positions of the runs [runs[r], runs[r + 1]) for
/// r = first, first + 2, ... (the runs of one sign), times `sign` (+1 or -1). Positions where
/// the minimum exceeds `cap` are skipped: they hold no site, so they already hold +-inf.
/// sites[count], keys[count] must hold a sentinel that never wins, at position >= n + cap_d.
template <typename Key, typename Line>
inline void evaluateRuns(Line line, const std::int32_t* runs, int run_count, int first,
                         const std::int32_t* sites, const Key* keys, std::int32_t cap,
                         std::int32_t cap_d, std::int32_t sign) {
  int k = 0;
  for (int r = first; r < run_count; r += 2) {
    const int end = runs[r + 1];
    int p = runs[r];
    while (p < end) {
      const Key two_p = 2 * static_cast<Key>(p);
      Key best = keys[k] - two_p * sites[k];
      for (;;) {
        const Key next = keys[k + 1] - two_p * sites[k + 1];
        if (next > best) break;
        best = next;
        ++k;
      }
      const Key d = best + static_cast<Key>(p) * p;
      if (d <= cap) {
        line[p] = sign * static_cast<std::int32_t>(d);
        ++p;
        continue;
      }
      // Nothing within reach here. Parabolas before k lose to k from here on, k itself (when
      // p >= sites[k]) only grows, and the others are more than cap_d away until their site is
      // within cap_d: jump there.
      const int next_site = p < sites[k] ? sites[k] : sites[k + 1];
      p = std::max(p + 1, next_site - cap_d);
    }
  }
}

/// The exact 1D transform of one line of n signed values, in place: each non-obstacle value
/// becomes min over j of f_out(j) + (p - j)^2 and each obstacle value -(min over j of
/// f_in(j) + (p - j)^2), capped (+-inf above cap).
/// - Outside transform: its sites are the non-obstacle voxels with a finite value, and the
///   obstacle voxels (f = 0) next to a non-obstacle voxel of the line (the inner voxels of an
///   obstacle run are never nearer to a non-obstacle voxel than the run's ends). It is evaluated
///   at non-obstacle voxels only.
/// - Inside transform: the same with the roles swapped.
/// With kSquare the finite inputs are distances (the x pass's output), else squared distances.
template <typename Key, typename Line, bool kSquare>
void transformLine(Line line, int n, std::int32_t cap, std::int32_t cap_d,
                   const LineBuffers<Key>& buffers) {
  std::int32_t* runs = buffers.runs;
  std::int32_t* out_sites = buffers.out_sites;
  Key* out_keys = buffers.out_keys;
  std::int32_t* in_sites = buffers.in_sites;
  Key* in_keys = buffers.in_keys;
  const std::int32_t inf = cap + 1;
  int out_count = 0;
  int in_count = 0;
  int run_count = 0;
  int j = 0;
  while (j < n) {
    const int l = j;
    runs[run_count++] = l;
    if (line[j] > 0) {
      if (l > 0) pushParabola<Key>(in_sites, in_keys, &in_count, l, static_cast<Key>(l) * l);
      for (; j < n && line[j] > 0; ++j) {
        const std::int32_t v = line[j];
        if (v < inf) {
          const Key f = kSquare ? static_cast<Key>(v) * v : static_cast<Key>(v);
          pushParabola<Key>(out_sites, out_keys, &out_count, j, static_cast<Key>(j) * j + f);
        }
      }
      const int r = j - 1;
      if (j < n && (r != l || l == 0)) {
        pushParabola<Key>(in_sites, in_keys, &in_count, r, static_cast<Key>(r) * r);
      }
    } else {
      if (l > 0) pushParabola<Key>(out_sites, out_keys, &out_count, l, static_cast<Key>(l) * l);
      for (; j < n && line[j] < 0; ++j) {
        const std::int32_t v = line[j];
        if (v > -inf) {
          const Key f = kSquare ? static_cast<Key>(v) * v : -static_cast<Key>(v);
          pushParabola<Key>(in_sites, in_keys, &in_count, j, static_cast<Key>(j) * j + f);
        }
      }
      const int r = j - 1;
      if (j < n && (r != l || l == 0)) {
        pushParabola<Key>(out_sites, out_keys, &out_count, r, static_cast<Key>(r) * r);
      }
    }
  }
  runs[run_count] = n;
  const int first_free = line[0] > 0 ? 0 : 1;
  // Sentinel: far right and above every real value at every position of the line.
  const int sentinel_site = n + cap_d + 1;
  const Key sentinel_key =
      static_cast<Key>(cap) + static_cast<Key>(n) * n + 2 * static_cast<Key>(n) * sentinel_site + 1;
  if (out_count > 0) {
    out_sites[out_count] = sentinel_site;
    out_keys[out_count] = sentinel_key;
    evaluateRuns<Key, Line>(line, runs, run_count, first_free, out_sites, out_keys, cap, cap_d, 1);
  }
  if (in_count > 0) {
    in_sites[in_count] = sentinel_site;
    in_keys[in_count] = sentinel_key;
    evaluateRuns<Key, Line>(line, runs, run_count, 1 - first_free, in_sites, in_keys, cap, cap_d,
                            -1);
  }
}

}  // namespace mlmap::esdf_kernel
