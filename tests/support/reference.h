#pragma once
// Slow, obviously-correct references for the tests.

#include "mlmap/core/types.h"

#include <set>
#include <tuple>

namespace mlmap::test {

using Key = std::tuple<int, int, int>;
inline Key key(const VoxelIndex& v) { return {v.x(), v.y(), v.z()}; }
inline VoxelIndex index(const Key& k) {
  return {std::get<0>(k), std::get<1>(k), std::get<2>(k)};
}

/// Voxels a segment passes through, by walking it in steps of `step_fraction * resolution`.
/// A voxel the segment crosses for less than about one step (it merely grazes an edge or a
/// corner) may be missing; every voxel it really passes through is found.
inline std::set<Key> referenceRayVoxels(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                        double resolution, double step_fraction = 0.002) {
  std::set<Key> out;
  const double length = (to - from).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length / (resolution * step_fraction))));
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector3d p = from + (to - from) * (static_cast<double>(i) / steps);
    out.insert(key(voxelIndexOf(p, resolution)));
  }
  return out;
}

}  // namespace mlmap::test
