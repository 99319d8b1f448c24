#pragma once
/// @file
/// What the awareness stage hands to the local-global stage for one frame (paper Algorithm 2
/// output L_o / L_n): each voxel appears at most once, and a voxel hit in the frame is never
/// also listed free (a hit wins over a miss, as in OctoMap).

#include "mlmap/core/types.h"
#include "mlmap/core/voxel_bitset.h"

#include <vector>

namespace mlmap {

/// Occupied measurement: the world voxel holding a measured point, and that point.
struct HitMeasurement {
  VoxelIndex index;     ///< world voxel index, floor(p_W / resolution)
  Eigen::Vector3d p_W;  ///< the measured point (first point of the frame in that voxel)
};

/// One frame's measurements for the local map.
struct MeasurementBatch {
  double stamp_s = 0.0;
  Transform T_W_B = Transform::Identity();  ///< body pose of the frame
  Eigen::Vector3d sensor_origin_W = Eigen::Vector3d::Zero();
  double resolution_m = 0.0;
  std::vector<HitMeasurement> hits;  ///< occupied list, unique voxels
  VoxelBitset free;                  ///< free list as a set over a box around the sensor
  std::size_t free_count = 0;        ///< number of bits set in `free`
  /// Voxels of hits in range beyond the free set's box (farther than the local map reaches from
  /// the body), one per point: their occupied evidence goes to the global map.
  std::vector<VoxelIndex> far_hits;
  double awareness_ms = 0.0;  ///< time the awareness stage spent on the frame
};

}  // namespace mlmap
