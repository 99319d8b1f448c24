#pragma once
/// @file
/// Complete free-space carving on the voxel grid.
///
/// Every ray from the sensor origin o to a point of a box B lies in the cone conv(o, B), whose
/// section at parameter s is the box o + s (B - o). The cone is rasterised slab by slab along its
/// dominant axis, where its extent along the two other axes is linear in s; each slab marks the
/// voxels of the section's bounding rectangle. So every voxel that any ray into B passes through
/// is marked, plus at most the rectangles' corners.
///
/// All coordinates are box-relative voxel units of a VoxelBitset: voxel (i, j, k) spans
/// [i, i + 1) x [j, j + 1) x [k, k + 1).

#include "mlmap/core/voxel_bitset.h"

#include <cstdint>
#include <cstring>

namespace mlmap {

/// An axis-aligned box in box-relative voxel units.
struct VoxelSpaceBox {
  Eigen::Vector3f min;
  Eigen::Vector3f max;
};

/// The largest float not above `x` (finite, within the float range), for rounding a box computed
/// in double outwards to a VoxelSpaceBox: -floatBelow(-x) is the smallest float not below x.
/// std::nextafter toward -infinity where the rounded value lies above x, without the libm call
/// and without a branch (rounding goes up for about half of the values, a branch the CPU cannot
/// predict). In sign and magnitude one step toward -infinity is bits - 1 for a positive float
/// and bits + 1 for a negative one; a float that rounded up to zero is -0 (x < 0), whose
/// bits + 1 are -denorm_min.
inline float floatBelow(double x) {
  float f = static_cast<float>(x);
  std::uint32_t bits = 0;
  std::memcpy(&bits, &f, sizeof bits);
  const std::uint32_t up = static_cast<double>(f) > x ? 1u : 0u;
  bits += up * (2u * (bits >> 31) - 1u);  // + 0, or -1 / +1 (unsigned wrap-around)
  std::memcpy(&f, &bits, sizeof bits);
  return f;
}

/// Marks in `free` every voxel that the part s in [s_min, 1] of the cone from `origin` to `box`
/// overlaps (voxels outside the bitset's box are skipped). Returns the number of slabs walked.
std::size_t carveCone(const Eigen::Vector3d& origin, const VoxelSpaceBox& box, double s_min,
                      VoxelBitset* free);

/// Which implementation walks a cone's slabs: the same bits either way.
enum class ConeCarverIsa { kPortable, kAvx2 };

/// Whether this build and CPU run the AVX2 slab walk (carveCone() then uses it).
bool coneCarverAvx2Supported();

/// carveCone() with the slab walk `isa` (kAvx2 only when coneCarverAvx2Supported()).
std::size_t carveCone(const Eigen::Vector3d& origin, const VoxelSpaceBox& box, double s_min,
                      VoxelBitset* free, ConeCarverIsa isa);

/// The same, marking only the voxels with box x in [x_begin, x_end): exactly the voxels of the
/// whole cone in that range, so that threads owning disjoint x ranges of `free` together mark
/// what one call marks.
std::size_t carveCone(const Eigen::Vector3d& origin, const VoxelSpaceBox& box, double s_min,
                      int x_begin, int x_end, VoxelBitset* free);

/// The cone to a whole voxel `end`, the end voxel included (for a ray whose end is only known to
/// lie somewhere in `end`).
std::size_t carveCone(const Eigen::Vector3d& origin, const Eigen::Vector3i& end, VoxelBitset* free);

}  // namespace mlmap
