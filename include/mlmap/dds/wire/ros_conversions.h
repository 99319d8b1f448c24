#pragma once
/// @file
/// Conversions between the ROS 2 wire types (generated from idl/) and mlmap's core types.
///
/// Decoders never trust a message: every size, step, offset and count is checked against the
/// others before a byte is read, and a message that disagrees with itself is rejected with a
/// reason, never read out of bounds. Points that are NaN/Inf are passed on as NaN points: the
/// engine drops and counts them, so a dense organised cloud keeps its meaning.

#include "mlmap/core/types.h"
#include "mlmap/planning/esdf.h"
#include "mlmap/planning/projected_grid.h"

#include "builtin_interfaces/msg/Time_.h"
#include "geometry_msgs/msg/PoseStamped_.h"
#include "geometry_msgs/msg/TransformStamped_.h"
#include "mlmap_msgs/msg/VoxelBlock_.h"
#include "nav_msgs/msg/OccupancyGrid_.h"
#include "nav_msgs/msg/Odometry_.h"
#include "sensor_msgs/msg/CameraInfo_.h"
#include "sensor_msgs/msg/Image_.h"
#include "sensor_msgs/msg/PointCloud2_.h"

#include <string>
#include <vector>

namespace mlmap::dds {

namespace ros_time = builtin_interfaces::msg::dds_;
namespace geometry_msgs = ::geometry_msgs::msg::dds_;
namespace nav_msgs = ::nav_msgs::msg::dds_;
namespace sensor_msgs = ::sensor_msgs::msg::dds_;
namespace mlmap_msgs = ::mlmap_msgs::msg::dds_;

/// Seconds since the epoch of a ROS time (sec may be negative; nanosec must be < 1e9).
double toSeconds(const ros_time::Time_& stamp);
/// ROS time of a stamp in seconds (rounded to the nanosecond; nanosec always in [0, 1e9), also
/// for negative stamps). Not finite gives 0; beyond the int32 seconds range clamps to its ends.
ros_time::Time_ toRosTime(double stamp_s);
/// The wall clock (system clock) in seconds since the epoch: what a driver stamps a capture
/// with, so receive time - stamp is a message's age.
double wallClockNow_s();

/// Why an input message was rejected (kOk: it was not).
enum class DecodeError {
  kOk,
  kBadLayout,        ///< sizes, steps or offsets disagree (data size, row_step, point_step, ...),
                     ///< or a CameraInfo that does not fit its image
  kMissingField,     ///< no x, y or z field
  kUnsupportedType,  ///< a datatype or encoding mlmap cannot read (x/y/z must be FLOAT32/FLOAT64)
  kBadStamp,         ///< nanosec >= 1e9
  kBadPose,          ///< not finite, or quaternion norm farther than 1e-3 from 1
};
/// Short name of a decode error ("bad layout", ...).
const char* toString(DecodeError error);

/// Result of a decode: the error and a human-readable detail (e.g. "row_step 100 < width 10 *
/// point_step 16") for the rate-limited log line.
struct DecodeStatus {
  DecodeError error = DecodeError::kOk;
  std::string detail;
  [[nodiscard]] bool ok() const { return error == DecodeError::kOk; }
};

/// Reads x, y, z of every point of a PointCloud2 into `points_S` (replacing its content; reused
/// memory): any field layout with FLOAT32 or FLOAT64 x, y, z (count 1) at any offset, organised
/// (height > 1) or not, little or big endian, rows padded (row_step > width * point_step).
/// Non-finite points (and FLOAT64 values beyond the float range) become all-NaN points.
/// The layout must hold together: exactly one field each named x, y, z, not overlapping, each
/// ending within point_step > 0; row_step >= width * point_step; and data.size() exactly
/// height * row_step, as sensor_msgs/PointCloud2 defines it (a shorter or longer buffer means the
/// sender's sizes are wrong). Other fields are not read and not checked. Nothing is allocated
/// before the checks pass, and then at most one Vector3f per 12 bytes of data.
/// On error `points_S` is left empty.
DecodeStatus decodePointCloud2(const sensor_msgs::PointCloud2_& msg,
                               std::vector<Eigen::Vector3f>* points_S);
/// The same with the point bytes elsewhere: the fields of `msg` other than data_ (not read)
/// describe the `data_size` bytes at `data`, e.g. still inside the received sample.
DecodeStatus decodePointCloud2(const sensor_msgs::PointCloud2_& msg, const std::uint8_t* data,
                               std::size_t data_size, std::vector<Eigen::Vector3f>* points_S);

/// A PointCloud2 of float32 x, y, z (and `intensity` when `intensity` is not null, one value per
/// point), unorganised (height 1), little endian, point_step 12 (16 with intensity); is_dense
/// unless a point is not finite. Throws std::invalid_argument when `intensity` has not one value
/// per point, std::length_error beyond 2^32 / point_step points.
sensor_msgs::PointCloud2_ encodePointCloud2(const std::vector<Eigen::Vector3f>& points,
                                            const std::vector<float>* intensity, double stamp_s,
                                            const std::string& frame_id);

/// Fills a DepthFrame's image and intrinsics (not its poses or stamp) from a depth Image
/// (16UC1 in millimetres or 32FC1 in metres; step >= width * bytes per pixel; either endianness)
/// and its CameraInfo (K; width and height must equal the image's; fx, fy > 0 and fx, fy, cx, cy
/// finite; skew and distortion are ignored). "mono16" is read as 16UC1. data.size() may exceed
/// step * height. The image is copied tightly packed in host byte order. On error `frame` is
/// left untouched.
DecodeStatus decodeDepthImage(const sensor_msgs::Image_& image,
                              const sensor_msgs::CameraInfo_& info, DepthFrame* frame);

/// Stamp and T_W_B of a PoseStamped (or an Odometry's pose; its twist is ignored): kBadStamp when
/// nanosec >= 1e9, kBadPose unless makePose() accepts it (finite, quaternion norm within 1e-3 of
/// 1; the quaternion is normalised). On error the outputs are left untouched.
DecodeStatus decodePose(const geometry_msgs::PoseStamped_& msg, double* stamp_s, Transform* T_W_B);
DecodeStatus decodePose(const nav_msgs::Odometry_& msg, double* stamp_s, Transform* T_W_B);

/// A PoseStamped carrying T_W_B in `frame_id` (decodePose()'s inverse; the quaternion normalised).
geometry_msgs::PoseStamped_ toPoseStamped(const Transform& T_W_B, double stamp_s,
                                          const std::string& frame_id);

/// Stamp and T_parent_child of a TransformStamped: kBadStamp when nanosec >= 1e9, kBadPose when
/// a value is not finite or the quaternion norm is not within 1e-3 of 1 (it is normalised), or
/// when the parent or child frame is empty or they are equal. On error the outputs are left
/// untouched.
DecodeStatus decodeTransform(const geometry_msgs::TransformStamped_& msg, double* stamp_s,
                             Transform* T_parent_child);

/// A TransformStamped parent -> child carrying T_parent_child.
geometry_msgs::TransformStamped_ toTransformStamped(const Transform& T_parent_child, double stamp_s,
                                                    const std::string& parent_frame,
                                                    const std::string& child_frame);

/// The 2D grid as nav_msgs/OccupancyGrid (cells as they are: -1 unknown, 0..100); origin at the
/// grid's lower corner and `z_m` height, identity orientation, map_load_time = stamp.
/// Throws std::invalid_argument when grid.cells does not hold width * height values.
nav_msgs::OccupancyGrid_ toOccupancyGrid(const ProjectedGrid& grid, double z_m, double stamp_s,
                                         const std::string& frame_id);

/// The ESDF's box as a dense mlmap_msgs/VoxelBlock (layer "esdf", distances in metres clamped to
/// the ESDF's maximum, NaN where unknown), in the box order of mlmap (x-major, z fastest);
/// version 1, origin the box's lower corner, max_value = config().max_distance_m. An empty ESDF
/// gives sizes 0 and no values.
mlmap_msgs::VoxelBlock_ toVoxelBlock(const EsdfMap& esdf, double stamp_s,
                                     const std::string& frame_id);

/// A horizontal slice of the ESDF at height z_m as a PointCloud2 of the voxel centres with an
/// `intensity` field holding the distance [m]; unknown voxels are left out. The slice is the z
/// layer of the voxel containing z_m (see voxelIndexOf()); an empty cloud when z_m is outside the
/// box or the ESDF is empty.
sensor_msgs::PointCloud2_ esdfSliceCloud(const EsdfMap& esdf, double z_m, double stamp_s,
                                         const std::string& frame_id);

}  // namespace mlmap::dds
