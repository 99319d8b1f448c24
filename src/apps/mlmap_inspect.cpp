// mlmap_inspect: subscribes to mlmap_node's layers, prints what arrives (rates, sizes) and writes
// pictures of the received layers and a JSON summary. With --scenario it also scores the received
// occupied voxels against the scenario's ground truth; with --expect-all (or --expect) it fails
// (exit 2) unless every enabled (or every listed) layer arrived. The age of each message at
// arrival (wall clock minus its header stamp: the delay from capture to the ground when the
// sensor stamps with the wall clock) is summarised per topic.

#include "mlmap/dds/entities.h"
#include "mlmap/dds/node_config.h"
#include "mlmap/dds/participant.h"
#include "mlmap/dds/ros_conversions.h"
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
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <mutex>
#include <thread>

namespace {

using namespace mlmap;
namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) { g_stop = true; }

/// What arrived on one topic.
struct TopicLog {
  std::uint64_t messages = 0;
  std::uint64_t bytes = 0;
  std::size_t last_points = 0;  // points / cells / voxels of the last message
  Clock::time_point first, last;
  std::vector<double> age_ms;   // wall clock at arrival minus header stamp, per message
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
cv::Mat esdfSliceImage(const std::vector<Eigen::Vector3f>& points, const std::vector<float>& distance_m,
                       double res) {
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
    const cv::Vec3b c = io::heightColorBgr(f);
    cv::rectangle(image, cv::Rect(x * px, y * px, px, px), cv::Scalar(c[0], c[1], c[2]), cv::FILLED);
  }
  cv::putText(image, cv::format("ESDF slice: %.2f m (blue) .. %.2f m (red)", d_lo, d_hi),
              cv::Point(4, 14), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
  return image;
}

io::VoxelList voxelList(const std::vector<Eigen::Vector3f>& points, double res) {
  io::VoxelList list{res, {}};
  list.centers_W.reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    // Re-snap to the voxel centre (float transport rounds a little).
    list.centers_W.push_back(voxelCenter(voxelIndexOf(p.cast<double>(), res), res));
  }
  return list;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap_inspect: watch mlmap_node's layers over DDS, write pictures and a summary"};
  std::string config_path, out_dir, scenario_path;
  double duration_s = 0.0, idle_s = 0.0;
  bool expect_all = false, use_default_scenario = false, as_bridge = false;
  std::vector<std::string> expect_topics;
  double min_precision = 0.0;
  app.add_option("-c,--config", config_path, "node configuration (topics, namespace, domain)")
      ->check(CLI::ExistingFile);
  app.add_option("--duration", duration_s, "stop after this many seconds (0: until SIGINT)");
  app.add_option("--idle-stop", idle_s, "stop once nothing arrived for this many seconds after the first message (0: never)");
  app.add_option("--out", out_dir, "write pictures and summary.json into this folder");
  app.add_option("--scenario", scenario_path, "score received voxels against this scenario's world")
      ->check(CLI::ExistingFile);
  app.add_flag("--default-scenario", use_default_scenario, "score against the built-in scenario");
  app.add_flag("--expect-all", expect_all, "exit 2 unless every enabled layer arrived");
  app.add_flag("--as-bridge", as_bridge,
               "subscribe as the ROS 2 ground-station bridge does over a radio link: BEST_EFFORT "
               "for the awareness, local map and ESDF slice, no ESDF block");
  app.add_option("--expect", expect_topics,
                 "exit 2 unless these layers arrived (topic names as in the config, e.g. mlmap/grid)")
      ->delimiter(',');
  app.add_option("--min-precision", min_precision, "exit 2 when the scored precision is lower");
  mlmap::apps::SecurityOptions security;
  security.add(app);
  CLI11_PARSE(app, argc, argv);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);

  try {
    mlmap::dds::NodeConfig config =
        config_path.empty() ? mlmap::dds::NodeConfig{} : mlmap::dds::loadNodeConfigYaml(config_path);
    security.apply(&config.dds.security);
    const mlmap::dds::TopicNames& n = config.dds.topics;
    const mlmap::dds::PublishRates& r = config.dds.rates;
    const std::string& ns = config.dds.ns;
    mlmap::dds::ParticipantPtr participant = mlmap::dds::createParticipant(config.dds, "mlmap_inspect");
    fdds::Subscriber* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    Received rx;
    std::vector<std::unique_ptr<fdds::DataReaderListener>> listeners;
    auto onError = [&rx](const std::string& what) {
      std::lock_guard<std::mutex> lock(rx.mutex);
      ++rx.malformed;
      spdlog::warn("{}", what);
    };
    std::vector<std::string> expected;
    // A PointCloud2 layer; `intensity` (optional) receives the `intensity` field, which mlmap's
    // clouds carry as float32 at offset 12 (the ESDF slice's distances).
    // Heavy layers over a lossy link: a lost sample is never repaired, the next one replaces it.
    const auto heavyQos = [as_bridge](int depth) {
      return as_bridge ? mlmap::dds::sensorReaderQos(1) : mlmap::dds::reliableReaderQos(false, depth);
    };
    auto cloudTopic = [&](const std::string& name, double rate_hz, bool latched,
                          std::vector<Eigen::Vector3f> Received::*store,
                          std::vector<float> Received::*intensity) {
      if (name.empty() || rate_hz <= 0) return;
      expected.push_back(name);
      auto l = std::make_unique<mlmap::dds::TakeListener<mlmap::dds::sensor_msgs::PointCloud2_>>(
          [&rx, name, store, intensity](mlmap::dds::sensor_msgs::PointCloud2_&& msg) {
            std::vector<Eigen::Vector3f> points;
            const bool ok = mlmap::dds::decodePointCloud2(msg, &points).ok();
            std::lock_guard<std::mutex> lock(rx.mutex);
            if (!ok) return void(++rx.malformed);
            rx.note(name, msg.data_().size(), points.size(), msg.header_().stamp_());
            if (intensity != nullptr && msg.point_step_() >= 16) {
              std::vector<float>& values = rx.*intensity;
              values.resize(points.size());
              for (std::size_t i = 0; i < points.size(); ++i) {
                std::memcpy(&values[i], msg.data_().data() + i * msg.point_step_() + 12, 4);
              }
            }
            rx.*store = std::move(points);
          },
          onError);
      mlmap::dds::createReader<mlmap::dds::sensor_msgs::PointCloud2_PubSubType>(
          subscriber, mlmap::dds::ddsTopicName(ns, name),
          latched ? mlmap::dds::reliableReaderQos(true, 2) : heavyQos(2), l.get());
      listeners.push_back(std::move(l));
    };
    cloudTopic(n.awareness, r.awareness_hz, false, &Received::awareness, nullptr);
    cloudTopic(n.local_map, r.local_map_hz, false, &Received::local, nullptr);
    cloudTopic(n.global_map, r.global_map_hz, true, &Received::global, nullptr);
    cloudTopic(n.esdf_slice, r.esdf_hz, false, &Received::esdf_slice, &Received::esdf_slice_distance);
    if (!n.grid.empty() && r.grid_hz > 0) {
      expected.push_back(n.grid);
      auto l = std::make_unique<mlmap::dds::TakeListener<mlmap::dds::nav_msgs::OccupancyGrid_>>(
          [&rx, name = n.grid](mlmap::dds::nav_msgs::OccupancyGrid_&& msg) {
            std::lock_guard<std::mutex> lock(rx.mutex);
            rx.note(name, msg.data_().size(), msg.data_().size(), msg.header_().stamp_());
            rx.grid = std::move(msg);
          },
          onError);
      mlmap::dds::createReader<mlmap::dds::nav_msgs::OccupancyGrid_PubSubType>(
          subscriber, mlmap::dds::ddsTopicName(ns, n.grid), mlmap::dds::reliableReaderQos(true, 1), l.get());
      listeners.push_back(std::move(l));
    }
    if (!n.esdf_block.empty() && r.esdf_hz > 0 && !as_bridge) {
      expected.push_back(n.esdf_block);
      auto l = std::make_unique<mlmap::dds::TakeListener<mlmap::dds::mlmap_msgs::VoxelBlock_>>(
          [&rx, name = n.esdf_block](mlmap::dds::mlmap_msgs::VoxelBlock_&& msg) {
            std::lock_guard<std::mutex> lock(rx.mutex);
            rx.note(name, msg.values_().size() * 4, msg.values_().size(), msg.header_().stamp_());
          },
          onError);
      mlmap::dds::createReader<mlmap::dds::mlmap_msgs::VoxelBlock_PubSubType>(
          subscriber, mlmap::dds::ddsTopicName(ns, n.esdf_block), mlmap::dds::reliableReaderQos(false, 2), l.get());
      listeners.push_back(std::move(l));
    }
    if (!n.status.empty() && r.status_hz > 0) {
      expected.push_back(n.status);
      auto l = std::make_unique<mlmap::dds::TakeListener<mlmap::dds::mlmap_msgs::Status_>>(
          [&rx, name = n.status](mlmap::dds::mlmap_msgs::Status_&& msg) {
            std::lock_guard<std::mutex> lock(rx.mutex);
            rx.note(name, sizeof(msg), 1, msg.header_().stamp_());
            rx.status = std::move(msg);
          },
          onError);
      mlmap::dds::createReader<mlmap::dds::mlmap_msgs::Status_PubSubType>(
          subscriber, mlmap::dds::ddsTopicName(ns, n.status), mlmap::dds::reliableReaderQos(false, 10), l.get());
      listeners.push_back(std::move(l));
    }
    {
      expected.push_back("tf");
      auto l = std::make_unique<mlmap::dds::TakeListener<::tf2_msgs::msg::dds_::TFMessage_>>(
          [&rx](::tf2_msgs::msg::dds_::TFMessage_&& msg) {
            std::lock_guard<std::mutex> lock(rx.mutex);
            if (msg.transforms_().empty()) return;
            rx.note("tf", 0, msg.transforms_().size(), msg.transforms_().front().header_().stamp_());
            for (const auto& t : msg.transforms_()) {
              const auto& p = t.transform_().translation_();
              rx.trajectory_W.emplace_back(p.x_(), p.y_(), p.z_());
            }
          },
          onError);
      mlmap::dds::createReader<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(
          subscriber, mlmap::dds::ddsTopicName(ns, "tf"), mlmap::dds::reliableReaderQos(false, 100), l.get());
      listeners.push_back(std::move(l));
    }

    spdlog::info("listening for {} layers of mlmap_node (namespace '{}')", expected.size(), ns);
    const auto start = Clock::now();
    auto last_print = start;
    while (!g_stop) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      const auto now = Clock::now();
      const double elapsed = std::chrono::duration<double>(now - start).count();
      if (duration_s > 0 && elapsed >= duration_s) break;
      std::lock_guard<std::mutex> lock(rx.mutex);
      if (idle_s > 0) {
        Clock::time_point newest = Clock::time_point::min();
        for (const auto& [name, t] : rx.topics) newest = std::max(newest, t.last);
        if (newest != Clock::time_point::min() &&
            std::chrono::duration<double>(now - newest).count() > idle_s) {
          break;
        }
      }
      if (std::chrono::duration<double>(now - last_print).count() >= 2.0) {
        last_print = now;
        std::string line;
        for (const auto& [name, t] : rx.topics) line += fmt::format(" {}:{}", name, t.messages);
        spdlog::info("received{}", line.empty() ? " nothing yet" : line);
      }
    }
    participant.reset();  // no more callbacks from here on
    listeners.clear();

    // Summary.
    const double res = config.map.local_map.resolution_m;
    std::vector<std::string> missing;
    for (const std::string& name : expected) {
      if (rx.topics.count(name) == 0) missing.push_back(name);
    }
    std::vector<std::string> missing_listed;
    for (const std::string& name : expect_topics) {
      if (rx.topics.count(name) == 0) missing_listed.push_back(name);
    }
    for (const auto& [name, t] : rx.topics) {
      const TimingSummary age = summarizeTimings(t.age_ms);
      const double span = std::chrono::duration<double>(t.last - t.first).count();
      const std::string age_text =
          t.age_ms.empty() ? std::string("no stamped message")
                           : fmt::format("age at arrival median {:.1f} ms, p99 {:.1f} ms", age.median_ms, age.p99_ms);
      spdlog::info("{:28} {:6} messages {:8.2f} Hz {:9.1f} kB/msg, last {} points/cells, {}",
                   name, t.messages, span > 0 ? static_cast<double>(t.messages - 1) / span : 0.0,
                   static_cast<double>(t.bytes) / 1e3 / static_cast<double>(t.messages), t.last_points,
                   age_text);
    }
    for (const std::string& name : missing) spdlog::warn("{:28} nothing received", name);
    for (const std::string& name : missing_listed) spdlog::error("{:28} expected, nothing received", name);

    // Score local + global voxels against ground truth.
    double precision = -1.0;
    std::size_t scored = 0;
    if (!scenario_path.empty() || use_default_scenario) {
      const io::Scenario scenario =
          scenario_path.empty() ? io::defaultScenario() : io::loadScenarioYaml(scenario_path);
      eval::VoxelSet voxels;
      for (const auto* list : {&rx.local, &rx.global}) {
        for (const Eigen::Vector3f& p : *list) voxels.insert(voxelIndexOf(p.cast<double>(), res));
      }
      std::size_t right = 0;
      for (const VoxelIndex& v : voxels) right += eval::touchesSolid(scenario.world, v, res) ? 1 : 0;
      scored = voxels.size();
      precision = scored > 0 ? static_cast<double>(right) / static_cast<double>(scored) : 0.0;
      spdlog::info("received occupied voxels (local + global): {}, precision against the scenario: {:.3f}",
                   scored, precision);
    }

    if (!out_dir.empty()) {
      std::filesystem::create_directories(out_dir);
      std::vector<Eigen::Vector3f> all = rx.global;
      all.insert(all.end(), rx.local.begin(), rx.local.end());
      io::MapImageOptions options;
      options.trajectory_W = rx.trajectory_W;
      options.title = "received over DDS: local + global occupied voxels";
      io::writePng(out_dir + "/dds_map_top.png", io::renderTopDown(voxelList(all, res), options));
      options.title = "received over DDS: awareness occupied cells (last frame)";
      io::writePng(out_dir + "/dds_awareness_top.png",
                   io::renderTopDown(voxelList(rx.awareness, res), options));
      if (!rx.grid.data_().empty()) io::writePng(out_dir + "/dds_grid.png", gridImage(rx.grid));
      if (!rx.esdf_slice.empty() && rx.esdf_slice_distance.size() == rx.esdf_slice.size()) {
        io::writePng(out_dir + "/dds_esdf_slice.png",
                     esdfSliceImage(rx.esdf_slice, rx.esdf_slice_distance, res));
      }
      std::ofstream json(out_dir + "/summary.json");
      json << "{\n  \"topics\": {";
      bool first = true;
      for (const auto& [name, t] : rx.topics) {
        const TimingSummary age = summarizeTimings(t.age_ms);
        json << (first ? "" : ",") << "\n    \"" << name << "\": {\"messages\": " << t.messages
             << ", \"bytes\": " << t.bytes << ", \"age_ms\": {\"median\": " << age.median_ms
             << ", \"p99\": " << age.p99_ms << "}, \"last_points\": " << t.last_points
             << "}";
        first = false;
      }
      json << "\n  },\n  \"missing\": [";
      for (std::size_t i = 0; i < missing.size(); ++i) json << (i ? ", " : "") << '"' << missing[i] << '"';
      json << "],\n  \"malformed\": " << rx.malformed << ",\n  \"scored_voxels\": " << scored
           << ",\n  \"precision\": " << precision << ",\n  \"node_frames_mapped\": "
           << rx.status.frames_mapped_() << ",\n  \"node_global_voxels\": " << rx.status.global_voxels_()
           << "\n}\n";
      spdlog::info("wrote pictures and summary.json to {}", out_dir);
    }
    if (expect_all && !missing.empty()) return 2;
    if (!missing_listed.empty()) return 2;
    if (min_precision > 0 && precision < min_precision) return 2;
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
