#include "mlmap/dds/sim/closed_loop_vehicle.h"

#include "mlmap/dds/nav/plan_messages.h"
#include "mlmap/dds/sim/sensor_messages.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/sim/depth_camera.h"
#include "mlmap/sim/vehicle.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>

#include <Eigen/Geometry>

#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

/// The latest setpoint, handed over by the reader's listener thread.
struct SetpointMailbox {
  std::mutex mutex;
  std::optional<geometry_msgs::PoseStamped_> latest;
  std::uint64_t received = 0;
};

/// The loop's DDS entities. The readers' listeners (in `readers`) outlive the participant.
struct LoopEntities {
  std::unique_ptr<TakeReaders> readers;
  ParticipantPtr participant;
  fdds::DataWriter* cloud = nullptr;
  fdds::DataWriter* pose = nullptr;
  fdds::DataWriter* goal = nullptr;
  fdds::DataReader* setpoints = nullptr;
  ~LoopEntities() {
    participant.reset();
    readers.reset();
  }
};

void createEntities(const ClosedLoopOptions& o, SetpointMailbox* mailbox, LoopEntities* e) {
  e->participant = createParticipant(o.dds, "mlmap_sensor_publisher");
  fdds::Publisher* publisher = e->participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  fdds::Subscriber* subscriber = e->participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (publisher == nullptr || subscriber == nullptr) {
    throw std::runtime_error("closed loop: cannot create a publisher or subscriber");
  }
  const std::string& ns = o.dds.ns;
  // As the streaming sensor publisher: RELIABLE KEEP_LAST 5 writers, which the node's best-effort
  // readers match (see mlmap_sensor_publisher.cpp).
  e->cloud = createWriter<sensor_msgs::PointCloud2_PubSubType>(
      publisher, ddsTopicName(ns, o.cloud_topic), reliableWriterQos(5));
  e->pose = createWriter<geometry_msgs::PoseStamped_PubSubType>(
      publisher, ddsTopicName(ns, o.pose_topic), reliableWriterQos(5));
  if (!o.goal_topic.empty()) {
    e->goal = createWriter<geometry_msgs::PoseStamped_PubSubType>(
        publisher, ddsTopicName(ns, o.goal_topic), reliableWriterQos());
  }
  e->readers = std::make_unique<TakeReaders>(subscriber, [](const std::string&) {});
  e->setpoints = e->readers->add<geometry_msgs::PoseStamped_PubSubType>(
      ddsTopicName(ns, o.setpoint_topic), reliableReaderQos(false, 10),
      [mailbox](geometry_msgs::PoseStamped_&& m) {
        const std::lock_guard<std::mutex> lock(mailbox->mutex);
        mailbox->latest = std::move(m);
        ++mailbox->received;
      });
}

/// Waits until the node reads the cloud and pose and a planner writes setpoints (and reads the
/// goal); false when `wait_s` passes or `stop` says so first.
bool waitForPeers(const LoopEntities& e, double wait_s, const std::function<bool()>& stop) {
  const auto start = Clock::now();
  for (;;) {
    fdds::PublicationMatchedStatus cloud;
    fdds::PublicationMatchedStatus pose;
    fdds::PublicationMatchedStatus goal;
    fdds::SubscriptionMatchedStatus setpoints;
    e.cloud->get_publication_matched_status(cloud);
    e.pose->get_publication_matched_status(pose);
    if (e.goal != nullptr) e.goal->get_publication_matched_status(goal);
    e.setpoints->get_subscription_matched_status(setpoints);
    if (cloud.current_count > 0 && pose.current_count > 0 && setpoints.current_count > 0 &&
        (e.goal == nullptr || goal.current_count > 0)) {
      // A writer can see its match before the remote reader has matched it.
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      return true;
    }
    if (stop() || std::chrono::duration<double>(Clock::now() - start).count() >= wait_s) {
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

/// The goal as a PoseStamped (heading +x).
geometry_msgs::PoseStamped_ goalPose(const Eigen::Vector3d& goal_W, double stamp_s,
                                     const std::string& frame_id) {
  Transform T_W_G = Transform::Identity();
  T_W_G.translation() = goal_W;
  return toPoseStamped(T_W_G, stamp_s, frame_id);
}

}  // namespace

ClosedLoopResult flyClosedLoop(const nav::NavWorld& world, const ClosedLoopOptions& options,
                               const std::function<bool()>& stop) {
  ClosedLoopResult result;
  SetpointMailbox mailbox;
  LoopEntities e;
  createEntities(options, &mailbox, &e);
  result.matched = waitForPeers(e, options.wait_s, stop);
  if (!result.matched) return result;

  const FrameNames frames = resolveFrames(options.dds);
  const nav::NavFlightOptions& f = options.flight;
  sim::VehicleState initial;
  initial.position_W = world.start_W;
  initial.yaw_rad = world.start_yaw_rad;
  sim::Vehicle vehicle(initial, f.vehicle);
  const sim::DepthCamera camera(f.camera);
  // Until a setpoint arrives: hold the start.
  Eigen::Vector3d target_W = world.start_W;
  double target_yaw_rad = world.start_yaw_rad;

  const double frame_period_s = 1.0 / f.camera_rate_hz;
  double next_frame_s = 0.0;
  double next_goal_s = 0.0;
  bool in_collision = false;
  result.min_clearance_m = std::numeric_limits<double>::infinity();
  const auto start = Clock::now();
  const double wall0_s = wallClockNow_s();
  const auto steps = static_cast<long>(std::ceil(f.timeout_s / f.control_dt_s));
  for (long k = 0; k <= steps && !stop(); ++k) {
    const double t = static_cast<double>(k) * f.control_dt_s;
    const auto due =
        start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t));
    std::this_thread::sleep_until(due);
    if (Clock::now() - due > std::chrono::duration<double>(f.control_dt_s)) ++result.late_steps;
    const sim::VehicleState& state = vehicle.state();
    result.time_s = t;
    const double stamp_s = wall0_s + t;
    if ((state.position_W - world.goal_W).head<2>().norm() <= f.planner.goal_tolerance_m) {
      result.reached = true;
      // Hovers at the goal for a moment, its pose sent every step, so that the planner sees it
      // reached too (the pose is best-effort: one sample alone can be lost, or outrun by this
      // participant leaving the graph).
      constexpr double kHoldAtGoal_s = 0.5;
      for (double hold_s = 0.0; hold_s < kHoldAtGoal_s && !stop(); hold_s += f.control_dt_s) {
        geometry_msgs::PoseStamped_ pose =
            toPoseStamped(state.T_W_B(), wallClockNow_s(), frames.world);
        e.pose->write(&pose);
        std::this_thread::sleep_for(std::chrono::duration<double>(f.control_dt_s));
      }
      break;
    }
    if (e.goal != nullptr && t >= next_goal_s) {
      next_goal_s += 1.0;
      geometry_msgs::PoseStamped_ goal = goalPose(world.goal_W, stamp_s, frames.world);
      e.goal->write(&goal);
    }
    // The pose first, then the frame captured there: the node pairs them by their equal stamps.
    geometry_msgs::PoseStamped_ pose = toPoseStamped(state.T_W_B(), stamp_s, frames.world);
    e.pose->write(&pose);
    if (t >= next_frame_s - 1e-9) {
      next_frame_s += frame_period_s;
      DepthFrame frame;
      camera.render(world.world, state.T_W_B() * options.T_B_S, t, &frame);
      sensor_msgs::PointCloud2_ cloud = organisedCloud(frame, stamp_s, frames.sensor);
      if (e.cloud->write(&cloud)) ++result.frames;
      result.capture_to_write_ms.push_back(1e3 * (wallClockNow_s() - stamp_s));
    }
    {
      const std::lock_guard<std::mutex> lock(mailbox.mutex);
      result.setpoints = mailbox.received;
      if (mailbox.latest) {
        double setpoint_stamp_s = 0.0;
        const DecodeStatus s =
            decodeSetpointPose(*mailbox.latest, &setpoint_stamp_s, &target_W, &target_yaw_rad);
        if (!s.ok()) ++result.rejected_setpoints;
        mailbox.latest.reset();
      }
    }
    const Eigen::Vector3d before = state.position_W;
    vehicle.step(target_W, Eigen::Vector3d::Zero(), target_yaw_rad, f.control_dt_s);
    const Eigen::Vector3d& after = vehicle.state().position_W;
    result.path_length_m += (after - before).norm();
    result.trajectory_W.push_back(after);
    const double gap = nav::clearance(world.world, after, t + f.control_dt_s);
    result.min_clearance_m = std::min(result.min_clearance_m, gap);
    const bool touching = gap < f.vehicle_radius_m;
    if (touching && !in_collision) ++result.collisions;
    in_collision = touching;
  }
  return result;
}

}  // namespace mlmap::dds
