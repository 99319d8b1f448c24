#include "mlmap/nav/recent_obstacles.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_set>

namespace mlmap::nav {

std::vector<Eigen::Vector3d> recentObstacles(const std::vector<Eigen::Vector3f>& points_S,
                                             const Transform& T_W_S, double height_m,
                                             double cell_m) {
  const double range_m = 5.0;
  const double band_m = 0.6;
  std::vector<Eigen::Vector3d> out;
  std::unordered_set<std::uint64_t> cells;
  const Eigen::Vector3d origin_W = T_W_S.translation();
  const double inv = 1.0 / std::max(cell_m, 0.05);
  for (const Eigen::Vector3f& p_S : points_S) {
    if (!p_S.allFinite()) continue;
    const Eigen::Vector3d p_W = T_W_S * p_S.cast<double>();
    if (std::abs(p_W.z() - height_m) >= band_m || (p_W - origin_W).norm() > range_m) continue;
    const auto key = [inv](double v) {
      return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v * inv)) & 0x1fffff);
    };
    if (!cells.insert(key(p_W.x()) << 42 | key(p_W.y()) << 21 | key(p_W.z())).second) continue;
    out.push_back(p_W);
  }
  return out;
}

}  // namespace mlmap::nav
