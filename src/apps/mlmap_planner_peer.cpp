// mlmap_planner_peer: the reference planner (mlmap_nav) as a DDS peer of mlmap_node, the way a
// ROS 2 planner runs beside it: it reads the node's grid and ESDF, the vehicle's pose and a goal
// (RViz2's /goal_pose), and publishes its route (nav_msgs/Path, /mlmap/plan) and setpoints
// (geometry_msgs/PoseStamped, /mlmap/setpoint) (mlmap_dds_nav's PlannerPeer; docs/planners.md,
// "Over DDS"). A program of its own rather than a mode of mlmap_navigate: onboard it links the
// planner and DDS only, no simulator, no OpenCV, as mlmap_node.
//
// With --cloud-topic (or --depth-image-topic and --camera-info-topic) it also reads the sensor's
// frames the node maps (usually the node's dds.topics.cloud), whose points near the flight height
// the planner avoids before the map has them (a person crossing). In the ROS 2 graph it is the node
// --node-name (mlmap_planner), its log lines on /rosout.
//
// At the end it prints the map-to-plan latency (a frame's stamp to the Path planned on the map
// state it ended: median and p99). Exit status 1 on an error, or with --exit-when-reached when
// the goal was not reached.

#include "mlmap/apps/stop_signal.h"
#include "mlmap/dds/nav/planner_peer.h"
#include "mlmap/dds/node/node_config.h"
#include "mlmap/pipeline/engine_stats.h"

#include "security_options.h"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <fstream>
#include <thread>
#include <vector>

namespace {

using namespace mlmap;

/// The command line of mlmap_planner_peer.
struct Options {
  std::string config_path;   ///< -c, --config: the node's configuration (dds, topics)
  std::vector<double> goal;  ///< --goal x y z (else wait for --goal-topic)
  std::string goal_topic = "goal_pose";
  std::string path_topic = "mlmap/plan";
  std::string setpoint_topic = "mlmap/setpoint";
  std::string cloud_topic;                  ///< --cloud-topic ("": off)
  std::string depth_image_topic;            ///< --depth-image-topic ("": off)
  std::string camera_info_topic;            ///< --camera-info-topic
  std::string node_name = "mlmap_planner";  ///< --node-name
  double duration_s = 0.0;                  ///< --duration (0: until stopped)
  double report_every_s = 5.0;              ///< --report-every
  bool exit_when_reached = false;           ///< --exit-when-reached
  std::string latency_out;         ///< --latency-out: map-to-plan samples, one per line [ms]
  apps::SecurityOptions security;  ///< --keystore, --enclave, --security-strategy
};

void addOptions(CLI::App& app, Options& o) {
  app.add_option("-c,--config", o.config_path,
                 "mlmap_node's configuration: its dds section, topics and esdf.unknown_as")
      ->check(CLI::ExistingFile);
  app.add_option("--goal", o.goal, "goal x y z in the world frame [m] (else from --goal-topic)")
      ->expected(3);
  app.add_option("--goal-topic", o.goal_topic, "geometry_msgs/PoseStamped goals (RViz2's)");
  app.add_option("--path-topic", o.path_topic, "nav_msgs/Path out: the route");
  app.add_option("--setpoint-topic", o.setpoint_topic, "geometry_msgs/PoseStamped setpoints out");
  app.add_option("--cloud-topic", o.cloud_topic,
                 "sensor_msgs/PointCloud2 in: the sensor's clouds the node maps (its "
                 "dds.topics.cloud); the latest frame's points are the planner's recent obstacles "
                 "(default: off)");
  app.add_option("--depth-image-topic", o.depth_image_topic,
                 "sensor_msgs/Image in (16UC1 or 32FC1), as --cloud-topic for a node fed depth "
                 "images (its dds.topics.depth_image); needs --camera-info-topic");
  app.add_option(
      "--camera-info-topic", o.camera_info_topic,
      "sensor_msgs/CameraInfo in: the depth images' (the node's dds.topics.camera_info)");
  app.add_option("--node-name", o.node_name, "its ROS 2 node name (ros2 node list, /rosout)");
  app.add_option("--duration", o.duration_s, "seconds to run (0: until SIGINT / SIGTERM)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--report-every", o.report_every_s, "seconds between progress lines (0: none)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--exit-when-reached", o.exit_when_reached,
               "stop once the vehicle is at the goal (exit status 1 when it never was)");
  app.add_option("--latency-out", o.latency_out,
                 "write every map-to-plan latency [ms] to this file, one a line (benchmarks)");
  o.security.add(app);
}

/// The peer's configuration from the node's and the options.
dds::PlannerPeerConfig peerConfig(const Options& o, const dds::NodeConfig& node) {
  dds::PlannerPeerConfig c;
  c.dds = node.dds;
  c.grid_topic = node.dds.topics.grid;
  c.esdf_topic = node.dds.topics.esdf_block;
  c.pose_topic = node.dds.topics.pose;
  if (c.grid_topic.empty() || c.esdf_topic.empty() || c.pose_topic.empty()) {
    throw std::runtime_error(
        "the planner needs the node's dds.topics.grid, esdf_block and pose (one is disabled)");
  }
  c.goal_topic = o.goal_topic;
  c.path_topic = o.path_topic;
  c.setpoint_topic = o.setpoint_topic;
  c.esdf_unknown_as = node.map.esdf.unknown_as;
  c.cloud_topic = o.cloud_topic;
  c.depth_image_topic = o.depth_image_topic;
  c.camera_info_topic = o.camera_info_topic;
  if ((!c.cloud_topic.empty() || !c.depth_image_topic.empty()) &&
      dds::resolveExtrinsicSource(node.dds) != dds::ExtrinsicSource::kConfig) {
    throw std::runtime_error(
        "--cloud-topic and --depth-image-topic place the frames with the configured mounting "
        "(sensor.*): the node's "
        "dds.sensor_extrinsic must be config");
  }
  c.T_B_S = node.map.sensor.T_B_S();
  c.pose_buffer = dds::poseBufferConfig(node.dds);
  c.recent_cell_m = node.map.local_map.resolution_m;
  c.node_name = o.node_name;
  c.log = [](LogLevel level, const std::string& line) {
    if (level == LogLevel::kInfo) {
      spdlog::info("{}", line);
    } else if (level == LogLevel::kWarning) {
      spdlog::warn("{}", line);
    } else {
      spdlog::error("{}", line);
    }
  };
  if (o.goal.size() == 3) c.goal_W = Eigen::Vector3d(o.goal[0], o.goal[1], o.goal[2]);
  return c;
}

/// The last lines: counts and the map-to-plan latency.
void finalReport(const dds::PlannerPeerStats& s) {
  spdlog::info(
      "done: {} maps planned on, {} grids, {} poses, {} goals, {} paths, {} setpoints, {} "
      "rejected, reached {}",
      s.maps, s.grids, s.poses, s.goals, s.paths, s.setpoints, s.rejected, s.reached ? 1 : 0);
  if (s.clouds + s.depth_images > 0) {
    spdlog::info(
        "sensor frames: {} clouds and {} depth images received, {} gave their points to the "
        "planner ({} recent obstacles in all), {} without a pose",
        s.clouds, s.depth_images, s.recent_obstacle_frames, s.recent_obstacles,
        s.frames_without_pose);
  }
  if (!s.last_rejection.empty()) spdlog::warn("last rejected message: {}", s.last_rejection);
  if (s.map_to_plan_ms.empty()) return;
  const TimingSummary plan = summarizeTimings(s.map_to_plan_ms);
  const TimingSummary arrival = summarizeTimings(s.map_arrival_ms);
  spdlog::info(
      "map-to-plan (over DDS) median {:.2f} ms p99 {:.2f} ms max {:.2f} ms ({} maps); the ESDF "
      "arrived after median {:.2f} ms p99 {:.2f} ms",
      plan.median_ms, plan.p99_ms, plan.max_ms, plan.samples, arrival.median_ms, arrival.p99_ms);
}

int run(const Options& o) {
  apps::installStopHandler();
  try {
    dds::NodeConfig node = dds::nodeConfigOrDefaults(o.config_path);
    o.security.apply(&node.dds.security);
    const dds::PlannerPeerConfig config = peerConfig(o, node);
    dds::PlannerPeer peer(config);
    spdlog::info("path on {}, setpoints on {}, goals from {}; node {}", config.path_topic,
                 config.setpoint_topic, config.goal_W ? "--goal" : config.goal_topic,
                 config.node_name);
    const auto start = std::chrono::steady_clock::now();
    auto last_report = start;
    bool reached = false;
    for (;;) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      const auto now = std::chrono::steady_clock::now();
      const double elapsed_s = std::chrono::duration<double>(now - start).count();
      const dds::PlannerPeerStats s = peer.stats();
      reached = reached || s.reached;
      if (apps::stopRequested() || (o.duration_s > 0.0 && elapsed_s >= o.duration_s) ||
          (o.exit_when_reached && reached)) {
        break;
      }
      if (o.report_every_s > 0.0 &&
          std::chrono::duration<double>(now - last_report).count() >= o.report_every_s) {
        last_report = now;
        spdlog::info("maps {}, paths {}, setpoints {}, rejected {}", s.maps, s.paths, s.setpoints,
                     s.rejected);
      }
    }
    const dds::PlannerPeerStats final_stats = peer.stats();
    finalReport(final_stats);
    if (!o.latency_out.empty()) {
      std::ofstream out(o.latency_out);
      for (const double ms : final_stats.map_to_plan_ms) out << ms << '\n';
      if (!out) throw std::runtime_error("cannot write " + o.latency_out);
    }
    return o.exit_when_reached && !reached ? 1 : 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap_planner_peer: the reference planner as a DDS peer of mlmap_node"};
  Options options;
  addOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  return run(options);
}
