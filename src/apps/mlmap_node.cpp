// mlmap_node: the onboard mapping process. ROS 2 topics in (PointCloud2 / depth Image + pose),
// map layers out, over plain Fast DDS: no ROS installation needed on the vehicle.

#include "mlmap/dds/node/mapping_node.h"
#include "mlmap/dds/node/node_config.h"
#include "mlmap/apps/stop_signal.h"

#include <CLI/CLI.hpp>
#include <spdlog/fmt/fmt.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <optional>
#include <vector>

namespace {

using namespace mlmap;

/// The command line of mlmap_node.
struct Options {
  std::string config_path;      ///< -c, --config (empty: defaults)
  double duration_s = 0.0;      ///< --duration (0: until SIGINT / SIGTERM)
  double report_every_s = 5.0;  ///< --report-every: seconds between progress lines (0: none)
  bool print_config = false;    ///< --print-config
};

/// Adds every option of mlmap_node to `app`.
void addOptions(CLI::App& app, Options& o) {
  app.add_option("-c,--config", o.config_path,
                 "YAML configuration: engine sections as config/mlmap.yaml plus a dds section "
                 "(config/mlmap_node.yaml); defaults when omitted")
      ->check(CLI::ExistingFile);
  app.add_option("--duration", o.duration_s,
                 "stop after this many seconds (0: until SIGINT/SIGTERM)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--report-every", o.report_every_s, "seconds between progress lines (0: none)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--print-config", o.print_config, "print the effective configuration and exit");
}

/// The node's messages to the log, at their level.
void logNodeMessage(LogLevel level, const std::string& message) {
  spdlog::log(level == LogLevel::kError     ? spdlog::level::err
              : level == LogLevel::kWarning ? spdlog::level::warn
                                            : spdlog::level::info,
              message);
}

/// Logs the domain, discovery, namespace and input topics the node listens on.
void logInputs(const mlmap::dds::NodeConfig& config, const mlmap::dds::MappingNode& node) {
  // Resolved as the participant was (the configuration was validated before).
  std::string discovery = mlmap::dds::toString(mlmap::dds::resolveDiscoveryRange(config.dds));
  const std::vector<std::string> peers = mlmap::dds::resolveStaticPeers(config.dds);
  for (std::size_t i = 0; i < peers.size(); ++i) discovery += (i == 0 ? " peers " : ";") + peers[i];
  // A profile may change discovery itself (a Discovery Server client): name it.
  if (!config.dds.participant_profile.empty())
    discovery += ", profile " + config.dds.participant_profile;
  std::string inputs;
  const mlmap::dds::TopicNames& t = config.dds.topics;
  for (const std::string* name : {&t.cloud, &t.depth_image, &t.camera_info, &t.pose, &t.odometry}) {
    if (!name->empty())
      inputs += (inputs.empty() ? "" : ", ") + mlmap::dds::ddsTopicName(config.dds.ns, *name);
  }
  node.log(LogLevel::kInfo,
           fmt::format("mapping on DDS domain {} (discovery {}, namespace '{}'), inputs: {}",
                       node.domainId(), discovery, config.dds.ns, inputs));
}

/// The frame checks' counters, when one is not zero: a frame_id or child_frame_id the node did
/// not expect, or the robot's odometry missing on /tf (docs/dds-and-ros2.md, TF).
void logFrameChecks(const mlmap::dds::MappingNode& node, const mlmap::dds::NodeCounters& c) {
  if (c.frames_unexpected_frame_id + c.frames_unresolved_frame_id +
          c.odometry_child_frame_mismatch + c.tf_odom_missing ==
      0) {
    return;
  }
  node.log(
      LogLevel::kWarning,
      fmt::format("frame checks: {} frames in an unexpected frame_id, {} frames with an "
                  "unresolved frame_id (dropped), {} odometry child_frame_id mismatches, {} "
                  "poses without the robot's odom -> body; {} transforms received",
                  c.frames_unexpected_frame_id, c.frames_unresolved_frame_id,
                  c.odometry_child_frame_mismatch, c.tf_odom_missing, c.tf_transforms_received));
}

/// The hits outside the local window, when there are any: their evidence went to the global map
/// without their free space, or was lost (docs/replay.md: a larger window maps them whole).
void logHitsOutsideWindow(const mlmap::dds::MappingNode& node, const EngineStats& s) {
  if (s.points.hits_beyond_local_map + s.local.hits_outside_window == 0) return;
  node.log(LogLevel::kWarning,
           fmt::format("outside the local window: {} points in range ({} of them above or below "
                       "it), {} hit voxels; {} hit updates went to the global map without their "
                       "free space, {} hits lost",
                       s.points.hits_beyond_local_map, s.points.hits_above_or_below_local_map,
                       s.local.hits_outside_window, s.hits_to_global, s.hits_lost));
}

/// The first time hits fall outside the local window, once: what happens to them and what to
/// change. The progress lines then carry the count, and the closing lines the totals.
void warnOfHitsOutsideWindowOnce(const mlmap::dds::MappingNode& node, const EngineStats& s,
                                 bool* warned) {
  if (*warned || s.points.hits_beyond_local_map + s.local.hits_outside_window == 0) return;
  *warned = true;
  node.log(LogLevel::kWarning,
           "hits are falling outside the local window: they reach the global map as occupied "
           "but without the free space in front of them, so obstacles that move away there are "
           "not cleared. To map them whole, make local_map.size_cells hold "
           "awareness.max_range_m around the vehicle: 2.5 x the range in x and y, and tall enough "
           "for the sensor's vertical reach (or lower max_range_m). Said once; the "
           "progress lines count them and the last lines give the totals.");
}

/// One progress line: frames, timings, memory and the hits outside the local window.
void logProgress(const mlmap::dds::MappingNode& node, bool* warned_outside) {
  const EngineStats s = node.engineStats();
  const mlmap::dds::NodeCounters c = node.counters();
  node.log(
      LogLevel::kInfo,
      fmt::format("frames: {} received, {} mapped, {} without pose, {} malformed; total "
                  "{:.1f} ms median, {:.1f} ms p99; {:.1f} MB; {} hit updates outside the "
                  "local window",
                  c.clouds_received + c.images_received, s.frames_mapped, c.frames_without_pose,
                  c.inputs_malformed, s.total.median_ms, s.total.p99_ms,
                  static_cast<double>(s.memory.total()) / 1e6, s.hits_to_global + s.hits_lost));
  logFrameChecks(node, c);
  warnOfHitsOutsideWindowOnce(node, s, warned_outside);
}

/// Maps until --duration or a stop signal, with a progress line every --report-every seconds.
void mapUntilStopped(const Options& o, const mlmap::dds::MappingNode& node) {
  bool warned_outside = false;
  apps::runUntilStopped(o.duration_s, o.report_every_s,
                        [&] { logProgress(node, &warned_outside); });
}

/// Stops the node and logs its counts; returns the exit status (1 when the map of this run was
/// not saved at shutdown).
int stopAndReport(const mlmap::dds::NodeConfig& config, mlmap::dds::MappingNode& node) {
  node.log(LogLevel::kInfo, "stopping");
  node.stop();  // from here on the node's lines go to stderr only: /rosout's writer is gone
  const EngineStats s = node.engineStats();
  const mlmap::dds::NodeCounters c = node.counters();
  node.log(LogLevel::kInfo,
           fmt::format("done: {} frames mapped ({} dropped, {} rejected by the engine, {} without "
                       "pose, {} across a pose jump, {} malformed inputs, {} poses rejected); {} "
                       "messages published; {} map saves, {} failed",
                       s.frames_mapped, s.frames_dropped + c.frames_handover_dropped,
                       c.frames_engine_rejected, c.frames_without_pose + c.frames_future,
                       c.frames_across_pose_jump, c.inputs_malformed, c.poses_rejected,
                       c.messages_published, c.map_saves, c.map_saves_failed));
  logFrameChecks(node, c);
  logHitsOutsideWindow(node, s);
  if (config.dds.fleet.publish || config.dds.fleet.subscribe) {
    node.log(LogLevel::kInfo,
             fmt::format("fleet: {} changed submaps sent ({:.1f} kB), {} submaps of other "
                         "vehicles taken as priors ({} voxels added), {} refused",
                         c.fleet_submaps_sent, static_cast<double>(c.fleet_bytes_sent) / 1e3,
                         c.fleet_priors_received, s.prior_voxels_added, c.fleet_samples_refused));
  }
  if (!config.map_file.save_path.empty() && c.last_map_save_failed) {
    // The map of this run is lost unless a supervisor notices: say so in the exit status.
    node.log(LogLevel::kError, fmt::format("the map was not saved to '{}' at shutdown (see above)",
                                           config.map_file.save_path));
    return 1;
  }
  return 0;
}

/// Runs the node the options describe; returns the exit status (1: an error, logged).
int run(const Options& o) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("mlmap_node"));
  try {
    const mlmap::dds::NodeConfig config = mlmap::dds::nodeConfigOrDefaults(o.config_path);
    if (o.print_config) {
      std::cout << mlmap::dds::toYaml(config);
      return 0;
    }
    apps::installStopHandler();
    std::optional<apps::ExitAtOnceOnStop> starting(std::in_place);  // SIGTERM works while loading
    mlmap::dds::MappingNode node(config, logNodeMessage);
    starting.reset();  // from here on a stop signal stops the node cleanly (final save)
    logInputs(config, node);
    mapUntilStopped(o, node);
    return stopAndReport(config, node);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap_node: multilayer mapping over ROS 2 compatible DDS topics (Fast DDS, no ROS)"};
  Options options;
  addOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  return run(options);
}
