// mlmap_inspect: subscribes to mlmap_node's layers, prints what arrives (rates, sizes) and writes
// pictures of the received layers and a JSON summary. With --scenario it also scores the received
// occupied voxels against the scenario's ground truth; with --expect-all (or --expect) it fails
// (exit 2) unless every enabled (or every listed) layer arrived. The age of each message at
// arrival (wall clock minus its header stamp: the delay from capture to the ground when the
// sensor stamps with the wall clock) is summarised per topic.

#include "mlmap/apps/stop_signal.h"
#include "mlmap/core/stopwatch.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/node_config.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/eval/json_output.h"
#include "mlmap/eval/sim_flight.h"
#include "mlmap/pictures/map_image.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/pipeline/map_engine.h"

#include "mlmap_msgs/msg/Status_PubSubTypes.h"
#include "mlmap_msgs/msg/VoxelBlock_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include "security_options.h"

#include <CLI/CLI.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

namespace {

using namespace mlmap;
namespace fdds = eprosima::fastdds::dds;
using Clock = SteadyClock;
using CloudMsg = mlmap::dds::sensor_msgs::PointCloud2_;

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

/// What arrived on one topic.
struct TopicLog {
  std::uint64_t messages = 0;
  std::uint64_t bytes = 0;
  std::size_t last_points = 0;  // points / cells / voxels of the last message
  Clock::time_point first, last;
  std::vector<double> age_ms;  // wall clock at arrival minus header stamp, per message
};

/// Everything received, guarded by one mutex (listener threads write, main reads).
struct Received {
  std::mutex mutex;
  std::map<std::string, TopicLog> topics;
  std::vector<Eigen::Vector3f> local, global, awareness, esdf_slice;
  std::vector<float> esdf_slice_distance;
  mlmap::dds::nav_msgs::OccupancyGrid_ grid;
  mlmap::dds::mlmap_msgs::Status_ status;
  std::vector<Eigen::Vector3d> trajectory_W;
  std::uint64_t malformed = 0;
  std::atomic<bool> node_found{false};  ///< a reader matched a publisher of the node (no mutex)

  /// Counts a message of `bytes` bytes with `points` points / cells on topic `name`, and its age
  /// from `stamp`; call with `mutex` held.
  void note(const std::string& name, std::size_t bytes, std::size_t points,
            const ::builtin_interfaces::msg::dds_::Time_& stamp) {
    TopicLog& t = topics[name];
    if (t.messages == 0) t.first = Clock::now();
    t.last = Clock::now();
    ++t.messages;
    t.bytes += bytes;
    t.last_points = points;
    // A zero stamp is ROS's "no time" (the node's status before its first mapped frame): no age.
    if (stamp.sec_() == 0 && stamp.nanosec_() == 0) return;
    t.age_ms.push_back(1e3 * (mlmap::dds::wallClockNow_s() - mlmap::dds::toSeconds(stamp)));
  }
};

/// The readers of the node's layers, with the names of the layers expected to arrive.
struct Subscription {
  mlmap::dds::ParticipantPtr participant;
  std::unique_ptr<mlmap::dds::TakeReaders> readers;
  std::vector<std::string> expected;
  std::string ns;                           ///< the node's DDS namespace
  std::atomic<bool>* node_found = nullptr;  ///< Received's: set when a reader matches

  /// Deletes the readers and then their listeners: no more callbacks from here on.
  void close() {
    participant.reset();
    readers.reset();
  }
  /// Adds a reader of `PubSubType` on the node's topic `name` (in the namespace unless
  /// `absolute`, as tf and tf_static are) and expects `name` to arrive. Logs each change of its
  /// matched publishers ("<name>: 1 publisher(s) matched"): the node found, handshakes included.
  template <typename PubSubType>
  void add(const std::string& name, const fdds::DataReaderQos& qos,
           std::function<void(typename PubSubType::type&&)> sink, bool absolute = false) {
    expected.push_back(name);
    readers->add<PubSubType>(mlmap::dds::ddsTopicName(absolute ? "" : ns, name), qos,
                             std::move(sink), [name, found = node_found](int publishers) {
                               spdlog::info("{}: {} publisher(s) matched", name, publishers);
                               if (publishers > 0) found->store(true);
                             });
  }
};

/// The points of a PointCloud2 layer into `rx.*store`, and the `intensity` field (float32 at
/// offset 12, as mlmap's clouds carry the ESDF slice's distances) into `rx.*intensity` if given.
std::function<void(CloudMsg&&)> cloudSink(Received* rx, const std::string& name,
                                          std::vector<Eigen::Vector3f> Received::*store,
                                          std::vector<float> Received::*intensity) {
  return [rx, name, store, intensity](CloudMsg&& msg) {
    std::vector<Eigen::Vector3f> points;
    const bool ok = mlmap::dds::decodePointCloud2(msg, &points).ok();
    std::lock_guard<std::mutex> lock(rx->mutex);
    if (!ok) return void(++rx->malformed);
    rx->note(name, msg.data_().size(), points.size(), msg.header_().stamp_());
    if (intensity != nullptr && msg.point_step_() >= 16) {
      std::vector<float>& values = rx->*intensity;
      values.resize(points.size());
      for (std::size_t i = 0; i < points.size(); ++i) {
        std::memcpy(&values[i], msg.data_().data() + i * msg.point_step_() + 12, 4);
      }
    }
    rx->*store = std::move(points);
  };
}

/// Subscribes to the four PointCloud2 layers the configuration enables. With --as-bridge the
/// heavy ones are read best-effort, as over a lossy link: a lost sample is never repaired, the
/// next one replaces it.
void subscribeClouds(const Options& o, const mlmap::dds::DdsConfig& dds, Subscription* sub,
                     Received* rx) {
  const mlmap::dds::TopicNames& n = dds.topics;
  const mlmap::dds::PublishRates& r = dds.rates;
  const fdds::DataReaderQos heavy =
      o.as_bridge ? mlmap::dds::sensorReaderQos(1) : mlmap::dds::reliableReaderQos(false, 2);
  const fdds::DataReaderQos latched = mlmap::dds::reliableReaderQos(true, 2);
  auto cloudTopic = [&](const std::string& name, double rate_hz, const fdds::DataReaderQos& qos,
                        std::vector<Eigen::Vector3f> Received::*store,
                        std::vector<float> Received::*intensity) {
    if (name.empty() || rate_hz <= 0) return;
    sub->add<mlmap::dds::sensor_msgs::PointCloud2_PubSubType>(
        name, qos, cloudSink(rx, name, store, intensity));
  };
  cloudTopic(n.awareness, r.awareness_hz, heavy, &Received::awareness, nullptr);
  cloudTopic(n.local_map, r.local_map_hz, heavy, &Received::local, nullptr);
  cloudTopic(n.global_map, r.global_map_hz, latched, &Received::global, nullptr);
  cloudTopic(n.esdf_slice, r.esdf_hz, heavy, &Received::esdf_slice, &Received::esdf_slice_distance);
}

/// Subscribes to the 2D grid and the ESDF block (not with --as-bridge), when enabled.
void subscribeGridAndEsdf(const Options& o, const mlmap::dds::DdsConfig& dds, Subscription* sub,
                          Received* rx) {
  const mlmap::dds::TopicNames& n = dds.topics;
  if (!n.grid.empty() && dds.rates.grid_hz > 0) {
    sub->add<mlmap::dds::nav_msgs::OccupancyGrid_PubSubType>(
        n.grid, mlmap::dds::reliableReaderQos(true, 1),
        [rx, name = n.grid](mlmap::dds::nav_msgs::OccupancyGrid_&& msg) {
          std::lock_guard<std::mutex> lock(rx->mutex);
          rx->note(name, msg.data_().size(), msg.data_().size(), msg.header_().stamp_());
          rx->grid = std::move(msg);
        });
  }
  if (!n.esdf_block.empty() && dds.rates.esdf_hz > 0 && !o.as_bridge) {
    sub->add<mlmap::dds::mlmap_msgs::VoxelBlock_PubSubType>(
        n.esdf_block, mlmap::dds::reliableReaderQos(false, 2),
        [rx, name = n.esdf_block](mlmap::dds::mlmap_msgs::VoxelBlock_&& msg) {
          std::lock_guard<std::mutex> lock(rx->mutex);
          rx->note(name, msg.values_().size() * 4, msg.values_().size(), msg.header_().stamp_());
        });
  }
}

/// Subscribes to the node's status, when enabled, and to the trajectory on tf.
void subscribeStatusAndTf(const mlmap::dds::DdsConfig& dds, Subscription* sub, Received* rx) {
  const std::string& status = dds.topics.status;
  if (!status.empty() && dds.rates.status_hz > 0) {
    sub->add<mlmap::dds::mlmap_msgs::Status_PubSubType>(
        status, mlmap::dds::reliableReaderQos(false, 10),
        [rx, status](mlmap::dds::mlmap_msgs::Status_&& msg) {
          std::lock_guard<std::mutex> lock(rx->mutex);
          rx->note(status, sizeof(msg), 1, msg.header_().stamp_());
          rx->status = std::move(msg);
        });
  }
  // The trajectory is world -> body, which the node sends in tf_mode world_body only.
  if (mlmap::dds::resolveTfMode(dds) != mlmap::dds::TfMode::kWorldBody) return;
  sub->add<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(
      "tf", mlmap::dds::reliableReaderQos(false, 100),
      [rx](::tf2_msgs::msg::dds_::TFMessage_&& msg) {
        std::lock_guard<std::mutex> lock(rx->mutex);
        if (msg.transforms_().empty()) return;
        rx->note("tf", 0, msg.transforms_().size(), msg.transforms_().front().header_().stamp_());
        for (const auto& t : msg.transforms_()) {
          const auto& p = t.transform_().translation_();
          rx->trajectory_W.emplace_back(p.x_(), p.y_(), p.z_());
        }
      },
      /*absolute=*/true);
}

/// Joins the node's DDS graph and subscribes to every layer the configuration enables.
Subscription subscribe(const Options& o, const mlmap::dds::DdsConfig& dds, Received* rx) {
  Subscription sub;
  sub.ns = dds.ns;
  sub.node_found = &rx->node_found;
  sub.participant = mlmap::dds::createParticipant(dds, "mlmap_inspect");
  fdds::Subscriber* subscriber = sub.participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  sub.readers =
      std::make_unique<mlmap::dds::TakeReaders>(subscriber, [rx](const std::string& what) {
        std::lock_guard<std::mutex> lock(rx->mutex);
        ++rx->malformed;
        spdlog::warn("{}", what);
      });
  subscribeClouds(o, dds, &sub, rx);
  subscribeGridAndEsdf(o, dds, &sub, rx);
  subscribeStatusAndTf(dds, &sub, rx);
  return sub;
}

/// True when something arrived and nothing has for more than `idle_s` seconds (0: never).
bool idleTooLong(const Received& rx, double idle_s, Clock::time_point now) {
  if (idle_s <= 0) return false;
  Clock::time_point newest = Clock::time_point::min();
  for (const auto& [name, t] : rx.topics) newest = std::max(newest, t.last);
  return newest != Clock::time_point::min() && secondsBetween(newest, now) > idle_s;
}

/// The names of `names` that nothing arrived on.
std::vector<std::string> missingOf(const Received& rx, const std::vector<std::string>& names) {
  std::vector<std::string> missing;
  for (const std::string& name : names) {
    if (rx.topics.count(name) == 0) missing.push_back(name);
  }
  return missing;
}

/// True with --until-expected once every expected layer arrived (call with rx.mutex held).
bool expectedArrived(const Options& o, const Received& rx, const std::vector<std::string>& all) {
  if (!o.until_expected) return false;
  return missingOf(rx, o.expect_topics).empty() && (!o.expect_all || missingOf(rx, all).empty());
}

/// Waits for messages until --duration, --idle-stop, --until-expected or a stop signal, printing
/// the counts every two seconds.
void listen(const Options& o, Received* rx, const std::vector<std::string>& expected) {
  const auto start = Clock::now();
  auto last_print = start;
  while (!apps::stopRequested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto now = Clock::now();
    if (o.duration_s > 0 && secondsBetween(start, now) >= o.duration_s) break;
    std::lock_guard<std::mutex> lock(rx->mutex);
    if (idleTooLong(*rx, o.idle_s, now) || expectedArrived(o, *rx, expected)) break;
    if (secondsBetween(last_print, now) >= 2.0) {
      last_print = now;
      std::string line;
      for (const auto& [name, t] : rx->topics) line += fmt::format(" {}:{}", name, t.messages);
      spdlog::info("received{}", line.empty() ? " nothing yet" : line);
    }
  }
}

/// One line per topic: messages, rate, size, points and the age at arrival.
void printTopics(const Received& rx) {
  for (const auto& [name, t] : rx.topics) {
    const TimingSummary age = summarizeTimings(t.age_ms);
    const double span = secondsBetween(t.first, t.last);
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
Score scoreAgainstScenario(const Options& o, const Received& rx, double res) {
  Score score;
  if (o.scenario_path.empty() && !o.use_default_scenario) return score;
  const datasets::Scenario scenario = o.scenario_path.empty()
                                          ? datasets::defaultScenario()
                                          : datasets::loadScenarioYaml(o.scenario_path);
  eval::VoxelSet voxels;
  for (const auto* list : {&rx.local, &rx.global}) {
    for (const Eigen::Vector3f& p : *list) voxels.insert(voxelIndexOf(p.cast<double>(), res));
  }
  std::size_t right = 0;
  for (const VoxelIndex& v : voxels) right += eval::touchesSolid(scenario.world, v, res) ? 1 : 0;
  score.voxels = voxels.size();
  score.precision =
      score.voxels > 0 ? static_cast<double>(right) / static_cast<double>(score.voxels) : 0.0;
  spdlog::info(
      "received occupied voxels (local + global): {}, precision against the scenario: {:.3f}",
      score.voxels, score.precision);
  return score;
}

/// The occupancy grid as a picture, north up, about 600 pixels across.
cv::Mat gridImage(const mlmap::dds::nav_msgs::OccupancyGrid_& grid) {
  const int w = static_cast<int>(grid.info_().width_());
  const int h = static_cast<int>(grid.info_().height_());
  cv::Mat image(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int v = grid.data_()[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) +
                                 static_cast<std::size_t>(x)];
      // Row 0 of the grid is its lowest y: flip so north is up.
      cv::Vec3b& px = image.at<cv::Vec3b>(h - 1 - y, x);
      if (v < 0) {
        px = cv::Vec3b(200, 200, 200);  // unknown: grey
      } else {
        const auto g = static_cast<unsigned char>(255 - 255 * v / 100);
        px = cv::Vec3b(g, g, g);  // free white .. occupied black
      }
    }
  }
  const int scale = std::max(1, 600 / std::max(1, std::max(w, h)));
  cv::Mat big;
  cv::resize(image, big, cv::Size(w * scale, h * scale), 0, 0, cv::INTER_NEAREST);
  return big;
}

/// The ESDF slice seen from above, each voxel coloured by its distance (TURBO, low = near).
cv::Mat esdfSliceImage(const std::vector<Eigen::Vector3f>& points,
                       const std::vector<float>& distance_m, double res) {
  Eigen::Vector2f lo(1e9f, 1e9f), hi(-1e9f, -1e9f);
  float d_lo = 1e9f, d_hi = -1e9f;
  for (std::size_t i = 0; i < points.size(); ++i) {
    lo = lo.cwiseMin(points[i].head<2>());
    hi = hi.cwiseMax(points[i].head<2>());
    d_lo = std::min(d_lo, distance_m[i]);
    d_hi = std::max(d_hi, distance_m[i]);
  }
  const int w = static_cast<int>(std::lround((hi.x() - lo.x()) / res)) + 1;
  const int h = static_cast<int>(std::lround((hi.y() - lo.y()) / res)) + 1;
  const int px = std::max(2, 600 / std::max(w, h));  // about 600 pixels across
  cv::Mat image(h * px, w * px, CV_8UC3, cv::Scalar(255, 255, 255));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const int x = static_cast<int>(std::lround((points[i].x() - lo.x()) / res));
    const int y = h - 1 - static_cast<int>(std::lround((points[i].y() - lo.y()) / res));
    const double f = d_hi > d_lo ? (distance_m[i] - d_lo) / (d_hi - d_lo) : 0.0;
    const cv::Vec3b c = pictures::heightColorBgr(f);
    cv::rectangle(image, cv::Rect(x * px, y * px, px, px), cv::Scalar(c[0], c[1], c[2]),
                  cv::FILLED);
  }
  cv::putText(image, cv::format("ESDF slice: %.2f m (blue) .. %.2f m (red)", d_lo, d_hi),
              cv::Point(4, 14), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
  return image;
}

/// Received points as voxel centres of size `res` [m], for the pictures.
pictures::VoxelList voxelList(const std::vector<Eigen::Vector3f>& points, double res) {
  pictures::VoxelList list{res, {}};
  list.centers_W.reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    // Re-snap to the voxel centre (float transport rounds a little).
    list.centers_W.push_back(voxelCenter(voxelIndexOf(p.cast<double>(), res), res));
  }
  return list;
}

/// Writes dds_map_top.png, dds_awareness_top.png and, when received, dds_grid.png and
/// dds_esdf_slice.png to `out_dir`.
void writePictures(const std::string& out_dir, const Received& rx, double res) {
  std::vector<Eigen::Vector3f> all = rx.global;
  all.insert(all.end(), rx.local.begin(), rx.local.end());
  pictures::MapImageOptions options;
  options.trajectory_W = rx.trajectory_W;
  options.title = "received over DDS: local + global occupied voxels";
  pictures::writePng(out_dir + "/dds_map_top.png",
                     pictures::renderTopDown(voxelList(all, res), options));
  options.title = "received over DDS: awareness occupied cells (last frame)";
  pictures::writePng(out_dir + "/dds_awareness_top.png",
                     pictures::renderTopDown(voxelList(rx.awareness, res), options));
  if (!rx.grid.data_().empty()) pictures::writePng(out_dir + "/dds_grid.png", gridImage(rx.grid));
  if (!rx.esdf_slice.empty() && rx.esdf_slice_distance.size() == rx.esdf_slice.size()) {
    pictures::writePng(out_dir + "/dds_esdf_slice.png",
                       esdfSliceImage(rx.esdf_slice, rx.esdf_slice_distance, res));
  }
}

/// summary.json: per topic the counts and ages, the missing layers, the score and the node's
/// own counts.
eval::Json summaryJson(const Received& rx, const std::vector<std::string>& missing,
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
int report(const Options& o, const Received& rx, const std::vector<std::string>& expected,
           double res) {
  const std::vector<std::string> missing = missingOf(rx, expected);
  const std::vector<std::string> missing_listed = missingOf(rx, o.expect_topics);
  printTopics(rx);
  for (const std::string& name : missing) spdlog::warn("{:28} nothing received", name);
  for (const std::string& name : missing_listed)
    spdlog::error("{:28} expected, nothing received", name);
  if (!rx.node_found.load()) {
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
    Received rx;
    Subscription sub = subscribe(o, config.dds, &rx);
    spdlog::info("listening for {} layers of mlmap_node (namespace '{}')", sub.expected.size(),
                 sub.ns);
    listen(o, &rx, sub.expected);
    sub.close();
    return report(o, rx, sub.expected, config.map.local_map.resolution_m);
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
