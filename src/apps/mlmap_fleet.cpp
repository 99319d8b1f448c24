// mlmap_fleet: the fleet's merger (ground station or any vehicle). Every vehicle's
// mlmap_msgs/Submap samples in (each on its own rt/<vehicle>/mlmap/submaps), the merged map out as
// standard ROS 2 topics, over plain Fast DDS: no ROS installation needed. The work is
// mlmap::dds::FleetMerger's.

#include "mlmap/apps/stop_signal.h"
#include "mlmap/config/config_yaml.h"
#include "mlmap/dds/fleet/fleet_merger.h"
#include "mlmap/map_io/map_file.h"

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <stdexcept>

namespace {

using namespace mlmap;

/// The command line of mlmap_fleet.
struct Options {
  dds::FleetMergerConfig merger;
  int domain_id = -1;                ///< --domain (-1: ROS_DOMAIN_ID, else 0)
  std::string discovery_range;       ///< --discovery-range ("": ROS_AUTOMATIC_DISCOVERY_RANGE)
  double duration_s = 0.0;           ///< --duration (0: until SIGINT / SIGTERM)
  double report_every_s = 5.0;       ///< --report-every (0: none)
  std::string config_path;           ///< --config: the vehicles' configuration ("": the defaults)
  std::string save_map_path;         ///< --save-map: the merged map's file at the end ("": none)
  bool overwrite = false;            ///< --overwrite: --save-map may replace an existing map file
  double vehicle_budget_mb = 256.0;  ///< --vehicle-budget [MiB]
  double fleet_budget_mb = 1024.0;   ///< --fleet-budget [MiB]
};

/// Adds every option of mlmap_fleet to `app`.
void addOptions(CLI::App& app, Options& o) {
  app.add_option("--domain", o.domain_id, "DDS domain (-1: ROS_DOMAIN_ID, else 0)");
  app.add_option("--discovery-range", o.discovery_range,
                 "LOCALHOST, SUBNET, OFF or SYSTEM_DEFAULT (\"\": ROS_AUTOMATIC_DISCOVERY_RANGE)");
  app.add_option("--ns", o.merger.dds.ns, "namespace of the outputs (\"\" for none)");
  app.add_option("--world-frame", o.merger.dds.world_frame, "frame_id of the merged map");
  app.add_option("--submaps-topic", o.merger.submaps_topic,
                 "input: each vehicle V's keyed topic, /V/<this>");
  app.add_option("--cloud-topic", o.merger.cloud_topic, "output: merged occupied voxels");
  app.add_option("--grid-topic", o.merger.grid_topic, "output: merged 2D grid");
  app.add_option("--status-topic", o.merger.status_topic, "output: mlmap_msgs/FleetStatus");
  app.add_option("--publish-hz", o.merger.publish_hz, "outputs at most this often [Hz]")
      ->check(CLI::PositiveNumber);
  app.add_option("--stale-after", o.merger.stale_after_s,
                 "a vehicle silent this long is marked stale, its voxels kept [s]")
      ->check(CLI::PositiveNumber);
  app.add_option("--grid-min-z", o.merger.grid_min_z_m, "the grid's height band, bottom [m]");
  app.add_option("--grid-max-z", o.merger.grid_max_z_m, "the grid's height band, top [m]");
  app.add_option("--duration", o.duration_s,
                 "stop after this many seconds (0: until SIGINT/SIGTERM)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--report-every", o.report_every_s, "seconds between status lines (0: none)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--config", o.config_path,
                 "the vehicles' mlmap configuration (mlmap_node's file): its log_odds section "
                 "clamps and thresholds the fused map and is the saved map's sensor model; its "
                 "local_map (resolution_m, size_cells / 5) is the fleet's grid: samples of "
                 "another are refused")
      ->check(CLI::ExistingFile);
  app.add_option("--vehicle", o.merger.trust.vehicles,
                 "a vehicle of the fleet (its dds.fleet.vehicle), repeated for each: samples "
                 "of any other name are refused (none: an open domain, any name may join)");
  app.add_option("--vehicle-budget", o.vehicle_budget_mb,
                 "memory one vehicle's submaps may take in the merger [MiB]")
      ->check(CLI::Range(1.0, 1048576.0));
  app.add_option("--fleet-budget", o.fleet_budget_mb, "memory the merged map may take [MiB]")
      ->check(CLI::Range(1.0, 1048576.0));
  app.add_option("--save-map", o.save_map_path,
                 "at the end, write the merged map to this mlmap map file (global layer; "
                 "mlmap_map_tool converts it, mlmap_node map_file.load_path starts from it)");
  app.add_flag("--overwrite", o.overwrite, "--save-map may replace an existing mlmap map file");
}

/// Why the merged map could not be saved where `o` says, or "" when it can (checked at start,
/// so that a mission does not end with a map that has nowhere to go).
std::string saveMapProblem(const Options& o) {
  if (o.save_map_path.empty()) return "";
  const std::string conflict =
      io::outputConflict(o.save_map_path, {o.config_path}, o.overwrite, "--overwrite");
  if (!conflict.empty()) return "--save-map: not writing " + conflict;
  const std::filesystem::path parent = std::filesystem::absolute(o.save_map_path).parent_path();
  if (!std::filesystem::is_directory(parent)) {
    return "--save-map: the folder " + parent.string() + " does not exist";
  }
  return "";
}

/// The merger's messages to the log, at their level.
void logMessage(LogLevel level, const std::string& message) {
  spdlog::log(level == LogLevel::kError     ? spdlog::level::err
              : level == LogLevel::kWarning ? spdlog::level::warn
                                            : spdlog::level::info,
              message);
}

/// Runs the merger the options describe; returns the exit status (1: an error, logged).
int run(Options o) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("mlmap_fleet"));
  try {
    o.merger.dds.domain_id = o.domain_id;
    o.merger.dds.discovery_range = o.discovery_range;
    if (!o.config_path.empty()) {
      const MapConfig vehicles = config::loadConfigYaml(o.config_path, config::kNodeOnlySections);
      o.merger.log_odds = vehicles.log_odds;
      o.merger.trust.resolution_m = vehicles.local_map.resolution_m;
      o.merger.trust.submap_cells = vehicles.local_map.submap_cells();
    }
    o.merger.trust.vehicle_budget_bytes = static_cast<std::size_t>(o.vehicle_budget_mb * 1048576.0);
    o.merger.trust.fleet_budget_bytes = static_cast<std::size_t>(o.fleet_budget_mb * 1048576.0);
    const std::string save_problem = saveMapProblem(o);
    if (!save_problem.empty()) throw std::runtime_error(save_problem);
    apps::installStopHandler();
    dds::FleetMerger merger(o.merger, logMessage);
    spdlog::info("merging the fleet's submaps on DDS domain {} (rt/{}), publishing under '{}'",
                 merger.domainId(), o.merger.submaps_topic, o.merger.dds.ns);
    merger.start();
    apps::runUntilStopped(o.duration_s, o.report_every_s,
                          [&] { spdlog::info("{}", merger.statusLine()); });
    spdlog::info("stopping");
    merger.stop();
    spdlog::info("done: {}", merger.statusLine());
    if (!o.save_map_path.empty()) {
      const MapState state = merger.mapState();
      io::saveMapFile(state, o.save_map_path);
      spdlog::info("saved the merged map ({} occupied voxels in {} submaps) to {}",
                   state.globalVoxelCount(), state.global_submaps.size(), o.save_map_path);
    }
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap_fleet: merges the submaps every mlmap_node of a fleet shares "
      "(dds.fleet.publish) and publishes the merged map as ROS 2 topics"};
  Options options;
  addOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  return run(options);
}
