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

#include <Eigen/Core>

#include <cstdint>
#include <cstring>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

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

/// The box [lo, hi] computed in double, rounded outwards to float: floatBelow() of each of lo's
/// coordinates and -floatBelow(-x) of hi's, the same floats. Two coordinates at a time in SSE2
/// where there is SSE2, so that the bits stay in vector registers (the scalar floatBelow() moves
/// each float to an integer register and back, a listing's cone boxes' main cost).
inline VoxelSpaceBox roundOutwards(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  VoxelSpaceBox box;
#ifdef __SSE2__
  // floatBelow() on two doubles: to float (to nearest, as static_cast), back, and one step
  // towards -infinity where that went up: bits - 1 for a positive float, bits + 1 for a negative
  // one, that is bits - (sign | 1) with sign 0 or -1.
  auto below2 = [](__m128d x, float* out) {
    const __m128 f = _mm_cvtpd_ps(x);
    const __m128d up = _mm_cmpgt_pd(_mm_cvtps_pd(f), x);  // 64-bit lanes
    const __m128i up32 = _mm_castps_si128(
        _mm_shuffle_ps(_mm_castpd_ps(up), _mm_castpd_ps(up), _MM_SHUFFLE(2, 0, 2, 0)));
    const __m128i bits = _mm_castps_si128(f);
    const __m128i step = _mm_or_si128(_mm_srai_epi32(bits, 31), _mm_set1_epi32(1));
    const __m128 r = _mm_castsi128_ps(_mm_sub_epi32(bits, _mm_and_si128(step, up32)));
    alignas(16) float lanes[4];
    _mm_store_ps(lanes, r);
    out[0] = lanes[0];
    out[1] = lanes[1];
  };
  float v[6];
  below2(_mm_setr_pd(lo.x(), lo.y()), v);
  below2(_mm_setr_pd(lo.z(), -hi.x()), v + 2);
  below2(_mm_setr_pd(-hi.y(), -hi.z()), v + 4);
  box.min = Eigen::Vector3f(v[0], v[1], v[2]);
  box.max = Eigen::Vector3f(-v[3], -v[4], -v[5]);
#else
  for (int k = 0; k < 3; ++k) {
    box.min[k] = floatBelow(lo[k]);
    box.max[k] = -floatBelow(-hi[k]);
  }
#endif
  return box;
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
