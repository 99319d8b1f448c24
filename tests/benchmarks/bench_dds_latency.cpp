// mlmap_bench_dds_latency: the subscriber end of the DDS latency benchmark
// (tools/bench_dds_latency.sh runs mlmap_sensor_publisher -> mlmap_node -> this program).
//
// Subscribes to mlmap_node's local-map layer, rt/tf and the status topic (with --probe-cloud
// also to the sensor's clouds) and measures, for every local map that arrives, wall-clock receive
// time - header stamp. The publisher stamps each cloud with its wall-clock capture time and the
// node carries that stamp to the local map, so this is the latency from capture to a subscriber
// holding the map of that frame. rt/tf leaves the node just before the local map with the same
// stamp, which splits the latency into "until the node's publishing thread has the snapshot"
// and "encoding and sending the local map". The node's final status gives the engine's own
// compute time and its frame counters.
//
// Prints a table against the targets of the issue (no dropped frame; p50 <= engine median + 5
// ms; p99 <= engine p99 + 15 ms) and writes JSON. Figures, not pass/fail: only --require-all
// (the ctest smoke run) fails, when a frame sent did not reach this program or no status came.

#include "mlmap/apps/stop_signal.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/pipeline/map_engine.h"
#include "mlmap/dds/node/node_config.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include "mlmap_msgs/msg/Status_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <numeric>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace mlmap;
namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

constexpr double kTargetP50Margin_ms = 5.0;   // p50 <= engine median + this
constexpr double kTargetP99Margin_ms = 15.0;  // p99 <= engine p99 + this

/// One message that arrived: its header stamp and receive time - stamp.
struct Arrival {
  double stamp_s = 0.0;
  double latency_ms = 0.0;
  std::size_t bytes = 0;
  std::size_t points = 0;
};

/// Median, p90, p99, max and mean of a sample, in ms (nearest rank, as the engine's stats).
struct Summary {
  std::size_t count = 0;
  double p50_ms = 0.0, p90_ms = 0.0, p99_ms = 0.0, max_ms = 0.0, mean_ms = 0.0;
};

Summary summarize(std::vector<double> values) {
  Summary s;
  s.count = values.size();
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  s.p50_ms = sortedQuantile(values, 0.5);
  s.p90_ms = sortedQuantile(values, 0.9);
  s.p99_ms = sortedQuantile(values, 0.99);
  s.max_ms = values.back();
  s.mean_ms = std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(s.count);
  return s;
}

std::string json(const Summary& s) {
  char text[256];
  std::snprintf(text, sizeof(text),
                "{\"count\": %zu, \"p50_ms\": %.3f, \"p90_ms\": %.3f, \"p99_ms\": %.3f, "
                "\"max_ms\": %.3f, \"mean_ms\": %.3f}",
                s.count, s.p50_ms, s.p90_ms, s.p99_ms, s.max_ms, s.mean_ms);
  return text;
}

/// Everything received (listener threads write, main reads).
struct Received {
  std::mutex mutex;
  std::vector<Arrival> local, tf, cloud;
  mlmap::dds::mlmap_msgs::Status_ status;
  std::uint64_t statuses = 0;
  std::uint64_t malformed = 0;
  Clock::time_point last_activity = Clock::time_point::min();
};

/// Stamp -> latency of the arrivals, the first arrival of each stamp.
std::map<double, double> byStamp(const std::vector<Arrival>& arrivals) {
  std::map<double, double> out;
  for (const Arrival& a : arrivals) out.emplace(a.stamp_s, a.latency_ms);
  return out;
}

const char* verdict(bool ok) { return ok ? "met" : "MISSED"; }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap_bench_dds_latency: end-to-end latency (capture -> local map at a subscriber) "
      "of mlmap_node over DDS; run by tools/bench_dds_latency.sh"};
  std::string config_path, json_path, label = "run";
  int frames_sent = 0;
  double duration_s = 600.0, idle_s = 3.0, warmup_s = 1.0;
  bool probe_cloud = false, require_all = false;
  app.add_option("-c,--config", config_path, "the node's configuration (topics, namespace, DDS)")
      ->check(CLI::ExistingFile);
  app.add_option("--frames", frames_sent, "frames the sensor publisher sends (to count drops)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--label", label, "name of this run in the table and the JSON")
      ->capture_default_str();
  app.add_option("--json", json_path, "write the figures as JSON to this file");
  app.add_option("--duration", duration_s, "stop after this many seconds at most")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--idle-stop", idle_s,
                 "stop once neither a local map nor a status arrived for this many seconds after "
                 "the first local map")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--warmup", warmup_s,
                 "seconds of stamps after the first frame left out of the latency figures "
                 "(discovery, first allocations); every frame still counts for drops")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_flag("--probe-cloud", probe_cloud,
               "also subscribe to the sensor's clouds to time their transport alone (a second "
               "4.8 MB reader: adds load, for diagnosis only)");
  app.add_flag("--require-all", require_all,
               "exit 3 unless every frame sent reached this program as a local map and a final "
               "status arrived (smoke test)");
  CLI11_PARSE(app, argc, argv);
  mlmap::apps::installStopHandler();

  try {
    const mlmap::dds::NodeConfig config = mlmap::dds::nodeConfigOrDefaults(config_path);
    const mlmap::dds::TopicNames& n = config.dds.topics;
    const std::string& ns = config.dds.ns;
    if (n.local_map.empty() || config.dds.rates.local_map_hz <= 0 || n.status.empty() ||
        config.dds.rates.status_hz <= 0) {
      throw std::runtime_error("the configuration disables the local map or the status output");
    }
    mlmap::dds::ParticipantPtr participant =
        mlmap::dds::createParticipant(config.dds, "mlmap_bench_dds_latency");
    fdds::Subscriber* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    Received rx;
    std::vector<std::unique_ptr<fdds::DataReaderListener>> listeners;
    auto onError = [&rx](const std::string&) {
      std::lock_guard<std::mutex> lock(rx.mutex);
      ++rx.malformed;
    };
    // Receive time first thing in the callback, after the take (the sample is usable then).
    auto cloudReader = [&](const std::string& name, std::vector<Arrival> Received::*store,
                           bool activity, const fdds::DataReaderQos& qos) {
      auto l = std::make_unique<mlmap::dds::TakeListener<mlmap::dds::sensor_msgs::PointCloud2_>>(
          [&rx, store, activity](mlmap::dds::sensor_msgs::PointCloud2_&& msg) {
            const double now_s = mlmap::dds::wallClockNow_s();
            Arrival a;
            a.stamp_s = mlmap::dds::toSeconds(msg.header_().stamp_());
            a.latency_ms = (now_s - a.stamp_s) * 1e3;
            a.bytes = msg.data_().size();
            a.points = static_cast<std::size_t>(msg.width_()) * msg.height_();
            std::lock_guard<std::mutex> lock(rx.mutex);
            (rx.*store).push_back(a);
            if (activity) rx.last_activity = Clock::now();
          },
          onError);
      fdds::DataReader* reader =
          mlmap::dds::createReader<mlmap::dds::sensor_msgs::PointCloud2_PubSubType>(
              subscriber, mlmap::dds::ddsTopicName(ns, name), qos, l.get());
      listeners.push_back(std::move(l));
      return reader;
    };
    fdds::DataReader* local_reader =
        cloudReader(n.local_map, &Received::local, true, mlmap::dds::reliableReaderQos(false, 10));
    if (probe_cloud && !n.cloud.empty()) {
      cloudReader(n.cloud, &Received::cloud, false, mlmap::dds::sensorReaderQos(5));
    }
    {
      auto l = std::make_unique<mlmap::dds::TakeListener<::tf2_msgs::msg::dds_::TFMessage_>>(
          [&rx](::tf2_msgs::msg::dds_::TFMessage_&& msg) {
            const double now_s = mlmap::dds::wallClockNow_s();
            std::lock_guard<std::mutex> lock(rx.mutex);
            for (const auto& t : msg.transforms_()) {
              Arrival a;
              a.stamp_s = mlmap::dds::toSeconds(t.header_().stamp_());
              a.latency_ms = (now_s - a.stamp_s) * 1e3;
              rx.tf.push_back(a);
            }
          },
          onError);
      mlmap::dds::createReader<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(
          subscriber, mlmap::dds::ddsTopicName(ns, "tf"), mlmap::dds::reliableReaderQos(false, 100),
          l.get());
      listeners.push_back(std::move(l));
    }
    fdds::DataReader* status_reader = nullptr;
    {
      auto l = std::make_unique<mlmap::dds::TakeListener<mlmap::dds::mlmap_msgs::Status_>>(
          [&rx](mlmap::dds::mlmap_msgs::Status_&& msg) {
            std::lock_guard<std::mutex> lock(rx.mutex);
            ++rx.statuses;
            if (msg.uptime_s_() >= rx.status.uptime_s_()) rx.status = std::move(msg);
            if (rx.last_activity != Clock::time_point::min()) rx.last_activity = Clock::now();
          },
          onError);
      status_reader = mlmap::dds::createReader<mlmap::dds::mlmap_msgs::Status_PubSubType>(
          subscriber, mlmap::dds::ddsTopicName(ns, n.status),
          mlmap::dds::reliableReaderQos(false, 10), l.get());
      listeners.push_back(std::move(l));
    }

    // Ready once the node's writers are matched: the driver starts the publisher after this line.
    const auto start = Clock::now();
    bool ready = false;
    while (!mlmap::apps::stopRequested()) {
      const auto now = Clock::now();
      const double elapsed_s = std::chrono::duration<double>(now - start).count();
      if (elapsed_s >= duration_s) {
        std::printf("stopping: --duration %.0f s reached\n", duration_s);
        break;
      }
      if (!ready) {
        fdds::SubscriptionMatchedStatus local_matched, status_matched;
        local_reader->get_subscription_matched_status(local_matched);
        status_reader->get_subscription_matched_status(status_matched);
        if (local_matched.current_count > 0 && status_matched.current_count > 0) {
          ready = true;
          std::printf("ready: matched the node's local map and status writers\n");
          std::fflush(stdout);
        }
      }
      {
        std::lock_guard<std::mutex> lock(rx.mutex);
        if (rx.last_activity != Clock::time_point::min() &&
            std::chrono::duration<double>(now - rx.last_activity).count() > idle_s) {
          break;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    participant.reset();  // no more callbacks from here on
    listeners.clear();

    // ---- Figures -----------------------------------------------------------------------------
    const std::map<double, double> local = byStamp(rx.local);
    const std::map<double, double> tf = byStamp(rx.tf);
    const double first_s = local.empty() ? 0.0 : local.begin()->first;
    std::vector<double> local_ms, local_all_ms, tf_ms, output_ms, cloud_ms;
    for (const auto& [stamp_s, ms] : local) {
      local_all_ms.push_back(ms);
      if (stamp_s < first_s + warmup_s) continue;
      local_ms.push_back(ms);
      const auto t = tf.find(stamp_s);
      if (t != tf.end()) {
        tf_ms.push_back(t->second);
        output_ms.push_back(ms - t->second);
      }
    }
    for (const Arrival& a : rx.cloud) {
      if (a.stamp_s >= first_s + warmup_s) cloud_ms.push_back(a.latency_ms);
    }
    double local_kb = 0.0, local_points = 0.0;
    for (const Arrival& a : rx.local) {
      local_kb += static_cast<double>(a.bytes) / 1e3;
      local_points += static_cast<double>(a.points);
    }
    if (!rx.local.empty()) {
      local_kb /= static_cast<double>(rx.local.size());
      local_points /= static_cast<double>(rx.local.size());
    }
    const Summary latency = summarize(local_ms), latency_all = summarize(local_all_ms),
                  to_tf = summarize(tf_ms), output = summarize(output_ms),
                  cloud = summarize(cloud_ms);
    const auto& st = rx.status;
    // Where frames were lost: on the way to the node (transport; sent - mapped - node drops), in
    // the node (hand-over / engine queue full, rejected, no pose, malformed), or as local maps:
    // published (rt/tf of that stamp arrived) but lost on the way, or never published because
    // the publishing thread found two snapshots at once (no rt/tf either).
    const auto sent = static_cast<std::int64_t>(frames_sent);
    const auto mapped = static_cast<std::int64_t>(st.frames_mapped_());
    const auto received = static_cast<std::int64_t>(local.size());
    const auto node_lost =
        static_cast<std::int64_t>(st.frames_dropped_() + st.frames_rejected_() +
                                  st.clouds_without_pose_() + st.clouds_malformed_());
    const std::int64_t missing = sent - received;
    const std::int64_t lost_before_node = std::max<std::int64_t>(0, sent - mapped - node_lost);
    std::int64_t local_lost_in_transport = 0;
    for (const auto& [stamp_s, ms] : tf)
      local_lost_in_transport += local.count(stamp_s) == 0 ? 1 : 0;
    const std::int64_t local_not_published =
        std::max<std::int64_t>(0, mapped - received - local_lost_in_transport);
    const bool have_status = rx.statuses > 0;
    const bool drops_ok = frames_sent > 0 && missing == 0 && node_lost == 0;
    const double p50_target_ms = st.total_median_ms_() + kTargetP50Margin_ms;
    const double p99_target_ms = st.total_p99_ms_() + kTargetP99Margin_ms;

    std::printf("\n== %s: capture -> local map at the subscriber (stamps after the first %.1f s)\n",
                label.c_str(), warmup_s);
    std::printf("frames: %d sent, %lld mapped, %lld local maps received (%lld missing)\n",
                frames_sent, static_cast<long long>(mapped), static_cast<long long>(received),
                static_cast<long long>(missing));
    std::printf(
        "  lost on the way to the node: %lld; in the node: %llu dropped (queue full), %llu "
        "rejected, %llu without pose, %llu malformed; local maps not published: %lld, "
        "published but lost on the way: %lld\n",
        static_cast<long long>(lost_before_node),
        static_cast<unsigned long long>(st.frames_dropped_()),
        static_cast<unsigned long long>(st.frames_rejected_()),
        static_cast<unsigned long long>(st.clouds_without_pose_()),
        static_cast<unsigned long long>(st.clouds_malformed_()),
        static_cast<long long>(local_not_published),
        static_cast<long long>(local_lost_in_transport));
    std::printf("local map: %.0f voxels, %.1f kB per message\n", local_points, local_kb);
    std::printf("%-44s %8s %8s %8s %8s\n", "[ms]", "p50", "p90", "p99", "max");
    auto row = [](const char* name, const Summary& s) {
      if (s.count == 0) return;
      std::printf("%-44s %8.2f %8.2f %8.2f %8.2f\n", name, s.p50_ms, s.p90_ms, s.p99_ms, s.max_ms);
    };
    row("end to end (capture -> local map received)", latency);
    row("  same, every frame (no warm-up cut)", latency_all);
    row("  capture -> rt/tf received (node has it)", to_tf);
    row("  rt/tf -> local map (encode + send)", output);
    row("  cloud transport alone (--probe-cloud)", cloud);
    std::printf("%-44s %8.2f %8s %8.2f\n", "engine compute (node status, total)",
                st.total_median_ms_(), "", st.total_p99_ms_());
    std::printf("%-44s %8.2f %8s %8.2f\n", "  awareness stage", st.awareness_median_ms_(), "",
                st.awareness_p99_ms_());
    std::printf("%-44s %8.2f %8s %8.2f\n", "  local-global stage", st.local_global_median_ms_(), "",
                st.local_global_p99_ms_());
    std::printf(
        "targets: no dropped frame: %s; p50 %.2f <= %.2f ms (compute + 5): %s; "
        "p99 %.2f <= %.2f ms (compute + 15): %s\n",
        verdict(drops_ok), latency.p50_ms, p50_target_ms,
        verdict(have_status && latency.count > 0 && latency.p50_ms <= p50_target_ms),
        latency.p99_ms, p99_target_ms,
        verdict(have_status && latency.count > 0 && latency.p99_ms <= p99_target_ms));
    if (!have_status) std::printf("no status message arrived: engine figures unknown\n");
    // One line for tools/bench_dds_latency.sh's comparison table.
    std::printf(
        "result %s sent=%d mapped=%lld received=%lld p50=%.2f p99=%.2f max=%.2f "
        "engine_p50=%.2f engine_p99=%.2f to_tf_p50=%.2f output_p50=%.2f\n",
        label.c_str(), frames_sent, static_cast<long long>(mapped),
        static_cast<long long>(received), latency.p50_ms, latency.p99_ms, latency.max_ms,
        st.total_median_ms_(), st.total_p99_ms_(), to_tf.p50_ms, output.p50_ms);

    if (!json_path.empty()) {
      std::ofstream out(json_path);
      out << "{\n  \"label\": \"" << label << "\",\n  \"warmup_s\": " << warmup_s
          << ",\n  \"frames_sent\": " << frames_sent << ",\n  \"local_maps_received\": " << received
          << ",\n  \"frames_missing\": " << missing
          << ",\n  \"lost_before_node\": " << lost_before_node
          << ",\n  \"local_maps_not_published\": " << local_not_published
          << ",\n  \"local_maps_lost_in_transport\": " << local_lost_in_transport
          << ",\n  \"node\": {\"frames_in\": " << st.frames_in_()
          << ", \"frames_mapped\": " << st.frames_mapped_()
          << ", \"frames_dropped\": " << st.frames_dropped_()
          << ", \"frames_rejected\": " << st.frames_rejected_()
          << ", \"clouds_without_pose\": " << st.clouds_without_pose_()
          << ", \"clouds_malformed\": " << st.clouds_malformed_()
          << ", \"statuses\": " << rx.statuses
          << "},\n  \"engine_ms\": {\"total_median\": " << st.total_median_ms_()
          << ", \"total_p99\": " << st.total_p99_ms_()
          << ", \"awareness_median\": " << st.awareness_median_ms_()
          << ", \"awareness_p99\": " << st.awareness_p99_ms_()
          << ", \"local_global_median\": " << st.local_global_median_ms_()
          << ", \"local_global_p99\": " << st.local_global_p99_ms_()
          << "},\n  \"latency\": " << json(latency)
          << ",\n  \"latency_all_frames\": " << json(latency_all)
          << ",\n  \"to_tf\": " << json(to_tf) << ",\n  \"tf_to_local_map\": " << json(output)
          << ",\n  \"cloud_transport\": " << json(cloud) << ",\n  \"local_map_kb\": " << local_kb
          << ",\n  \"local_map_voxels\": " << local_points << ",\n  \"malformed\": " << rx.malformed
          << ",\n  \"targets\": {\"no_drops\": " << (drops_ok ? "true" : "false")
          << ", \"p50_limit_ms\": " << p50_target_ms << ", \"p99_limit_ms\": " << p99_target_ms
          << ", \"p50_met\": "
          << (latency.count > 0 && latency.p50_ms <= p50_target_ms ? "true" : "false")
          << ", \"p99_met\": "
          << (latency.count > 0 && latency.p99_ms <= p99_target_ms ? "true" : "false") << "}\n}\n";
    }
    if (require_all &&
        (!have_status || frames_sent == 0 || missing != 0 || latency_all.count == 0)) {
      std::printf("FAIL: %llu of %d frames reached the subscriber as local maps%s\n",
                  static_cast<unsigned long long>(received), frames_sent,
                  have_status ? "" : ", and no status arrived");
      return 3;
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
