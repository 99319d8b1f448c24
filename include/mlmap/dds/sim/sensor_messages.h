#pragma once
/// @file
/// A depth camera's frames as a ROS 2 camera driver publishes them: an organised PointCloud2, or
/// a depth Image with its CameraInfo (what mlmap_sensor_publisher sends, streamed or in its
/// closed loop). Sensor frame S (optical: x right, y down, z forward), metres.

#include "mlmap/core/types.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include <string>

namespace mlmap::dds {

/// An organised cloud (width x height) of float32 x, y, z, intensity (16 bytes per point, as a
/// depth camera driver publishes it, intensity = depth); pixels without a return are NaN
/// (is_dense false).
sensor_msgs::PointCloud2_ organisedCloud(const DepthFrame& frame, double stamp_s,
                                         const std::string& frame_id);

/// The depth image of `frame` (16UC1 millimetres or 32FC1 metres, as it was captured).
sensor_msgs::Image_ depthImage(const DepthFrame& frame, double stamp_s,
                               const std::string& frame_id);

/// The CameraInfo of a pinhole camera without distortion.
sensor_msgs::CameraInfo_ cameraInfo(const PinholeIntrinsics& k, double stamp_s,
                                    const std::string& frame_id);

}  // namespace mlmap::dds
