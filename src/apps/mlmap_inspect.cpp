// mlmap_inspect: subscribes to mlmap_node's layers, prints what arrives (rates, sizes) and writes
// pictures of the received layers and a JSON summary. With --scenario it also scores the received
// occupied voxels against the scenario's ground truth; with --expect-all (or --expect) it fails
// (exit 2) unless every enabled (or every listed) layer arrived. The age of each message at
// arrival (wall clock minus its header stamp: the delay from capture to the ground when the
// sensor stamps with the wall clock) is summarised per topic. The receiving is
// mlmap::dds::LayerReceiver's, the pictures are mlmap::pictures'; this file parses options and
// reports.

#include "mlmap/apps/stop_signal.h"
#include "mlmap/core/stopwatch.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/dds/ground/layer_receiver.h"
#include "mlmap/dds/node/node_config.h"
#include "mlmap/eval/json_output.h"
#include "mlmap/eval/sim_flight.h"
#include "mlmap/pictures/layer_images.h"
#include "mlmap/pictures/map_image.h"

#include "security_options.h"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <thread>

namespace {

using namespace mlmap;
using mlmap::dds::LayerReceiver;
using mlmap::dds::ReceivedLayers;

/// The command line of mlmap_inspect.
struct Options {
  std::string config_path;            ///< -c, --config: node configuration (empty: defaults)
  double duration_s = 0.0;            ///< --duration (0: until SIGINT / SIGTERM)
  double idle_s = 0.0;                ///< --idle-stop (0: never)
  std::string out_dir;                ///< --out: pictures and summary.json (empty: none)
  std::string scenario_path;          ///< --scenario: score against this world
  bool use_default_scenario = false;  ///< --default-scenario: score against the built-in room
  bool expect_all = false;            ///< --expect-all: exit 2 unless every enabled layer arrived
  bool as_bridge = false;             ///< --as-bridge: subscribe with the ROS 2 bridge's QoS
  std::vector<std::string> expect_topics;  ///< --expect: exit 2 unless these arrived
  bool until_expected = false;     ///< --until-expected: stop once the expected layers arrived
  double min_precision = 0.0;      ///< --min-precision: exit 2 below it (0: no check)
  apps::SecurityOptions security;  ///< --keystore, --enclave, --security-strategy
};

/// Adds every option of mlmap_inspect to `app`.
void addOptions(CLI::App& app, Options& o) {
  app.add_option("-c,--config", o.config_path, "node configuration (topics, namespace, domain)")
      ->check(CLI::ExistingFile);
  app.add_option("--duration", o.duration_s, "stop after this many seconds (0: until SIGINT)");
  app.add_option(
      "--idle-stop", o.idle_s,
      "stop once nothing arrived for this many seconds after the first message (0: never)");
  app.add_option("--out", o.out_dir, "write pictures and summary.json into this folder");
  app.add_option("--scenario", o.scenario_path,
                 "score received voxels against this scenario's world")
      ->check(CLI::ExistingFile);
  app.add_flag("--default-scenario", o.use_default_scenario, "score against the built-in scenario");
  app.add_flag("--expect-all", o.expect_all, "exit 2 unless every enabled layer arrived");
  app.add_flag("--as-bridge", o.as_bridge,
               "subscribe as the ROS 2 ground-station bridge does over a radio link: BEST_EFFORT "
               "for the awareness, local map and ESDF slice, no ESDF block");
  app.add_option(
         "--expect", o.expect_topics,
         "exit 2 unless these layers arrived (topic names as in the config, e.g. mlmap/grid)")
      ->delimiter(',');
  app.add_flag("--until-expected", o.until_expected,
               "stop as soon as the expected layers arrived (--expect, or every layer with "
               "--expect-all); --duration stays the limit");
  app.add_option("--min-precision", o.min_precision, "exit 2 when the scored precision is lower");
  o.security.add(app);
}

/// True when something arrived and nothing has for more than `idle_s` seconds (0: never).
bool idleTooLong(const LayerReceiver& rx, double idle_s, SteadyClock::time_point now) {
  if (idle_s <= 0) return false;
  const auto newest = rx.lastArrival();
  return newest && secondsBetween(*newest, now) > idle_s;
}

/// True with --until-expected once every expected layer arrived.
bool expectedArrived(const Options& o, const LayerReceiver& rx) {
  if (!o.until_expected) return false;
  return rx.missingOf(o.expect_topics).empty() &&
         (!o.expect_all || rx.missingOf(rx.subscribed()).empty());
}

/// Waits for messages until --duration, --idle-stop, --until-expected or a stop signal, printing
/// the counts every two seconds.
void listen(const Options& o, const LayerReceiver& rx) {
  const auto start = SteadyClock::now();
  auto last_print = start;
  while (!apps::stopRequested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto now = SteadyClock::now();
    if (o.duration_s > 0 && secondsBetween(start, now) >= o.duration_s) break;
    if (idleTooLong(rx, o.idle_s, now) || expectedArrived(o, rx)) break;
    if (secondsBetween(last_print, now) >= 2.0) {
      last_print = now;
      std::string line;
      for (const auto& [name, messages] : rx.messageCounts()) {
        line += fmt::format(" {}:{}", name, messages);
      }
      spdlog::info("received{}", line.empty() ? " nothing yet" : line);
    }
  }
}

/// One line per topic: messages, rate, size, points and the age at arrival.
void printTopics(const ReceivedLayers& rx) {
  for (const auto& [name, t] : rx.topics) {
    const TimingSummary age = summarizeTimings(t.age_ms);
    const double span = secondsBetween(t.first_at, t.last_at);
    const std::string age_text = t.age_ms.empty()
                                     ? std::string("no stamped message")
                                     : fmt::format("age at arrival median {:.1f} ms, p99 {:.1f} ms",
                                                   age.median_ms, age.p99_ms);
    spdlog::info("{:28} {:6} messages {:8.2f} Hz {:9.1f} kB/msg, last {} points/cells, {}", name,
                 t.messages, span > 0 ? static_cast<double>(t.messages - 1) / span : 0.0,
                 static_cast<double>(t.bytes) / 1e3 / static_cast<double>(t.messages),
                 t.last_points, age_text);
  }
}

/// The received occupied voxels scored against a scenario's world.
struct Score {
  double precision = -1.0;  ///< -1: not scored
  std::size_t voxels = 0;   ///< distinct voxels scored
};

/// Scores the local + global voxels against --scenario or the built-in one (if asked).
Score scoreAgainstScenario(const Options& o, const ReceivedLayers& rx, double res) {
  Score score;
  if (o.scenario_path.empty() && !o.use_default_scenario) return score;
  const datasets::Scenario scenario = o.scenario_path.empty()
                                          ? datasets::defaultScenario()
                                          : datasets::loadScenarioYaml(o.scenario_path);
  eval::VoxelSet voxels;
  for (const auto* list : {&rx.local_W, &rx.global_W}) {
    for (const Eigen::Vector3f& p : *list) voxels.insert(voxelIndexOf(p.cast<double>(), res));
  }
  const eval::Accuracy accuracy =
      eval::scoreOccupancy({voxels.begin(), voxels.end()}, {}, scenario.world, res);
  score.voxels = accuracy.mapped;
  score.precision = accuracy.precision;
  spdlog::info(
      "received occupied voxels (local + global): {}, precision against the scenario: {:.3f}",
      score.voxels, score.precision);
  return score;
}

/// Writes dds_map_top.png, dds_awareness_top.png and, when received, dds_grid.png and
/// dds_esdf_slice.png to `out_dir`.
void writePictures(const std::string& out_dir, const ReceivedLayers& rx, double res) {
  std::vector<Eigen::Vector3f> all = rx.global_W;
  all.insert(all.end(), rx.local_W.begin(), rx.local_W.end());
  pictures::MapImageOptions options;
  options.trajectory_W = rx.trajectory_W;
  options.title = "received over DDS: local + global occupied voxels";
  pictures::writePng(out_dir + "/dds_map_top.png",
                     pictures::renderTopDown(pictures::voxelListOf(all, res), options));
  options.title = "received over DDS: awareness occupied cells (last frame)";
  pictures::writePng(out_dir + "/dds_awareness_top.png",
                     pictures::renderTopDown(pictures::voxelListOf(rx.awareness_W, res), options));
  if (!rx.grid.data_().empty()) {
    pictures::writePng(out_dir + "/dds_grid.png",
                       pictures::renderOccupancyGrid(static_cast<int>(rx.grid.info_().width_()),
                                                     static_cast<int>(rx.grid.info_().height_()),
                                                     rx.grid.data_()));
  }
  if (!rx.esdf_slice_W.empty() && rx.esdf_slice_distance_m.size() == rx.esdf_slice_W.size()) {
    pictures::writePng(out_dir + "/dds_esdf_slice.png",
                       pictures::renderEsdfSlice(rx.esdf_slice_W, rx.esdf_slice_distance_m, res));
  }
}

/// summary.json: per topic the counts and ages, the missing layers, the score and the node's
/// own counts.
eval::Json summaryJson(const ReceivedLayers& rx, const std::vector<std::string>& missing,
                       const Score& score) {
  eval::Json topics = eval::Json::object();
  for (const auto& [name, t] : rx.topics) {
    const TimingSummary age = summarizeTimings(t.age_ms);
    topics[name] = {{"messages", t.messages},
                    {"bytes", t.bytes},
                    {"age_ms", {{"median", age.median_ms}, {"p99", age.p99_ms}}},
                    {"last_points", t.last_points}};
  }
  eval::Json summary;
  summary["topics"] = std::move(topics);
  summary["missing"] = missing;
  summary["malformed"] = rx.malformed;
  summary["scored_voxels"] = score.voxels;
  summary["precision"] = score.precision;
  summary["node_frames_mapped"] = rx.status.frames_mapped_();
  summary["node_global_voxels"] = rx.status.global_voxels_();
  return summary;
}

/// Prints what arrived, scores it, writes the pictures and summary.json (--out) and returns the
/// exit status: 2 when an expected layer is missing or the precision is too low, else 0.
int report(const Options& o, const ReceivedLayers& rx, const std::vector<std::string>& expected,
           bool node_found, double res) {
  const std::vector<std::string> missing = mlmap::dds::missingOf(rx, expected);
  const std::vector<std::string> missing_listed = mlmap::dds::missingOf(rx, o.expect_topics);
  printTopics(rx);
  for (const std::string& name : missing) spdlog::warn("{:28} nothing received", name);
  for (const std::string& name : missing_listed)
    spdlog::error("{:28} expected, nothing received", name);
  if (!node_found) {
    spdlog::error(
        "no publisher of mlmap_node matched any reader: the node was not discovered (is it "
        "running, on this domain and namespace, in reach of the discovery range, with the "
        "same security?)");
  }
  const Score score = scoreAgainstScenario(o, rx, res);
  if (!o.out_dir.empty()) {
    std::filesystem::create_directories(o.out_dir);
    writePictures(o.out_dir, rx, res);
    eval::writeJsonFile(o.out_dir + "/summary.json", summaryJson(rx, missing, score),
                        /*expanded_levels=*/2);
    spdlog::info("wrote pictures and summary.json to {}", o.out_dir);
  }
  if (o.expect_all && !missing.empty()) return 2;
  if (!missing_listed.empty()) return 2;
  if (o.min_precision > 0 && score.precision < o.min_precision) return 2;
  return 0;
}

/// Subscribes, listens and reports; returns the exit status (1: an error, logged).
int run(const Options& o) {
  apps::installStopHandler();
  try {
    mlmap::dds::NodeConfig config = mlmap::dds::nodeConfigOrDefaults(o.config_path);
    o.security.apply(&config.dds.security);
    mlmap::dds::LayerReceiverEvents events;
    events.on_matched = [](const std::string& topic, int publishers) {
      spdlog::info("{}: {} publisher(s) matched", topic, publishers);
    };
    events.on_malformed = [](const std::string& what) { spdlog::warn("{}", what); };
    mlmap::dds::LayerReceiverOptions options;
    options.as_bridge = o.as_bridge;
    LayerReceiver rx(config.dds, options, events);
    spdlog::info("listening for {} layers of mlmap_node (namespace '{}')", rx.subscribed().size(),
                 config.dds.ns);
    listen(o, rx);
    const bool node_found = rx.nodeFound();
    const ReceivedLayers received = rx.finish();
    return report(o, received, rx.subscribed(), node_found, config.map.local_map.resolution_m);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap_inspect: watch mlmap_node's layers over DDS, write pictures and a summary"};
  Options options;
  addOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  return run(options);
}
