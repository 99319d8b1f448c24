// The OctoMap .bt export, read back with liboctomap itself.

#include "../support/small_flight.h"
#include "mlmap/map_io/octomap_export.h"
#include "../support/random_draws.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <unistd.h>

#include <filesystem>
#include <random>
#include <set>
#include <tuple>

namespace mlmap {
namespace {

using Key = std::tuple<int, int, int>;

TEST(OctomapExport, OctomapKeysAreFloorOfCoordinateOverResolutionLikeMlmapVoxels) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coordinate(-300.0, 300.0);
  for (double res : {0.2, 0.1, 0.05, 0.02}) {
    octomap::OcTree tree(res);
    for (int i = 0; i < 20000; ++i) {
      Eigen::Vector3d p = test::draw3(coordinate, rng);
      if (i % 4 == 0) p = (p / res).array().round().matrix() * res;  // on cell borders too
      const VoxelIndex g = voxelIndexOf(p, res);
      const octomap::OcTreeKey key = tree.coordToKey(p.x(), p.y(), p.z());
      ASSERT_EQ(static_cast<int>(key[0]) - 32768, g.x()) << p.transpose() << " at " << res;
      ASSERT_EQ(static_cast<int>(key[1]) - 32768, g.y());
      ASSERT_EQ(static_cast<int>(key[2]) - 32768, g.z());
      // And the cell centres agree.
      const octomap::point3d c = tree.keyToCoord(key);
      const Eigen::Vector3d centre = voxelCenter(g, res);
      ASSERT_NEAR(c.x(), centre.x(), 1e-4);
      ASSERT_NEAR(c.z(), centre.z(), 1e-4);
    }
  }
}

TEST(OctomapExport, TheBtFileHoldsTheSameOccupiedAndFreeVoxels) {
  MapEngine engine(test::smallWindowConfig());
  test::flyCheap(engine, 0, 30);
  const MapState state = engine.exportState();

  std::set<Key> occupied;
  std::set<Key> free;
  engine.globalMap().forEachVoxel([&](const VoxelIndex& g, double) {
    occupied.insert({g.x(), g.y(), g.z()});
  });
  const LocalMap& local = engine.localMap();
  for (int x = local.minIndex().x(); x < local.maxIndex().x(); ++x) {
    for (int y = local.minIndex().y(); y < local.maxIndex().y(); ++y) {
      for (int z = local.minIndex().z(); z < local.maxIndex().z(); ++z) {
        const Occupancy s = local.state(VoxelIndex(x, y, z));
        if (s == Occupancy::kOccupied) occupied.insert({x, y, z});
        if (s == Occupancy::kFree) free.insert({x, y, z});
      }
    }
  }
  ASSERT_GT(occupied.size(), 500u);
  ASSERT_GT(free.size(), 1000u);

  const std::string path = (std::filesystem::temp_directory_path() /
                            ("mlmap_octomap_test_" + std::to_string(::getpid()) + ".bt"))
                               .string();
  const io::OctomapExportCounts counts = io::writeOctomapBinary(state, path);
  EXPECT_EQ(counts.occupied, occupied.size());
  EXPECT_EQ(counts.free, free.size());
  EXPECT_EQ(counts.out_of_range, 0u);

  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(path));
  std::filesystem::remove(path);
  EXPECT_DOUBLE_EQ(tree.getResolution(), 0.2);
  tree.expand();  // undo the pruning: one leaf per voxel
  std::set<Key> read_occupied;
  std::set<Key> read_free;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    ASSERT_EQ(it.getDepth(), tree.getTreeDepth());
    const octomap::OcTreeKey k = it.getKey();
    const Key key{static_cast<int>(k[0]) - 32768, static_cast<int>(k[1]) - 32768,
                  static_cast<int>(k[2]) - 32768};
    (tree.isNodeOccupied(*it) ? read_occupied : read_free).insert(key);
  }
  EXPECT_TRUE(read_occupied == occupied) << read_occupied.size() << " vs " << occupied.size();
  EXPECT_TRUE(read_free == free) << read_free.size() << " vs " << free.size();
}

}  // namespace
}  // namespace mlmap
