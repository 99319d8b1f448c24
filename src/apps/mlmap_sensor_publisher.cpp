// mlmap_sensor_publisher: plays a sensor driver and an odometry source over DDS. Flies the
// simulator through a scenario (or replays a folder of RGB-D frames) and publishes, in real time,
// sensor_msgs/PointCloud2 (or a depth Image + CameraInfo) and geometry_msgs/PoseStamped on the
// topics of the node configuration.
//
// Stamps are wall-clock capture times, as a real driver's: frame i is captured at start + i / rate
// (system clock) and sent at that instant, so receive time - stamp is the end-to-end latency
// (tools/bench_dds_latency.sh). --speed maps flight time onto those stamps (flight time = speed
// x wall time), poses included, so faster flights stay consistent. --prerender renders and
// encodes every frame before streaming, so a slow simulator cannot delay the frames.
//
// --closed-loop flies the simulated vehicle through a planner's setpoints instead, in a world of
// nav_worlds (mlmap_dds_sim's flyClosedLoop(); docs/planners.md, "Over DDS").
//
// Clouds are offered with data-sharing unless dds.data_sharing is false: a same-host mlmap_node
// then reads them in this process's shared memory (see createDataSharingCloudWriter()). Exit
// status 1 when a frame could not be written.

#include "mlmap/apps/stop_signal.h"
#include "mlmap/core/stopwatch.h"
#include "mlmap/dds/wire/cloud_sample.h"
#include "mlmap/dds/transport/cloud_writer.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/node_config.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/datasets/frame_source.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/pipeline/engine_stats.h"
#include "mlmap/dds/sim/closed_loop_vehicle.h"
#include "mlmap/dds/sim/sensor_messages.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include "security_options.h"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

namespace {

using namespace mlmap;
namespace fdds = eprosima::fastdds::dds;
using Clock = SteadyClock;

/// The command line of mlmap_sensor_publisher.
struct Options {
  std::string config_path;         ///< -c, --config: node configuration (empty: defaults)
  std::string scenario_path;       ///< --scenario (empty: the built-in room)
  std::string frames_dir;          ///< --frames-dir: replay these RGB-D frames instead
  std::string mode = "cloud";      ///< --mode: cloud (PointCloud2) or depth (Image + CameraInfo)
  double rate_hz = 0.0;            ///< --rate (0: the scenario's, or 30 for a replay)
  double pose_rate_hz = 50.0;      ///< --pose-rate: poses per second of flight (simulator)
  double wait_s = 10.0;            ///< --wait-for-subscriber [s]
  double speed = 1.0;              ///< --speed: flight seconds per wall-clock second (simulator)
  int max_frames = 0;              ///< --max-frames (0: all)
  bool prerender = false;          ///< --prerender: render and encode every frame first
  apps::SecurityOptions security;  ///< --keystore, --enclave, --security-strategy
  /// --closed-loop: fly a planner's setpoints in this world (forest, rooms, paper; "": stream)
  std::string closed_loop;
  unsigned world_seed = 21;                       ///< --world-seed
  double forest_density = 0.08;                   ///< --forest-density [trees / m^2]
  std::vector<double> forest_size_m{14.0, 8.0};   ///< --forest-size [m]
  double timeout_s = 60.0;                        ///< --timeout: closed-loop flight time limit [s]
  std::string setpoint_topic = "mlmap/setpoint";  ///< --setpoint-topic
  std::string goal_topic = "goal_pose";           ///< --goal-topic ("": none)
};

/// Adds every option of mlmap_sensor_publisher to `app`.
void addOptions(CLI::App& app, Options& o) {
  app.add_option("-c,--config", o.config_path,
                 "node configuration (its dds section and sensor mounting)")
      ->check(CLI::ExistingFile);
  app.add_option("--scenario", o.scenario_path, "scenario YAML (default: the built-in room)")
      ->check(CLI::ExistingFile);
  app.add_option("--frames-dir", o.frames_dir,
                 "replay a folder of RGB-D frames instead (see docs/replay.md)")
      ->check(CLI::ExistingDirectory);
  app.add_option("--mode", o.mode,
                 "what the sensor publishes: cloud (PointCloud2) or depth (Image)")
      ->check(CLI::IsMember({"cloud", "depth"}));
  app.add_option("--rate", o.rate_hz,
                 "frames per second (default: the scenario's; 30 for a replay)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--speed", o.speed,
                 "flight seconds per wall-clock second (simulator only): > 1 flies farther in the "
                 "same number of frames (stamps stay wall-clock times)")
      ->check(CLI::PositiveNumber);
  app.add_option("--pose-rate", o.pose_rate_hz, "poses per second of flight (simulator only)")
      ->check(CLI::PositiveNumber);
  app.add_option("--max-frames", o.max_frames, "stop after this many frames (0: all)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--wait-for-subscriber", o.wait_s,
                 "seconds to wait for subscribers of the sensor and pose topics before starting")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--prerender", o.prerender,
               "render and encode every frame before streaming (benchmarks: the simulator cannot "
               "hold the rate; memory = frames x message size, 4.8 MB per 640x480 cloud)");
  o.security.add(app);
  app.add_option("--closed-loop", o.closed_loop,
                 "fly the simulated vehicle through a planner's setpoints in this world of "
                 "nav_worlds (forest, rooms or paper) instead of streaming a scenario")
      ->check(CLI::IsMember({"forest", "rooms", "paper"}));
  app.add_option("--world-seed", o.world_seed, "seed of the --closed-loop world");
  app.add_option("--forest-density", o.forest_density, "trees per m^2 of a forest world")
      ->check(CLI::PositiveNumber);
  app.add_option("--forest-size", o.forest_size_m, "x and y extent of a forest world [m]")
      ->expected(2);
  app.add_option("--timeout", o.timeout_s, "closed loop: seconds to reach the goal")
      ->check(CLI::PositiveNumber);
  app.add_option("--setpoint-topic", o.setpoint_topic, "closed loop: the planner's setpoints");
  app.add_option("--goal-topic", o.goal_topic,
                 "closed loop: where the world's goal is published once a second (\"\": not)");
}

/// One frame ready to send: its sensor message(s), stamped at send time (setStamp()).
struct PreparedFrame {
  double flight_s = 0.0;                    ///< simulator time the frame shows (replay: unused)
  Transform T_W_B = Transform::Identity();  ///< body pose of a replayed frame
  std::optional<mlmap::dds::sensor_msgs::PointCloud2_> cloud;  ///< cloud mode
  std::optional<mlmap::dds::sensor_msgs::Image_> image;        ///< depth mode, with `info`
  std::optional<mlmap::dds::sensor_msgs::CameraInfo_> info;

  /// Stamps every message of the frame with `stamp_s` [s since the epoch].
  void setStamp(double stamp_s) {
    const auto stamp = mlmap::dds::toRosTime(stamp_s);
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
      prepared.info = mlmap::dds::cameraInfo(frame.intrinsics, 0.0, sensor_frame);
      prepared.image = mlmap::dds::depthImage(frame, 0.0, sensor_frame);
    } else {
      prepared.cloud = mlmap::dds::organisedCloud(frame, 0.0, sensor_frame);
    }
    return prepared;
  }
};

/// Throws when the configuration disables a topic the mode needs.
void checkTopics(const Options& o, const mlmap::dds::TopicNames& topics) {
  const bool depth_mode = o.mode == "depth";
  const std::string& sensor_topic = depth_mode ? topics.depth_image : topics.cloud;
  const bool no_pose = topics.pose.empty() && topics.odometry.empty();
  if (sensor_topic.empty() || no_pose || (depth_mode && topics.camera_info.empty())) {
    throw std::runtime_error("the configuration disables the " + o.mode +
                             " or pose topic (dds.topics.pose and dds.topics.odometry)");
  }
}

/// Opens the frame source the options name, with its rate and number of frames.
SensorFeed openSource(const Options& o, const mlmap::dds::NodeConfig& config) {
  SensorFeed source;
  const Transform T_B_S = config.map.sensor.T_B_S();
  if (!o.frames_dir.empty()) {
    source.frames_in = std::make_unique<datasets::FrameDirectorySource>(o.frames_dir);
    source.rate_hz = o.rate_hz > 0 ? o.rate_hz : datasets::kFrameDirectoryRate_hz;
    if (!T_B_S.isApprox(Transform::Identity())) {
      spdlog::warn(
          "replayed frames are camera poses (T_B_S = identity) but the configuration mounts "
          "the sensor elsewhere: give mlmap_node a config with sensor translation 0 and "
          "rotation 0 (config/mlmap_node_replay.yaml)");
    }
  } else {
    datasets::Scenario scenario = o.scenario_path.empty()
                                      ? datasets::defaultScenario()
                                      : datasets::loadScenarioYaml(o.scenario_path);
    datasets::SimulatedTiming timing;
    timing.rate_hz = o.rate_hz > 0 ? o.rate_hz : scenario.frame_rate_hz;
    timing.speed = o.speed;
    auto simulator =
        std::make_unique<datasets::SimulatedFlightSource>(std::move(scenario), T_B_S, timing);
    source.simulator = simulator.get();
    source.rate_hz = timing.rate_hz;
    source.frames_in = std::move(simulator);
  }
  checkTopics(o, config.dds.topics);
  const int available = static_cast<int>(source.frames_in->size());
  source.frames = o.max_frames > 0 ? std::min(o.max_frames, available) : available;
  source.speed = o.speed;
  source.depth_mode = o.mode == "depth";
  source.sensor_frame = mlmap::dds::resolveFrames(config.dds).sensor;
  return source;
}

/// The writers of the sensor (cloud, or image + camera info) and pose topics, and the robot's
/// own TF.
struct Writers {
  mlmap::dds::ParticipantPtr participant;
  fdds::DataWriter* sensor = nullptr;
  fdds::DataWriter* info = nullptr;      ///< depth mode only
  fdds::DataWriter* pose = nullptr;      ///< PoseStamped, when dds.topics.pose is set
  fdds::DataWriter* odometry = nullptr;  ///< Odometry, when dds.topics.odometry is set
  /// rt/tf, when the node leaves the pose's TF to the robot (tf_mode none: world -> body, as an
  /// odometry owning its TF; map_odom: odom -> body, an odometry that equals the pose).
  fdds::DataWriter* tf = nullptr;
  /// rt/tf_static with the sensor's mounting, when the node reads it from there.
  fdds::DataWriter* tf_static = nullptr;
  std::uint32_t cloud_bytes = 0;  ///< every cloud's serialised size, with data-sharing
  std::string sensor_topic;       ///< the sensor's DDS topic name
};

/// The sensor writer: images, or clouds (with data-sharing unless dds.data_sharing is false).
void createSensorWriter(const mlmap::dds::DdsConfig& dds, const SensorFeed& source,
                        fdds::Publisher* publisher, const fdds::DataWriterQos& qos, Writers* w) {
  if (source.depth_mode) {
    w->sensor = mlmap::dds::createWriter<mlmap::dds::sensor_msgs::Image_PubSubType>(
        publisher, w->sensor_topic, qos);
  } else if (dds.data_sharing) {
    // Every cloud has the size of the first (one camera): the writer's slots get that size.
    PreparedFrame first = source.prepare(0);
    mlmap::dds::sensor_msgs::PointCloud2_PubSubType plain;
    w->cloud_bytes = plain.getSerializedSizeProvider(&*first.cloud)();
    w->sensor =
        mlmap::dds::createDataSharingCloudWriter(publisher, w->sensor_topic, qos, w->cloud_bytes);
    spdlog::info("clouds of {:.2f} MB offered with data-sharing (dds.data_sharing)",
                 w->cloud_bytes / 1e6);
  } else {
    w->sensor = mlmap::dds::createWriter<mlmap::dds::sensor_msgs::PointCloud2_PubSubType>(
        publisher, w->sensor_topic, qos);
  }
}

/// What a robot publishes on TF besides mlmap_node, as the node's configuration expects it: the
/// pose's TF when the node publishes none or only map -> odom (rt/tf, absolute), and the sensor's
/// mounting on rt/tf_static when the node reads it from there (as robot_state_publisher or a
/// camera driver would, latched).
void createRobotTf(const mlmap::dds::DdsConfig& dds, const Transform& T_B_S,
                   fdds::Publisher* publisher, Writers* w) {
  using TfType = ::tf2_msgs::msg::dds_::TFMessage_PubSubType;
  if (mlmap::dds::resolveTfMode(dds) != mlmap::dds::TfMode::kWorldBody) {
    w->tf = mlmap::dds::createWriter<TfType>(publisher, mlmap::dds::ddsTopicName("", "tf"),
                                             mlmap::dds::reliableWriterQos(100));
  }
  if (mlmap::dds::resolveExtrinsicSource(dds) == mlmap::dds::ExtrinsicSource::kTfStatic) {
    w->tf_static = mlmap::dds::createWriter<TfType>(
        publisher, mlmap::dds::ddsTopicName("", "tf_static"), mlmap::dds::latchedWriterQos());
    const mlmap::dds::FrameNames frames = mlmap::dds::resolveFrames(dds);
    ::tf2_msgs::msg::dds_::TFMessage_ mounting;
    mounting.transforms_().push_back(
        mlmap::dds::toTransformStamped(T_B_S, 0.0, frames.body, frames.sensor));
    w->tf_static->write(&mounting);
  }
}

/// Joins the DDS graph and creates the writers. `T_B_S`: the sensor's mounting (sensor.*).
Writers createWriters(const mlmap::dds::DdsConfig& dds, const SensorFeed& source,
                      const Transform& T_B_S) {
  Writers w;
  w.participant = mlmap::dds::createParticipant(dds, "mlmap_sensor_publisher");
  fdds::Publisher* publisher = w.participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  const mlmap::dds::TopicNames& topics = dds.topics;
  // Sensor drivers and odometry publish best-effort (ROS 2 sensor data QoS; PX4 does too), and
  // mlmap_node reads best-effort: that is what its readers get from this writer. The writer
  // offers RELIABLE (KEEP_LAST 5, so it never blocks) because Fast DDS 2.9.1's best-effort
  // writers do not drop a same-host reader's UDP locator when shared memory reaches it
  // (eProsima/Fast-DDS#3655, fixed after 2.9.1; Jazzy's 2.14 has the fix): every 4.9 MB cloud
  // crossed loopback UDP too, which doubled its transport cost in the latency benchmark.
  const fdds::DataWriterQos qos = mlmap::dds::reliableWriterQos(5);
  w.sensor_topic =
      mlmap::dds::ddsTopicName(dds.ns, source.depth_mode ? topics.depth_image : topics.cloud);
  createSensorWriter(dds, source, publisher, qos, &w);
  if (source.depth_mode) {
    w.info = mlmap::dds::createWriter<mlmap::dds::sensor_msgs::CameraInfo_PubSubType>(
        publisher, mlmap::dds::ddsTopicName(dds.ns, topics.camera_info), qos);
  }
  if (!topics.pose.empty()) {
    w.pose = mlmap::dds::createWriter<mlmap::dds::geometry_msgs::PoseStamped_PubSubType>(
        publisher, mlmap::dds::ddsTopicName(dds.ns, topics.pose), qos);
  }
  if (!topics.odometry.empty()) {
    w.odometry = mlmap::dds::createWriter<mlmap::dds::nav_msgs::Odometry_PubSubType>(
        publisher, mlmap::dds::ddsTopicName(dds.ns, topics.odometry), qos);
  }
  createRobotTf(dds, T_B_S, publisher, &w);
  return w;
}

/// Waits until every writer has a matched reader (false: timed out or stopped).
bool waitForReaders(const std::vector<fdds::DataWriter*>& writers, double timeout_s) {
  const auto start = Clock::now();
  for (;;) {
    bool all = true;
    for (fdds::DataWriter* w : writers) {
      fdds::PublicationMatchedStatus matched;
      w->get_publication_matched_status(matched);
      all = all && matched.current_count > 0;
    }
    if (all) return true;
    if (apps::stopRequested() || secondsBetween(start, Clock::now()) >= timeout_s) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

/// Waits for the mapping node (matching is asynchronous; frames sent before it are lost) and
/// returns the number of subscribers of the sensor topic. A writer can see its match before the
/// reader has matched it: a short grace period after.
int waitForSubscribers(const Writers& w, double wait_s) {
  std::vector<fdds::DataWriter*> writers = {w.sensor, w.pose != nullptr ? w.pose : w.odometry};
  if (w.info != nullptr) writers.push_back(w.info);
  if (w.tf_static != nullptr) writers.push_back(w.tf_static);  // the node needs it for every frame
  const bool matched = waitForReaders(writers, wait_s);
  if (matched) std::this_thread::sleep_for(std::chrono::milliseconds(250));
  fdds::PublicationMatchedStatus sensor_matched;
  w.sensor->get_publication_matched_status(sensor_matched);
  if (!matched)
    spdlog::warn("not every topic has a subscriber after {} s: publishing anyway", wait_s);
  return sensor_matched.current_count;
}

/// Every frame rendered and encoded (--prerender), with a progress line every two seconds.
std::vector<PreparedFrame> prerenderFrames(const SensorFeed& source) {
  std::vector<PreparedFrame> prerendered;
  const auto render_start = Clock::now();
  auto last_line = render_start;
  std::size_t bytes = 0;
  prerendered.reserve(static_cast<std::size_t>(source.frames));
  for (int i = 0; i < source.frames && !apps::stopRequested(); ++i) {
    prerendered.push_back(source.prepare(i));
    bytes += prerendered.back().bytes();
    if (secondsBetween(last_line, Clock::now()) >= 2.0 || i + 1 == source.frames) {
      last_line = Clock::now();
      spdlog::info("prerendered {} / {} frames ({:.0f} MB, {:.1f} s)", i + 1, source.frames,
                   static_cast<double>(bytes) / 1e6, secondsBetween(render_start, last_line));
    }
  }
  return prerendered;
}

/// What the stream did.
struct StreamStats {
  int sent = 0;              ///< frames written
  int late = 0;              ///< frames sent more than kLate_ms after their capture time
  int failed = 0;            ///< frames whose write failed
  double max_late_ms = 0.0;  ///< the latest a frame left after its capture time [ms]
};

/// A frame sent later than this after its capture time counts as late [ms].
constexpr double kLate_ms = 5.0;

/// Sends frames in real time: frame i is captured at start + i / rate, with the wall-clock stamp
/// wall0 + i / rate. The simulator's flight time t maps to the stamp wall0 + t / speed (poses as
/// well as frames).
class Streamer {
 public:
  Streamer(const SensorFeed& source, const Writers& writers, const mlmap::dds::DdsConfig& dds,
           double pose_rate_hz)
      : source_(source),
        writers_(writers),
        frames_(mlmap::dds::resolveFrames(dds)),
        tf_parent_(mlmap::dds::resolveTfMode(dds) == mlmap::dds::TfMode::kMapOdom ? frames_.odom
                                                                                  : frames_.world),
        pose_period_s_(1.0 / pose_rate_hz),
        start_(Clock::now()),
        wall0_s_(mlmap::dds::wallClockNow_s()) {}

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
      spdlog::error("frame {}: the DDS write failed{}", i,
                    writers_.cloud_bytes > 0
                        ? " (data-sharing: a cloud larger than the first, or every "
                          "slot still held by a reader that has not taken it)"
                        : "");
    }
  }
  [[nodiscard]] const StreamStats& stats() const { return stats_; }

 private:
  /// T_W_B as a PoseStamped or an Odometry (child: the body frame), and the robot's TF of it.
  void publishPose(const Transform& T_W_B, double stamp_s) {
    mlmap::dds::geometry_msgs::PoseStamped_ pose =
        mlmap::dds::toPoseStamped(T_W_B, stamp_s, frames_.world);
    if (writers_.pose != nullptr) writers_.pose->write(&pose);
    if (writers_.odometry != nullptr) {
      mlmap::dds::nav_msgs::Odometry_ odometry;
      odometry.header_(pose.header_());
      odometry.child_frame_id_(frames_.body);
      odometry.pose_().pose_(pose.pose_());
      writers_.odometry->write(&odometry);
    }
    if (writers_.tf != nullptr) {  // an odometry that equals the pose (map_odom: map -> odom = I)
      ::tf2_msgs::msg::dds_::TFMessage_ tf;
      tf.transforms_().push_back(
          mlmap::dds::toTransformStamped(T_W_B, stamp_s, tf_parent_, frames_.body));
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
  const Writers& writers_;
  mlmap::dds::FrameNames frames_;
  std::string tf_parent_;  ///< parent of the robot's TF of the pose: world, or odom in map_odom
  double pose_period_s_;
  Clock::time_point start_;
  double wall0_s_;
  long pose_k_ = 0;
  StreamStats stats_;
};

/// Publishes every frame (prerendered ones if given) until done or stopped.
StreamStats stream(const SensorFeed& source, const Writers& writers,
                   const mlmap::dds::DdsConfig& dds, double pose_rate_hz,
                   std::vector<PreparedFrame>* prerendered) {
  Streamer streamer(source, writers, dds, pose_rate_hz);
  const int frames = source.frames;
  for (int i = 0; i < frames && !apps::stopRequested(); ++i) {
    streamer.send(i, prerendered != nullptr ? std::move((*prerendered)[static_cast<std::size_t>(i)])
                                            : source.prepare(i));
    if (frames >= 10 && (i + 1) % (frames / 10) == 0)
      spdlog::info("{} / {} frames published", i + 1, frames);
  }
  return streamer.stats();
}

/// Reports late and failed frames; returns the exit status (1 when a frame could not be written).
int finish(const StreamStats& s, bool prerender) {
  if (s.late > 0) {
    spdlog::warn(
        "{} of {} frames left more than {} ms after their capture time (max {:.1f} ms; "
        "their latency includes it): {}",
        s.late, s.sent + s.failed, kLate_ms, s.max_late_ms,
        prerender ? "the machine is busy"
                  : "the simulator is slower than --rate (try --prerender)");
  }
  if (s.failed > 0)
    spdlog::error("{} of {} frames could not be written", s.failed, s.sent + s.failed);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the last samples leave
  spdlog::info("done: {} frames published; at most {:.2f} ms after their capture time", s.sent,
               s.max_late_ms);
  return s.failed > 0 ? 1 : 0;
}

/// The --closed-loop world.
nav::NavWorld closedLoopWorld(const Options& o) {
  if (o.closed_loop == "rooms") return nav::roomsWorld(o.world_seed, 2);
  if (o.closed_loop == "paper") return nav::paperRoomWorld(o.world_seed);
  return nav::forestWorld(o.world_seed, o.forest_density,
                          Eigen::Vector2d(o.forest_size_m[0], o.forest_size_m[1]));
}

/// Flies the closed loop; returns the exit status (0: the goal reached without collision).
int runClosedLoop(const Options& o, const mlmap::dds::NodeConfig& config) {
  mlmap::dds::ClosedLoopOptions loop;
  loop.dds = config.dds;
  loop.cloud_topic = config.dds.topics.cloud;
  loop.pose_topic = config.dds.topics.pose;
  if (loop.cloud_topic.empty() || loop.pose_topic.empty()) {
    throw std::runtime_error("--closed-loop needs dds.topics.cloud and dds.topics.pose");
  }
  loop.setpoint_topic = o.setpoint_topic;
  loop.goal_topic = o.goal_topic;
  loop.T_B_S = config.map.sensor.T_B_S();
  loop.flight.timeout_s = o.timeout_s;
  if (o.rate_hz > 0) loop.flight.camera_rate_hz = o.rate_hz;
  loop.wait_s = o.wait_s;
  const nav::NavWorld world = closedLoopWorld(o);
  spdlog::info("closed loop in {}: from ({:.1f}, {:.1f}) to ({:.1f}, {:.1f}), setpoints on {}",
               world.name, world.start_W.x(), world.start_W.y(), world.goal_W.x(), world.goal_W.y(),
               o.setpoint_topic);
  const mlmap::dds::ClosedLoopResult r =
      mlmap::dds::flyClosedLoop(world, loop, [] { return apps::stopRequested(); });
  if (!r.matched) {
    spdlog::error("no mapping node or planner found within {} s", o.wait_s);
    return 1;
  }
  spdlog::info(
      "closed loop: reached {}, collisions {}, min clearance {:.2f} m, time {:.1f} s, path "
      "{:.1f} m, frames {}, setpoints {} ({} rejected), late steps {}",
      r.reached ? 1 : 0, r.collisions, r.min_clearance_m, r.time_s, r.path_length_m, r.frames,
      r.setpoints, r.rejected_setpoints, r.late_steps);
  if (!r.capture_to_write_ms.empty()) {
    const TimingSummary w = summarizeTimings(r.capture_to_write_ms);
    spdlog::info("a frame's capture stamp to its write: median {:.2f} ms, p99 {:.2f} ms",
                 w.median_ms, w.p99_ms);
  }
  return r.reached && r.collisions == 0 ? 0 : 1;
}

/// Opens the source, waits for the subscribers and publishes; returns the exit status (1: an
/// error, logged, or a frame that could not be written).
int run(const Options& o) {
  apps::installStopHandler();
  try {
    mlmap::dds::NodeConfig config = mlmap::dds::nodeConfigOrDefaults(o.config_path);
    o.security.apply(&config.dds.security);
    if (!o.closed_loop.empty()) return runClosedLoop(o, config);
    const SensorFeed source = openSource(o, config);
    const Writers writers = createWriters(config.dds, source, config.map.sensor.T_B_S());
    const int subscribers = waitForSubscribers(writers, o.wait_s);
    std::vector<PreparedFrame> prerendered;
    if (o.prerender) prerendered = prerenderFrames(source);
    spdlog::info("publishing {} on {} ({} subscriber(s)) at {} Hz",
                 source.depth_mode ? "depth images" : "clouds", writers.sensor_topic, subscribers,
                 source.rate_hz);
    const StreamStats stats =
        stream(source, writers, config.dds, o.pose_rate_hz, o.prerender ? &prerendered : nullptr);
    return finish(stats, o.prerender);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap_sensor_publisher: simulated (or replayed) depth sensor + odometry over DDS"};
  Options options;
  addOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  return run(options);
}
