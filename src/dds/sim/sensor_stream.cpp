#include "mlmap/dds/sim/sensor_stream.h"

#include "mlmap/core/stopwatch.h"
#include "mlmap/dds/transport/cloud_writer.h"
#include "mlmap/dds/transport/entities.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>

#include <algorithm>
#include <chrono>
#include <thread>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
using Clock = SteadyClock;

/// The sensor writer: images, or clouds (with data-sharing unless dds.data_sharing is false).
void createSensorWriter(const DdsConfig& dds, const SensorFeed& source, fdds::Publisher* publisher,
                        const fdds::DataWriterQos& qos, SensorWriters* w) {
  if (source.depth_mode) {
    w->sensor = createWriter<sensor_msgs::Image_PubSubType>(publisher, w->sensor_topic, qos);
  } else if (dds.data_sharing) {
    // Every cloud has the size of the first (one camera): the writer's slots get that size.
    PreparedFrame first = source.prepare(0);
    sensor_msgs::PointCloud2_PubSubType plain;
    w->cloud_bytes = plain.getSerializedSizeProvider(&*first.cloud)();
    w->sensor = createDataSharingCloudWriter(publisher, w->sensor_topic, qos, w->cloud_bytes);
  } else {
    w->sensor = createWriter<sensor_msgs::PointCloud2_PubSubType>(publisher, w->sensor_topic, qos);
  }
}

/// What a robot publishes on TF besides mlmap_node, as the node's configuration expects it: the
/// pose's TF when the node publishes none or only map -> odom (rt/tf, absolute), and the sensor's
/// mounting on rt/tf_static when the node reads it from there (as robot_state_publisher or a
/// camera driver would, latched).
void createRobotTf(const DdsConfig& dds, const Transform& T_B_S, fdds::Publisher* publisher,
                   SensorWriters* w) {
  using TfType = ::tf2_msgs::msg::dds_::TFMessage_PubSubType;
  if (resolveTfMode(dds) != TfMode::kWorldBody) {
    w->tf = createWriter<TfType>(publisher, ddsTopicName("", "tf"), reliableWriterQos(100));
  }
  if (resolveExtrinsicSource(dds) == ExtrinsicSource::kTfStatic) {
    w->tf_static =
        createWriter<TfType>(publisher, ddsTopicName("", "tf_static"), latchedWriterQos());
    const FrameNames frames = resolveFrames(dds);
    ::tf2_msgs::msg::dds_::TFMessage_ mounting;
    mounting.transforms_().push_back(toTransformStamped(T_B_S, 0.0, frames.body, frames.sensor));
    w->tf_static->write(&mounting);
  }
}

/// Joins the DDS graph and creates the writers. `T_B_S`: the sensor's mounting (sensor.*).
}  // namespace

SensorWriters createSensorWriters(const DdsConfig& dds, const SensorFeed& source,
                                  const Transform& T_B_S) {
  SensorWriters w;
  w.participant = createParticipant(dds, "mlmap_sensor_publisher");
  fdds::Publisher* publisher = w.participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  const TopicNames& topics = dds.topics;
  // Sensor drivers and odometry publish best-effort (ROS 2 sensor data QoS; PX4 does too), and
  // mlmap_node reads best-effort: that is what its readers get from this writer. The writer
  // offers RELIABLE (KEEP_LAST 5, so it never blocks) because Fast DDS 2.9.1's best-effort
  // writers do not drop a same-host reader's UDP locator when shared memory reaches it
  // (eProsima/Fast-DDS#3655, fixed after 2.9.1; Jazzy's 2.14 has the fix): every 4.9 MB cloud
  // crossed loopback UDP too, which doubled its transport cost in the latency benchmark.
  const fdds::DataWriterQos qos = reliableWriterQos(5);
  w.sensor_topic = ddsTopicName(dds.ns, source.depth_mode ? topics.depth_image : topics.cloud);
  createSensorWriter(dds, source, publisher, qos, &w);
  if (source.depth_mode) {
    w.info = createWriter<sensor_msgs::CameraInfo_PubSubType>(
        publisher, ddsTopicName(dds.ns, topics.camera_info), qos);
  }
  if (!topics.pose.empty()) {
    w.pose = createWriter<geometry_msgs::PoseStamped_PubSubType>(
        publisher, ddsTopicName(dds.ns, topics.pose), qos);
  }
  if (!topics.odometry.empty()) {
    w.odometry = createWriter<nav_msgs::Odometry_PubSubType>(
        publisher, ddsTopicName(dds.ns, topics.odometry), qos);
  }
  createRobotTf(dds, T_B_S, publisher, &w);
  return w;
}

namespace {

/// Waits until every writer has a matched reader (false: timed out or stopped).
bool waitForReaders(const std::vector<fdds::DataWriter*>& writers, double timeout_s,
                    const std::function<bool()>& stop) {
  const auto start = Clock::now();
  for (;;) {
    bool all = true;
    for (fdds::DataWriter* w : writers) {
      fdds::PublicationMatchedStatus matched;
      w->get_publication_matched_status(matched);
      all = all && matched.current_count > 0;
    }
    if (all) return true;
    if (stop() || secondsBetween(start, Clock::now()) >= timeout_s) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

}  // namespace

/// Waits for the mapping node (matching is asynchronous; frames sent before it are lost) and
/// returns the number of subscribers of the sensor topic. A writer can see its match before the
/// reader has matched it: a short grace period after.
int waitForSubscribers(const SensorWriters& w, double wait_s, const std::function<bool()>& stop,
                       bool* all_matched) {
  std::vector<fdds::DataWriter*> writers = {w.sensor, w.pose != nullptr ? w.pose : w.odometry};
  if (w.info != nullptr) writers.push_back(w.info);
  if (w.tf_static != nullptr) writers.push_back(w.tf_static);  // the node needs it for every frame
  const bool matched = waitForReaders(writers, wait_s, stop);
  if (matched) std::this_thread::sleep_for(std::chrono::milliseconds(250));
  fdds::PublicationMatchedStatus sensor_matched;
  w.sensor->get_publication_matched_status(sensor_matched);
  if (all_matched != nullptr) *all_matched = matched;
  return sensor_matched.current_count;
}

namespace {

/// Sends frames in real time: frame i is captured at start + i / rate, with the wall-clock stamp
/// wall0 + i / rate. The simulator's flight time t maps to the stamp wall0 + t / speed (poses as
/// well as frames).
class Streamer {
 public:
  Streamer(const SensorFeed& source, const SensorWriters& writers, const DdsConfig& dds,
           double pose_rate_hz)
      : source_(source),
        writers_(writers),
        frames_(resolveFrames(dds)),
        tf_parent_(resolveTfMode(dds) == TfMode::kMapOdom ? frames_.odom : frames_.world),
        pose_period_s_(1.0 / pose_rate_hz),
        start_(Clock::now()),
        wall0_s_(wallClockNow_s()) {}

  /// Sends frame `i` at its capture time, with the poses up to it.
  void send(int i, PreparedFrame frame) {
    const auto due = start_ + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(i / source_.rate_hz));
    std::this_thread::sleep_until(due);
    const double late_ms = msSince(due);
    stats_.max_late_ms = std::max(stats_.max_late_ms, late_ms);
    stats_.late += late_ms > kLate_ms ? 1 : 0;
    const double stamp_s = wall0_s_ + i / source_.rate_hz;
    publishPosesFor(frame, stamp_s);
    frame.setStamp(stamp_s);
    if (write(frame)) {
      ++stats_.sent;
    } else if (stats_.failed++ == 0) {
      stats_.first_failed_frame = i;
    }
  }
  [[nodiscard]] const StreamStats& stats() const { return stats_; }

 private:
  /// T_W_B as a PoseStamped or an Odometry (child: the body frame), and the robot's TF of it.
  void publishPose(const Transform& T_W_B, double stamp_s) {
    geometry_msgs::PoseStamped_ pose = toPoseStamped(T_W_B, stamp_s, frames_.world);
    if (writers_.pose != nullptr) writers_.pose->write(&pose);
    if (writers_.odometry != nullptr) {
      nav_msgs::Odometry_ odometry;
      odometry.header_(pose.header_());
      odometry.child_frame_id_(frames_.body);
      odometry.pose_().pose_(pose.pose_());
      writers_.odometry->write(&odometry);
    }
    if (writers_.tf != nullptr) {  // an odometry that equals the pose (map_odom: map -> odom = I)
      ::tf2_msgs::msg::dds_::TFMessage_ tf;
      tf.transforms_().push_back(toTransformStamped(T_W_B, stamp_s, tf_parent_, frames_.body));
      writers_.tf->write(&tf);
    }
  }
  void publishPosesFor(const PreparedFrame& frame, double stamp_s) {
    if (source_.simulator == nullptr) {
      publishPose(frame.T_W_B, stamp_s);  // the recording has one pose per frame
      return;
    }
    // Odometry runs ahead of the camera by up to one pose period, as a fast IMU-based
    // estimator does, so each frame finds poses on both sides of its stamp.
    for (; static_cast<double>(pose_k_) * pose_period_s_ <= frame.flight_s + pose_period_s_ + 1e-9;
         ++pose_k_) {
      const double pose_t_s = static_cast<double>(pose_k_) * pose_period_s_;
      publishPose(source_.simulator->scenario().trajectory.poseAt(pose_t_s),
                  wall0_s_ + pose_t_s / source_.speed);
    }
  }
  bool write(PreparedFrame& frame) {
    if (source_.depth_mode) {
      const bool info_written = writers_.info->write(&*frame.info);
      return writers_.sensor->write(&*frame.image) && info_written;
    }
    return writers_.sensor->write(&*frame.cloud);
  }

  const SensorFeed& source_;
  const SensorWriters& writers_;
  FrameNames frames_;
  std::string tf_parent_;  ///< parent of the robot's TF of the pose: world, or odom in map_odom
  double pose_period_s_;
  Clock::time_point start_;
  double wall0_s_;
  long pose_k_ = 0;
  StreamStats stats_;
};

}  // namespace

/// Publishes every frame (prerendered ones if given) until done or stopped.
StreamStats stream(const SensorFeed& source, const SensorWriters& writers, const DdsConfig& dds,
                   double pose_rate_hz, std::vector<PreparedFrame>* prerendered,
                   const std::function<bool()>& stop,
                   const std::function<void(int sent, int total)>& progress) {
  Streamer streamer(source, writers, dds, pose_rate_hz);
  const int frames = source.frames;
  for (int i = 0; i < frames && !stop(); ++i) {
    streamer.send(i, prerendered != nullptr ? std::move((*prerendered)[static_cast<std::size_t>(i)])
                                            : source.prepare(i));
    if (progress && frames >= 10 && (i + 1) % (frames / 10) == 0) progress(i + 1, frames);
  }
  return streamer.stats();
}

}  // namespace mlmap::dds
