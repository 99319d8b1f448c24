#include "mlmap/dds/nav/planner_peer.h"

#include "mlmap/dds/nav/plan_messages.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "mlmap_msgs/msg/VoxelBlock_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "nav_msgs/msg/Path_PubSubTypes.h"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace mlmap::dds {

namespace fdds = eprosima::fastdds::dds;

/// The samples handed over by the listener threads (the latest of each kind).
struct PeerInbox {
  std::optional<nav_msgs::OccupancyGrid_> grid;
  std::optional<mlmap_msgs::VoxelBlock_> block;
  double block_arrival_s = 0.0;  ///< wall clock at the block's arrival
  std::optional<geometry_msgs::PoseStamped_> pose;
  std::optional<geometry_msgs::PoseStamped_> goal;
  std::uint64_t malformed = 0;  ///< samples Fast CDR could not read
  std::string malformed_detail;
};

struct PlannerPeer::Impl {
  explicit Impl(const PlannerPeerConfig& c) : config(c), navigator(c.planner) {}

  void start();
  void run();
  /// One pass over what arrived: grid, goal, ESDF block (planned on at once), pose.
  void step(PeerInbox in);
  void reject(const std::string& what, const DecodeStatus& status);
  /// Plans from the latest pose when there is one; publishes the route when it planned.
  /// Returns true when it planned.
  bool plan(double now_stamp_s);
  void publishSetpoint(double stamp_s);

  PlannerPeerConfig config;
  nav::Navigator navigator;
  std::string world_frame;
  // Declared before the participant: it is deleted (with the readers) first.
  std::unique_ptr<TakeReaders> readers;
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

  mutable std::mutex stats_mutex;
  PlannerPeerStats stats;
  std::thread thread;
};

void PlannerPeer::Impl::start() {
  if (!(config.position_gain_per_s > 0.0) || !std::isfinite(config.position_gain_per_s)) {
    throw std::invalid_argument("planner peer: position_gain_per_s must be finite and positive");
  }
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
  readers->add<geometry_msgs::PoseStamped_PubSubType>(
      ddsTopicName(ns, config.pose_topic), sensorReaderQos(5),
      [hand_over](geometry_msgs::PoseStamped_&& m) {
        hand_over([&m](PeerInbox& in) { in.pose = std::move(m); });
      });
  readers->add<geometry_msgs::PoseStamped_PubSubType>(
      ddsTopicName(ns, config.goal_topic), reliableReaderQos(false, 10),
      [hand_over](geometry_msgs::PoseStamped_&& m) {
        hand_over([&m](PeerInbox& in) { in.goal = std::move(m); });
      });
  thread = std::thread([this] { run(); });
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

void PlannerPeer::Impl::reject(const std::string& what, const DecodeStatus& status) {
  const std::lock_guard<std::mutex> lock(stats_mutex);
  ++stats.rejected;
  stats.last_rejection = what + ": " + toString(status.error) + " (" + status.detail + ")";
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
      const std::lock_guard<std::mutex> lock(stats_mutex);
      ++stats.goals;
    }
  }
  if (in.pose) {
    Transform T_W_B = Transform::Identity();
    const DecodeStatus s = decodePose(*in.pose, &pose_stamp_s, &T_W_B);
    if (s.ok()) {
      have_pose = true;
      p_W = T_W_B.translation();
      const Eigen::Vector3d x_W = T_W_B.linear().col(0);
      yaw_rad = std::atan2(x_W.y(), x_W.x());
      const std::lock_guard<std::mutex> lock(stats_mutex);
      ++stats.poses;
    } else {
      reject("pose", s);
      in.pose.reset();
    }
  }
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
  if (in.pose) {
    plan(pose_stamp_s);
    publishSetpoint(pose_stamp_s);
  }
}

bool PlannerPeer::Impl::plan(double now_stamp_s) {
  if (!have_pose || !goal_W) return false;
  const nav::PlanReason reason = navigator.update(*map, p_W, now_stamp_s);
  const bool reached = navigator.reached(p_W);
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
