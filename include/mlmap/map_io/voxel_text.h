#pragma once
/// @file
/// Occupied voxels as a text list, so that maps of different tools can be compared cell by cell:
///
///   # mlmap occupied voxels: ix iy iz, i = floor(coordinate / resolution), resolution_m 0.1
///   -12 4 0
///   -12 4 1
///   ...
///
/// One voxel per line, three integers separated by one space, sorted by (ix, iy, iz), no
/// duplicates. The indices are on the world grid aligned at the origin: voxel i spans
/// [i * res, (i + 1) * res) along each axis (mlmap's VoxelIndex). Lines starting with `#` are
/// comments; the first one states the resolution.

#include "mlmap/core/types.h"

#include <string>
#include <vector>

namespace mlmap::io {

/// `voxels` sorted by (x, y, z) without duplicates.
[[nodiscard]] std::vector<VoxelIndex> sortedUnique(std::vector<VoxelIndex> voxels);

/// The text of `voxels` (any order; duplicates once) in the format above.
[[nodiscard]] std::string encodeVoxelText(const std::vector<VoxelIndex>& voxels,
                                          double resolution_m);
/// Writes encodeVoxelText() to `path` atomically (writeFileAtomically(): a failed write leaves
/// no partial file). @throws std::runtime_error naming the path when it cannot be written.
void writeVoxelText(const std::string& path, const std::vector<VoxelIndex>& voxels,
                    double resolution_m);

/// Reads a voxel list written by writeVoxelText() (or any tool writing `ix iy iz` lines).
/// @throws std::runtime_error "<path>: line N: ..." on a malformed line.
[[nodiscard]] std::vector<VoxelIndex> readVoxelText(const std::string& path);

}  // namespace mlmap::io
