#include "mlmap/map_io/octomap_export.h"

#include "mlmap/core/atomic_file.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <sstream>

namespace mlmap::io {
namespace {

constexpr int kKeyOffset = 32768;  // OctoMap's tree_max_val at depth 16

bool toKey(const VoxelIndex& g, octomap::OcTreeKey* key) {
  for (int a = 0; a < 3; ++a) {
    const int k = g[a] + kKeyOffset;
    if (k < 0 || k > 65535) return false;
    (*key)[static_cast<unsigned>(a)] = static_cast<octomap::key_type>(k);
  }
  return true;
}

}  // namespace

OctomapExportCounts writeOctomapBinary(const MapState& state, const std::string& path) {
  octomap::OcTree tree(state.local_map.resolution_m);
  const LogOddsConfig& lo = state.log_odds;
  tree.setClampingThresMin(probabilityFromLogOdds(lo.clamp_min));
  tree.setClampingThresMax(probabilityFromLogOdds(lo.clamp_max));
  tree.setOccupancyThres(probabilityFromLogOdds(lo.occupied_threshold));
  const float free_max = tree.getOccupancyThresLog() - static_cast<float>(kLogOddsQuantum);

  OctomapExportCounts counts;
  octomap::OcTreeKey key;
  for (const OccupiedVoxel& v : occupiedVoxels(state)) {
    if (!toKey(v.index, &key)) {
      ++counts.out_of_range;
      continue;
    }
    tree.setNodeValue(key, std::max(static_cast<float>(v.log_odds), tree.getOccupancyThresLog()),
                      true);
    ++counts.occupied;
  }
  const LocalWindow& w = state.window;
  for (int x = 0; x < w.size.x(); ++x) {
    for (int y = 0; y < w.size.y(); ++y) {
      for (int z = 0; z < w.size.z(); ++z) {
        const VoxelIndex g = w.min_index + VoxelIndex(x, y, z);
        if (w.state(g) != Occupancy::kFree) continue;
        if (!toKey(g, &key)) {
          ++counts.out_of_range;
          continue;
        }
        tree.setNodeValue(key, std::min(static_cast<float>(dequantizeLogOdds(w.at(g))), free_max),
                          true);
        ++counts.free;
      }
    }
  }
  tree.updateInnerOccupancy();
  std::ostringstream bytes;
  if (!tree.writeBinary(bytes)) {
    throw std::runtime_error("cannot write '" + path + "': OctoMap refused to serialise the tree");
  }
  writeFileAtomically(path, bytes.str());
  return counts;
}

}  // namespace mlmap::io
