#pragma once
// Helpers of the fleet tests: a small LiDAR flight through the simulated room, and a vehicle's
// whole map (global map and window) as world voxel -> stored log-odds.

#include "mlmap/pipeline/map_engine.h"
#include "mlmap/sim/lidar.h"
#include "mlmap/sim/trajectory.h"
#include "mlmap/sim/world.h"

#include <cmath>
#include <map>
#include <set>
#include <tuple>
#include <vector>

namespace mlmap::fleet::test_support {

/// Orders voxel indices (std::map keys).
struct VoxelLess {
  bool operator()(const VoxelIndex& a, const VoxelIndex& b) const {
    return std::tie(a.x(), a.y(), a.z()) < std::tie(b.x(), b.y(), b.z());
  }
};
using VoxelValues = std::map<VoxelIndex, LogOddsQ, VoxelLess>;

/// A voxel index as an ordered triple (std::set of voxels).
using Key3 = std::tuple<int, int, int>;

/// The voxels of `voxels` as a set.
inline std::set<Key3> keys(const std::vector<VoxelIndex>& voxels) {
  std::set<Key3> out;
  for (const VoxelIndex& v : voxels) out.insert({v.x(), v.y(), v.z()});
  return out;
}

/// Intersection over union of two voxel sets (1 when both are empty).
inline double iou(const std::set<Key3>& a, const std::set<Key3>& b) {
  std::size_t both = 0;
  for (const Key3& k : a) both += b.count(k);
  const std::size_t either = a.size() + b.size() - both;
  return either == 0 ? 1.0 : static_cast<double>(both) / static_cast<double>(either);
}

/// 0.2 m voxels, a 16 x 16 x 6 m window (submaps of 16 x 16 x 6 voxels), 8 m range: small enough
/// for a test, several submaps retired and restored along the room's loop.
inline MapConfig fleetMapConfig() {
  MapConfig c;
  c.local_map.resolution_m = 0.2;
  c.local_map.size_cells = {80, 80, 30};
  c.awareness.max_range_m = 8.0;
  return c;
}

/// Where the simulator's world lies in the map's world frame (see roomFlight()) [m].
inline const Eigen::Vector3d kMapFromSimulator_m(0.1, 0.1, 0.1);

/// True when voxel `v` of the map (world shifted by `map_from_simulator_m`) touches a
/// static solid of World::defaultRoom(), if only with a face: a right "occupied".
inline bool touchesRoomSolid(const sim::World& world, const VoxelIndex& v, double resolution_m,
                             const Eigen::Vector3d& map_from_simulator_m = kMapFromSimulator_m) {
  const Eigen::Vector3d min_W = v.cast<double>() * resolution_m - map_from_simulator_m;
  return world.intersectsBox(min_W, min_W + Eigen::Vector3d::Constant(resolution_m), 1e-6);
}

/// `count` LiDAR scans (16 x 360 rays, noise-free) along Trajectory::defaultRoomFlight() through
/// World::defaultRoom(), evenly spread in time; the LiDAR sits at the body origin. The map's
/// world frame is the simulator's shifted by `map_from_simulator_m` (default (0.1, 0.1, 0.1) m:
/// the room's faces lie on multiples of 0.1 m, which at 0.2 m voxels would put the floor and
/// walls exactly on voxel borders, where rounding alone decides between two voxels; use half a
/// voxel at 0.1 m).
inline std::vector<PointCloudFrame> roomFlight(
    int count, double max_range_m = 8.0,
    const Eigen::Vector3d& map_from_simulator_m = kMapFromSimulator_m) {
  const sim::World world = sim::World::defaultRoom();
  const sim::Trajectory trajectory = sim::Trajectory::defaultRoomFlight();
  sim::LidarModel model;
  model.beams = 16;
  model.azimuth_steps = 360;
  model.max_range_m = max_range_m;
  const sim::Lidar lidar(model);
  std::vector<PointCloudFrame> frames(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    const double t = trajectory.duration_s() * (i + 0.5) / count;
    PointCloudFrame& f = frames[static_cast<std::size_t>(i)];
    f.T_W_B = trajectory.poseAt(t);
    lidar.render(world, f.T_W_B, t, &f);
    f.T_W_B.translation() += map_from_simulator_m;
  }
  return frames;
}

/// Every occupied voxel of the engine's map (global map and window) with its stored log-odds.
inline VoxelValues engineContent(const MapEngine& engine) {
  VoxelValues out;
  engine.globalMap().forEachVoxel(
      [&](const VoxelIndex& g, double l) { out[g] = quantizeLogOdds(l); });
  engine.localMap().forEachOccupied(
      [&](const VoxelIndex& g, double l) { out[g] = quantizeLogOdds(l); });
  return out;
}

}  // namespace mlmap::fleet::test_support
