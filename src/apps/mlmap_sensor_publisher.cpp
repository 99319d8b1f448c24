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
// Clouds are offered with data-sharing unless dds.data_sharing is false: a same-host mlmap_node
// then reads them in this process's shared memory (see createDataSharingCloudWriter()). Exit
// status 1 when a frame could not be written.

#include "mlmap/dds/cloud_sample.h"
#include "mlmap/dds/cloud_writer.h"
#include "mlmap/dds/entities.h"
#include "mlmap/dds/node_config.h"
#include "mlmap/dds/participant.h"
#include "mlmap/dds/ros_conversions.h"
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/sim/depth_camera.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include "security_options.h"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

namespace {

using namespace mlmap;
namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) { g_stop = true; }

/// An organised cloud (width x height) of float32 x, y, z, intensity (16 bytes per point, as a
/// depth camera driver publishes it); pixels without a return are NaN (is_dense false).
mlmap::dds::sensor_msgs::PointCloud2_ organisedCloud(const DepthFrame& frame, double stamp_s,
                                              const std::string& frame_id) {
  mlmap::dds::sensor_msgs::PointCloud2_ msg;
  msg.header_().stamp_(mlmap::dds::toRosTime(stamp_s));
  msg.header_().frame_id_(frame_id);
  const PinholeIntrinsics& k = frame.intrinsics;
  msg.width_(static_cast<std::uint32_t>(k.width));
  msg.height_(static_cast<std::uint32_t>(k.height));
  const char* names[] = {"x", "y", "z", "intensity"};
  for (std::uint32_t i = 0; i < 4; ++i) {
    mlmap::dds::sensor_msgs::PointField_ f;
    f.name_(names[i]);
    f.offset_(4 * i);
    f.datatype_(7);  // FLOAT32
    f.count_(1);
    msg.fields_().push_back(f);
  }
  msg.is_bigendian_(false);
  msg.point_step_(16);
  msg.row_step_(16u * msg.width_());
  msg.is_dense_(false);
  std::vector<std::uint8_t>& data = msg.data_();
  data.resize(static_cast<std::size_t>(msg.row_step_()) * msg.height_());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::size_t i = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u, ++i) {
      const double z = frame.encoding == DepthEncoding::kFloat32Metres ? frame.depth_m[i]
                                                                       : frame.depth_mm[i] * 1e-3;
      float p[4] = {nan, nan, nan, nan};
      if (std::isfinite(z) && z > 0.0 && !(frame.encoding == DepthEncoding::kUint16Millimetres &&
                                           frame.depth_mm[i] == 65535)) {
        p[0] = static_cast<float>((u - k.cx) * z / k.fx);
        p[1] = static_cast<float>((v - k.cy) * z / k.fy);
        p[2] = static_cast<float>(z);
        p[3] = static_cast<float>(z);
      }
      std::memcpy(data.data() + 16 * i, p, sizeof(p));
    }
  }
  return msg;
}

mlmap::dds::sensor_msgs::Image_ depthImage(const DepthFrame& frame, double stamp_s, const std::string& frame_id) {
  mlmap::dds::sensor_msgs::Image_ msg;
  msg.header_().stamp_(mlmap::dds::toRosTime(stamp_s));
  msg.header_().frame_id_(frame_id);
  msg.width_(static_cast<std::uint32_t>(frame.intrinsics.width));
  msg.height_(static_cast<std::uint32_t>(frame.intrinsics.height));
  msg.is_bigendian_(0);
  const bool mm = frame.encoding == DepthEncoding::kUint16Millimetres;
  msg.encoding_(mm ? "16UC1" : "32FC1");
  msg.step_(msg.width_() * (mm ? 2u : 4u));
  const std::size_t bytes = static_cast<std::size_t>(msg.step_()) * msg.height_();
  msg.data_().resize(bytes);
  std::memcpy(msg.data_().data(), mm ? static_cast<const void*>(frame.depth_mm.data())
                                     : static_cast<const void*>(frame.depth_m.data()),
              bytes);
  return msg;
}

mlmap::dds::sensor_msgs::CameraInfo_ cameraInfo(const PinholeIntrinsics& k, double stamp_s,
                                         const std::string& frame_id) {
  mlmap::dds::sensor_msgs::CameraInfo_ msg;
  msg.header_().stamp_(mlmap::dds::toRosTime(stamp_s));
  msg.header_().frame_id_(frame_id);
  msg.width_(static_cast<std::uint32_t>(k.width));
  msg.height_(static_cast<std::uint32_t>(k.height));
  msg.distortion_model_("plumb_bob");
  msg.d_(std::vector<double>(5, 0.0));
  msg.k_({k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1});
  msg.r_({1, 0, 0, 0, 1, 0, 0, 0, 1});
  msg.p_({k.fx, 0, k.cx, 0, 0, k.fy, k.cy, 0, 0, 0, 1, 0});
  return msg;
}

/// One frame ready to send: its sensor message(s), stamped at send time (setStamp()).
struct PreparedFrame {
  double flight_s = 0.0;  ///< simulator time the frame shows (replay: unused)
  Transform T_W_B = Transform::Identity();  ///< body pose of a replayed frame
  std::optional<mlmap::dds::sensor_msgs::PointCloud2_> cloud;  ///< cloud mode
  std::optional<mlmap::dds::sensor_msgs::Image_> image;        ///< depth mode, with `info`
  std::optional<mlmap::dds::sensor_msgs::CameraInfo_> info;

  void setStamp(double stamp_s) {
    const auto stamp = mlmap::dds::toRosTime(stamp_s);
    if (cloud) cloud->header_().stamp_(stamp);
    if (image) image->header_().stamp_(stamp);
    if (info) info->header_().stamp_(stamp);
  }
  [[nodiscard]] std::size_t bytes() const {
    return (cloud ? cloud->data_().size() : 0) + (image ? image->data_().size() : 0);
  }
};

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
    if (g_stop || std::chrono::duration<double>(Clock::now() - start).count() >= timeout_s) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap_sensor_publisher: simulated (or replayed) depth sensor + odometry over DDS"};
  std::string config_path, scenario_path, frames_dir, mode = "cloud";
  double rate_hz = 0.0, pose_rate_hz = 50.0, wait_s = 10.0, speed = 1.0;
  int max_frames = 0;
  bool prerender = false;
  app.add_option("-c,--config", config_path, "node configuration (its dds section and sensor mounting)")
      ->check(CLI::ExistingFile);
  app.add_option("--scenario", scenario_path, "scenario YAML (default: the built-in room)")
      ->check(CLI::ExistingFile);
  app.add_option("--frames-dir", frames_dir, "replay a folder of RGB-D frames instead (see README)")
      ->check(CLI::ExistingDirectory);
  app.add_option("--mode", mode, "what the sensor publishes: cloud (PointCloud2) or depth (Image)")
      ->check(CLI::IsMember({"cloud", "depth"}));
  app.add_option("--rate", rate_hz, "frames per second (default: the scenario's; 30 for a replay)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--speed", speed,
                 "flight seconds per wall-clock second (simulator only): > 1 flies farther in the "
                 "same number of frames (stamps stay wall-clock times)")
      ->check(CLI::PositiveNumber);
  app.add_option("--pose-rate", pose_rate_hz, "poses per second of flight (simulator only)")
      ->check(CLI::PositiveNumber);
  app.add_option("--max-frames", max_frames, "stop after this many frames (0: all)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--wait-for-subscriber", wait_s,
                 "seconds to wait for subscribers of the sensor and pose topics before starting")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--prerender", prerender,
               "render and encode every frame before streaming (benchmarks: the simulator cannot "
               "hold the rate; memory = frames x message size, 4.8 MB per 640x480 cloud)");
  mlmap::apps::SecurityOptions security;
  security.add(app);
  CLI11_PARSE(app, argc, argv);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);

  try {
    mlmap::dds::NodeConfig config =
        config_path.empty() ? mlmap::dds::NodeConfig{} : mlmap::dds::loadNodeConfigYaml(config_path);
    security.apply(&config.dds.security);
    std::optional<io::Scenario> scenario;
    std::unique_ptr<io::FrameDirectory> replay;
    if (!frames_dir.empty()) {
      replay = std::make_unique<io::FrameDirectory>(frames_dir);
      if (rate_hz <= 0) rate_hz = io::kFrameDirectoryRate_hz;
    } else {
      scenario = scenario_path.empty() ? io::defaultScenario() : io::loadScenarioYaml(scenario_path);
      if (rate_hz <= 0) rate_hz = scenario->frame_rate_hz;
    }
    const mlmap::dds::TopicNames& topics = config.dds.topics;
    const bool depth_mode = mode == "depth";
    const std::string sensor_topic = depth_mode ? topics.depth_image : topics.cloud;
    if (sensor_topic.empty() || topics.pose.empty() || (depth_mode && topics.camera_info.empty())) {
      throw std::runtime_error("the configuration disables the " + mode + " or pose topic");
    }

    const int available = replay ? static_cast<int>(replay->size())
                                 : static_cast<int>(std::floor(scenario->trajectory.duration_s() * rate_hz)) + 1;
    const int frames = max_frames > 0 ? std::min(max_frames, available) : available;
    const Transform T_B_S = config.map.sensor.T_B_S();
    if (replay && !T_B_S.isApprox(Transform::Identity())) {
      spdlog::warn("replayed frames are camera poses (T_B_S = identity) but the configuration mounts "
                   "the sensor elsewhere: give mlmap_node a config with sensor translation 0 and "
                   "rotation 0 (config/mlmap_node_replay.yaml)");
    }
    std::optional<sim::DepthCamera> camera;
    if (scenario) camera.emplace(scenario->camera);
    const std::string& world = config.dds.world_frame;
    const std::string& sensor = config.dds.sensor_frame;

    // Frame i, encoded (stamps are set when it is sent).
    auto prepare = [&](int i) {
      PreparedFrame prepared;
      DepthFrame frame;
      if (replay) {
        frame = replay->read(static_cast<std::size_t>(i));
        prepared.T_W_B = frame.T_W_B;
      } else {
        prepared.flight_s = speed * i / rate_hz;
        frame.T_W_B = scenario->trajectory.poseAt(prepared.flight_s);
        camera->render(scenario->world, frame.T_W_B * T_B_S, prepared.flight_s, &frame);
      }
      if (depth_mode) {
        prepared.info = cameraInfo(frame.intrinsics, 0.0, sensor);
        prepared.image = depthImage(frame, 0.0, sensor);
      } else {
        prepared.cloud = organisedCloud(frame, 0.0, sensor);
      }
      return prepared;
    };
    mlmap::dds::ParticipantPtr participant = mlmap::dds::createParticipant(config.dds, "mlmap_sensor_publisher");
    fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    const auto ns = config.dds.ns;
    // Sensor drivers and odometry publish best-effort (ROS 2 sensor data QoS; PX4 does too), and
    // mlmap_node reads best-effort: that is what its readers get from this writer. The writer
    // offers RELIABLE (KEEP_LAST 5, so it never blocks) because Fast DDS 2.9.1's best-effort
    // writers do not drop a same-host reader's UDP locator when shared memory reaches it
    // (eProsima/Fast-DDS#3655, fixed after 2.9.1; Jazzy's 2.14 has the fix): every 4.9 MB cloud
    // crossed loopback UDP too, which doubled its transport cost in the latency benchmark.
    const fdds::DataWriterQos sensor_qos = mlmap::dds::reliableWriterQos(5);
    const std::string sensor_dds_topic = mlmap::dds::ddsTopicName(ns, sensor_topic);
    fdds::DataWriter* sensor_writer = nullptr;
    std::uint32_t cloud_bytes = 0;  // every cloud's serialised size, with data-sharing
    if (depth_mode) {
      sensor_writer = mlmap::dds::createWriter<mlmap::dds::sensor_msgs::Image_PubSubType>(publisher, sensor_dds_topic, sensor_qos);
    } else if (config.dds.data_sharing) {
      // Every cloud has the size of the first (one camera): the writer's slots get that size.
      PreparedFrame first = prepare(0);
      mlmap::dds::sensor_msgs::PointCloud2_PubSubType plain;
      cloud_bytes = plain.getSerializedSizeProvider(&*first.cloud)();
      sensor_writer = mlmap::dds::createDataSharingCloudWriter(publisher, sensor_dds_topic, sensor_qos, cloud_bytes);
      spdlog::info("clouds of {:.2f} MB offered with data-sharing (dds.data_sharing)", cloud_bytes / 1e6);
    } else {
      sensor_writer = mlmap::dds::createWriter<mlmap::dds::sensor_msgs::PointCloud2_PubSubType>(publisher, sensor_dds_topic, sensor_qos);
    }
    fdds::DataWriter* info_writer =
        depth_mode ? mlmap::dds::createWriter<mlmap::dds::sensor_msgs::CameraInfo_PubSubType>(publisher, mlmap::dds::ddsTopicName(ns, topics.camera_info), sensor_qos)
                   : nullptr;
    fdds::DataWriter* pose_writer = mlmap::dds::createWriter<mlmap::dds::geometry_msgs::PoseStamped_PubSubType>(
        publisher, mlmap::dds::ddsTopicName(ns, topics.pose), sensor_qos);

    // Wait for the mapping node (matching is asynchronous; frames sent before it are lost). A
    // writer can see its match before the reader has matched it: a short grace period after.
    std::vector<fdds::DataWriter*> writers = {sensor_writer, pose_writer};
    if (info_writer != nullptr) writers.push_back(info_writer);
    const bool matched = waitForReaders(writers, wait_s);
    if (matched) std::this_thread::sleep_for(std::chrono::milliseconds(250));
    fdds::PublicationMatchedStatus sensor_matched;
    sensor_writer->get_publication_matched_status(sensor_matched);
    if (!matched) spdlog::warn("not every topic has a subscriber after {} s: publishing anyway", wait_s);

    std::vector<PreparedFrame> prerendered;
    if (prerender) {
      const auto render_start = Clock::now();
      auto last_line = render_start;
      std::size_t bytes = 0;
      prerendered.reserve(static_cast<std::size_t>(frames));
      for (int i = 0; i < frames && !g_stop; ++i) {
        prerendered.push_back(prepare(i));
        bytes += prerendered.back().bytes();
        if (std::chrono::duration<double>(Clock::now() - last_line).count() >= 2.0 || i + 1 == frames) {
          last_line = Clock::now();
          spdlog::info("prerendered {} / {} frames ({:.0f} MB, {:.1f} s)", i + 1, frames,
                       static_cast<double>(bytes) / 1e6,
                       std::chrono::duration<double>(last_line - render_start).count());
        }
      }
    }
    spdlog::info("publishing {} on {} ({} subscriber(s)) at {} Hz", depth_mode ? "depth images" : "clouds",
                 mlmap::dds::ddsTopicName(ns, sensor_topic), sensor_matched.current_count, rate_hz);

    // Frame i is captured at start + i / rate: wall-clock stamp wall0 + i / rate. The simulator's
    // flight time t maps to the stamp wall0 + t / speed (poses as well as frames).
    const auto start = Clock::now();
    const double wall0_s = mlmap::dds::wallClockNow_s();
    const double pose_period_s = 1.0 / pose_rate_hz;
    long pose_k = 0;
    int sent = 0, late = 0, failed = 0;
    double max_late_ms = 0.0;
    constexpr double kLate_ms = 5.0;
    auto publishPose = [&](const Transform& T_W_B, double stamp_s) {
      mlmap::dds::geometry_msgs::PoseStamped_ pose = mlmap::dds::toPoseStamped(T_W_B, stamp_s, world);
      pose_writer->write(&pose);
    };
    for (int i = 0; i < frames && !g_stop; ++i) {
      PreparedFrame frame = prerender ? std::move(prerendered[static_cast<std::size_t>(i)]) : prepare(i);
      const auto due = start + std::chrono::duration_cast<Clock::duration>(
                                   std::chrono::duration<double>(i / rate_hz));
      std::this_thread::sleep_until(due);
      const double late_ms = std::chrono::duration<double, std::milli>(Clock::now() - due).count();
      max_late_ms = std::max(max_late_ms, late_ms);
      late += late_ms > kLate_ms ? 1 : 0;
      const double stamp_s = wall0_s + i / rate_hz;
      if (replay) {
        publishPose(frame.T_W_B, stamp_s);  // the recording has one pose per frame
      } else {
        // Odometry runs ahead of the camera by up to one pose period, as a fast IMU-based
        // estimator does, so each frame finds poses on both sides of its stamp.
        for (; static_cast<double>(pose_k) * pose_period_s <= frame.flight_s + pose_period_s + 1e-9;
             ++pose_k) {
          const double pose_t_s = static_cast<double>(pose_k) * pose_period_s;
          publishPose(scenario->trajectory.poseAt(pose_t_s), wall0_s + pose_t_s / speed);
        }
      }
      frame.setStamp(stamp_s);
      bool written = true;
      if (depth_mode) {
        const bool info_written = info_writer->write(&*frame.info);
        written = sensor_writer->write(&*frame.image) && info_written;
      } else {
        written = sensor_writer->write(&*frame.cloud);
      }
      if (written) {
        ++sent;
      } else if (failed++ == 0) {
        spdlog::error("frame {}: the DDS write failed{}", i,
                      cloud_bytes > 0 ? " (data-sharing: a cloud larger than the first, or every "
                                        "slot still held by a reader that has not taken it)"
                                      : "");
      }
      if (frames >= 10 && (i + 1) % (frames / 10) == 0) {
        spdlog::info("{} / {} frames published", i + 1, frames);
      }
    }
    if (late > 0) {
      spdlog::warn("{} of {} frames left more than {} ms after their capture time (max {:.1f} ms; "
                   "their latency includes it): {}",
                   late, sent + failed, kLate_ms, max_late_ms,
                   prerender ? "the machine is busy" : "the simulator is slower than --rate (try --prerender)");
    }
    if (failed > 0) spdlog::error("{} of {} frames could not be written", failed, sent + failed);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the last samples leave
    spdlog::info("done: {} frames published; at most {:.2f} ms after their capture time", sent,
                 max_late_ms);
    return failed > 0 ? 1 : 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
