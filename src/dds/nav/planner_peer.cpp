#include "mlmap/dds/nav/planner_peer.h"

#include "mlmap/dds/graph/ros_graph.h"
#include "mlmap/dds/nav/plan_messages.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/cloud_sample.h"
#include "mlmap/nav/recent_obstacles.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "mlmap_msgs/msg/VoxelBlock_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "nav_msgs/msg/Path_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>

#include <cctype>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace mlmap::dds {

namespace fdds = eprosima::fastdds::dds;

namespace {

/// Poses kept between two passes of the planning thread (the oldest dropped beyond it): far more
/// than arrive in one pass at any pose rate.
constexpr std::size_t kMaxInboxPoses = 256;
/// Wall time a sensor frame may wait for the pose at its stamp (as the node's FramePairer) [s].
constexpr double kFramePoseWait_s = 0.5;
/// A rejection is logged at most this often (the others counted) [s].
constexpr double kRejectionLogInterval_s = 1.0;

/// True for a valid ROS 2 node name: letters, digits, '_', not starting with a digit.
bool isRosNodeName(const std::string& name) {
  if (name.empty() || std::isdigit(static_cast<unsigned char>(name.front())) != 0) return false;
  for (const char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c)) == 0 && c != '_') return false;
  }
  return true;
}

}  // namespace

/// A sensor frame's points waiting for the pose at its stamp.
struct WaitingFrame {
  double stamp_s = 0.0;
  std::vector<Eigen::Vector3f> points_S;  ///< in the sensor frame
  double since_s = 0.0;                   ///< wall clock at its arrival
};

/// The samples handed over by the listener threads (the latest of each kind; every pose).
struct PeerInbox {
  std::optional<nav_msgs::OccupancyGrid_> grid;
  std::optional<mlmap_msgs::VoxelBlock_> block;
  double block_arrival_s = 0.0;                    ///< wall clock at the block's arrival
  std::vector<geometry_msgs::PoseStamped_> poses;  ///< in arrival order
  std::optional<geometry_msgs::PoseStamped_> goal;
  std::optional<CloudSample> cloud;
  double cloud_arrival_s = 0.0;              ///< wall clock at the cloud's arrival
  std::optional<sensor_msgs::Image_> image;  ///< a depth image
  double image_arrival_s = 0.0;              ///< wall clock at its arrival
  std::optional<sensor_msgs::CameraInfo_> camera_info;
  std::uint64_t malformed = 0;  ///< samples Fast CDR could not read
  std::string malformed_detail;
};

struct PlannerPeer::Impl {
  explicit Impl(const PlannerPeerConfig& c) : config(c), navigator(c.planner) {}

  void start();
  /// Creates the readers of the inputs.
  void addReaders(fdds::Subscriber* subscriber);
  void run();
  /// One pass over what arrived: grid, goal, poses, ESDF block (planned on at once), cloud or
  /// depth image (planned on at once), the latest pose's plan and setpoint.
  void step(PeerInbox in);
  /// Takes the poses into the pose buffer; the latest valid one is the vehicle's. True when
  /// one was.
  bool takePoses(const std::vector<geometry_msgs::PoseStamped_>& msgs);
  /// Checks a new cloud; its points wait for their pose in waiting_frame.
  void takeCloud(CloudSample&& cloud, double arrival_s);
  /// Checks and back-projects a new depth image (with the latest CameraInfo); its points wait
  /// for their pose in waiting_frame.
  void takeImage(const sensor_msgs::Image_& image, double arrival_s);
  /// Makes `frame` the one waiting for its pose (one that still waited is dropped, counted).
  void wait(WaitingFrame&& frame);
  /// Gives the waiting frame's points to the Navigator and plans when its pose is known, drops
  /// it when it will have none.
  void placeWaitingFrame();
  void reject(const std::string& what, const DecodeStatus& status);
  /// Counts a rejected message and logs it (at most every kRejectionLogInterval_s).
  void reject(const std::string& line);
  /// A log line to config.log and /rosout.
  void log(LogLevel level, const std::string& message);
  /// Plans from the latest pose when there is one; publishes the route when it planned.
  /// Returns true when it planned.
  bool plan(double now_stamp_s);
  void publishSetpoint(double stamp_s);

  PlannerPeerConfig config;
  nav::Navigator navigator;
  std::string world_frame;
  // Declared before the participant: it is deleted (with the readers) first.
  std::unique_ptr<TakeReaders> readers;
  std::unique_ptr<DiscoveryInfoPublisher> graph;
  std::unique_ptr<RosoutWriter> rosout;
  ParticipantPtr participant;
  fdds::DataWriter* path_writer = nullptr;
  fdds::DataWriter* setpoint_writer = nullptr;

  std::mutex inbox_mutex;
  std::condition_variable inbox_cv;
  PeerInbox inbox;
  bool news = false;
  bool stopping = false;

  // The planning thread's state.
  ProjectedGrid grid;
  OccupancyBox box;
  std::shared_ptr<const MapSnapshot> map;
  std::uint64_t map_frame = 0;
  bool have_pose = false;
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
  double pose_stamp_s = 0.0;
  std::optional<Eigen::Vector3d> goal_W;
  PoseBuffer poses{PoseBufferConfig{}};
  std::optional<WaitingFrame> waiting_frame;  ///< a frame waiting for the pose at its stamp
  std::optional<sensor_msgs::CameraInfo_> camera_info;  ///< the latest, for the depth images
  double last_rejection_log_s = -1e300;
  std::uint64_t rejections_unlogged = 0;
  bool was_reached = false;  ///< the vehicle was at the goal at the last plan()

  mutable std::mutex stats_mutex;
  PlannerPeerStats stats;
  std::thread thread;
};

void PlannerPeer::Impl::start() {
  if (!(config.position_gain_per_s > 0.0) || !std::isfinite(config.position_gain_per_s)) {
    throw std::invalid_argument("planner peer: position_gain_per_s must be finite and positive");
  }
  if (!isRosNodeName(config.node_name)) {
    throw std::invalid_argument("planner peer: node_name '" + config.node_name +
                                "' is not a ROS 2 node name (letters, digits, _)");
  }
  if (config.depth_image_topic.empty() != config.camera_info_topic.empty()) {
    throw std::invalid_argument(
        "planner peer: depth_image_topic and camera_info_topic go together (both or neither)");
  }
  if (!(config.recent_cell_m > 0.0) || !std::isfinite(config.recent_cell_m)) {
    throw std::invalid_argument("planner peer: recent_cell_m must be finite and positive");
  }
  poses = PoseBuffer(config.pose_buffer);  // throws std::invalid_argument for a bad one
  world_frame = resolveFrames(config.dds).world;
  map = std::make_shared<const MapSnapshot>(std::make_shared<const LocalWindow>(),
                                            std::make_shared<const ProjectedGrid>(), nullptr, 0,
                                            0.0, Transform::Identity());
  if (config.goal_W) {
    goal_W = config.goal_W;
    navigator.setGoal(*config.goal_W);
  }
  participant = createParticipant(config.dds, "mlmap_planner_peer");
  fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  fdds::Subscriber* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (publisher == nullptr || subscriber == nullptr) {
    throw std::runtime_error("planner peer: cannot create a publisher or subscriber");
  }
  const std::string& ns = config.dds.ns;
  path_writer = createWriter<nav_msgs::Path_PubSubType>(
      publisher, ddsTopicName(ns, config.path_topic), reliableWriterQos());
  setpoint_writer = createWriter<geometry_msgs::PoseStamped_PubSubType>(
      publisher, ddsTopicName(ns, config.setpoint_topic), reliableWriterQos());
  addReaders(subscriber);
  const std::string node_namespace = rosNodeNamespace(ns);
  rosout =
      std::make_unique<RosoutWriter>(publisher, rosLoggerName(node_namespace, config.node_name));
  graph =
      std::make_unique<DiscoveryInfoPublisher>(participant.get(), config.node_name, node_namespace);
  graph->announce({publisher}, {subscriber});
  log(LogLevel::kInfo,
      "planning on " + config.grid_topic + " and " + config.esdf_topic +
          (config.cloud_topic.empty() && config.depth_image_topic.empty()
               ? ", no sensor topic: recent obstacles only from the map"
               : ", the latest frame's points from " +
                     (config.cloud_topic.empty() ? config.depth_image_topic : config.cloud_topic)));
  thread = std::thread([this] { run(); });
}

void PlannerPeer::Impl::addReaders(fdds::Subscriber* subscriber) {
  const std::string& ns = config.dds.ns;
  readers = std::make_unique<TakeReaders>(subscriber, [this](const std::string& what) {
    const std::lock_guard<std::mutex> lock(inbox_mutex);
    ++inbox.malformed;
    inbox.malformed_detail = what;
  });
  // Each sink keeps the latest sample and wakes the planning thread.
  const auto hand_over = [this](auto assign) {
    {
      const std::lock_guard<std::mutex> lock(inbox_mutex);
      assign(inbox);
      news = true;
    }
    inbox_cv.notify_one();
  };
  readers->add<nav_msgs::OccupancyGrid_PubSubType>(
      ddsTopicName(ns, config.grid_topic), reliableReaderQos(true, 1),
      [hand_over](nav_msgs::OccupancyGrid_&& m) {
        hand_over([&m](PeerInbox& in) { in.grid = std::move(m); });
      });
  readers->add<mlmap_msgs::VoxelBlock_PubSubType>(ddsTopicName(ns, config.esdf_topic),
                                                  reliableReaderQos(false, 2),
                                                  [hand_over](mlmap_msgs::VoxelBlock_&& m) {
                                                    const double arrival_s = wallClockNow_s();
                                                    hand_over([&m, arrival_s](PeerInbox& in) {
                                                      in.block = std::move(m);
                                                      in.block_arrival_s = arrival_s;
                                                    });
                                                  });
  readers->add<geometry_msgs::PoseStamped_PubSubType>(ddsTopicName(ns, config.pose_topic),
                                                      sensorReaderQos(5),
                                                      [hand_over](geometry_msgs::PoseStamped_&& m) {
                                                        hand_over([&m](PeerInbox& in) {
                                                          if (in.poses.size() >= kMaxInboxPoses)
                                                            in.poses.erase(in.poses.begin());
                                                          in.poses.push_back(std::move(m));
                                                        });
                                                      });
  readers->add<geometry_msgs::PoseStamped_PubSubType>(
      ddsTopicName(ns, config.goal_topic), reliableReaderQos(false, 10),
      [hand_over](geometry_msgs::PoseStamped_&& m) {
        hand_over([&m](PeerInbox& in) { in.goal = std::move(m); });
      });
  if (!config.cloud_topic.empty()) {
    fdds::DataReaderQos qos = sensorReaderQos();  // as the node reads the sensor
    if (!config.dds.data_sharing) qos.data_sharing().off();
    readers->add<CloudSamplePubSubType>(ddsTopicName(ns, config.cloud_topic), qos,
                                        [hand_over](CloudSample&& m) {
                                          const double arrival_s = wallClockNow_s();
                                          hand_over([&m, arrival_s](PeerInbox& in) {
                                            in.cloud = std::move(m);
                                            in.cloud_arrival_s = arrival_s;
                                          });
                                        });
  }
  if (!config.depth_image_topic.empty()) {
    fdds::DataReaderQos qos = sensorReaderQos();
    if (!config.dds.data_sharing) qos.data_sharing().off();
    readers->add<sensor_msgs::Image_PubSubType>(ddsTopicName(ns, config.depth_image_topic), qos,
                                                [hand_over](sensor_msgs::Image_&& m) {
                                                  const double arrival_s = wallClockNow_s();
                                                  hand_over([&m, arrival_s](PeerInbox& in) {
                                                    in.image = std::move(m);
                                                    in.image_arrival_s = arrival_s;
                                                  });
                                                });
    readers->add<sensor_msgs::CameraInfo_PubSubType>(
        ddsTopicName(ns, config.camera_info_topic), qos, [hand_over](sensor_msgs::CameraInfo_&& m) {
          hand_over([&m](PeerInbox& in) { in.camera_info = std::move(m); });
        });
  }
}

void PlannerPeer::Impl::run() {
  for (;;) {
    PeerInbox in;
    {
      std::unique_lock<std::mutex> lock(inbox_mutex);
      inbox_cv.wait_for(lock, std::chrono::milliseconds(100), [this] { return news || stopping; });
      if (stopping) return;
      news = false;
      in = std::move(inbox);
      inbox = PeerInbox();
    }
    step(std::move(in));
  }
}

void PlannerPeer::Impl::log(LogLevel level, const std::string& message) {
  if (config.log) config.log(level, message);
  if (rosout) rosout->write(level, message);
}

void PlannerPeer::Impl::reject(const std::string& what, const DecodeStatus& status) {
  reject(what + ": " + toString(status.error) + " (" + status.detail + ")");
}

void PlannerPeer::Impl::reject(const std::string& line) {
  {
    const std::lock_guard<std::mutex> lock(stats_mutex);
    ++stats.rejected;
    stats.last_rejection = line;
  }
  const double now_s = wallClockNow_s();
  if (now_s - last_rejection_log_s < kRejectionLogInterval_s) {
    ++rejections_unlogged;
    return;
  }
  last_rejection_log_s = now_s;
  log(LogLevel::kWarning,
      "rejected a malformed " + line +
          (rejections_unlogged > 0
               ? " (and " + std::to_string(rejections_unlogged) + " more since the last such line)"
               : ""));
  rejections_unlogged = 0;
}

bool PlannerPeer::Impl::takePoses(const std::vector<geometry_msgs::PoseStamped_>& msgs) {
  bool taken = false;
  for (const geometry_msgs::PoseStamped_& msg : msgs) {
    double stamp_s = 0.0;
    Transform T_W_B = Transform::Identity();
    const DecodeStatus s = decodePose(msg, &stamp_s, &T_W_B);
    if (!s.ok()) {
      reject("pose", s);
      continue;
    }
    {
      const std::lock_guard<std::mutex> lock(stats_mutex);
      ++stats.poses;
    }
    // Refused ones (out of order, a jump ahead) are still the vehicle's latest word on where it
    // is; they only place no cloud.
    (void)poses.add(stamp_s, T_W_B);
    taken = true;
    pose_stamp_s = stamp_s;
    have_pose = true;
    p_W = T_W_B.translation();
    const Eigen::Vector3d x_W = T_W_B.linear().col(0);
    yaw_rad = std::atan2(x_W.y(), x_W.x());
  }
  return taken;
}

void PlannerPeer::Impl::takeCloud(CloudSample&& cloud, double arrival_s) {
  {
    const std::lock_guard<std::mutex> lock(stats_mutex);
    ++stats.clouds;
  }
  if (cloud.header_().stamp_().nanosec_() >= 1000000000u) {
    return reject("PointCloud2", DecodeStatus{DecodeError::kBadStamp, "nanosec >= 1e9"});
  }
  if (!cloud.status.ok()) return reject("PointCloud2", cloud.status);  // decoded when taken
  wait(WaitingFrame{toSeconds(cloud.header_().stamp_()), std::move(cloud.points_S), arrival_s});
}

void PlannerPeer::Impl::takeImage(const sensor_msgs::Image_& image, double arrival_s) {
  {
    const std::lock_guard<std::mutex> lock(stats_mutex);
    ++stats.depth_images;
  }
  if (image.header_().stamp_().nanosec_() >= 1000000000u) {
    return reject("depth Image", DecodeStatus{DecodeError::kBadStamp, "nanosec >= 1e9"});
  }
  if (!camera_info) return reject("depth Image: before any CameraInfo");
  DepthFrame frame;
  const DecodeStatus s = decodeDepthImage(image, *camera_info, &frame);
  if (!s.ok()) return reject("depth Image", s);
  WaitingFrame waiting{toSeconds(image.header_().stamp_()), {}, arrival_s};
  backProject(frame, &waiting.points_S);  // the sizes agree: decodeDepthImage() checked them
  wait(std::move(waiting));
}

void PlannerPeer::Impl::wait(WaitingFrame&& frame) {
  if (waiting_frame) {
    const std::lock_guard<std::mutex> lock(stats_mutex);
    ++stats.frames_without_pose;  // superseded while it waited
  }
  waiting_frame = std::move(frame);
}

void PlannerPeer::Impl::placeWaitingFrame() {
  if (!waiting_frame) return;
  Transform T_W_B = Transform::Identity();
  const PoseBuffer::LookupResult found = poses.lookup(waiting_frame->stamp_s, &T_W_B);
  if (found == PoseBuffer::LookupResult::kPending &&
      wallClockNow_s() - waiting_frame->since_s < kFramePoseWait_s) {
    return;  // its pose may still come
  }
  const WaitingFrame frame = std::move(*waiting_frame);
  waiting_frame.reset();
  if (found != PoseBuffer::LookupResult::kFound) {
    const std::lock_guard<std::mutex> lock(stats_mutex);
    ++stats.frames_without_pose;
    return;
  }
  if (!goal_W) return;  // no flight height yet: nothing to plan
  std::vector<Eigen::Vector3d> points_W =
      nav::recentObstacles(frame.points_S, T_W_B * config.T_B_S, goal_W->z(), config.recent_cell_m);
  const std::size_t count = points_W.size();
  navigator.setRecentObstacles(std::move(points_W));
  {
    const std::lock_guard<std::mutex> lock(stats_mutex);
    ++stats.recent_obstacle_frames;
    stats.recent_obstacles += count;
  }
  plan(frame.stamp_s);  // at the frame's time, as the one-process flight
}

void PlannerPeer::Impl::step(PeerInbox in) {
  if (in.malformed > 0) {
    const std::lock_guard<std::mutex> lock(stats_mutex);
    stats.rejected += in.malformed;
    stats.last_rejection = in.malformed_detail;
  }
  if (in.grid) {
    const DecodeStatus s = decodeOccupancyGrid(*in.grid, &grid);
    if (!s.ok()) reject("grid", s);
    const std::lock_guard<std::mutex> lock(stats_mutex);
    stats.grids += s.ok() ? 1 : 0;
  }
  if (in.goal) {
    double stamp_s = 0.0;
    Transform T_W_G = Transform::Identity();
    const DecodeStatus s = decodePose(*in.goal, &stamp_s, &T_W_G);
    if (!s.ok()) {
      reject("goal", s);
    } else if (!goal_W || (*goal_W - T_W_G.translation()).norm() > 1e-3) {
      goal_W = T_W_G.translation();
      navigator.setGoal(*goal_W);
      log(LogLevel::kInfo, "new goal (" + std::to_string(goal_W->x()) + ", " +
                               std::to_string(goal_W->y()) + ", " + std::to_string(goal_W->z()) +
                               ")");
      const std::lock_guard<std::mutex> lock(stats_mutex);
      ++stats.goals;
    }
  }
  const bool new_pose = takePoses(in.poses);
  if (in.block) {
    double max_distance_m = 0.0;
    const DecodeStatus s = decodeEsdfBlock(*in.block, &box, &max_distance_m);
    if (!s.ok()) {
      reject("ESDF block", s);
    } else {
      EsdfConfig esdf;
      esdf.max_distance_m = max_distance_m;
      esdf.unknown_as = config.esdf_unknown_as;
      const double stamp_s = toSeconds(in.block->header_().stamp_());
      map = plannerSnapshot(box, grid, esdf, ++map_frame, stamp_s);
      if (plan(pose_stamp_s)) {
        const double now_s = wallClockNow_s();
        const std::lock_guard<std::mutex> lock(stats_mutex);
        ++stats.maps;
        stats.map_to_plan_ms.push_back(1e3 * (now_s - stamp_s));
        stats.map_arrival_ms.push_back(1e3 * (in.block_arrival_s - stamp_s));
      }
    }
  }
  if (in.camera_info) camera_info = std::move(in.camera_info);  // checked with each image
  if (in.cloud) takeCloud(std::move(*in.cloud), in.cloud_arrival_s);
  if (in.image) takeImage(*in.image, in.image_arrival_s);
  placeWaitingFrame();
  if (new_pose) {
    plan(pose_stamp_s);
    publishSetpoint(pose_stamp_s);
  }
}

bool PlannerPeer::Impl::plan(double now_stamp_s) {
  if (!have_pose || !goal_W) return false;
  const nav::PlanReason reason = navigator.update(*map, p_W, now_stamp_s);
  const bool reached = navigator.reached(p_W);
  if (reached && !was_reached) log(LogLevel::kInfo, "the vehicle is at the goal");
  was_reached = reached;
  if (reason == nav::PlanReason::kNone) {
    const std::lock_guard<std::mutex> lock(stats_mutex);
    stats.reached = reached;
    return false;
  }
  nav_msgs::Path_ path = toPath(navigator.route_W(), map->stamp_s(), world_frame);
  path_writer->write(&path);
  const std::lock_guard<std::mutex> lock(stats_mutex);
  stats.reached = reached;
  ++stats.paths;
  return true;
}

void PlannerPeer::Impl::publishSetpoint(double stamp_s) {
  const nav::Setpoint sp = navigator.setpoint(p_W, yaw_rad);
  geometry_msgs::PoseStamped_ msg =
      toSetpointPose(sp, config.position_gain_per_s, stamp_s, world_frame);
  setpoint_writer->write(&msg);
  const std::lock_guard<std::mutex> lock(stats_mutex);
  ++stats.setpoints;
}

PlannerPeer::PlannerPeer(const PlannerPeerConfig& config) : impl_(std::make_unique<Impl>(config)) {
  impl_->start();
}

PlannerPeer::~PlannerPeer() {
  {
    const std::lock_guard<std::mutex> lock(impl_->inbox_mutex);
    impl_->stopping = true;
  }
  impl_->inbox_cv.notify_one();
  if (impl_->thread.joinable()) impl_->thread.join();
  impl_->participant.reset();
  impl_->readers.reset();
}

PlannerPeerStats PlannerPeer::stats() const {
  const std::lock_guard<std::mutex> lock(impl_->stats_mutex);
  return impl_->stats;
}

}  // namespace mlmap::dds
