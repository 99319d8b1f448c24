#pragma once
/// @file
/// mlmap_sensor_publisher's stream: frames of a datasets::FrameSource (the simulator flying a
/// scenario, or recorded RGB-D frames) sent in real time as a depth camera driver and an odometry
/// send them (an organised PointCloud2, or a depth Image with its CameraInfo; the pose as
/// PoseStamped or Odometry; the robot's TF as the node's configuration expects it), stamped with
/// the wall clock at capture. The program parses options and logs; this is what it does.

#include "mlmap/datasets/frame_source.h"
#include "mlmap/dds/sim/sensor_messages.h"
#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/dds/transport/participant.h"

#include <fastdds/dds/publisher/DataWriter.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace mlmap::dds {

/// One frame ready to send: its sensor message(s), stamped at send time (setStamp()).
struct PreparedFrame {
  double flight_s = 0.0;                    ///< simulator time the frame shows (replay: unused)
  Transform T_W_B = Transform::Identity();  ///< body pose of a replayed frame
  std::optional<sensor_msgs::PointCloud2_> cloud;  ///< cloud mode
  std::optional<sensor_msgs::Image_> image;        ///< depth mode, with `info`
  std::optional<sensor_msgs::CameraInfo_> info;

  /// Stamps every message of the frame with `stamp_s` [s since the epoch].
  void setStamp(double stamp_s) {
    const auto stamp = toRosTime(stamp_s);
    if (cloud) cloud->header_().stamp_(stamp);
    if (image) image->header_().stamp_(stamp);
    if (info) info->header_().stamp_(stamp);
  }
  /// The size of the frame's payload [bytes].
  [[nodiscard]] std::size_t bytes() const {
    return (cloud ? cloud->data_().size() : 0) + (image ? image->data_().size() : 0);
  }
};

/// Where the frames come from (an datasets::FrameSource: the simulator flying a scenario, or a
/// folder of recorded frames) and how they go out.
struct SensorFeed {
  std::unique_ptr<datasets::FrameSource> frames_in;  ///< the frames
  const datasets::SimulatedFlightSource* simulator =
      nullptr;               ///< frames_in when it is the simulator
  double rate_hz = 0.0;      ///< frames per second
  double speed = 1.0;        ///< flight seconds per wall-clock second
  int frames = 0;            ///< frames to publish
  bool depth_mode = false;   ///< depth images instead of clouds
  std::string sensor_frame;  ///< frame_id of the sensor messages

  /// Frame i, encoded (stamps are set when it is sent).
  [[nodiscard]] PreparedFrame prepare(int i) const {
    PreparedFrame prepared;
    const DepthFrame frame = std::get<DepthFrame>(frames_in->read(static_cast<std::size_t>(i)));
    prepared.T_W_B = frame.T_W_B;
    if (simulator != nullptr) prepared.flight_s = simulator->frameTime(static_cast<std::size_t>(i));
    if (depth_mode) {
      prepared.info = cameraInfo(frame.intrinsics, 0.0, sensor_frame);
      prepared.image = depthImage(frame, 0.0, sensor_frame);
    } else {
      prepared.cloud = organisedCloud(frame, 0.0, sensor_frame);
    }
    return prepared;
  }
};

/// The writers of the sensor (cloud, or image + camera info) and pose topics, and the robot's
/// own TF.
struct SensorWriters {
  ParticipantPtr participant;
  eprosima::fastdds::dds::DataWriter* sensor = nullptr;
  eprosima::fastdds::dds::DataWriter* info = nullptr;  ///< depth mode only
  eprosima::fastdds::dds::DataWriter* pose = nullptr;  ///< PoseStamped, when dds.topics.pose is set
  eprosima::fastdds::dds::DataWriter* odometry =
      nullptr;  ///< Odometry, when dds.topics.odometry is set
  /// rt/tf, when the node leaves the pose's TF to the robot (tf_mode none: world -> body, as an
  /// odometry owning its TF; map_odom: odom -> body, an odometry that equals the pose).
  eprosima::fastdds::dds::DataWriter* tf = nullptr;
  /// rt/tf_static with the sensor's mounting, when the node reads it from there.
  eprosima::fastdds::dds::DataWriter* tf_static = nullptr;
  std::uint32_t cloud_bytes = 0;  ///< every cloud's serialised size, with data-sharing
  std::string sensor_topic;       ///< the sensor's DDS topic name
};

/// Joins the DDS graph (participant "mlmap_sensor_publisher") and creates the writers of `source`
/// on the topics of `dds` (sensor, camera info, pose / odometry, the robot's TF). `T_B_S`: the
/// sensor's mounting (sensor.*). Throws std::runtime_error when an entity cannot be created.
SensorWriters createSensorWriters(const DdsConfig& dds, const SensorFeed& source,
                                  const Transform& T_B_S);

/// Waits up to `wait_s` for the mapping node (matching is asynchronous; frames sent before it are
/// lost) or until `stop` says so, and returns the number of subscribers of the sensor topic;
/// `all_matched` (optional) says whether every topic found one. A writer can see its match
/// before the reader has matched it: a short grace period after.
int waitForSubscribers(const SensorWriters& w, double wait_s, const std::function<bool()>& stop,
                       bool* all_matched = nullptr);

/// What the stream did.
struct StreamStats {
  int sent = 0;                 ///< frames written
  int late = 0;                 ///< frames sent more than kLate_ms after their capture time
  int failed = 0;               ///< frames whose write failed
  double max_late_ms = 0.0;     ///< the latest a frame left after its capture time [ms]
  int first_failed_frame = -1;  ///< index of the first frame whose write failed (-1: none)
};

/// A frame sent later than this after its capture time counts as late [ms].
constexpr double kLate_ms = 5.0;

/// Publishes every frame of `source` (the prerendered ones when given) in real time until done
/// or `stop` says so: frame i is captured at start + i / rate, stamped wall0 + i / rate; the
/// simulator's flight time t maps to the stamp wall0 + t / speed (poses as well as frames).
/// `progress` (optional) hears every tenth of the frames sent.
StreamStats stream(const SensorFeed& source, const SensorWriters& writers, const DdsConfig& dds,
                   double pose_rate_hz, std::vector<PreparedFrame>* prerendered,
                   const std::function<bool()>& stop,
                   const std::function<void(int sent, int total)>& progress = {});

}  // namespace mlmap::dds
