#pragma once
// Slow, obviously-correct references for the tests.

#include "mlmap/core/types.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>
#include <vector>

namespace mlmap::test {

using Key = std::tuple<int, int, int>;
inline Key key(const VoxelIndex& v) { return {v.x(), v.y(), v.z()}; }
inline VoxelIndex index(const Key& k) { return {std::get<0>(k), std::get<1>(k), std::get<2>(k)}; }

/// Voxels a segment passes through for at least `min_fraction * resolution` of its length: cut
/// it at every grid plane it crosses and take the voxel of each piece's midpoint. A voxel the
/// segment merely grazes (an edge or a corner, for less than that length) may be missing; every
/// voxel it really passes through is found. A segment shorter than that length gives its
/// midpoint's voxel.
inline std::set<Key> referenceRayVoxels(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                        double resolution, double min_fraction = 0.002) {
  const Eigen::Vector3d a = from / resolution;
  const Eigen::Vector3d d = (to - from) / resolution;  // in voxels
  const double length = d.norm();
  if (length < min_fraction) return {key(voxelIndexOf(0.5 * (from + to), resolution))};
  std::vector<double> cuts = {0.0, 1.0};  // segment parameters of the plane crossings
  for (int axis = 0; axis < 3; ++axis) {
    if (d[axis] == 0.0) continue;
    const double lo = std::min(a[axis], a[axis] + d[axis]);
    const double hi = std::max(a[axis], a[axis] + d[axis]);
    for (double plane = std::ceil(lo); plane <= hi; plane += 1.0) {
      cuts.push_back((plane - a[axis]) / d[axis]);
    }
  }
  std::sort(cuts.begin(), cuts.end());
  std::set<Key> out;
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
    if ((cuts[i + 1] - cuts[i]) * length < min_fraction) continue;
    const double t = 0.5 * (cuts[i] + cuts[i + 1]);
    out.insert(key(voxelIndexOf(from + (to - from) * t, resolution)));
  }
  return out;
}

}  // namespace mlmap::test
