// mlmap_fleet: the fleet's merger (ground station or any vehicle). Every vehicle's
// mlmap_msgs/Submap samples in (rt/mlmap/submaps), the merged map out as standard ROS 2 topics,
// over plain Fast DDS: no ROS installation needed. The work is mlmap::dds::FleetMerger's.

#include "mlmap/apps/stop_signal.h"
#include "mlmap/dds/fleet_merger.h"

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>


namespace {

using namespace mlmap;

/// The command line of mlmap_fleet.
struct Options {
  dds::FleetMergerConfig merger;
  int domain_id = -1;           ///< --domain (-1: ROS_DOMAIN_ID, else 0)
  std::string discovery_range;  ///< --discovery-range ("": ROS_AUTOMATIC_DISCOVERY_RANGE)
  double duration_s = 0.0;      ///< --duration (0: until SIGINT / SIGTERM)
  double report_every_s = 5.0;  ///< --report-every (0: none)
};

/// Adds every option of mlmap_fleet to `app`.
void addOptions(CLI::App& app, Options& o) {
  app.add_option("--domain", o.domain_id, "DDS domain (-1: ROS_DOMAIN_ID, else 0)");
  app.add_option("--discovery-range", o.discovery_range,
                 "LOCALHOST, SUBNET, OFF or SYSTEM_DEFAULT (\"\": ROS_AUTOMATIC_DISCOVERY_RANGE)");
  app.add_option("--ns", o.merger.dds.ns, "namespace of the outputs (\"\" for none)");
  app.add_option("--world-frame", o.merger.dds.world_frame, "frame_id of the merged map");
  app.add_option("--submaps-topic", o.merger.submaps_topic, "input: the vehicles' keyed topic");
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
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap_fleet: merges the submaps every mlmap_node of a fleet shares "
               "(dds.fleet.publish) and publishes the merged map as ROS 2 topics"};
  Options options;
  addOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  return run(options);
}
