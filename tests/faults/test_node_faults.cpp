// Faults at the mapping node's inputs and outputs, in process, over DDS on loopback (domains
// 200..205, 208, 209): the sensor stream stops and resumes; the pose stream lags, jumps and goes
// backwards; clouds arrive faster than the engine maps; a subscriber leaves and returns. Each test
// asserts the behaviour docs/soak-and-faults.md documents. The vehicle is a sparse simulated LiDAR
// (the sensor frame is the body frame) in two rooms 40 m apart.
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/mapping_node.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"
#include "mlmap/sim/lidar.h"
#include "mlmap/sim/world.h"

#include "dds_test_support.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
using test_support::localhostConfig;
using test_support::waitFor;
using test_support::writerMatched;

constexpr double kHeight_m = 1.5;
constexpr double kRoomB_x_m = 40.0;  // room A is centred on x = 0

Transform bodyAt(double x_m, double yaw_rad = 0.0) {
  Transform T = Transform::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, 0.0, kHeight_m);
  return T;
}

/// Two closed 12 x 12 m rooms with a floor, centred on x = 0 and x = 40; nothing in between.
sim::World twoRooms() {
  sim::World world;
  for (double cx : {0.0, kRoomB_x_m}) {
    world.addBox({Eigen::Vector3d(cx - 6.0, -6.0, -0.2), Eigen::Vector3d(cx + 6.0, 6.0, 0.0)});
    world.addBox({Eigen::Vector3d(cx - 6.2, -6.0, 0.0), Eigen::Vector3d(cx - 6.0, 6.0, 3.0)});
    world.addBox({Eigen::Vector3d(cx + 6.0, -6.0, 0.0), Eigen::Vector3d(cx + 6.2, 6.0, 3.0)});
    world.addBox({Eigen::Vector3d(cx - 6.2, -6.2, 0.0), Eigen::Vector3d(cx + 6.2, -6.0, 3.0)});
    world.addBox({Eigen::Vector3d(cx - 6.2, 6.0, 0.0), Eigen::Vector3d(cx + 6.2, 6.2, 3.0)});
    world.addCylinder({Eigen::Vector2d(cx + 2.0, 2.5), 0.4, 0.0, 3.0});
  }
  return world;
}

/// A node on loopback whose sensor is its body (a LiDAR mounted level at the body origin).
NodeConfig lidarNodeConfig(int domain_id) {
  NodeConfig config;
  config.dds = localhostConfig(domain_id);
  config.map.sensor.translation_B_m = Eigen::Vector3d::Zero();
  config.map.sensor.rotation_rpy_deg = Eigen::Vector3d::Zero();
  return config;
}

/// The vehicle's side: a LiDAR driver publishing clouds and an odometry source publishing
/// PoseStamped, each stamped as the test says.
class Vehicle {
 public:
  Vehicle(int domain_id, const NodeConfig& config, int beams = 16, int azimuth_steps = 180)
      : participant_(createParticipant(localhostConfig(domain_id), "fault_vehicle")),
        world_(twoRooms()),
        lidar_([&] {
          sim::LidarModel m;
          m.beams = beams;
          m.azimuth_steps = azimuth_steps;
          m.max_range_m = config.map.awareness.max_range_m;
          return m;
        }()),
        sensor_frame_(config.dds.sensor_frame) {
    fdds::Publisher* publisher = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    cloud_ = createWriter<sensor_msgs::PointCloud2_PubSubType>(
        publisher, "rt/" + config.dds.topics.cloud, reliableWriterQos(50));
    pose_ = createWriter<geometry_msgs::PoseStamped_PubSubType>(
        publisher, "rt/" + config.dds.topics.pose, reliableWriterQos(200));
  }

  /// Waits until both writers and the node's readers matched each other, on both sides: the
  /// node's BEST_EFFORT readers drop what comes before they learnt of the writers.
  bool matched(const MappingNode& node) const {
    return waitFor([&] {
      return writerMatched(cloud_) && writerMatched(pose_) &&
             node.counters().publishers_matched == 2;
    });
  }

  void pose(double stamp_s, const Transform& T_W_B) {
    geometry_msgs::PoseStamped_ msg = toPoseStamped(T_W_B, stamp_s, "map");
    ASSERT_TRUE(pose_->write(&msg));
  }

  /// What the LiDAR measures from `T_W_B` at `stamp_s`.
  [[nodiscard]] sensor_msgs::PointCloud2_ scan(double stamp_s, const Transform& T_W_B) const {
    PointCloudFrame frame;
    lidar_.render(world_, T_W_B, stamp_s, &frame);
    return encodePointCloud2(frame.points_S, nullptr, stamp_s, sensor_frame_);
  }

  void cloud(sensor_msgs::PointCloud2_ msg) { ASSERT_TRUE(cloud_->write(&msg)); }

  /// The pose at the stamp, then the scan from it.
  void frame(double stamp_s, const Transform& T_W_B) {
    pose(stamp_s, T_W_B);
    cloud(scan(stamp_s, T_W_B));
  }

 private:
  ParticipantPtr participant_;
  sim::World world_;
  sim::Lidar lidar_;
  std::string sensor_frame_;
  fdds::DataWriter* cloud_ = nullptr;
  fdds::DataWriter* pose_ = nullptr;
};

bool mapped(const MappingNode& node, std::uint64_t frames) {
  return waitFor([&] { return node.engineStats().frames_mapped == frames; });
}

/// The body position of the latest snapshot (what the last mapped frame was mapped at).
Eigen::Vector3d mappedAt(const MappingNode& node) {
  const std::shared_ptr<const MapSnapshot> snap = node.snapshot();
  if (!snap) return Eigen::Vector3d::Constant(std::nan(""));
  return snap->T_W_B().translation();
}

/// Flies `frames` frames from (t0_s, x0_m), 0.1 s and 0.1 m apart along x at `yaw_rad`; each must
/// be mapped, at its own pose, before the next goes out. `n` counts the frames mapped so far.
void flyMapped(Vehicle& vehicle, const MappingNode& node, double t0_s, double x0_m, int frames,
               std::uint64_t* n, double yaw_rad = 0.0) {
  for (int k = 0; k < frames; ++k) {
    const Transform T = bodyAt(x0_m + 0.1 * k, yaw_rad);
    vehicle.frame(t0_s + 0.1 * k, T);
    ASSERT_TRUE(mapped(node, ++*n)) << "frame " << k << " from t = " << t0_s << " s not mapped";
    EXPECT_NEAR((mappedAt(node) - T.translation()).norm(), 0.0, 1e-9);
  }
}

/// Every frame the node took is accounted for once: mapped, refused or dropped for its pose. (The
/// input thread counts a frame as submitted after the engine took it, maybe after it was mapped:
/// the counts settle a moment later.)
void expectEveryCloudAccountedFor(const MappingNode& node) {
  auto balanced = [&] {
    const NodeCounters c = node.counters();
    const EngineStats e = node.engineStats();
    return c.clouds_received == c.frames_submitted + c.frames_engine_rejected +
                                    c.frames_without_pose + c.frames_future +
                                    c.frames_across_pose_jump &&
           c.frames_submitted == e.frames_mapped + e.frames_dropped;
  };
  EXPECT_TRUE(waitFor(balanced)) << "received " << node.counters().clouds_received << ", submitted "
                                 << node.counters().frames_submitted << ", mapped "
                                 << node.engineStats().frames_mapped;
}

TEST(NodeFaults, SensorStreamStopsAndResumesWithoutStalePairing) {
  const NodeConfig config = lidarNodeConfig(200);
  MappingNode node(config);
  Vehicle vehicle(200, config);
  ASSERT_TRUE(vehicle.matched(node));
  // The vehicle flies along x at 0.5 m/s; poses at 50 Hz, clouds at 10 Hz between two poses.
  auto x_at = [](double t_s) { return 0.5 * (t_s - 10.0); };
  std::uint64_t n = 0;
  auto fly = [&](double from_s, double to_s, bool clouds, bool real_time) {
    for (int k = 0; from_s + 0.02 * k < to_s - 1e-9; ++k) {
      const double t = from_s + 0.02 * k;
      vehicle.pose(t, bodyAt(x_at(t)));
      if (clouds && k % 5 == 1) {
        const double t_cloud = t - 0.01;  // interpolated between this pose and the one before
        vehicle.cloud(vehicle.scan(t_cloud, bodyAt(x_at(t_cloud))));
        ASSERT_TRUE(mapped(node, ++n)) << "cloud at " << t_cloud << " not mapped";
        EXPECT_NEAR(mappedAt(node).x(), x_at(t_cloud), 1e-6) << "cloud at " << t_cloud;
      }
      if (real_time) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  };
  fly(10.0, 11.0, true, false);
  ASSERT_EQ(n, 10u);
  // The LiDAR stops for a second; the odometry goes on.
  fly(11.0, 12.0, false, true);
  EXPECT_EQ(node.engineStats().frames_mapped, 10u) << "something was mapped without a cloud";
  // A cloud of before the stop arrives late: older than what is mapped, it is refused, not
  // mapped with a newer pose.
  vehicle.cloud(vehicle.scan(10.55, bodyAt(x_at(10.55))));
  ASSERT_TRUE(waitFor([&] { return node.counters().frames_engine_rejected == 1; }));
  // The LiDAR resumes: every cloud is paired with the pose at its own stamp.
  fly(12.0, 13.0, true, false);
  ASSERT_EQ(n, 20u);
  // Both streams stop for 3 s of stamps (a driver and odometry restart), then resume.
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  fly(16.0, 17.0, true, false);
  ASSERT_EQ(n, 30u);

  const NodeCounters c = node.counters();
  EXPECT_EQ(c.clouds_received, 31u);
  EXPECT_EQ(c.frames_without_pose, 0u);
  EXPECT_EQ(c.frames_handover_dropped, 0u);
  // The first pose after the 3 s pause is more than max_future_s ahead: refused until the next
  // one confirms it, then both are used (the cloud between them was mapped above).
  EXPECT_EQ(c.poses_rejected, 1u);
  EXPECT_EQ(node.engineStats().rejected_out_of_order, 1u);
  expectEveryCloudAccountedFor(node);
}

TEST(NodeFaults, LaggingPosesMakeCloudsWaitAndTooLatePosesDropThem) {
  const NodeConfig config = lidarNodeConfig(201);
  MappingNode node(config);
  Vehicle vehicle(201, config);
  ASSERT_TRUE(vehicle.matched(node));
  vehicle.frame(20.0, bodyAt(0.0));
  ASSERT_TRUE(mapped(node, 1));

  // The pose lags 0.2 s behind the cloud: the cloud waits for it and is mapped at its own stamp.
  vehicle.cloud(vehicle.scan(20.1, bodyAt(0.1)));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(node.engineStats().frames_mapped, 1u) << "mapped before its pose came";
  vehicle.pose(20.09, bodyAt(0.09));
  vehicle.pose(20.11, bodyAt(0.11));
  ASSERT_TRUE(mapped(node, 2)) << "a cloud whose pose came 0.2 s late was not mapped";
  EXPECT_NEAR(mappedAt(node).x(), 0.1, 1e-9);

  // The pose lags more than the 0.5 s a cloud may wait: the cloud is dropped and counted, and
  // the late pose does not bring it back.
  vehicle.cloud(vehicle.scan(20.2, bodyAt(0.2)));
  ASSERT_TRUE(waitFor([&] { return node.counters().frames_without_pose == 1; }))
      << "a cloud whose pose never came in time was not dropped";
  vehicle.pose(20.19, bodyAt(0.19));
  vehicle.pose(20.21, bodyAt(0.21));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(node.engineStats().frames_mapped, 2u) << "a dropped cloud was mapped after all";

  // Poses on time again: mapping goes on.
  vehicle.frame(20.3, bodyAt(0.3));
  ASSERT_TRUE(mapped(node, 3));
  EXPECT_NEAR(mappedAt(node).x(), 0.3, 1e-9);
  expectEveryCloudAccountedFor(node);
}

TEST(NodeFaults, PoseJumpIsMappedAtTheNewPoseAndNothingIsSmearedBetween) {
  NodeConfig config = lidarNodeConfig(202);
  const std::string dir = ::testing::TempDir() + "mlmap_fault_jump_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  config.map_file.save_path = dir + "/map.mlmap";
  {
    MappingNode node(config);
    Vehicle vehicle(202, config);
    ASSERT_TRUE(vehicle.matched(node));
    std::uint64_t n = 0;
    flyMapped(vehicle, node, 30.0, 0.0, 5, &n);
    // The odometry relocalises: 40 m and a quarter turn within 20 ms. A cloud stamped between
    // the two poses would be interpolated half-way (20 m, where nothing is): it is dropped.
    vehicle.pose(30.5, bodyAt(0.5));
    vehicle.pose(30.52, bodyAt(kRoomB_x_m, M_PI / 2));
    vehicle.cloud(vehicle.scan(30.51, bodyAt(kRoomB_x_m, M_PI / 2)));
    ASSERT_TRUE(waitFor([&] { return node.counters().frames_across_pose_jump == 1; }))
        << "a cloud between the two poses of a jump was not dropped";
    // After the jump: mapped at the new pose.
    flyMapped(vehicle, node, 30.6, kRoomB_x_m, 5, &n, M_PI / 2);
    EXPECT_EQ(node.counters().frames_without_pose, 0u);
    expectEveryCloudAccountedFor(node);
  }  // stop(): saves the whole map, local and global layers
  const MapState state = io::loadMapFile(config.map_file.save_path);
  std::size_t room_a = 0, room_b = 0, between = 0;
  const double res = config.map.local_map.resolution_m;
  for (const io::OccupiedVoxel& v : io::occupiedVoxels(state)) {
    const double x = (v.index.x() + 0.5) * res;
    room_a += x < 6.5 ? 1 : 0;
    room_b += x > kRoomB_x_m - 6.5 ? 1 : 0;
    between += x > 8.0 && x < kRoomB_x_m - 8.0 ? 1 : 0;
  }
  EXPECT_GT(room_a, 100u) << "room A before the jump";
  EXPECT_GT(room_b, 100u) << "room B after the jump";
  EXPECT_EQ(between, 0u)
      << "voxels were mapped between the rooms: a frame was smeared across the jump";
  std::filesystem::remove_all(dir);
}

TEST(NodeFaults, PoseJumpLimitsComeFromTheConfiguration) {
  NodeConfig config = lidarNodeConfig(208);
  config.dds.max_pose_speed_mps = 5.0;  // default 50
  MappingNode node(config);
  Vehicle vehicle(208, config);
  ASSERT_TRUE(vehicle.matched(node));
  std::uint64_t n = 0;
  flyMapped(vehicle, node, 30.0, 0.0, 5, &n);
  // 0.5 m in 20 ms: 25 m/s, a flight under the default limit, a jump under this one.
  vehicle.pose(30.5, bodyAt(0.5));
  vehicle.pose(30.52, bodyAt(1.0));
  vehicle.cloud(vehicle.scan(30.51, bodyAt(0.75)));
  ASSERT_TRUE(waitFor([&] { return node.counters().frames_across_pose_jump == 1; }))
      << "dds.max_pose_speed_mps was not applied: the cloud was interpolated";
  flyMapped(vehicle, node, 30.6, 1.1, 3, &n);
  expectEveryCloudAccountedFor(node);
}

// The node's map file against what a supervisor and a user expect: a map saved on another time
// base (wall-clock stamps, then a sensor on sim time) is extended from the first live frame,
// said plainly; an existing map that was not loaded is never replaced without map_file.overwrite;
// temporary files of a save killed before its rename are removed at start.
TEST(NodeFaults, MapFileTimeBaseOverwriteAndLeftovers) {
  const std::string dir =
      ::testing::TempDir() + "mlmap_fault_map_file_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  NodeConfig config = lidarNodeConfig(209);
  config.map_file.save_path = dir + "/map.mlmap";
  {
    MappingNode node(config);
    Vehicle vehicle(209, config);
    ASSERT_TRUE(vehicle.matched(node));
    std::uint64_t n = 0;
    flyMapped(vehicle, node, 1000.0, 0.0, 5, &n);  // stamps of a wall clock
  }
  ASSERT_TRUE(io::isMapFile(config.map_file.save_path));
  const std::string saved = io::encodeMapFile(io::loadMapFile(config.map_file.save_path));

  // The same save_path, nothing loaded: the node refuses to start, the map stays.
  try {
    MappingNode node(config);
    ADD_FAILURE() << "a node started that would replace an existing map it did not load";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("map_file.save_path '" + config.map_file.save_path +
                                         "' already exists"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(io::encodeMapFile(io::loadMapFile(config.map_file.save_path)), saved);

  // Loaded, with a leftover of a killed save beside it, and a sensor on another time base.
  config.map_file.load_path = config.map_file.save_path;
  const std::string leftover = config.map_file.save_path + ".tmp-Ab12Cd";
  std::ofstream(leftover) << "half a map";
  std::vector<std::string> lines;
  std::mutex lines_mutex;
  {
    MappingNode node(config, [&](LogLevel, const std::string& m) {
      std::lock_guard<std::mutex> lock(lines_mutex);
      lines.push_back(m);
    });
    EXPECT_FALSE(std::filesystem::exists(leftover));
    Vehicle vehicle(209, config);
    ASSERT_TRUE(vehicle.matched(node));
    std::uint64_t n = 0;  // frames_mapped counts this run
    flyMapped(vehicle, node, 20.0, 0.0, 5, &n);
    EXPECT_EQ(node.engineStats().stamp_order_restarts, 1u);
    EXPECT_EQ(node.engineStats().rejected_out_of_order, 0u);
  }
  auto logged = [&](const std::string& text) {
    return std::any_of(lines.begin(), lines.end(),
                       [&](const std::string& l) { return l.find(text) != std::string::npos; });
  };
  EXPECT_TRUE(logged("removed 1 temporary file(s) of an interrupted save"));
  EXPECT_TRUE(logged("saved on another time base"));
  EXPECT_TRUE(logged("older than the map's last stamp 1000.4 s"));
  std::filesystem::remove_all(dir);
}

TEST(NodeFaults, BackwardPosesAreRejectedCountedAndMappingResumes) {
  const NodeConfig config = lidarNodeConfig(203);
  MappingNode node(config);
  Vehicle vehicle(203, config);
  ASSERT_TRUE(vehicle.matched(node));
  std::uint64_t n = 0;
  flyMapped(vehicle, node, 40.0, 0.0, 5, &n);
  // The odometry replays 20 poses of the past, somewhere else.
  for (int k = 1; k <= 20; ++k) vehicle.pose(40.4 - 0.02 * k, bodyAt(5.0));
  ASSERT_TRUE(waitFor([&] { return node.counters().poses_rejected == 20; }));
  // A cloud of that past: not mapped (it is older than the map), counted.
  vehicle.cloud(vehicle.scan(40.35, bodyAt(5.0)));
  ASSERT_TRUE(waitFor([&] {
    const NodeCounters c = node.counters();
    return c.frames_engine_rejected + c.frames_without_pose == 1;
  }));
  // The odometry goes forward again: mapping resumes with the right poses.
  flyMapped(vehicle, node, 40.5, 0.5, 5, &n);
  EXPECT_EQ(node.counters().poses_rejected, 20u);
  expectEveryCloudAccountedFor(node);
}

TEST(NodeFaults, CloudsFasterThanTheEngineAreDroppedOldestFirstAndNeverQueueUp) {
  NodeConfig config = lidarNodeConfig(204);
  config.map.local_map.resolution_m = 0.1;
  config.map.local_map.size_cells = Eigen::Vector3i(190, 190, 70);
  MappingNode node(config);
  Vehicle vehicle(204, config, 64, 1024);  // 65,536 rays: each frame costs the engine milliseconds
  ASSERT_TRUE(vehicle.matched(node));
  // Hovering in room A; the same scan over and over, each with its stamp and pose.
  const Transform T = bodyAt(0.0);
  sensor_msgs::PointCloud2_ scan = vehicle.scan(0.0, T);
  constexpr int kClouds = 400;
  constexpr double kPeriod_s = 0.01;
  // Frames that can still be mapped once the sensor stops: the hand-over (3), the one the input
  // thread holds, the engine's input queue, the one in the awareness stage, the batch queue, the
  // one in the local-global stage. A node that queued instead of dropping would map a backlog of
  // hundreds here.
  const std::uint64_t max_in_flight = 3 + 1 + config.map.pipeline.input_queue_capacity + 1 +
                                      config.map.pipeline.batch_queue_capacity + 1;
  auto index_of = [&](double stamp_s) {
    return static_cast<int>(std::lround(stamp_s / kPeriod_s));
  };
  std::vector<int> backlog;  // frames sent since the one the latest snapshot shows (printed only)
  for (int i = 1; i <= kClouds; ++i) {
    const double t = i * kPeriod_s;
    vehicle.pose(t, T);
    scan.header_().stamp_(toRosTime(t));
    vehicle.cloud(scan);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    const std::shared_ptr<const MapSnapshot> snap = node.snapshot();
    if (snap && snap->frame() > 0) backlog.push_back(i - index_of(snap->stamp_s()));
  }
  const std::uint64_t mapped_when_the_sensor_stopped = node.engineStats().frames_mapped;
  // The newest frame always survives the drops: the last one sent is the last one mapped.
  ASSERT_TRUE(waitFor([&] {
    const std::shared_ptr<const MapSnapshot> snap = node.snapshot();
    return snap && index_of(snap->stamp_s()) == kClouds;
  })) << "the last cloud sent was not mapped";
  const NodeCounters c = node.counters();
  const EngineStats e = node.engineStats();
  auto worst = [&](std::size_t from, std::size_t to) {
    return backlog.empty() ? 0 : *std::max_element(backlog.begin() + from, backlog.begin() + to);
  };
  const std::size_t q = backlog.size() / 4;
  std::printf(
      "sent %d clouds: %llu taken, %llu dropped at the hand-over, %llu in the engine's input "
      "queue, %llu mapped (%llu after the sensor stopped, bound %llu); frames between the "
      "newest sent and the newest mapped, worst of each quarter: %d %d %d %d\n",
      kClouds, static_cast<unsigned long long>(c.clouds_received + c.frames_handover_dropped),
      static_cast<unsigned long long>(c.frames_handover_dropped),
      static_cast<unsigned long long>(e.frames_dropped),
      static_cast<unsigned long long>(e.frames_mapped),
      static_cast<unsigned long long>(e.frames_mapped - mapped_when_the_sensor_stopped),
      static_cast<unsigned long long>(max_in_flight), worst(0, q), worst(q, 2 * q),
      worst(2 * q, 3 * q), worst(3 * q, backlog.size()));
  EXPECT_GT(c.frames_handover_dropped + e.frames_dropped, 0u)
      << "the engine kept up: no overload tested";
  EXPECT_LE(e.frames_mapped - mapped_when_the_sensor_stopped, max_in_flight)
      << "a backlog was mapped after the sensor stopped: frames queued up instead of being dropped";
  EXPECT_LE(c.clouds_received + c.frames_handover_dropped, static_cast<std::uint64_t>(kClouds));
  EXPECT_EQ(c.frames_without_pose, 0u);
  EXPECT_EQ(c.frames_engine_rejected, 0u);
  expectEveryCloudAccountedFor(node);
}

/// A ground station: the local map (volatile) and the latched global map and grid.
class GroundStation {
 public:
  explicit GroundStation(const NodeConfig& config)
      : participant_(createParticipant(localhostConfig(config.dds.domain_id), "fault_ground")) {
    fdds::Subscriber* subscriber = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    auto counting = [](std::atomic<int>* n) { return [n](auto&&) { ++*n; }; };
    local_ = std::make_unique<TakeListener<sensor_msgs::PointCloud2_>>(counting(&local_maps),
                                                                       [](auto&) {});
    global_ = std::make_unique<TakeListener<sensor_msgs::PointCloud2_>>(
        [this](sensor_msgs::PointCloud2_&& m) {
          global_points = static_cast<int>(m.width_() * m.height_());
          ++global_maps;
        },
        [](auto&) {});
    grid_ =
        std::make_unique<TakeListener<nav_msgs::OccupancyGrid_>>(counting(&grids), [](auto&) {});
    const TopicNames& t = config.dds.topics;
    local_reader_ = createReader<sensor_msgs::PointCloud2_PubSubType>(
        subscriber, "rt/" + t.local_map, reliableReaderQos(), local_.get());
    createReader<sensor_msgs::PointCloud2_PubSubType>(subscriber, "rt/" + t.global_map,
                                                      reliableReaderQos(true), global_.get());
    createReader<nav_msgs::OccupancyGrid_PubSubType>(subscriber, "rt/" + t.grid,
                                                     reliableReaderQos(true), grid_.get());
  }
  ~GroundStation() { participant_.reset(); }  // readers before their listeners

  /// Waits until the node's local map writer matched (the local map is volatile: what goes out
  /// before that is not for this station).
  bool matched() const {
    const bool ok = waitFor([&] { return test_support::readerMatched(local_reader_); });
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // and the writer this reader
    return ok;
  }

  std::atomic<int> local_maps{0}, global_maps{0}, grids{0}, global_points{-1};

 private:
  std::unique_ptr<TakeListener<sensor_msgs::PointCloud2_>> local_, global_;
  std::unique_ptr<TakeListener<nav_msgs::OccupancyGrid_>> grid_;
  ParticipantPtr participant_;
  fdds::DataReader* local_reader_ = nullptr;
};

// The ground station is another process in real use; here its participant is deleted and made
// again beside the node's, and Fast DDS 2.9's delivery within the process raced that deletion
// once under ASan (SEGV in StatefulWriter::intraprocess_gap), so the test goes through the
// transports as two processes do.
TEST(NodeFaults, SubscriberThatLeavesAndReturnsGetsTheLayersAgainAndMappingNeverWaits) {
  const test_support::NoIntraprocessDelivery between_processes;
  NodeConfig config = lidarNodeConfig(205);
  config.map.local_map.size_cells = Eigen::Vector3i(45, 45, 25);  // 9 m: flying 8 m retires submaps
  config.dds.rates.global_map_hz = 10.0;
  config.dds.rates.local_map_hz = 100.0;  // every frame's local map goes out
  MappingNode node(config);
  Vehicle vehicle(205, config);
  ASSERT_TRUE(vehicle.matched(node));
  std::uint64_t n = 0;
  double t = 50.0;
  auto fly = [&](int frames) {
    for (int k = 0; k < frames; ++k, t += 0.1) {
      vehicle.frame(t, bodyAt(0.2 * static_cast<double>(n) - 4.0));
      ASSERT_TRUE(mapped(node, ++n)) << "mapping stalled at frame " << n;
    }
  };
  auto ground = std::make_unique<GroundStation>(config);
  ASSERT_TRUE(ground->matched());
  fly(10);
  ASSERT_TRUE(waitFor([&] { return ground->local_maps > 0 && ground->global_maps > 0; }));
  ground.reset();  // the ground station leaves (its participant is gone)
  fly(30);         // mapping goes on without it: 8 m further, submaps retire
  ASSERT_GT(node.engineStats().global_voxels, 0u);
  std::this_thread::sleep_for(
      std::chrono::milliseconds(300));  // the rate-limited global copy goes out

  ground = std::make_unique<GroundStation>(config);  // it returns
  // The latched layers arrive with no new frame.
  ASSERT_TRUE(waitFor([&] { return ground->global_maps > 0 && ground->grids > 0; }))
      << "the returning subscriber did not get the latched global map and grid";
  // As last published, then as the node holds it: the global map is copied at most at
  // global_map_hz on mapped frames, and once more when the input has been idle for a second. It
  // can shrink as well as grow (the window takes back the hits it left to the global map), so the
  // latched copy may be larger or smaller than the map until that last copy arrives.
  EXPECT_GT(ground->global_points, 0);
  EXPECT_TRUE(waitFor([&] {
    return ground->global_points == static_cast<int>(node.engineStats().global_voxels);
  })) << ground->global_points
      << " global points received, " << node.engineStats().global_voxels << " in the node";
  EXPECT_EQ(ground->local_maps, 0) << "the local map is volatile: nothing before a new frame";
  ASSERT_TRUE(ground->matched());
  fly(5);
  ASSERT_TRUE(waitFor([&] { return ground->local_maps > 0; })) << "the local map did not come back";
  EXPECT_EQ(node.counters().frames_handover_dropped, 0u);
  ground.reset();
}

TEST(PoseBufferFaults, AStreamThatResumesAfterAPauseIsTakenBackAndABogusStampIsNot) {
  PoseBuffer buffer(PoseBufferConfig{});  // max_future_s 1
  Transform T;
  ASSERT_EQ(buffer.add(1.00, bodyAt(0.0)), PoseBuffer::AddResult::kAdded);
  ASSERT_EQ(buffer.add(1.02, bodyAt(0.02)), PoseBuffer::AddResult::kAdded);
  // One bogus stamp far ahead, then the stream goes on: the bogus one is never used.
  EXPECT_EQ(buffer.add(50.0, bodyAt(9.0)), PoseBuffer::AddResult::kFuture);
  ASSERT_EQ(buffer.add(1.04, bodyAt(0.04)), PoseBuffer::AddResult::kAdded);
  EXPECT_EQ(buffer.add(50.02, bodyAt(9.0)), PoseBuffer::AddResult::kFuture)
      << "the bogus pose was kept";
  ASSERT_EQ(buffer.add(1.06, bodyAt(0.06)), PoseBuffer::AddResult::kAdded);
  // A 5 s pause: the first pose after it is held, the second confirms it, both are used.
  EXPECT_EQ(buffer.add(6.06, bodyAt(5.0)), PoseBuffer::AddResult::kFuture);
  EXPECT_EQ(buffer.lookup(6.07, &T), PoseBuffer::LookupResult::kPending);
  ASSERT_EQ(buffer.add(6.08, bodyAt(5.02)), PoseBuffer::AddResult::kAdded);
  ASSERT_EQ(buffer.lookup(6.07, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_NEAR(T.translation().x(), 5.01, 1e-12);
  EXPECT_EQ(buffer.lookup(1.05, &T), PoseBuffer::LookupResult::kNoPose)
      << "nothing spans the pause";
  EXPECT_EQ(buffer.oldestStamp(), 6.06);
  EXPECT_EQ(buffer.counters().restarts, 1u);
  EXPECT_EQ(buffer.counters().rejected_future, 3u);
}

TEST(PoseBufferFaults, FramesBetweenTheTwoPosesOfAJumpAreNotInterpolated) {
  PoseBuffer buffer(PoseBufferConfig{});
  Transform T;
  // 1 m/s: interpolated.
  ASSERT_EQ(buffer.add(1.00, bodyAt(0.0)), PoseBuffer::AddResult::kAdded);
  ASSERT_EQ(buffer.add(1.02, bodyAt(0.02)), PoseBuffer::AddResult::kAdded);
  ASSERT_EQ(buffer.lookup(1.01, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_NEAR(T.translation().x(), 0.01, 1e-12);
  // 1 m in 20 ms (50 m/s) is still flight; 1.1 m is a jump.
  ASSERT_EQ(buffer.add(1.04, bodyAt(1.02)), PoseBuffer::AddResult::kAdded);
  EXPECT_EQ(buffer.lookup(1.03, &T), PoseBuffer::LookupResult::kFound);
  ASSERT_EQ(buffer.add(1.06, bodyAt(2.12)), PoseBuffer::AddResult::kAdded);
  EXPECT_EQ(buffer.lookup(1.05, &T), PoseBuffer::LookupResult::kAcrossJump);
  // Exactly at either pose of the jump: that pose.
  ASSERT_EQ(buffer.lookup(1.04, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_NEAR(T.translation().x(), 1.02, 1e-12);
  ASSERT_EQ(buffer.lookup(1.06, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_NEAR(T.translation().x(), 2.12, 1e-12);
  // A quarter turn in 20 ms (4500 deg/s) is a jump; 30 deg (1500 deg/s) is not.
  ASSERT_EQ(buffer.add(1.08, bodyAt(2.12, M_PI / 6)), PoseBuffer::AddResult::kAdded);
  EXPECT_EQ(buffer.lookup(1.07, &T), PoseBuffer::LookupResult::kFound);
  ASSERT_EQ(buffer.add(1.10, bodyAt(2.12, M_PI / 6 + M_PI / 2)), PoseBuffer::AddResult::kAdded);
  EXPECT_EQ(buffer.lookup(1.09, &T), PoseBuffer::LookupResult::kAcrossJump);
  // Bad limits are refused by name.
  PoseBufferConfig bad;
  bad.max_speed_mps = 0.0;
  bad.max_rotation_rate_dps = std::nan("");
  std::vector<std::string> errors;
  bad.validate(&errors);
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0].rfind("max_speed_mps:", 0), 0u) << errors[0];
  EXPECT_EQ(errors[1].rfind("max_rotation_rate_dps:", 0), 0u) << errors[1];
  EXPECT_THROW(PoseBuffer{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace mlmap::dds
