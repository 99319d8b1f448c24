#include "mlmap/awareness/cone_carver.h"

#include <algorithm>
#include <cmath>

namespace mlmap {
namespace {
constexpr double kEdgeEpsilon = 1e-9;  // a cone only touching a voxel face does not mark it
constexpr std::uint64_t kAllBits = ~std::uint64_t{0};

// Sets bits z0..z1 (z0 <= z1) of a z row that spans several words (out of line: rare, and its
// loop would take the registers of the slab walk).
[[gnu::noinline]] void markLongRun(std::uint64_t* row, int z0, int z1) {
  const int w0 = z0 >> 6;
  const int w1 = z1 >> 6;
  row[w0] |= kAllBits << (z0 & 63);
  for (int w = w0 + 1; w < w1; ++w) row[w] = kAllBits;
  row[w1] |= kAllBits >> (63 - (z1 & 63));
}

// Sets bits z0..z1 of `rows` rows `stride` words apart.
inline void markRuns(std::uint64_t* row, std::size_t stride, int rows, int z0, int z1) {
  const int w0 = z0 >> 6;
  if (w0 != (z1 >> 6)) {
    for (int r = 0; r < rows; ++r, row += stride) markLongRun(row, z0, z1);
    return;
  }
  const std::uint64_t mask = (kAllBits << (z0 & 63)) & (kAllBits >> (63 - (z1 & 63)));
  row += w0;
  for (int r = 0; r < rows; ++r, row += stride) *row |= mask;
}

// The cone's walk along its dominant axis A; b = A + 1 and c = A + 2 (mod 3) are the section's
// axes. The section's extent on b and c at parameter s is o + s * [lo, hi], so for slab i, which
// the cone overlaps for s in [s_lo, s_hi], the low bound on b is o_b + min(s_lo lo_b, s_hi lo_b):
// s_lo lo_b when lo_b >= 0, else s_hi lo_b (rounding is monotonic, so this is the same double).
// Which s each bound takes is fixed per cone: `pick` indexes {s_lo, s_hi}.
struct Walk {
  double oa, ob, oc;
  double lo_b, hi_b, lo_c, hi_c;
  int pick_lo_b, pick_hi_b, pick_lo_c, pick_hi_c;
  double inv_na, inv_fa;  // 1 / near face, 1 / far face offset along A
  double off_lo, off_hi;  // slab i overlaps s in [(i + off_lo - oa) / fa, (i + off_hi - oa) / na]
  double s0;
  int dim_b, dim_c;
};

// Marks slabs i_begin..i_end (inside the box along A). Templated on A so that each slab's
// rectangle maps to whole z runs (or, along z, to one bit per row) with no per-voxel index math.
template <int A>
void walkSlabs(const Walk& w, int i_begin, int i_end, std::uint64_t* words, std::size_t stride_x,
               std::size_t stride_y) {
  for (int i = i_begin; i <= i_end; ++i) {
    double s[2];
    s[0] = std::max((static_cast<double>(i) + w.off_lo - w.oa) * w.inv_fa, w.s0);
    s[1] = std::min((static_cast<double>(i) + w.off_hi - w.oa) * w.inv_na, 1.0);
    if (!(s[0] <= s[1])) continue;
    const double b_lo = w.ob + s[w.pick_lo_b] * w.lo_b;
    const double b_hi = w.ob + s[w.pick_hi_b] * w.hi_b;
    const double c_lo = w.oc + s[w.pick_lo_c] * w.lo_c;
    const double c_hi = w.oc + s[w.pick_hi_c] * w.hi_c;
    const int j0 = std::max(floorToInt(b_lo + kEdgeEpsilon), 0);
    const int j1 = std::min(ceilToInt(b_hi - kEdgeEpsilon) - 1, w.dim_b - 1);
    const int k0 = std::max(floorToInt(c_lo + kEdgeEpsilon), 0);
    const int k1 = std::min(ceilToInt(c_hi - kEdgeEpsilon) - 1, w.dim_c - 1);
    if (j0 > j1 || k0 > k1) continue;
    const std::size_t ui = static_cast<std::size_t>(i);
    if constexpr (A == 0) {  // b = y, c = z
      markRuns(words + ui * stride_x + static_cast<std::size_t>(j0) * stride_y, stride_y,
               j1 - j0 + 1, k0, k1);
    } else if constexpr (A == 1) {  // b = z, c = x
      markRuns(words + static_cast<std::size_t>(k0) * stride_x + ui * stride_y, stride_x,
               k1 - k0 + 1, j0, j1);
    } else {  // b = x, c = y: one bit of each row
      const std::uint64_t bit = std::uint64_t{1} << (i & 63);
      std::uint64_t* column = words + (ui >> 6) + static_cast<std::size_t>(j0) * stride_x;
      for (int j = j0; j <= j1; ++j, column += stride_x) {
        std::uint64_t* word = column + static_cast<std::size_t>(k0) * stride_y;
        for (int k = k0; k <= k1; ++k, word += stride_y) *word |= bit;
      }
    }
  }
}
}  // namespace

std::size_t carveCone(const Eigen::Vector3d& origin, const VoxelSpaceBox& box, double s_min,
                      VoxelBitset* free) {
  const Eigen::Vector3i& dims = free->dims();
  // Per axis, the section at s spans [o + s * lo, o + s * hi].
  const Eigen::Vector3d lo = box.min.cast<double>() - origin;
  const Eigen::Vector3d hi = box.max.cast<double>() - origin;
  // Dominant axis: the one along which the box lies entirely on one side of the origin, farthest.
  int a = -1;
  double best = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double gap = lo[k] > 0.0 ? lo[k] : (hi[k] < 0.0 ? -hi[k] : 0.0);
    const double reach = std::max(std::abs(lo[k]), std::abs(hi[k]));
    if (gap > 0.0 && reach > best) {
      best = reach;
      a = k;
    }
  }
  std::uint64_t* words = free->data();
  const std::size_t stride_y = free->wordsPerRow();
  const std::size_t stride_x = stride_y * static_cast<std::size_t>(dims.y());
  if (a < 0) {
    // The origin lies inside the box: the cone is the box's hull with the origin; mark the
    // voxels of the box (a sensor inside an end voxel).
    const Eigen::Vector3i v0 = box.min.array().floor().cast<int>().max(0);
    const Eigen::Vector3i v1 = box.max.array().floor().cast<int>().min(dims.array() - 1);
    if (v0.y() > v1.y() || v0.z() > v1.z()) return 1;
    for (int x = v0.x(); x <= v1.x(); ++x)
      markRuns(words + free->rowWord(x, v0.y()), stride_y, v1.y() - v0.y() + 1, v0.z(), v1.z());
    return 1;
  }
  const int b = (a + 1) % 3;
  const int c = (a + 2) % 3;
  const bool forward = lo[a] > 0.0;
  // Along a the extent is monotonic in s: near face `na`, far face `fa` (both same sign).
  const double na = forward ? lo[a] : hi[a];
  const double fa = forward ? hi[a] : lo[a];
  Walk w{};
  w.oa = origin[a];
  w.ob = origin[b];
  w.oc = origin[c];
  w.lo_b = lo[b];
  w.hi_b = hi[b];
  w.lo_c = lo[c];
  w.hi_c = hi[c];
  w.pick_lo_b = lo[b] < 0.0 ? 1 : 0;
  w.pick_hi_b = hi[b] < 0.0 ? 0 : 1;
  w.pick_lo_c = lo[c] < 0.0 ? 1 : 0;
  w.pick_hi_c = hi[c] < 0.0 ? 0 : 1;
  w.inv_na = 1.0 / na;
  w.inv_fa = 1.0 / fa;
  w.off_lo = forward ? 0.0 : 1.0;
  w.off_hi = forward ? 1.0 : 0.0;
  w.s0 = std::max(s_min, 0.0);
  w.dim_b = dims[b];
  w.dim_c = dims[c];
  // Slabs from the one holding s0 to the one holding the far face; at least the first (when s0
  // lies beyond the far face).
  const int i_first = floorToInt(w.oa + w.s0 * na);
  const int i_last = floorToInt(w.oa + fa - (forward ? kEdgeEpsilon : -kEdgeEpsilon));
  const int i_far = forward ? std::max(i_last, i_first) : std::min(i_last, i_first);
  const std::size_t slabs = static_cast<std::size_t>(std::abs(i_far - i_first)) + 1;
  const int i_begin = std::max(std::min(i_first, i_far), 0);
  const int i_end = std::min(std::max(i_first, i_far), dims[a] - 1);
  if (a == 0) walkSlabs<0>(w, i_begin, i_end, words, stride_x, stride_y);
  if (a == 1) walkSlabs<1>(w, i_begin, i_end, words, stride_x, stride_y);
  if (a == 2) walkSlabs<2>(w, i_begin, i_end, words, stride_x, stride_y);
  return slabs;
}

std::size_t carveCone(const Eigen::Vector3d& origin, const Eigen::Vector3i& end, VoxelBitset* free) {
  const Eigen::Vector3f lo = end.cast<float>();
  // Just inside the far faces: a point on a far face belongs to the next voxel.
  const Eigen::Vector3f hi = lo + Eigen::Vector3f::Constant(1.0f - 1e-6f);
  return carveCone(origin, VoxelSpaceBox{lo, hi}, 0.0, free);
}

}  // namespace mlmap
