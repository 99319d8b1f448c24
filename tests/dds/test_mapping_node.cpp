// The mapping node's input side over DDS: malformed samples (bad CDR, bad layouts, bad values,
// bad poses, bad stamps) are rejected and counted while good frames keep being mapped.
// Participants on loopback only (DiscoveryRange::kLocalhost), domains 170..189.
#include "mlmap/dds/wire/cloud_sample.h"
#include "mlmap/dds/transport/cloud_writer.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/mapping_node.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include "dds_test_support.h"
#include "raw_type.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "mlmap_msgs/msg/Status_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/rtps/transport/test_UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <fastrtps/xmlparser/XMLProfileManager.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
using sensor_msgs::PointCloud2_;
using test_support::CdrBytes;
using test_support::localhostConfig;
using test_support::RawBytes;
using test_support::RawType;
using test_support::readerMatched;
using test_support::waitFor;
using test_support::writerMatched;

constexpr const char* kCloudType = "sensor_msgs::msg::dds_::PointCloud2_";

/// A writer of arbitrary bytes on `dds_topic` under the type name `type_name`.
fdds::DataWriter* rawWriter(fdds::DomainParticipant* participant, const std::string& dds_topic,
                            const std::string& type_name) {
  fdds::TypeSupport type(new RawType(type_name, 1u << 20));
  if (type.register_type(participant) != ReturnCode_t::RETCODE_OK) return nullptr;
  fdds::Topic* topic = participant->create_topic(dds_topic, type_name, fdds::TOPIC_QOS_DEFAULT);
  fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  if (topic == nullptr || publisher == nullptr) return nullptr;
  return publisher->create_datawriter(topic, reliableWriterQos(50));
}

/// The CDR of a PointCloud2 with one float32 x, y, z point, up to (not including) is_bigendian.
CdrBytes cloudPrefix(std::int32_t stamp_s) {
  CdrBytes b;
  b.i32(stamp_s).u32(0).str("sensor");  // header
  b.u32(1).u32(1);                      // height, width
  b.u32(3);                             // fields
  const char* names[] = {"x", "y", "z"};
  for (std::uint32_t i = 0; i < 3; ++i) b.str(names[i]).u32(4 * i).u8(7).u32(1);
  return b;
}

/// The rest of that cloud: is_bigendian, point_step, row_step, data, is_dense.
RawBytes cloudBytes(std::int32_t stamp_s, std::uint8_t is_bigendian_byte) {
  CdrBytes b = cloudPrefix(stamp_s);
  b.u8(is_bigendian_byte).u32(12).u32(12).u32(12);
  const float xyz[3] = {1.0f, 2.0f, 3.0f};
  for (float v : xyz) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &v, 4);
    for (int k = 0; k < 4; ++k) b.u8(static_cast<std::uint8_t>(bits >> (8 * k)));
  }
  b.u8(1);
  return b.bytes();
}

TEST(TakeListener, PayloadsFastCdrCannotParseAreCountedOnceAndTheNextSampleArrives) {
  const ParticipantPtr sender = createParticipant(localhostConfig(170), "raw_sender");
  const ParticipantPtr receiver = createParticipant(localhostConfig(170), "listener");
  fdds::DataWriter* writer = rawWriter(sender.get(), "rt/test/cloud", kCloudType);
  ASSERT_NE(writer, nullptr);

  std::atomic<int> good{0}, errors{0};
  std::atomic<std::int32_t> last_stamp{0};
  TakeListener<PointCloud2_> listener(
      [&](PointCloud2_&& cloud) {
        last_stamp = cloud.header_().stamp_().sec_();
        ++good;
      },
      [&](const std::string&) { ++errors; });
  fdds::Subscriber* subscriber = receiver->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  createReader<sensor_msgs::PointCloud2_PubSubType>(subscriber, "rt/test/cloud",
                                                    reliableReaderQos(), &listener);
  ASSERT_TRUE(waitFor([&] { return writerMatched(writer); }));

  RawBytes sample = cloudBytes(1, 0);
  ASSERT_TRUE(writer->write(&sample));
  ASSERT_TRUE(waitFor([&] { return good == 1; })) << "a well-formed raw cloud was not received";
  EXPECT_EQ(last_stamp, 1);

  // A bool byte that is neither 0 nor 1 (Fast CDR throws BadParamException), a payload cut in
  // the middle of the data (NotEnoughMemoryException), an unknown encapsulation.
  RawBytes bad_bool = cloudBytes(2, 7);
  RawBytes truncated = cloudBytes(3, 0);
  truncated.resize(truncated.size() - 8);
  RawBytes bad_encapsulation = cloudBytes(4, 0);
  bad_encapsulation[1] = 0x77;
  for (RawBytes* b : {&bad_bool, &truncated, &bad_encapsulation}) ASSERT_TRUE(writer->write(b));
  sample = cloudBytes(5, 0);
  ASSERT_TRUE(writer->write(&sample));
  ASSERT_TRUE(waitFor([&] { return good == 2; })) << "the good sample after the bad ones was lost";
  EXPECT_EQ(last_stamp, 5);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(errors, 3) << "each bad sample must be reported exactly once";
  EXPECT_EQ(good, 2) << "a bad sample was handed over as if it were valid";
}

TEST(TakeListener, ATfSampleDeclaringMoreTransformsThanItsBytesIsRefusedWithTheReason) {
  // Issue 43 item 10 on the wire, through TakeReaders as the node's /tf and /tf_static readers
  // take it: 1,000,000 transforms declared in 64 kB (Fast CDR alone would have sized the vector
  // first: 128 MB). Refused before Fast CDR reads it, reported with the member, and the next
  // sample arrives.
  std::mutex mutex;
  std::vector<std::string> errors;
  std::atomic<int> good{0};
  std::unique_ptr<TakeReaders> readers;  // outlives the participant that holds its readers
  const ParticipantPtr sender = createParticipant(localhostConfig(166), "raw_tf_sender");
  const ParticipantPtr receiver = createParticipant(localhostConfig(166), "tf_listener");
  fdds::DataWriter* writer = rawWriter(sender.get(), "rt/tf", "tf2_msgs::msg::dds_::TFMessage_");
  ASSERT_NE(writer, nullptr);
  readers = std::make_unique<TakeReaders>(receiver->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT),
                                          [&](const std::string& what) {
                                            std::lock_guard<std::mutex> lock(mutex);
                                            errors.push_back(what);
                                          });
  readers->add<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(
      "rt/tf", reliableReaderQos(false, 100), [&](::tf2_msgs::msg::dds_::TFMessage_&& msg) {
        if (msg.transforms_().size() == 1 && msg.transforms_()[0].child_frame_id_() == "base_link")
          ++good;
      });
  ASSERT_TRUE(waitFor([&] { return writerMatched(writer); }));

  CdrBytes hostile;
  hostile.u32(1000000);
  RawBytes bytes = hostile.bytes();
  bytes.resize(64 * 1024, 0);
  ASSERT_TRUE(writer->write(&bytes));
  CdrBytes one;
  one.u32(1).i32(7).u32(0).str("odom").str("base_link");
  for (int i = 0; i < 6; ++i) one.f64(0.0);
  one.f64(1.0);  // rotation.w
  RawBytes valid = one.bytes();
  ASSERT_TRUE(writer->write(&valid));
  ASSERT_TRUE(waitFor([&] { return good == 1; }))
      << "the valid /tf sample after the hostile one was lost";
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(errors.size(), 1U);
  EXPECT_EQ(errors[0],
            "cannot deserialise a sample on rt/tf (malformed CDR: tf2_msgs::msg::dds_::TFMessage_ "
            "`transforms`: sequence declares 1000000 elements of >= 72 bytes, 65528 bytes remain)");
}

// ---- The node ------------------------------------------------------------------------------

/// How SensorSide publishes.
struct SensorOptions {
  /// The clouds' writer offers data-sharing (createDataSharingCloudWriter, bounded by the wall
  /// cloud's size), as mlmap_sensor_publisher's does.
  bool data_sharing = false;
  /// The sensor's one transport (UDPv4 on 127.0.0.1) drops every DATA_FRAG it would send: a
  /// sample larger than a fragment reaches no reader through it.
  bool transport_drops_fragments = false;
  double wall_step_m = 0.05;  ///< spacing of the wall's points (0.005: 0.45 MB clouds)
  /// The sensor's participant also has the SHM transport (dds.shared_memory), as a ROS 2 Jazzy
  /// node on its default rmw_fastrtps_cpp with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST.
  bool shared_memory = false;
};

/// The sensor side's main participant: the test's LOCALHOST one, or the same with only a UDPv4
/// transport that drops DATA_FRAG submessages (Fast DDS's test transport), on 127.0.0.1.
ParticipantPtr sensorParticipant(int domain_id, const SensorOptions& options) {
  const bool drop_fragments = options.transport_drops_fragments;
  if (!drop_fragments) {
    DdsConfig config = localhostConfig(domain_id);
    config.shared_memory = options.shared_memory;
    return createParticipant(config, "sensor_side");
  }
  ParticipantSetup setup = participantSetup(localhostConfig(domain_id), "sensor_side");
  auto udp = std::make_shared<eprosima::fastdds::rtps::test_UDPv4TransportDescriptor>();
  udp->dropDataFragMessagesPercentage = 100;
  udp->maxInitialPeersRange = kLocalhostMaxInitialPeersRange;
  setup.qos.transport().use_builtin_transports = false;
  setup.qos.transport().user_transports = {udp};
  eprosima::fastrtps::rtps::Locator_t loopback;
  eprosima::fastrtps::rtps::IPLocator::setIPv4(loopback, "127.0.0.1");
  setup.qos.wire_protocol().default_unicast_locator_list.push_back(loopback);
  return ParticipantPtr(fdds::DomainParticipantFactory::get_instance()->create_participant(
      static_cast<fdds::DomainId_t>(setup.domain_id), setup.qos));
}

/// A vehicle hovering at (0, 0, 1) facing +x, a wall at x = 3 m: stamped poses and clouds as a
/// sensor driver and an odometry source would publish them to a MappingNode.
class SensorSide {
 public:
  SensorSide(int domain_id, const NodeConfig& node_config, const SensorOptions& options = {})
      : config_(node_config),
        participant_(sensorParticipant(domain_id, options)),
        raw_participant_(createParticipant(localhostConfig(domain_id), "raw_sensor_side")) {
    T_W_B_.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
    const Transform T_S_W = (T_W_B_ * config_.map.sensor.T_B_S()).inverse();
    const double step = options.wall_step_m;
    for (double y = -1.0; y <= 1.0; y += step) {
      for (double z = 0.5; z <= 1.5; z += step) {
        wall_S_.push_back((T_S_W * Eigen::Vector3d(3.0, y, z)).cast<float>());
      }
    }
    fdds::Publisher* publisher = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    const TopicNames& topics = config_.dds.topics;
    if (options.data_sharing) {
      sensor_msgs::PointCloud2_ msg = wallCloud(0.0);  // every wall cloud has this size
      cloud_bytes_ = sensor_msgs::PointCloud2_PubSubType().getSerializedSizeProvider(&msg)();
      cloud_ = createDataSharingCloudWriter(publisher, "rt/" + topics.cloud, reliableWriterQos(50),
                                            cloud_bytes_);
    } else {
      cloud_ = createWriter<sensor_msgs::PointCloud2_PubSubType>(publisher, "rt/" + topics.cloud,
                                                                 reliableWriterQos(50));
    }
    if (!topics.pose.empty()) {
      pose_ = createWriter<geometry_msgs::PoseStamped_PubSubType>(publisher, "rt/" + topics.pose,
                                                                  reliableWriterQos(50));
    }
    if (!topics.odometry.empty()) {
      odometry_ = createWriter<nav_msgs::Odometry_PubSubType>(publisher, "rt/" + topics.odometry,
                                                              reliableWriterQos(50));
    }
    raw_cloud_ = rawWriter(raw_participant_.get(), "rt/" + topics.cloud, kCloudType);
  }

  /// Serialised size of the data-sharing writer's clouds (0 without data-sharing) [bytes].
  [[nodiscard]] std::uint32_t cloudBytes() const { return cloud_bytes_; }

  /// Waits until every writer matched the node's reader and every reader of the node matched its
  /// writer: the node's inputs are BEST_EFFORT, so a sample that arrives before the reader knows
  /// its writer is lost for good.
  bool matched(const MappingNode& node) const {
    return waitFor([&] {
      std::uint64_t writers = 0;
      for (fdds::DataWriter* w : {cloud_, pose_, odometry_, raw_cloud_}) {
        if (w == nullptr) continue;
        if (!writerMatched(w)) return false;
        ++writers;
      }
      return node.counters().publishers_matched == writers;
    });
  }

  /// A PoseStamped (or Odometry, whichever the node reads) of the hovering vehicle.
  void pose(double stamp_s, const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity(),
            double x_m = 0.0) {
    geometry_msgs::Pose_ p;
    p.position_().x_(x_m);
    p.position_().z_(T_W_B_.translation().z());
    p.orientation_().x_(q.x());
    p.orientation_().y_(q.y());
    p.orientation_().z_(q.z());
    p.orientation_().w_(q.w());
    if (pose_ != nullptr) {
      geometry_msgs::PoseStamped_ msg;
      msg.header_().stamp_(toRosTime(stamp_s));
      msg.header_().frame_id_("map");
      msg.pose_(p);
      ASSERT_TRUE(pose_->write(&msg));
    } else {
      nav_msgs::Odometry_ msg;
      msg.header_().stamp_(toRosTime(stamp_s));
      msg.header_().frame_id_("map");
      msg.child_frame_id_("base_link");
      msg.pose_().pose_(p);
      msg.pose_().covariance_().fill(0.0);
      ASSERT_TRUE(odometry_->write(&msg));
    }
  }

  /// The wall as the sensor sees it from the hover pose.
  [[nodiscard]] sensor_msgs::PointCloud2_ wallCloud(double stamp_s) const {
    return encodePointCloud2(wall_S_, nullptr, stamp_s, config_.dds.sensor_frame);
  }

  void cloud(sensor_msgs::PointCloud2_ msg) { ASSERT_TRUE(cloud_->write(&msg)); }
  void rawCloud(RawBytes bytes) { ASSERT_TRUE(raw_cloud_->write(&bytes)); }

  /// Poses just before and after `stamp_s`, then the wall cloud at `stamp_s`.
  void frame(double stamp_s) {
    pose(stamp_s - 0.01);
    pose(stamp_s + 0.01);
    cloud(wallCloud(stamp_s));
  }

 private:
  NodeConfig config_;
  ParticipantPtr participant_;
  ParticipantPtr raw_participant_;
  fdds::DataWriter* cloud_ = nullptr;
  fdds::DataWriter* pose_ = nullptr;
  fdds::DataWriter* odometry_ = nullptr;
  fdds::DataWriter* raw_cloud_ = nullptr;
  std::uint32_t cloud_bytes_ = 0;
  Transform T_W_B_ = Transform::Identity();
  std::vector<Eigen::Vector3f> wall_S_;
};

NodeConfig nodeConfig(int domain_id) {
  NodeConfig config;
  config.dds = localhostConfig(domain_id);
  return config;
}

/// Log lines of a node, kept for inspection.
struct CapturedLog {
  std::mutex mutex;
  std::vector<std::string> lines;
  LogSink sink() {
    return [this](LogLevel, const std::string& line) {
      std::lock_guard<std::mutex> lock(mutex);
      lines.push_back(line);
    };
  }
  int count(const std::string& part) {
    std::lock_guard<std::mutex> lock(mutex);
    int n = 0;
    for (const std::string& line : lines) n += line.find(part) != std::string::npos ? 1 : 0;
    return n;
  }
};

/// Waits until the engine mapped `frames` frames. Poses and clouds travel on different topics, so
/// the tests wait for the outcome they expect rather than for a message count.
bool mapped(const MappingNode& node, std::uint64_t frames) {
  return waitFor([&] { return node.engineStats().frames_mapped == frames; });
}

/// Waits until `counter` of the node reaches `value`.
bool counted(const MappingNode& node, std::uint64_t NodeCounters::*counter, std::uint64_t value) {
  return waitFor([&] { return node.counters().*counter == value; });
}

TEST(MappingNodeInput, MalformedCloudsAreRejectedCountedLoggedOnceAndGoodFramesStillMapped) {
  const NodeConfig config = nodeConfig(171);
  CapturedLog log;
  MappingNode node(config, log.sink());
  SensorSide sensor(171, config);
  ASSERT_TRUE(sensor.matched(node)) << "the node's readers did not match";

  double t_s = 100.0;
  sensor.frame(t_s);
  ASSERT_TRUE(mapped(node, 1)) << "a good frame was not mapped";

  // Each breaks one rule of sensor_msgs/PointCloud2; a decoder that trusted it would read out of
  // bounds or map garbage.
  using Mutation = std::function<void(sensor_msgs::PointCloud2_&)>;
  const std::vector<Mutation> broken = {
      [](auto& m) { m.data_().pop_back(); },            // data shorter than the sizes
      [](auto& m) { m.data_().push_back(0); },          // data longer than the sizes
      [](auto& m) { m.row_step_(m.row_step_() - 1); },  // row_step < width * point_step
      [](auto& m) {
        m.point_step_(8);
        m.row_step_(8 * m.width_());
        m.data_().resize(m.row_step_());
      },
      [](auto& m) { m.fields_().pop_back(); },                      // no z
      [](auto& m) { m.fields_()[0].datatype_(5); },                 // x as INT32
      [](auto& m) { m.fields_()[1].offset_(2); },                   // y overlaps x
      [](auto& m) { m.fields_()[2].count_(0); },                    // z with count 0
      [](auto& m) { m.header_().stamp_().nanosec_(1000000000u); },  // not a time
  };
  for (std::size_t i = 0; i < broken.size(); ++i) {
    t_s += 0.1;
    sensor_msgs::PointCloud2_ msg = sensor.wallCloud(t_s);
    broken[i](msg);
    sensor.pose(t_s - 0.01);
    sensor.pose(t_s + 0.01);
    sensor.cloud(msg);
    ASSERT_TRUE(counted(node, &NodeCounters::inputs_malformed, i + 1)) << "broken cloud " << i;
  }
  // Payloads Fast CDR cannot parse never reach the node's input thread (no clouds_received).
  t_s += 0.1;
  RawBytes truncated = cloudBytes(static_cast<std::int32_t>(t_s), 0);
  truncated.resize(truncated.size() - 8);
  sensor.rawCloud(truncated);
  sensor.rawCloud(cloudBytes(static_cast<std::int32_t>(t_s), 9));
  ASSERT_TRUE(counted(node, &NodeCounters::inputs_malformed, broken.size() + 2))
      << "malformed clouds counted: " << node.counters().inputs_malformed
      << " (clouds received: " << node.counters().clouds_received << ")";

  // Non-finite points are not a malformed cloud: the frame is mapped, the points are counted.
  t_s += 0.1;
  sensor_msgs::PointCloud2_ with_nan = sensor.wallCloud(t_s);
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity()};
  for (std::size_t i = 0; i < 3; ++i)
    std::memcpy(with_nan.data_().data() + 12 * i + 4 * i, &bad[i], 4);
  sensor.pose(t_s - 0.01);
  sensor.pose(t_s + 0.01);
  sensor.cloud(with_nan);
  ASSERT_TRUE(mapped(node, 2)) << "a cloud with some non-finite points was not mapped";

  t_s += 0.1;
  sensor.frame(t_s);
  ASSERT_TRUE(mapped(node, 3)) << "good frames after bad ones must still be mapped";

  // The engine may finish a frame before the input thread counts it as submitted.
  EXPECT_TRUE(counted(node, &NodeCounters::frames_submitted, 3));
  const NodeCounters c = node.counters();
  const EngineStats e = node.engineStats();
  EXPECT_EQ(c.inputs_malformed, broken.size() + 2);
  EXPECT_EQ(c.clouds_received, 1 + broken.size() + 2);  // not the two raw ones
  EXPECT_EQ(c.frames_submitted, 3u);
  EXPECT_EQ(e.frames_mapped, 3u);
  EXPECT_EQ(e.points.rejected_non_finite, 3u);
  EXPECT_GT(e.points.hit_voxels, 0u);
  // One log line for the burst (the limit is one per reason and second), not one per cloud.
  const int lines = log.count("malformed");
  EXPECT_GE(lines, 1);
  EXPECT_LE(lines, 2);
}

TEST(MappingNodeInput, BadPosesAndStampsAreRejectedAndCountedAndMappingResumesWithThePoses) {
  const NodeConfig config = nodeConfig(172);
  CapturedLog log;
  MappingNode node(config, log.sink());
  SensorSide sensor(172, config);
  ASSERT_TRUE(sensor.matched(node));
  double t_s = 200.0;
  sensor.frame(t_s);
  ASSERT_TRUE(mapped(node, 1));

  // Poses that must never be used: not a rotation, not finite, older than the newest, far ahead.
  const double newest_s = t_s + 0.01;
  sensor.pose(newest_s + 0.01, Eigen::Quaterniond(2.0, 0.0, 0.0, 0.0));  // norm 2
  sensor.pose(newest_s + 0.02, Eigen::Quaterniond::Identity(), std::nan(""));
  sensor.pose(newest_s - 0.5);
  sensor.pose(newest_s + config.dds.max_future_s + 5.0);
  ASSERT_TRUE(counted(node, &NodeCounters::poses_received, 2 + 4));
  NodeCounters c = node.counters();
  EXPECT_EQ(c.inputs_malformed, 2u) << "non-unit quaternion and NaN position";
  EXPECT_EQ(c.poses_rejected, 2u) << "out of order and far future";

  // A cloud far ahead of every pose: dropped at once (no pose will ever be close to it).
  sensor.cloud(sensor.wallCloud(newest_s + config.dds.max_future_s + 2.0));
  EXPECT_TRUE(counted(node, &NodeCounters::frames_future, 1));

  // A cloud older than the last mapped frame, though it has poses: the engine refuses it.
  sensor.cloud(sensor.wallCloud(t_s - 0.005));
  EXPECT_TRUE(counted(node, &NodeCounters::frames_engine_rejected, 1));

  // The pose stream stops: a newer cloud waits for its pose, then is dropped, not mapped with
  // the last pose.
  sensor.cloud(sensor.wallCloud(newest_s + 0.2));
  ASSERT_TRUE(counted(node, &NodeCounters::frames_without_pose, 1))
      << "a frame without a pose was not dropped";
  // A cloud in a gap of the pose stream (nearest pose 0.5 s away): dropped, not interpolated.
  t_s = newest_s + 1.0;
  sensor.pose(t_s);
  sensor.cloud(sensor.wallCloud(t_s - 0.5));
  ASSERT_TRUE(counted(node, &NodeCounters::frames_without_pose, 2));

  // Poses resume: mapping resumes.
  for (int k = 1; k <= 3; ++k) {
    sensor.frame(t_s + 0.1 * k);
    ASSERT_TRUE(mapped(node, 1 + static_cast<std::uint64_t>(k))) << "mapping did not resume";
  }
  EXPECT_TRUE(counted(node, &NodeCounters::frames_submitted, 4));
  c = node.counters();
  EXPECT_EQ(c.frames_engine_rejected, 1u);
  EXPECT_EQ(c.frames_without_pose, 2u);
  EXPECT_EQ(node.engineStats().rejected_out_of_order, 1u);
  EXPECT_GE(log.count("no pose within"), 1);
  EXPECT_GE(log.count("rejected a pose"), 1);
}

TEST(MappingNodeInput, OdometryInsteadOfPoseStampedPairsAndMaps) {
  NodeConfig config = nodeConfig(173);
  config.dds.topics.pose = "";
  config.dds.topics.odometry = "odom";
  MappingNode node(config);
  SensorSide sensor(173, config);
  ASSERT_TRUE(sensor.matched(node));
  for (int k = 0; k < 3; ++k) {
    sensor.frame(300.0 + 0.1 * k);
    ASSERT_TRUE(mapped(node, static_cast<std::uint64_t>(k) + 1));
  }
  EXPECT_EQ(node.counters().poses_received, 6u);
  EXPECT_EQ(node.engineStats().frames_mapped, 3u);
  EXPECT_GT(node.engineStats().points.hit_voxels, 0u);
}

TEST(MappingNodeInput, PublishersAreCountedAndLoggedAsTheyMatchAndLeave) {
  const NodeConfig config = nodeConfig(176);
  CapturedLog log;
  MappingNode node(config, log.sink());
  EXPECT_EQ(node.counters().publishers_matched, 0u);
  {
    SensorSide sensor(176, config);  // cloud, pose and raw cloud writers
    ASSERT_TRUE(sensor.matched(node));
    EXPECT_EQ(log.count(": a publisher matched ("), 3);
    EXPECT_EQ(log.count("rt/cloud: a publisher matched (2 now)"), 1);
    EXPECT_EQ(log.count("rt/pose: a publisher matched (1 now)"), 1);
  }
  ASSERT_TRUE(counted(node, &NodeCounters::publishers_matched, 0))
      << "the sensor's writers are gone";
  EXPECT_EQ(log.count(": a publisher left ("), 3);
  EXPECT_EQ(log.count("rt/cloud: a publisher left (0 now)"), 1);
}

// What a configuration will not do is said at start: a range beyond the local window, no sensor
// topic, and the memory of the configured layers.
TEST(MappingNodeStart, SaysWhatItsConfigurationWillNotDo) {
  NodeConfig config = nodeConfig(178);
  config.map.awareness.rho_cells = 300;
  config.map.awareness.max_range_m = 30.0;
  config.dds.topics.cloud.clear();
  config.dds.topics.depth_image.clear();
  config.dds.topics.camera_info.clear();
  CapturedLog log;
  { MappingNode node(config, log.sink()); }
  EXPECT_EQ(log.count("awareness.max_range_m (30 m) reaches beyond the local window"), 1);
  EXPECT_EQ(log.count("farther than 7.6 to 11.4 m from the body (by where it is in its submap) go "
                      "to the global map without their free space"),
            1);
  EXPECT_EQ(log.count("local_map.size_cells 375 x 375 horizontally holds the range"), 1);
  EXPECT_EQ(log.count("no sensor topic is configured"), 1);
  EXPECT_EQ(log.count("memory of the configured layers (global map not included): "), 1);
  config.map = MapConfig{};  // defaults: a 10 m range, a 19 m window (3 submaps: 11.4 m)
  config.dds.topics = TopicNames{};
  CapturedLog quiet;
  { MappingNode node(config, quiet.sink()); }
  EXPECT_EQ(quiet.count("reaches beyond the local window"), 0);
  EXPECT_EQ(quiet.count("no sensor topic"), 0);
  EXPECT_EQ(quiet.count("no pose topic"), 0);
}

// A subscriber asking for more than a layer's writer offers (here TRANSIENT_LOCAL of the
// VOLATILE local map, as a map display may) gets nothing from DDS and no error: the node says so.
TEST(MappingNodeOutput, SubscribersWithIncompatibleQosAreLoggedWithThePolicyAndCounted) {
  const NodeConfig config = nodeConfig(177);
  CapturedLog log;
  MappingNode node(config, log.sink());
  const ParticipantPtr ground = createParticipant(localhostConfig(177), "ground");
  fdds::Subscriber* subscriber = ground->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  TakeListener<PointCloud2_> ignore([](PointCloud2_&&) {}, [](const std::string&) {});
  const std::string topic = "rt/" + config.dds.topics.local_map;
  fdds::DataReader* volatile_reader = createReader<sensor_msgs::PointCloud2_PubSubType>(
      subscriber, topic, reliableReaderQos(false), &ignore);
  fdds::DataReader* latched_reader = createReader<sensor_msgs::PointCloud2_PubSubType>(
      subscriber, topic, reliableReaderQos(true), &ignore);
  ASSERT_TRUE(waitFor([&] { return readerMatched(volatile_reader); }));
  ASSERT_TRUE(counted(node, &NodeCounters::subscribers_incompatible, 1));
  EXPECT_FALSE(readerMatched(latched_reader));
  EXPECT_EQ(log.count(topic + ": a subscriber requests a QoS this writer does not offer "
                              "(DURABILITY, this writer offers VOLATILE); it receives nothing"),
            1);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(node.counters().subscribers_incompatible, 1u) << "only the TRANSIENT_LOCAL reader";
}

// Hits beyond the local window are not dropped without a word: their evidence goes to the
// global map, and the node's status (layout version 3) says how many, as the engine counted.
TEST(MappingNodeOutput, TheStatusCountsTheHitsOutsideTheLocalWindow) {
  constexpr int kDomain = 181;
  NodeConfig config = nodeConfig(kDomain);
  config.map.local_map.size_cells =
      Eigen::Vector3i(15, 15, 35);  // reach 1.2-1.8 m; the wall is at 3 m
  ASSERT_LT(1.5 * config.map.local_map.horizontalReach_m(), 3.0);
  const ParticipantPtr ground = createParticipant(localhostConfig(kDomain), "ground");
  std::mutex mutex;
  mlmap_msgs::Status_ last;
  TakeListener<mlmap_msgs::Status_> listener(
      [&](mlmap_msgs::Status_&& status) {
        std::lock_guard<std::mutex> lock(mutex);
        last = std::move(status);
      },
      [](const std::string& what) { ADD_FAILURE() << what; });
  createReader<mlmap_msgs::Status_PubSubType>(
      ground->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT), "rt/" + config.dds.topics.status,
      reliableReaderQos(), &listener);
  MappingNode node(config);
  SensorSide sensor(kDomain, config);
  ASSERT_TRUE(sensor.matched(node));
  for (std::uint64_t k = 1; k <= 3; ++k) {
    sensor.frame(700.0 + 0.1 * static_cast<double>(k));
    ASSERT_TRUE(mapped(node, k));
  }
  const EngineStats s = node.engineStats();
  ASSERT_GT(s.points.hits_beyond_local_map, 0u) << "every point of the wall lies beyond the reach";
  ASSERT_GT(s.hits_to_global, 0u);
  const auto status = [&] {
    std::lock_guard<std::mutex> lock(mutex);
    return last;
  };
  ASSERT_TRUE(waitFor([&] { return status().frames_mapped_() == 3; }))
      << "no status after 3 frames";
  const mlmap_msgs::Status_ m = status();
  EXPECT_EQ(m.version_(), 3u);
  EXPECT_EQ(m.hits_beyond_local_map_(), s.points.hits_beyond_local_map);
  EXPECT_EQ(m.hits_outside_window_(), s.local.hits_outside_window);
  EXPECT_EQ(m.hits_to_global_map_(), s.hits_to_global);
  EXPECT_EQ(m.hits_lost_(), 0u);
  EXPECT_EQ(s.hits_lost, 0u);
  EXPECT_GT(m.global_voxels_(), 0u) << "the wall is in the global map";
}

/// Every sample a TakeListener delivered, in order, kept for inspection.
template <typename T>
struct Samples {
  std::mutex mutex;
  std::vector<T> all;
  TakeListener<T> listener{[this](T&& sample) {
                             std::lock_guard<std::mutex> lock(mutex);
                             all.push_back(std::move(sample));
                           },
                           [](const std::string&) {}};
  std::vector<T> samples() {
    std::lock_guard<std::mutex> lock(mutex);
    return all;
  }
};

/// Value of the OccupancyGrid cell holding world point (x, y); -2 outside the grid.
int gridValueAt(const nav_msgs::OccupancyGrid_& grid, double x_m, double y_m) {
  const auto& info = grid.info_();
  const int cx =
      static_cast<int>(std::floor((x_m - info.origin_().position_().x_()) / info.resolution_()));
  const int cy =
      static_cast<int>(std::floor((y_m - info.origin_().position_().y_()) / info.resolution_()));
  if (cx < 0 || cy < 0 || cx >= static_cast<int>(info.width_()) ||
      cy >= static_cast<int>(info.height_())) {
    return -2;
  }
  return grid.data_()[static_cast<std::size_t>(cy) * info.width_() + static_cast<std::size_t>(cx)];
}

// The fixed-origin map grid (nav2's static layer) keeps every wall the vehicle passed, also
// those the rolling grid (the local window) has left behind; its origin only moves by whole
// chunks towards -x / -y, and where the final rolling grid knows a cell the map agrees with it.
TEST(MappingNodeOutput, TheMapGridKeepsWhatTheRollingGridLeftBehindOnAFixedLattice) {
  constexpr int kDomain = 179;
  NodeConfig config = nodeConfig(kDomain);
  config.dds.rates.map_grid_hz = 50.0;
  config.dds.rates.grid_hz = 50.0;
  Samples<nav_msgs::OccupancyGrid_> maps;
  Samples<nav_msgs::OccupancyGrid_> grids;
  const ParticipantPtr ground = createParticipant(localhostConfig(kDomain), "ground");
  fdds::Subscriber* subscriber = ground->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  ASSERT_NE(createReader<nav_msgs::OccupancyGrid_PubSubType>(
                subscriber, "rt/" + config.dds.topics.map_grid, reliableReaderQos(true, 100),
                &maps.listener),
            nullptr);
  ASSERT_NE(createReader<nav_msgs::OccupancyGrid_PubSubType>(
                subscriber, "rt/" + config.dds.topics.grid, reliableReaderQos(true, 100),
                &grids.listener),
            nullptr);
  std::vector<double> walls_x;
  {
    MappingNode node(config, [](LogLevel, const std::string&) {});
    SensorSide sensor(kDomain, config);
    ASSERT_TRUE(sensor.matched(node));
    const Eigen::Quaterniond level = Eigen::Quaterniond::Identity();
    for (int i = 0; i < 12; ++i) {  // 3 m a second along +x: 33 m, beyond the 19 m window
      const double x_m = 3.0 * i;
      const double stamp_s = 1.0 + i;
      sensor.pose(stamp_s - 0.01, level, x_m);
      sensor.pose(stamp_s + 0.01, level, x_m);
      sensor.cloud(sensor.wallCloud(stamp_s));
      ASSERT_TRUE(mapped(node, static_cast<std::uint64_t>(i + 1)));
      walls_x.push_back(x_m + 3.0);
      std::this_thread::sleep_for(std::chrono::milliseconds(60));  // a grid per frame
    }
  }  // the node publishes its final state as it stops
  ASSERT_TRUE(waitFor([&] { return !maps.samples().empty() && !grids.samples().empty(); }));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const std::vector<nav_msgs::OccupancyGrid_> all_maps = maps.samples();
  const nav_msgs::OccupancyGrid_& map = all_maps.back();
  const nav_msgs::OccupancyGrid_ grid = grids.samples().back();
  const double res = map.info_().resolution_();
  const double chunk_m = 64 * res;
  double first_x = 0.0;
  double first_y = 0.0;
  for (std::size_t k = 0; k < all_maps.size(); ++k) {
    const auto& origin = all_maps[k].info_().origin_().position_();
    EXPECT_NEAR(std::remainder(origin.x_(), chunk_m), 0.0, 1e-6);
    EXPECT_NEAR(std::remainder(origin.y_(), chunk_m), 0.0, 1e-6);
    EXPECT_EQ(all_maps[k].info_().width_() % 64, 0u);
    if (k == 0) {
      first_x = origin.x_();
      first_y = origin.y_();
    }
    EXPECT_LE(origin.x_(), first_x + 1e-9);
    EXPECT_LE(origin.y_(), first_y + 1e-9);
  }
  // Every wall is an obstacle in the map; the first ones are no longer in the rolling grid.
  int walls_outside_rolling_grid = 0;
  for (const double x_m : walls_x) {
    const bool in_map = gridValueAt(map, x_m - 0.5 * res, 0.05) == 100 ||
                        gridValueAt(map, x_m + 0.5 * res, 0.05) == 100;
    EXPECT_TRUE(in_map) << "wall at x = " << x_m;
    walls_outside_rolling_grid += gridValueAt(grid, x_m, 0.05) == -2 ? 1 : 0;
  }
  EXPECT_GE(walls_outside_rolling_grid, 3);
  // Where the final rolling grid knows a cell, the map holds its value.
  const auto& g = grid.info_();
  std::size_t compared = 0;
  std::size_t mismatches = 0;
  for (std::uint32_t cy = 0; cy < g.height_(); ++cy) {
    for (std::uint32_t cx = 0; cx < g.width_(); ++cx) {
      const int value = grid.data_()[cy * g.width_() + cx];
      if (value < 0) continue;
      const double x_m = g.origin_().position_().x_() + (cx + 0.5) * g.resolution_();
      const double y_m = g.origin_().position_().y_() + (cy + 0.5) * g.resolution_();
      if (gridValueAt(map, x_m, y_m) != value) ++mismatches;
      ++compared;
    }
  }
  EXPECT_GT(compared, 100u);
  EXPECT_EQ(mismatches, 0u) << "of " << compared;
}

// mlmap_sensor_publisher's cloud writer offers data-sharing. Here the sensor's one transport
// drops every DATA_FRAG it sends, so its 0.45 MB clouds (many fragments) reach the node only by
// data-sharing: with dds.data_sharing true every frame is mapped; with false no cloud arrives,
// while the poses (one small DATA each) still do. (Delivery within the process is off, as
// between mlmap_sensor_publisher and mlmap_node.)
TEST(MappingNodeInput, CloudsOfADataSharingWriterAreReadInItsMemoryUnlessDataSharingIsOff) {
  const test_support::NoIntraprocessDelivery between_processes;
  for (const bool data_sharing : {true, false}) {
    SCOPED_TRACE(data_sharing ? "dds.data_sharing true" : "dds.data_sharing false");
    const int domain_id = data_sharing ? 174 : 175;
    NodeConfig config = nodeConfig(domain_id);
    config.dds.data_sharing = data_sharing;
    MappingNode node(config);
    SensorOptions options;
    options.data_sharing = true;
    options.transport_drops_fragments = true;
    options.wall_step_m = 0.005;
    SensorSide sensor(domain_id, config, options);
    ASSERT_GT(sensor.cloudBytes(), 400'000u) << "the cloud must span many fragments";
    ASSERT_TRUE(sensor.matched(node));
    for (std::uint64_t k = 1; k <= 3; ++k) {
      sensor.frame(400.0 + 0.1 * static_cast<double>(k));
      if (data_sharing) {
        ASSERT_TRUE(mapped(node, k));
      }
    }
    ASSERT_TRUE(counted(node, &NodeCounters::poses_received, 6));
    if (data_sharing) {
      EXPECT_EQ(node.counters().clouds_received, 3u);
      EXPECT_GT(node.engineStats().points.hit_voxels, 0u);
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      EXPECT_EQ(node.counters().clouds_received, 0u) << "the transport was to drop every cloud";
    }
  }
}

// ---- A foreign participant on the same host ------------------------------------------------

/// What a participant learns of the others through discovery: each one's announced locators and
/// the data-sharing its readers and writers announce.
class DiscoveryLog : public fdds::DomainParticipantListener {
 public:
  struct Peer {
    std::vector<eprosima::fastrtps::rtps::Locator_t> locators;  ///< default + metatraffic unicast
    std::vector<fdds::DataSharingQosPolicy> data_sharing;       ///< of each endpoint
    std::vector<std::string> topics;                            ///< of each endpoint
  };

  void on_participant_discovery(
      fdds::DomainParticipant*,
      eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override {
    if (info.status != eprosima::fastrtps::rtps::ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT)
      return;
    std::lock_guard<std::mutex> lock(mutex_);
    Peer& peer = peers_[prefixOf(info.info.m_guid)];
    for (const auto* list : {&info.info.default_locators, &info.info.metatraffic_locators}) {
      for (const auto& l : list->unicast) peer.locators.push_back(l);
      for (const auto& l : list->multicast) peer.locators.push_back(l);
    }
    names_[info.info.m_participantName.to_string()] = prefixOf(info.info.m_guid);
  }
  void on_subscriber_discovery(fdds::DomainParticipant*,
                               eprosima::fastrtps::rtps::ReaderDiscoveryInfo&& info) override {
    endpoint(info.info.guid(), info.info.topicName().to_string(), info.info.m_qos.data_sharing);
  }
  void on_publisher_discovery(fdds::DomainParticipant*,
                              eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override {
    endpoint(info.info.guid(), info.info.topicName().to_string(), info.info.m_qos.data_sharing);
  }

  /// The participant named `name` as discovered so far (empty when it was not).
  Peer peer(const std::string& name) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto found = names_.find(name);
    return found == names_.end() ? Peer{} : peers_[found->second];
  }

 private:
  static std::string prefixOf(const eprosima::fastrtps::rtps::GUID_t& guid) {
    std::ostringstream text;
    text << guid.guidPrefix;
    return text.str();
  }
  void endpoint(const eprosima::fastrtps::rtps::GUID_t& guid, const std::string& topic,
                const fdds::DataSharingQosPolicy& data_sharing) {
    std::lock_guard<std::mutex> lock(mutex_);
    Peer& peer = peers_[prefixOf(guid)];
    peer.data_sharing.push_back(data_sharing);
    peer.topics.push_back(topic);
  }

  std::mutex mutex_;
  std::map<std::string, std::string> names_;  ///< participant name -> GUID prefix
  std::map<std::string, Peer> peers_;         ///< by GUID prefix
};

// A ROS 2 Jazzy node on its default rmw (Fast DDS 2.14) announces shared-memory locators and
// data-sharing in its host's automatic domain; Fast DDS 2.9 aborts when it opens a 2.14 segment.
// Here the foreign participants are Fast DDS 2.9 set up as that node (SHM + UDPv4 on 127.0.0.1):
// the node must offer them UDP locators only, announce data-sharing in mlmap's own domain alone,
// and exchange samples with them both ways (over UDP, the one transport both sides have).
TEST(ForeignPeer, IsOfferedNoSharedMemoryAndSamplesCrossBothWays) {
  const test_support::NoIntraprocessDelivery between_processes;
  constexpr int kDomain = 180;
  const NodeConfig config = nodeConfig(kDomain);
  ASSERT_FALSE(config.dds.shared_memory) << "the default";
  DiscoveryLog discovered;
  DdsConfig foreign_config = localhostConfig(kDomain);
  foreign_config.shared_memory = true;
  const ParticipantSetup foreign_setup = participantSetup(foreign_config, "ros2_monitor");
  ParticipantPtr monitor(fdds::DomainParticipantFactory::get_instance()->create_participant(
      kDomain, foreign_setup.qos, &discovered, fdds::StatusMask::none()));
  ASSERT_TRUE(monitor);
  fdds::Subscriber* subscriber = monitor->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  std::atomic<int> statuses{0};
  TakeListener<mlmap_msgs::Status_> status_listener([&](mlmap_msgs::Status_&&) { ++statuses; },
                                                    [](const std::string&) {});
  createReader<mlmap_msgs::Status_PubSubType>(subscriber, "rt/" + config.dds.topics.status,
                                              reliableReaderQos(), &status_listener);

  MappingNode node(config);
  SensorOptions options;
  options.shared_memory = true;
  SensorSide sensor(kDomain, config, options);
  ASSERT_TRUE(sensor.matched(node));
  for (std::uint64_t k = 1; k <= 3; ++k) {
    sensor.frame(500.0 + 0.1 * static_cast<double>(k));
    ASSERT_TRUE(mapped(node, k)) << "a frame from a participant with shared memory was not mapped";
  }
  ASSERT_TRUE(waitFor([&] { return statuses > 0; })) << "no status reached the foreign reader";

  const DiscoveryLog::Peer peer = discovered.peer("mlmap_node");
  ASSERT_FALSE(peer.locators.empty()) << "the node was not discovered";
  for (const eprosima::fastrtps::rtps::Locator_t& l : peer.locators) {
    EXPECT_EQ(l.kind, LOCATOR_KIND_UDPv4) << "the node offers a locator of kind " << l.kind << " ("
                                          << LOCATOR_KIND_SHM << " is shared memory)";
  }
  ASSERT_TRUE(waitFor([&] { return discovered.peer("mlmap_node").topics.size() >= 3; }));
  const DiscoveryLog::Peer endpoints = discovered.peer("mlmap_node");
  int sharing = 0;
  for (std::size_t i = 0; i < endpoints.topics.size(); ++i) {
    const fdds::DataSharingQosPolicy& d = endpoints.data_sharing[i];
    // Fast DDS 2.9 announces no data-sharing parameter for an endpoint without it, which the
    // receiving side reads as its default: AUTO with no domain (no data-sharing with anyone).
    if (d.kind() == fdds::OFF || d.domain_ids().empty()) continue;
    ++sharing;
    EXPECT_EQ(d.domain_ids(), std::vector<std::uint64_t>{dataSharingDomainId()})
        << endpoints.topics[i] << " announces data-sharing outside mlmap's domain";
  }
  EXPECT_GE(sharing, 1) << "the cloud reader accepts data-sharing from mlmap's publisher";
}

}  // namespace
}  // namespace mlmap::dds
