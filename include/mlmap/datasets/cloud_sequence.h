#pragma once
/// @file
/// A sequence of point-cloud files (`.pcd` / `.ply` in one directory) paired with a trajectory
/// file (mlmap/datasets/pose_file.h), as frames for the engine.
///
/// Pairing rule:
/// - **By time**, when every cloud's file name (without extension) is a time stamp: a number
///   with a fractional part in seconds (`1305031102.175304.pcd`), or an integer of 19-20
///   digits in nanoseconds (`1305031102175304000.pcd`, as ROS bag exporters write) or of 16-17
///   digits in microseconds (`1305031102175304.pcd`). Each cloud
///   gets the pose at its stamp, exactly as `mlmap_node` pairs clouds with poses
///   (mlmap/core/pose_buffer.h): a pose with the same stamp (within 1 us), or the
///   interpolation (linear translation, slerp) between the two poses around it when the nearer
///   one is at most `pose_tolerance_s` away. Never extrapolated. A cloud with no such pose is
///   skipped and listed in unpaired(). Two clouds with the same stamp are an error.
/// - **By order** otherwise (`000015.pcd`, `scan_7.ply`, ...): the clouds, sorted by name with
///   numbers compared as numbers (`scan_2` before `scan_10`), get the poses in file order; the
///   two counts must be equal. Each frame's stamp is its pose's stamp.
///
/// Frames: the trajectory gives T_W_P, the pose of frame P in the world; the extrinsic T_P_C is
/// the cloud frame C in P (identity when the poses are the sensor's, as in TUM RGB-D; a LiDAR's
/// mounting when they are the vehicle's). A PCD VIEWPOINT T_C_V (the sensor in C) is honoured:
/// the frame's points are T_V_C * p_C and its sensor pose T_W_P * T_P_C * T_C_V, so the rays
/// start at the viewpoint. The frame handed to the engine has T_W_B = T_W_P and
/// T_B_S = T_P_C * T_C_V.

#include "mlmap/core/types.h"
#include "mlmap/datasets/point_cloud_file.h"
#include "mlmap/datasets/pose_file.h"

#include <optional>
#include <string>
#include <vector>

namespace mlmap::datasets {

/// Default of CloudSequenceOptions::pose_tolerance_s (the same as mlmap_node's default).
inline constexpr double kCloudPoseTolerance_s = 0.05;

/// How the clouds of a sequence were paired with poses.
enum class CloudPairing { kByTime, kByOrder };
const char* toString(CloudPairing pairing);

/// Settings of a CloudSequence.
struct CloudSequenceOptions {
  Transform T_P_C = Transform::Identity();          ///< extrinsic: cloud frame C in pose frame P
  double pose_tolerance_s = kCloudPoseTolerance_s;  ///< by time: farthest pose used, > 0
};

/// One cloud with its pose.
struct PairedCloud {
  std::string file_name;  ///< name inside the directory
  double stamp_s = 0.0;   ///< time stamp (file name by time; the pose's by order)
  Transform T_W_P = Transform::Identity();
};

/// The time stamp in a cloud's file name (see the file comment), or nothing.
[[nodiscard]] std::optional<double> stampFromFileName(const std::string& file_name);

/// True when `a` sorts before `b` with embedded numbers compared as numbers.
[[nodiscard]] bool naturalLess(const std::string& a, const std::string& b);

/// Pairs cloud file names with poses by the rule of the file comment. `pairing` receives the
/// rule used; `unpaired` (optional) the names of clouds skipped for want of a pose.
/// @throws std::runtime_error when there are no clouds, the counts differ (by order), two
///         clouds share a stamp, or no cloud got a pose.
[[nodiscard]] std::vector<PairedCloud> pairCloudsWithPoses(std::vector<std::string> file_names,
                                                           const std::vector<StampedPose>& poses,
                                                           double pose_tolerance_s,
                                                           CloudPairing* pairing,
                                                           std::vector<std::string>* unpaired);

/// A directory of point clouds with a trajectory file.
class CloudSequence {
 public:
  /// Lists `clouds_dir`'s `.pcd` / `.ply` files, reads the trajectory and pairs them.
  /// @throws std::runtime_error naming the directory or file on any problem (none found, a
  ///         malformed trajectory, a pairing failure), std::invalid_argument on bad options.
  CloudSequence(const std::string& clouds_dir, const std::string& poses_path,
                const CloudSequenceOptions& options = {});

  /// Clouds that have a pose (the ones read() serves), in order.
  [[nodiscard]] std::size_t size() const { return clouds_.size(); }
  /// How the clouds were paired with the poses.
  [[nodiscard]] CloudPairing pairing() const { return pairing_; }
  [[nodiscard]] const std::vector<PairedCloud>& clouds() const { return clouds_; }
  /// Clouds skipped for want of a pose (by time only).
  [[nodiscard]] const std::vector<std::string>& unpaired() const { return unpaired_; }
  /// Poses in the trajectory file.
  [[nodiscard]] std::size_t poseCount() const { return pose_count_; }

  /// Reads cloud `i` as an engine frame (see the file comment for its frames). `file`
  /// (optional) receives what the reader found (counts, encoding; its points are moved out).
  /// @throws std::out_of_range for a bad index, std::runtime_error for a malformed file.
  [[nodiscard]] PointCloudFrame read(std::size_t i, PointCloudFile* file = nullptr) const;

 private:
  std::string dir_;
  CloudSequenceOptions options_;
  CloudPairing pairing_ = CloudPairing::kByOrder;
  std::vector<PairedCloud> clouds_;
  std::vector<std::string> unpaired_;
  std::size_t pose_count_ = 0;
};

}  // namespace mlmap::datasets
