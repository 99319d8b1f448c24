#pragma once
/// @file
/// A ROS 2 bag as a FrameSource: point-cloud frames from PointCloud2 topics, or depth frames from
/// a depth Image (16UC1 in millimetres, 32FC1 in metres) with its CameraInfo; the body pose
/// T_W_B from a PoseStamped or Odometry topic, or from /tf (world_frame -> body_frame, through
/// the frames between them: /tf and /tf_static edges, e.g. map -> odom -> base_link; the poses
/// are at the stamps of the lowest /tf edge, the other edges interpolated there and their
/// nearest transform held outside their range); the sensor extrinsic T_B_S from /tf_static,
/// between body_frame and each message's frame_id.
///
/// Pairing is CloudSequence's (mlmap/datasets/cloud_sequence.h) on the messages' header stamps:
/// a pose with the frame's stamp (within 1 us), or mlmap's PoseBuffer interpolation between the
/// two poses around it when the nearer is at most pose_tolerance_s away; never extrapolated. A
/// frame without such a pose is skipped and counted.
///
/// Opening reads the poses, /tf_static and the header of every input message once (one pass
/// over their chunks); the frames keep only where their message is, and read() decodes it. The
/// memory held is a few dozen bytes per frame and per pose, whatever the size of the bag.

#include "mlmap/bag/bag_reader.h"
#include "mlmap/bag/tf_tree.h"
#include "mlmap/core/types.h"
#include "mlmap/datasets/frame_source.h"

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace mlmap::bag {

/// Which topics give the frames and the pose.
struct BagInputs {
  std::vector<std::string> cloud_topics;  ///< PointCloud2 topics (or none)
  std::string depth_topic;                ///< a depth Image topic (or empty)
  std::string camera_info_topic;          ///< the CameraInfo of depth_topic
  std::string pose_topic;                 ///< PoseStamped or Odometry giving T_W_B (or empty)
  bool pose_from_tf = false;              ///< T_W_B from /tf: world_frame -> body_frame
};

/// Settings of a BagFrameSource.
struct BagFrameSourceOptions {
  BagInputs inputs;
  std::string world_frame;               ///< /tf poses: the world (fixed) frame, e.g. "map"
  std::string body_frame = "base_link";  ///< the body B: /tf child, /tf_static parent of sensors
  /// Extrinsic of every input's sensor frame; unset: from /tf_static (identity when the
  /// message's frame_id is body_frame).
  std::optional<Transform> T_B_S;
  double pose_tolerance_s = 0.05;  ///< a frame needs a pose at most this far from its stamp, > 0
};

/// The inputs of `bag`: those named in `requested` are checked (they exist, their types fit),
/// the others chosen when the bag leaves no doubt: the only PointCloud2 topic or the only depth
/// Image (16UC1 / 32FC1 / mono16, by its first message) when there is not one of each; the
/// CameraInfo beside the depth image (same namespace) or the only one; the only PoseStamped /
/// Odometry topic, else /tf when the bag has it and world_frame is given.
/// @throws std::runtime_error listing the bag's topics with their types and counts and saying
///         which option to set (cloud_topics, depth_topic, camera_info_topic, pose_topic,
///         world_frame) when the choice is ambiguous or impossible.
[[nodiscard]] BagInputs autoSelect(const BagReader& bag, const BagInputs& requested,
                                   const std::string& world_frame);

/// The frames of a bag (see the file comment).
class BagFrameSource : public datasets::FrameSource {
 public:
  /// Opens `bag` with `options` (inputs completed by autoSelect()), reads the poses and the
  /// extrinsics, and indexes and pairs the frames. @throws std::runtime_error naming the bag, the
  /// topic and the message when something cannot be read or no frame gets a pose;
  /// std::invalid_argument on bad options.
  BagFrameSource(std::shared_ptr<const BagReader> bag, const BagFrameSourceOptions& options);

  [[nodiscard]] std::size_t size() const override { return frames_.size(); }
  [[nodiscard]] datasets::SourceFrame read(
      std::size_t i, datasets::SourceFrameInfo* info = nullptr) const override;
  [[nodiscard]] std::string describe() const override;

  /// The inputs used (after autoSelect()).
  [[nodiscard]] const BagInputs& inputs() const { return inputs_; }
  /// Input messages skipped for want of a pose.
  [[nodiscard]] std::size_t unpairedCount() const { return unpaired_; }
  /// Poses read.
  [[nodiscard]] std::size_t poseCount() const { return pose_count_; }
  /// What was wrong but did not stop the reading (the bag's own warnings included).
  [[nodiscard]] const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  /// A frame: where its message is, its stamp and pose.
  struct FrameRef {
    std::size_t entry = 0;       ///< the input message in bag entries()
    std::size_t info_entry = 0;  ///< depth: its CameraInfo message in bag entries()
    double stamp_s = 0.0;        ///< header stamp
    Transform T_W_B = Transform::Identity();
    std::size_t extrinsic = 0;  ///< index into extrinsics_
  };
  /// What one pass over the bag found.
  struct Scan {
    /// An input message.
    struct Input {
      std::size_t entry = 0;     ///< in bag entries()
      double stamp_s = 0.0;      ///< header stamp
      std::size_t frame_id = 0;  ///< index into frame_ids
    };
    std::vector<StampedTransform> poses;                ///< by stamp
    std::vector<std::pair<double, std::size_t>> infos;  ///< CameraInfo stamp, entry; by stamp
    std::vector<Input> inputs;                          ///< in log-time order
    std::vector<std::string> frame_ids;                 ///< of the inputs
  };
  /// Reads the poses, /tf_static, the CameraInfo stamps and the inputs' headers in one pass.
  Scan scanBag();
  /// Adds the /tf_static transforms of one message to tf_.
  void addStaticTransforms(const std::vector<std::uint8_t>& bytes, const std::string& what);
  /// Adds the T_W_B of one pose (or /tf) message to `poses`.
  void addPoses(const std::vector<std::uint8_t>& bytes, const std::string& what, bool odometry,
                std::vector<StampedTransform>* poses) const;
  /// Adds the transforms of one /tf message to tf_.
  void addTf(const std::vector<std::uint8_t>& bytes, const std::string& what);
  /// Index into extrinsics_ of T_B_S for a sensor frame (found through /tf_static once).
  std::size_t extrinsicFor(const std::string& frame_id);
  /// Pairs the inputs with poses into frames_.
  void indexFrames();

  std::shared_ptr<const BagReader> bag_;
  BagFrameSourceOptions options_;
  BagInputs inputs_;
  TfTree tf_;  ///< /tf (when the poses come from it) and /tf_static
  std::vector<std::pair<std::string, Transform>> extrinsics_;  ///< frame_id -> T_B_S
  std::vector<FrameRef> frames_;
  std::size_t unpaired_ = 0;
  std::size_t pose_count_ = 0;
  std::vector<std::string> warnings_;
};

}  // namespace mlmap::bag
