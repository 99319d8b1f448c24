#include "mlmap/planning/map_snapshot.h"

#include <cmath>
#include <limits>

namespace mlmap {

MapSnapshot::MapSnapshot(std::shared_ptr<const LocalWindow> window,
                         std::shared_ptr<const ProjectedGrid> grid,
                         std::shared_ptr<const EsdfMap> esdf, std::uint64_t frame, double stamp_s,
                         const Transform& T_W_B, std::uint64_t esdf_frame,
                         std::shared_ptr<const EsdfQueryGrid> esdf_grid)
    : window_(window ? std::move(window) : std::make_shared<const LocalWindow>()),
      grid_(grid ? std::move(grid) : std::make_shared<const ProjectedGrid>()),
      esdf_(std::move(esdf)),
      frame_(frame),
      stamp_s_(stamp_s),
      T_W_B_(T_W_B),
      esdf_frame_(esdf_frame),
      esdf_grid_(std::move(esdf_grid)) {}

Occupancy MapSnapshot::state(const Eigen::Vector3d& p_W) const {
  if (!p_W.allFinite()) return Occupancy::kUnknown;
  return window_->state(voxelIndexOf(p_W, window_->resolution_m));
}

bool MapSnapshot::probability(const Eigen::Vector3d& p_W, double* probability) const {
  if (!p_W.allFinite()) return false;
  const VoxelIndex g = voxelIndexOf(p_W, window_->resolution_m);
  if (!window_->contains(g)) return false;
  const LogOddsQ v = window_->at(g);
  if (v == kUnknownLogOdds) return false;
  *probability = probabilityFromLogOdds(dequantizeLogOdds(v));
  return true;
}

EsdfMap::Query MapSnapshot::distance(const Eigen::Vector3d& p_W) const {
  if (esdf_ == nullptr) return {};
  return esdf_->query(p_W);
}

Eigen::Vector3d MapSnapshot::windowMin_W() const {
  return window_->min_index.cast<double>() * window_->resolution_m;
}

Eigen::Vector3d MapSnapshot::windowMax_W() const {
  return (window_->min_index + window_->size).cast<double>() * window_->resolution_m;
}

bool MapSnapshot::voxelBlocks(const VoxelIndex& g, UnknownAs unknown) const {
  switch (window_->state(g)) {
    case Occupancy::kOccupied:
      return true;
    case Occupancy::kUnknown:
      return unknown == UnknownAs::kOccupied;
    case Occupancy::kFree:
      return false;
  }
  return true;
}

bool MapSnapshot::isSegmentFree(const Eigen::Vector3d& a_W, const Eigen::Vector3d& b_W,
                                UnknownAs unknown) const {
  if (!a_W.allFinite() || !b_W.allFinite()) return false;
  // Voxel walk (Amanatides & Woo) in voxel units from a to b.
  const double inv = 1.0 / window_->resolution_m;
  const Eigen::Vector3d a = a_W * inv;
  const Eigen::Vector3d d = b_W * inv - a;
  VoxelIndex g(floorToInt(a.x()), floorToInt(a.y()), floorToInt(a.z()));
  const VoxelIndex last(floorToInt(a.x() + d.x()), floorToInt(a.y() + d.y()),
                        floorToInt(a.z() + d.z()));
  Eigen::Vector3i step;
  Eigen::Vector3d t_max;
  Eigen::Vector3d t_delta;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    if (d[k] > 0.0) {
      step[k] = 1;
      t_delta[k] = 1.0 / d[k];
      t_max[k] = (g[k] + 1 - a[k]) * t_delta[k];
    } else if (d[k] < 0.0) {
      step[k] = -1;
      t_delta[k] = -1.0 / d[k];
      t_max[k] = (a[k] - g[k]) * t_delta[k];
    } else {
      step[k] = 0;
      t_delta[k] = kInf;
      t_max[k] = kInf;
    }
  }
  // At most one step per voxel boundary crossed; the bound also ends the walk if rounding made
  // it miss `last`.
  const int max_steps = (last - g).cwiseAbs().sum();
  for (int n = 0;; ++n) {
    if (voxelBlocks(g, unknown)) return false;
    if (g == last || n >= max_steps) break;
    int k = 0;
    if (t_max[1] < t_max[k]) k = 1;
    if (t_max[2] < t_max[k]) k = 2;
    if (t_max[k] > 1.0) break;
    g[k] += step[k];
    t_max[k] += t_delta[k];
  }
  return true;
}

bool MapSnapshot::isBoxFree(const Eigen::Vector3d& min_W, const Eigen::Vector3d& max_W,
                            UnknownAs unknown) const {
  if (!min_W.allFinite() || !max_W.allFinite() || (max_W.array() < min_W.array()).any()) {
    return false;
  }
  const double inv = 1.0 / window_->resolution_m;
  VoxelIndex lo;
  VoxelIndex hi;  // inclusive: voxels whose interior overlaps the box
  for (int k = 0; k < 3; ++k) {
    lo[k] = floorToInt(min_W[k] * inv);
    hi[k] = std::max(lo[k], ceilToInt(max_W[k] * inv) - 1);
  }
  // A box reaching outside the window holds unknown space.
  const VoxelIndex w_lo = window_->min_index;
  const VoxelIndex w_hi = window_->min_index + window_->size;  // exclusive
  const bool inside = (lo.array() >= w_lo.array()).all() && (hi.array() < w_hi.array()).all();
  if (!inside && unknown == UnknownAs::kOccupied) return false;
  const VoxelIndex a = lo.cwiseMax(w_lo);
  const VoxelIndex b = hi.cwiseMin(w_hi - VoxelIndex::Ones());
  for (int x = a.x(); x <= b.x(); ++x) {
    for (int y = a.y(); y <= b.y(); ++y) {
      for (int z = a.z(); z <= b.z(); ++z) {
        if (voxelBlocks(VoxelIndex(x, y, z), unknown)) return false;
      }
    }
  }
  return true;
}

}  // namespace mlmap
