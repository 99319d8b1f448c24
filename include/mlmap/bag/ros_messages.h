#pragma once
/// @file
/// ROS 2 messages of a bag decoded with mlmap's own IDL types (mlmap_dds_cdr): the CDR bytes are
/// checked and deserialised by the generated types with Fast CDR, as the generated PubSubTypes
/// of mlmap_node's DDS readers do it, and PointCloud2 goes through decodeCloudSampleCdr(), the
/// node's in-place decoder. A bag message and a live topic therefore decode the same; the bag
/// reader links Fast CDR, not Fast DDS.

#include "mlmap/core/types.h"
#include "mlmap/dds/wire/cloud_cdr.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include "tf2_msgs/msg/TFMessage_.h"

#include <cstdint>
#include <string>
#include <vector>

namespace mlmap::bag {

namespace tf2_msgs = ::tf2_msgs::msg::dds_;

/// The ROS 2 type names read (as bags store them).
inline constexpr const char* kPointCloud2Type = "sensor_msgs/msg/PointCloud2";
inline constexpr const char* kImageType = "sensor_msgs/msg/Image";
inline constexpr const char* kCameraInfoType = "sensor_msgs/msg/CameraInfo";
inline constexpr const char* kPoseStampedType = "geometry_msgs/msg/PoseStamped";
inline constexpr const char* kOdometryType = "nav_msgs/msg/Odometry";
inline constexpr const char* kTfMessageType = "tf2_msgs/msg/TFMessage";

/// Decodes CDR `bytes` (encapsulation header first) into `msg`, once they passed the type's CDR
/// layout check (mlmap/dds/wire/cdr_check.h: no sequence declares more elements than its bytes
/// hold).
/// @throws std::runtime_error "`what`: malformed CDR (N bytes)", with the layout check's reason
/// when it refused them, when the check or the generated type rejects them.
void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::sensor_msgs::Image_* msg);
/// The same for a CameraInfo.
void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::sensor_msgs::CameraInfo_* msg);
/// The same for a PoseStamped.
void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::geometry_msgs::PoseStamped_* msg);
/// The same for an Odometry.
void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::nav_msgs::Odometry_* msg);
/// The same for a TFMessage.
void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               tf2_msgs::TFMessage_* msg);
/// A PointCloud2 through the node's decodeCloudSampleCdr(): header and layout in `sample`, x, y,
/// z in sample->points_S, the layout check's outcome in sample->status.
void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::CloudSample* sample);

/// T_parent_child of a TransformStamped. false (T untouched) when not finite or the quaternion
/// is not of unit norm (within 1e-3).
bool transformOf(const dds::geometry_msgs::TransformStamped_& msg, Transform* T_parent_child);

}  // namespace mlmap::bag
