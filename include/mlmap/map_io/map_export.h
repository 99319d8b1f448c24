#pragma once
/// @file
/// Exports of a map (MapState) to the formats other tools open:
/// - occupied voxels (local and global) as PLY (binary little endian: float x, y, z of the voxel
///   centre, float log_odds, float probability) or PCD v0.7 (binary: float x, y, z, intensity =
///   occupancy probability);
/// - the 2D grid as PGM + YAML, exactly as ROS map_server / nav2 map_saver write it (trinary:
///   occupied 0, free 254, unknown 205; values >= 65 occupied, <= 25 free; the YAML's
///   occupied_thresh / free_thresh 0.65 / 0.196 make map_server load 205 back as unknown).
/// The OctoMap `.bt` export lives in mlmap/map_io/octomap_export.h (its own target, liboctomap).
/// Every writer goes through writeFileAtomically(): a failed export leaves no partial file.

#include "mlmap/core/config.h"
#include "mlmap/local/map_state.h"
#include "mlmap/planning/projected_grid.h"

#include <cstddef>
#include <string>
#include <vector>

namespace mlmap::io {

/// One occupied voxel of a map.
struct OccupiedVoxel {
  VoxelIndex index = VoxelIndex::Zero();  ///< world voxel index: floor(coordinate / resolution)
  double log_odds = 0.0;                  ///< natural log-odds
  bool global = false;                    ///< from the global map (else the local window)
};

/// Every occupied voxel of the map: the local window's, then the global map's (by submap index,
/// then offset).
[[nodiscard]] std::vector<OccupiedVoxel> occupiedVoxels(const MapState& state);

/// Largest 2D grid projectMap() makes (cells): 2^28, a 268 MB image.
inline constexpr std::size_t kMaxExportGridCells = std::size_t{1} << 28;

/// The 2D grid of the map (ProjectedGrid rules) over the local window and, with
/// `config.include_global`, the global map. A relative band is anchored at the map's last body
/// height. Throws std::runtime_error when the grid would exceed kMaxExportGridCells.
[[nodiscard]] ProjectedGrid projectMap(const MapState& state, const ProjectedGridConfig& config);

/// The bytes of a binary little-endian PLY file of the voxel centres (see the file comment).
[[nodiscard]] std::string encodePly(const std::vector<OccupiedVoxel>& voxels, double resolution_m);
/// The bytes of a binary PCD v0.7 file of the voxel centres (see the file comment).
[[nodiscard]] std::string encodePcd(const std::vector<OccupiedVoxel>& voxels, double resolution_m);
/// The PGM (P5) image of a grid as map_saver writes it: top row = largest y; trinary values
/// (occupied >= 65 -> 0, 0 <= value <= 25 -> 254, else 205).
[[nodiscard]] std::string encodeGridPgm(const ProjectedGrid& grid);
/// The map_server YAML of a grid whose image is `image_name` (image, mode, resolution,
/// origin [x, y, yaw], negate, occupied_thresh, free_thresh).
[[nodiscard]] std::string encodeGridYaml(const ProjectedGrid& grid, const std::string& image_name);

/// Writes the occupied voxels as PLY / PCD. Throws std::runtime_error naming the path.
void writePly(const std::vector<OccupiedVoxel>& voxels, double resolution_m,
              const std::string& path);
void writePcd(const std::vector<OccupiedVoxel>& voxels, double resolution_m,
              const std::string& path);
/// Writes `base`.pgm and `base`.yaml (the YAML names the image by its file name, as map_saver
/// does). Throws std::runtime_error naming the path.
void writeGridMap(const ProjectedGrid& grid, const std::string& base);

}  // namespace mlmap::io
