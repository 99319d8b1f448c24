#pragma once
/// @file
/// Agreement of two occupied-voxel sets on the same world grid (voxel i = floor(coordinate /
/// resolution)), e.g. mlmap's map against OctoMap's. Exact and within one cell.

#include "mlmap/eval/sim_flight.h"

#include <cstddef>
#include <vector>

namespace mlmap::eval {

/// How well map A (e.g. mlmap) agrees with map B (e.g. OctoMap, taken as the reference).
///
/// Exact: intersection = |A ∩ B|, IoU = |A ∩ B| / |A ∪ B|, precision = |A ∩ B| / |A|, recall =
/// |A ∩ B| / |B|.
///
/// Within one cell: a voxel of A is matched when B has a voxel within Chebyshev distance 1 (one
/// of the 27 cells around it, itself included), and the other way round. precision_1 =
/// matched_a / |A|, recall_1 = matched_b / |B|, and IoU_1 = m / (|A| + |B| - m) with
/// m = (matched_a + matched_b) / 2, which is the exact IoU when the tolerance is zero.
/// Every ratio is 0 when its denominator is.
struct VoxelAgreement {
  std::size_t a = 0;             ///< |A|
  std::size_t b = 0;             ///< |B|
  std::size_t intersection = 0;  ///< |A ∩ B|
  double iou = 0.0;
  double precision = 0.0;       ///< of A against B
  double recall = 0.0;          ///< of A against B
  std::size_t matched_a_1 = 0;  ///< voxels of A with a voxel of B within one cell
  std::size_t matched_b_1 = 0;  ///< voxels of B with a voxel of A within one cell
  double iou_1 = 0.0;
  double precision_1 = 0.0;
  double recall_1 = 0.0;
};

/// Compares two voxel sets (duplicates in the inputs count once).
[[nodiscard]] VoxelAgreement compareVoxels(const std::vector<VoxelIndex>& a,
                                           const std::vector<VoxelIndex>& b);

/// True when `set` holds a voxel within Chebyshev distance 1 of `v` (v itself included).
[[nodiscard]] bool hasNeighbourWithinOne(const VoxelSet& set, const VoxelIndex& v);

}  // namespace mlmap::eval
