#pragma once
/// @file
/// Export of a map to an OctoMap binary tree (`.bt`, Debian's liboctomap-dev), for octovis and
/// every OctoMap-based tool. Its own target (mlmap_octomap_io): neither the core nor mlmap_node
/// links liboctomap.
///
/// The grids match cell for cell: OctoMap's key of a coordinate is floor(coordinate /
/// resolution) + 32768 per axis (OcTreeBaseImpl::coordToKey), mlmap's voxel index is
/// floor(coordinate / resolution), so voxel g is key g + 32768. Occupied voxels (local and
/// global) go in as occupied, the local window's observed-free voxels as free, unknown stays
/// unknown; each keeps its log-odds (nudged just below the threshold for a free voxel exactly at
/// it, since OctoMap calls a value equal to the threshold occupied). A `.bt` file stores only
/// the three states (OcTree::writeBinary: maximum likelihood, pruned).

#include "mlmap/local/map_state.h"

#include <cstddef>
#include <string>

namespace mlmap::io {

/// What went into the tree.
struct OctomapExportCounts {
  std::size_t occupied = 0;      ///< occupied voxels written
  std::size_t free = 0;          ///< free voxels written
  std::size_t out_of_range = 0;  ///< voxels beyond OctoMap's +-32768 keys (left out)
};

/// Writes the map to `path` as an OctoMap `.bt` file with the map's resolution and clamping
/// bounds. Throws std::runtime_error naming the path when it cannot be written (through a
/// temporary file, as the other exports).
OctomapExportCounts writeOctomapBinary(const MapState& state, const std::string& path);

}  // namespace mlmap::io
