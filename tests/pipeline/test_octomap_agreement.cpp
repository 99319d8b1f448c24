// mlmap's occupied voxels against OctoMap's (liboctomap, OcTree::insertPointCloud with its default
// sensor model, which is mlmap's default too) on the same scans: the 360-degree LiDAR at 0.1 m and
// 30 m on the simulated room, and the shared real RealSense frames.
//
// The simulated room's walls and floor lie on voxel faces (at multiples of 0.1 m), so each of
// their points is a tie between two voxels that the last bit of the arithmetic decides: OctoMap
// takes the point's world coordinates in float (octomap::Pointcloud), mlmap transforms the
// sensor-frame float point in double. The scans are therefore also mapped with the whole scene
// moved off the voxel grid (the poses shifted after rendering, which moves the world under the
// sensor), as a real scene is.

#include "mlmap/eval/run_outputs.h"
#include "mlmap/eval/sim_flight.h"
#include "mlmap/eval/voxel_agreement.h"
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/pipeline/map_engine.h"
#include "mlmap/sim/lidar.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

namespace mlmap {
namespace {

constexpr double kLidarResolution_m = 0.1;
constexpr double kLidarRange_m = 30.0;
constexpr int kLidarScans = 8;  // consecutive scans of the default flight at 10 Hz
// Moves the room off the voxel grid: no wall, floor or box face then lies within 1 cm of a face.
const Eigen::Vector3d kOffGrid_m(0.0437, 0.0306, 0.0175);

/// Every occupied leaf of `tree` as a voxel index on mlmap's grid (key - 2^15), pruned leaves
/// expanded (every cell they cover, from the centre of the lowest one).
std::vector<VoxelIndex> octomapOccupied(const octomap::OcTree& tree) {
  std::vector<VoxelIndex> out;
  const double res = tree.getResolution();
  const unsigned max_depth = tree.getTreeDepth();
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    if (it.getDepth() == max_depth) {
      const octomap::OcTreeKey& key = it.getKey();
      out.push_back(VoxelIndex(key[0], key[1], key[2]) - VoxelIndex::Constant(32768));
      continue;
    }
    const int n = 1 << (max_depth - it.getDepth());
    const octomap::point3d c = it.getCoordinate();
    const double half = 0.5 * it.getSize() - 0.5 * res;
    const VoxelIndex lo =
        voxelIndexOf(Eigen::Vector3d(c.x() - half, c.y() - half, c.z() - half), res);
    for (int x = 0; x < n; ++x) {
      for (int y = 0; y < n; ++y) {
        for (int z = 0; z < n; ++z) out.push_back(lo + VoxelIndex(x, y, z));
      }
    }
  }
  return out;
}

/// The points of `points_S` that mlmap maps (finite, at least `min_range_m` from the sensor) in
/// W, as insertPointCloud takes them.
void toWorld(const std::vector<Eigen::Vector3f>& points_S, const Transform& T_W_S,
             double min_range_m, octomap::Pointcloud* cloud_W) {
  cloud_W->clear();
  for (const Eigen::Vector3f& p : points_S) {
    if (!p.allFinite() || p.norm() < min_range_m) continue;
    const Eigen::Vector3d p_W = T_W_S * p.cast<double>();
    cloud_W->push_back(static_cast<float>(p_W.x()), static_cast<float>(p_W.y()),
                       static_cast<float>(p_W.z()));
  }
}

octomap::point3d toOctomap(const Eigen::Vector3d& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
}

void printAgreement(const eval::VoxelAgreement& g) {
  std::printf(
      "mlmap %zu, OctoMap %zu, both %zu: IoU %.3f, precision %.3f, recall %.3f; within one "
      "cell IoU %.3f, precision %.3f, recall %.3f\n",
      g.a, g.b, g.intersection, g.iou, g.precision, g.recall, g.iou_1, g.precision_1, g.recall_1);
}

/// mlmap's engine for the LiDAR: a window that holds every hit within range (75 x 75 x 7.5 m, as
/// mlmap_compare_octomap and tests/benchmarks/replay_lidar_30m.yaml size it), no planning layers.
MapConfig lidarConfig() {
  MapConfig c;
  c.local_map.resolution_m = kLidarResolution_m;
  c.local_map.size_cells = {750, 750, 75};
  c.awareness.max_range_m = kLidarRange_m;
  c.awareness.rho_cells = 300;
  c.sensor.translation_B_m.setZero();
  c.pipeline.planning_layers = false;
  return c;
}

/// Scan i of the default flight at 10 Hz, its pose shifted by `shift_W` after rendering.
PointCloudFrame lidarScan(const datasets::Scenario& scenario, const sim::Lidar& lidar, int i,
                          const Eigen::Vector3d& shift_W) {
  const double t = eval::frameTime(scenario, i);
  PointCloudFrame f;
  f.T_W_B = scenario.trajectory.poseAt(t);
  f.T_B_S = Transform::Identity();
  lidar.render(scenario.world, f.T_W_B, t, &f);
  f.T_W_B.translation() += shift_W;
  return f;
}

/// Both maps of the first kLidarScans scans.
eval::VoxelAgreement mapLidarScans(const Eigen::Vector3d& shift_W) {
  const datasets::Scenario scenario = datasets::defaultScenario();
  EXPECT_DOUBLE_EQ(scenario.frame_rate_hz, 10.0);
  const sim::Lidar lidar;
  const MapConfig config = lidarConfig();
  MapEngine engine(config);
  octomap::OcTree tree(kLidarResolution_m);
  octomap::Pointcloud cloud_W;
  for (int i = 0; i < kLidarScans; ++i) {
    PointCloudFrame f = lidarScan(scenario, lidar, i, shift_W);
    const Transform T_W_S = f.T_W_B * f.T_B_S;
    toWorld(f.points_S, T_W_S, config.awareness.min_range_m, &cloud_W);
    tree.insertPointCloud(cloud_W, toOctomap(T_W_S.translation()), kLidarRange_m);
    EXPECT_EQ(engine.submit(std::move(f)), FrameStatus::kAccepted);
  }
  EXPECT_EQ(engine.stats().hits_lost, 0u);
  const eval::VoxelAgreement g =
      eval::compareVoxels(engine.occupiedVoxels(), octomapOccupied(tree));
  printAgreement(g);
  return g;
}

// Issue 27's LiDAR target: exact-cell IoU >= 0.8 and recall within one cell >= 0.95. The scene
// off the grid, as a real one is, gives 0.993 and 0.999; the bounds below leave a margin for
// nothing but rounding.
TEST(OctomapAgreement, LidarScansAt10cmAnd30mAgreeWithOctomapOffTheVoxelGrid) {
  const eval::VoxelAgreement g = mapLidarScans(kOffGrid_m);
  ASSERT_GT(g.b, 30000u);
  EXPECT_GE(g.iou, 0.97) << "mlmap " << g.a << ", OctoMap " << g.b << ", both " << g.intersection;
  EXPECT_GE(g.precision, 0.99);
  EXPECT_GE(g.recall_1, 0.995);
  EXPECT_GE(g.precision_1, 0.995);
}

// On the grid the exact cells of the room's faces are a coin toss between the two (the IoU falls
// to 0.758), while within one cell the maps still agree: what differs is which side of a voxel
// face a point on that face falls, not the mapping.
TEST(OctomapAgreement, LidarScansOnTheVoxelGridDifferOnlyWithinOneCell) {
  const eval::VoxelAgreement g = mapLidarScans(Eigen::Vector3d::Zero());
  EXPECT_GE(g.recall_1, 0.99);
  EXPECT_GE(g.precision_1, 0.99);
}

// The points behind those differences: wherever mlmap's voxel of a point (voxelIndexOf of its
// world coordinates in double) and OctoMap's (its key from the float coordinates) differ, the
// point lies on a voxel face, within float precision.
TEST(OctomapAgreement, PointsFallInDifferentVoxelsOnlyOnVoxelFaces) {
  const datasets::Scenario scenario = datasets::defaultScenario();
  const sim::Lidar lidar;
  octomap::OcTree tree(kLidarResolution_m);
  std::size_t differing = 0;
  for (const Eigen::Vector3d& shift : {Eigen::Vector3d::Zero().eval(), kOffGrid_m}) {
    const PointCloudFrame f = lidarScan(scenario, lidar, 0, shift);
    std::size_t differing_here = 0;
    for (const Eigen::Vector3f& p : f.points_S) {
      const Eigen::Vector3d p_W = f.T_W_B * p.cast<double>();
      const VoxelIndex mlmap_voxel = voxelIndexOf(p_W, kLidarResolution_m);
      const octomap::OcTreeKey key = tree.coordToKey(toOctomap(p_W));
      const VoxelIndex octomap_voxel =
          VoxelIndex(key[0], key[1], key[2]) - VoxelIndex::Constant(32768);
      if (mlmap_voxel == octomap_voxel) continue;
      ++differing_here;
      for (int a = 0; a < 3; ++a) {
        if (mlmap_voxel[a] == octomap_voxel[a]) continue;
        const double face_m = std::max(mlmap_voxel[a], octomap_voxel[a]) * kLidarResolution_m;
        ASSERT_NEAR(p_W[a], face_m, 1e-5) << "point " << p_W.transpose();
      }
    }
    if (shift.isZero()) {
      EXPECT_GT(differing_here, 1000u);  // the room's faces: many ties
    } else {
      EXPECT_EQ(differing_here, 0u);
    }
    differing += differing_here;
  }
  EXPECT_GT(differing, 0u);
}

// The shared real RealSense frames at 0.02 m and 2 m range, mapped as mlmap_replay --frames maps
// them at its defaults (eval::runConfig) and by OctoMap at its own: every voxel mlmap marks,
// OctoMap marks too; OctoMap keeps a few more, on the surfaces, that mlmap's cones carve free
// though no ray crosses them (see docs/comparison.md): fewer with direction bins one voxel wide
// (the default) than two.
eval::VoxelAgreement realSenseAgreement(const std::string& dir, double bin_width_voxels) {
  const datasets::FrameDirectory frames(dir);
  MapConfig config = eval::runConfig("", eval::DataKind::kFrameDirectory, 0.02);
  config.awareness.bin_width_voxels = bin_width_voxels;
  config.awareness.max_range_m = 2.0;
  config.pipeline.planning_layers = false;
  MapEngine engine(config);
  octomap::OcTree tree(0.02);
  octomap::Pointcloud cloud_W;
  std::vector<Eigen::Vector3f> points_S;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    DepthFrame f = frames.read(i);
    backProject(f, &points_S);
    const Transform T_W_S = f.T_W_B * f.T_B_S;
    toWorld(points_S, T_W_S, config.awareness.min_range_m, &cloud_W);
    tree.insertPointCloud(cloud_W, toOctomap(T_W_S.translation()), config.awareness.max_range_m);
    EXPECT_EQ(engine.submit(std::move(f)), FrameStatus::kAccepted);
  }
  const eval::VoxelAgreement g =
      eval::compareVoxels(engine.occupiedVoxels(), octomapOccupied(tree));
  printAgreement(g);
  return g;
}

TEST(OctomapAgreement, RealSenseFramesAt2cmAgreeWithOctomap) {
  const std::string dir = MLMAP_SHARED_DATA_DIR "/realsense_tabletop";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << dir << " is not there";
  ASSERT_EQ(MapConfig{}.awareness.bin_width_voxels, 1.0) << "the defaults this test is about";
  for (const double bin_width_voxels : {1.0, 2.0}) {
    const eval::VoxelAgreement g = realSenseAgreement(dir, bin_width_voxels);
    ASSERT_GT(g.b, 4000u);
    EXPECT_GE(g.precision, 0.999);
    EXPECT_GE(g.iou, bin_width_voxels == 1.0 ? 0.95 : 0.94)
        << "bins " << bin_width_voxels << " voxels wide: mlmap " << g.a << ", OctoMap " << g.b
        << ", both " << g.intersection;
    EXPECT_GE(g.recall_1, 0.99);
  }
}

}  // namespace
}  // namespace mlmap
