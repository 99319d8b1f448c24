#pragma once
/// @file
/// What datasets::parsePcd() and datasets::parsePly() document about a file they accept.

#include "fuzz_support.h"

#include "mlmap/datasets/point_cloud_file.h"

namespace mlmap::fuzz {

/// Every declared point is kept (finite) or counted as dropped.
inline void checkPointCloudFile(const datasets::PointCloudFile& cloud) {
  requireThat(cloud.points_C.size() + cloud.non_finite_dropped == cloud.points_in_file,
              "kept + dropped points != points in the file");
  for (const Eigen::Vector3f& p : cloud.points_C)
    requireThat(p.allFinite(), "a kept point is not finite");
  requireThat(cloud.T_C_V.matrix().allFinite() && isValidPose(cloud.T_C_V), "T_C_V is not a pose");
}

}  // namespace mlmap::fuzz
