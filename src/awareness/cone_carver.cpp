#include "mlmap/awareness/cone_carver.h"

#include <algorithm>
#include <cmath>

namespace mlmap {
namespace {
constexpr double kEdgeEpsilon = 1e-9;  // a cone only touching a voxel face does not mark it
}  // namespace

std::size_t carveCone(const Eigen::Vector3d& origin, const VoxelSpaceBox& box, double s_min,
                      VoxelBitset* free) {
  const Eigen::Vector3i& dims = free->dims();
  std::size_t slabs = 0;
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
  uint64_t* words = free->data();
  auto mark = [&](int x, int y, int z) {
    words[free->rowWord(x, y) + static_cast<std::size_t>(z >> 6)] |= uint64_t{1} << (z & 63);
  };
  if (a < 0) {
    // The origin lies inside the box: the cone is the box's hull with the origin; mark the
    // voxels of the box (a sensor inside an end voxel).
    const Eigen::Vector3i v0 = box.min.array().floor().cast<int>().max(0);
    const Eigen::Vector3i v1 = box.max.array().floor().cast<int>().min(dims.array() - 1);
    for (int x = v0.x(); x <= v1.x(); ++x)
      for (int y = v0.y(); y <= v1.y(); ++y)
        for (int z = v0.z(); z <= v1.z(); ++z) mark(x, y, z);
    return 1;
  }
  const int b = (a + 1) % 3;
  const int c = (a + 2) % 3;
  const double oa = origin[a];
  const double ob = origin[b];
  const double oc = origin[c];
  const bool forward = lo[a] > 0.0;
  // Along a the extent is monotonic in s: near face `na`, far face `fa` (both same sign).
  const double na = forward ? lo[a] : hi[a];
  const double fa = forward ? hi[a] : lo[a];
  const double inv_na = 1.0 / na;
  const double inv_fa = 1.0 / fa;
  const int step = forward ? 1 : -1;
  const double s0 = std::max(s_min, 0.0);
  int i = floorToInt(oa + s0 * na);
  const int i_last = floorToInt(oa + fa - (forward ? kEdgeEpsilon : -kEdgeEpsilon));
  int xyz[3];
  for (;; i += step) {
    const bool last = i == i_last;
    ++slabs;
    if (i >= 0 && i < dims[a]) {
      // s range in which the extent along a overlaps slab [i, i + 1].
      double s_lo;
      double s_hi;
      if (forward) {
        s_lo = (i - oa) * inv_fa;
        s_hi = (i + 1 - oa) * inv_na;
      } else {
        s_lo = (i + 1 - oa) * inv_fa;
        s_hi = (i - oa) * inv_na;
      }
      s_lo = std::max(s_lo, s0);
      s_hi = std::min(s_hi, 1.0);
      if (s_lo <= s_hi) {
        const double b_lo = ob + std::min(s_lo * lo[b], s_hi * lo[b]);
        const double b_hi = ob + std::max(s_lo * hi[b], s_hi * hi[b]);
        const double c_lo = oc + std::min(s_lo * lo[c], s_hi * lo[c]);
        const double c_hi = oc + std::max(s_lo * hi[c], s_hi * hi[c]);
        const int j0 = std::max(floorToInt(b_lo + kEdgeEpsilon), 0);
        const int j1 = std::min(ceilToInt(b_hi - kEdgeEpsilon) - 1, dims[b] - 1);
        const int k0 = std::max(floorToInt(c_lo + kEdgeEpsilon), 0);
        const int k1 = std::min(ceilToInt(c_hi - kEdgeEpsilon) - 1, dims[c] - 1);
        xyz[a] = i;
        for (int j = j0; j <= j1; ++j) {
          xyz[b] = j;
          for (int k = k0; k <= k1; ++k) {
            xyz[c] = k;
            mark(xyz[0], xyz[1], xyz[2]);
          }
        }
      }
    }
    if (last) break;
    if ((forward && i > i_last) || (!forward && i < i_last)) break;  // s_min beyond the end
  }
  return slabs;
}

std::size_t carveCone(const Eigen::Vector3d& origin, const Eigen::Vector3i& end, VoxelBitset* free) {
  const Eigen::Vector3f lo = end.cast<float>();
  // Just inside the far faces: a point on a far face belongs to the next voxel.
  const Eigen::Vector3f hi = lo + Eigen::Vector3f::Constant(1.0f - 1e-6f);
  return carveCone(origin, VoxelSpaceBox{lo, hi}, 0.0, free);
}

}  // namespace mlmap
