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
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/datasets/frame_source.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/dds/node/node_config.h"
#include "mlmap/dds/sim/closed_loop_vehicle.h"
#include "mlmap/dds/sim/sensor_stream.h"
#include "mlmap/pipeline/engine_stats.h"

#include "security_options.h"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <thread>
#include <vector>

namespace {

using namespace mlmap;
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
  bool person = false;                            ///< --person
  double person_lead_m = 3.0;                     ///< --person-lead [m]
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
                 "nav_worlds (forest, rooms, paper or building) instead of streaming a scenario")
      ->check(CLI::IsMember({"forest", "rooms", "paper", "building"}));
  app.add_option("--world-seed", o.world_seed, "seed of the --closed-loop world");
  app.add_flag("--person", o.person,
               "closed loop: a person crosses the world's shortest route halfway, timed to pass "
               "it 3 m ahead of a vehicle flying it from the start at 0.95 x the planner's top "
               "speed (as the navigation benchmark's; --person-lead changes the 3 m)");
  app.add_option("--person-lead", o.person_lead_m,
                 "--person: how far ahead of that vehicle the person passes the route [m]; "
                 "negative: after it passed, for a vehicle that starts late");
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
using mlmap::dds::PreparedFrame;
using mlmap::dds::SensorFeed;
using mlmap::dds::StreamStats;

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

/// Reports late and failed frames; returns the exit status (1 when a frame could not be written).
int finish(const StreamStats& s, bool prerender) {
  if (s.late > 0) {
    spdlog::warn(
        "{} of {} frames left more than {} ms after their capture time (max {:.1f} ms; "
        "their latency includes it): {}",
        s.late, s.sent + s.failed, mlmap::dds::kLate_ms, s.max_late_ms,
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
  nav::NavWorld world;
  if (o.closed_loop == "rooms") {
    world = nav::roomsWorld(o.world_seed, 2);
  } else if (o.closed_loop == "paper") {
    world = nav::paperRoomWorld(o.world_seed);
  } else if (o.closed_loop == "building") {
    world = nav::buildingFloorWorld(o.world_seed);
  } else {
    world = nav::forestWorld(o.world_seed, o.forest_density,
                             Eigen::Vector2d(o.forest_size_m[0], o.forest_size_m[1]));
  }
  if (o.person) {
    const nav::NavigatorConfig planner;
    nav::addCrossingPerson(&world, nav::shortestRoute(world, planner.inflation_m, 0.1),
                           0.95 * planner.max_speed_mps, o.person_lead_m);
  }
  return world;
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
    const mlmap::dds::SensorWriters writers =
        mlmap::dds::createSensorWriters(config.dds, source, config.map.sensor.T_B_S());
    if (writers.cloud_bytes > 0) {
      spdlog::info("clouds of {:.2f} MB offered with data-sharing (dds.data_sharing)",
                   writers.cloud_bytes / 1e6);
    }
    bool all_matched = false;
    const int subscribers = mlmap::dds::waitForSubscribers(
        writers, o.wait_s, [] { return apps::stopRequested(); }, &all_matched);
    if (!all_matched) {
      spdlog::warn("not every topic has a subscriber after {} s: publishing anyway", o.wait_s);
    }
    std::vector<PreparedFrame> prerendered;
    if (o.prerender) prerendered = prerenderFrames(source);
    spdlog::info("publishing {} on {} ({} subscriber(s)) at {} Hz",
                 source.depth_mode ? "depth images" : "clouds", writers.sensor_topic, subscribers,
                 source.rate_hz);
    const StreamStats stats = mlmap::dds::stream(
        source, writers, config.dds, o.pose_rate_hz, o.prerender ? &prerendered : nullptr,
        [] { return apps::stopRequested(); },
        [](int sent, int total) { spdlog::info("{} / {} frames published", sent, total); });
    if (stats.failed > 0) {
      spdlog::error("frame {}: the DDS write failed{}", stats.first_failed_frame,
                    writers.cloud_bytes > 0
                        ? " (data-sharing: a cloud larger than the first, or every "
                          "slot still held by a reader that has not taken it)"
                        : "");
    }
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
