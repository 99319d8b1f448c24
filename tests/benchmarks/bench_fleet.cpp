// mlmap_bench_fleet: what one vehicle of a fleet sends (dds.fleet.publish), against republishing
// its whole global map as one PointCloud2 at the same rate. A LiDAR flies the simulated room's
// loop, then hovers at the end; every share round collects the changed submaps as mlmap_node
// does (global map changes and the window of the same frame) and counts the serialized
// mlmap_msgs/Submap samples. Bytes do not depend on the machine; the share step's time does
// (wall clock, median and p99 per round: say the load next to it).

#include "mlmap/core/stopwatch.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/dds/fleet/submap_messages.h"
#include "mlmap/fleet/fleet_map.h"
#include "mlmap/fleet/submap_share.h"
#include "mlmap/pipeline/map_engine.h"
#include "mlmap/sim/lidar.h"
#include "mlmap/sim/trajectory.h"
#include "mlmap/sim/world.h"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

namespace {

using namespace mlmap;

struct Options {
  double resolution_m = 0.1;
  double frame_hz = 10.0;
  double share_hz = 1.0;
  double hover_s = 20.0;
  int beams = 16;
  int azimuth_steps = 360;
  double range_m = 8.0;
  bool rounds = false;      ///< print every round
  int merger_vehicles = 8;  ///< vehicles the merger's figure replays the stream as
};

/// Bytes and submaps of one phase.
struct Phase {
  double seconds = 0.0;
  std::size_t submaps = 0;
  std::size_t bytes = 0;
  std::size_t whole_map_bytes = 0;
};

/// Serialized bytes of the PointCloud2 the node's /mlmap/global_map would be for `map`.
std::size_t wholeGlobalMapBytes(const GlobalMap& map, double stamp_s) {
  std::vector<Eigen::Vector3f> points;
  points.reserve(map.voxelCount());
  map.forEachVoxel([&](const VoxelIndex& g, double) {
    points.push_back(voxelCenter(g, map.resolution_m()).cast<float>());
  });
  const auto msg = mlmap::dds::encodePointCloud2(points, nullptr, stamp_s, "map");
  return ::sensor_msgs::msg::dds_::PointCloud2_::getCdrSerializedSize(msg) + 4;
}

int run(const Options& o) {
  MapConfig config;
  config.local_map.resolution_m = o.resolution_m;
  const int xy = static_cast<int>(std::lround(16.0 / o.resolution_m / 5.0)) * 5;
  const int z = static_cast<int>(std::lround(6.0 / o.resolution_m / 5.0)) * 5;
  config.local_map.size_cells = {xy, xy, z};
  config.awareness.max_range_m = o.range_m;
  config.sensor.translation_B_m = Eigen::Vector3d::Zero();
  config.sensor.rotation_rpy_deg = Eigen::Vector3d::Zero();
  MapEngine engine(config);
  const sim::World world = sim::World::defaultRoom();
  const sim::Trajectory trajectory = sim::Trajectory::defaultRoomFlight();
  sim::LidarModel model;
  model.beams = o.beams;
  model.azimuth_steps = o.azimuth_steps;
  model.max_range_m = o.range_m;
  const sim::Lidar lidar(model);
  const mlmap::dds::SubmapGeometry geometry{o.resolution_m, config.local_map.submap_cells()};
  fleet::SubmapShare share(geometry.cells);
  std::uint64_t version = 0;
  std::uint64_t sequence = 0;
  std::vector<double> share_ms;
  // Every sample as the merger decodes it, to replay as several vehicles below.
  std::vector<mlmap::dds::DecodedSubmap> stream;
  // Exploring (the loop), settling (the first seconds of hovering: the last scans saturate),
  // hovering.
  constexpr double kSettle_s = 2.0;
  Phase phases[3];
  const int frames_per_share = std::max(1, static_cast<int>(std::lround(o.frame_hz / o.share_hz)));
  const double flight_s = trajectory.duration_s();
  const int frames = static_cast<int>((flight_s + o.hover_s) * o.frame_hz);
  // The map's world is the simulator's shifted by 0.05 m: faces off the voxel borders.
  const Eigen::Vector3d shift = Eigen::Vector3d::Constant(0.05);
  for (int i = 0; i < frames; ++i) {
    const double t = (i + 1) / o.frame_hz;
    PointCloudFrame f;
    f.T_W_B = trajectory.poseAt(std::min(t, flight_s));
    lidar.render(world, f.T_W_B, std::min(t, flight_s), &f);
    f.stamp_s = t;
    f.T_W_B.translation() += shift;
    engine.submit(std::move(f));
    if ((i + 1) % frames_per_share != 0) continue;
    Phase& phase = phases[t <= flight_s ? 0 : t <= flight_s + kSettle_s ? 1 : 2];
    const SteadyClock::time_point watch = SteadyClock::now();
    fleet::GlobalMapDelta delta = fleet::collectGlobalDelta(engine.globalMap(), version);
    version = delta.version;
    const std::shared_ptr<const MapSnapshot> snap = engine.snapshot();
    const std::vector<fleet::SubmapUpdate> updates =
        share.changes(std::move(delta), snap ? &snap->window() : nullptr);
    for (const fleet::SubmapUpdate& u : updates) {
      const auto msg = mlmap::dds::toSubmapMessage(u, geometry, "uav1", ++sequence, t, "map");
      phase.bytes += mlmap::dds::serializedSubmapBytes(msg);
      stream.emplace_back();
      if (!mlmap::dds::decodeSubmapMessage(msg, &stream.back()).empty()) return 1;
    }
    share_ms.push_back(msSince(watch));
    if (o.rounds) std::printf("t %.1f s: %zu submaps\n", t, updates.size());
    phase.submaps += updates.size();
    phase.whole_map_bytes += wholeGlobalMapBytes(engine.globalMap(), t);
  }
  phases[0].seconds = flight_s;
  phases[1].seconds = std::min(kSettle_s, o.hover_s);
  phases[2].seconds = std::max(0.0, o.hover_s - kSettle_s);
  const TimingSummary step = summarizeTimings(share_ms);
  std::printf(
      "fleet bandwidth of one vehicle: %.2f m voxels, LiDAR %d x %d to %.0f m, frames at "
      "%.0f Hz, shared at %.1f Hz; %zu occupied voxels mapped\n",
      o.resolution_m, o.beams, o.azimuth_steps, o.range_m, o.frame_hz, o.share_hz,
      engine.occupiedVoxels().size());
  std::printf("%-10s %8s %11s %11s %28s\n", "phase", "seconds", "submaps/s", "bytes/s",
              "whole global map bytes/s");
  const char* names[3] = {"exploring", "settling", "hovering"};
  for (int p = 0; p < 3; ++p) {
    const Phase& ph = phases[p];
    if (ph.seconds <= 0) continue;
    std::printf("%-10s %8.1f %11.1f %11.0f %28.0f\n", names[p], ph.seconds,
                static_cast<double>(ph.submaps) / ph.seconds,
                static_cast<double>(ph.bytes) / ph.seconds,
                static_cast<double>(ph.whole_map_bytes) / ph.seconds);
  }
  std::printf(
      "share step per round (collect, compare, encode): median %.2f ms, p99 %.2f ms over "
      "%zu rounds\n",
      step.median_ms, step.p99_ms, step.samples);

  // The merger: the vehicle's whole stream replayed as `merger_vehicles` vehicles in turn (the
  // same voxels: the worst case for fusion, every voxel held by all), each sample decoded and
  // fused as mlmap_fleet does.
  fleet::FleetMap merged(config.log_odds);
  merged.acceptGeometry(geometry.resolution_m, geometry.cells);
  std::vector<double> apply_us;
  const SteadyClock::time_point merge_start = SteadyClock::now();
  for (const mlmap::dds::DecodedSubmap& sample : stream) {
    for (int v = 0; v < o.merger_vehicles; ++v) {
      std::vector<VoxelRecord> records = sample.records;
      const SteadyClock::time_point t0 = SteadyClock::now();
      merged.apply("uav" + std::to_string(v), sample.index, sample.sequence, std::move(records));
      apply_us.push_back(1000.0 * msSince(t0));
    }
  }
  const double merge_s = msSince(merge_start) / 1000.0;
  const TimingSummary apply = summarizeTimings(apply_us);  // in us, as apply_us
  const double samples =
      static_cast<double>(stream.size() * static_cast<std::size_t>(o.merger_vehicles));
  std::printf(
      "merger, %d vehicles of this stream: %.0f samples fused in %.2f s wall clock (%.1f %% of "
      "one core for %.0f s of flight); per sample median %.0f us, p99 %.0f us; %zu fused "
      "voxels in %.1f MB (%.1f B per voxel and vehicle)\n",
      o.merger_vehicles, samples, merge_s, 100.0 * merge_s / (flight_s + o.hover_s),
      flight_s + o.hover_s, apply.median_ms, apply.p99_ms, merged.voxelCount(),
      static_cast<double>(merged.memoryBytes()) / 1e6,
      static_cast<double>(merged.memoryBytes()) /
          static_cast<double>(merged.voxelCount() * static_cast<std::size_t>(o.merger_vehicles)));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap_bench_fleet: bytes a vehicle sends to the fleet, against whole-map republishing"};
  Options o;
  app.add_option("--resolution", o.resolution_m, "voxel edge [m]")->check(CLI::PositiveNumber);
  app.add_option("--frame-hz", o.frame_hz, "LiDAR scans per second")->check(CLI::PositiveNumber);
  app.add_option("--share-hz", o.share_hz, "dds.fleet.rate_hz")->check(CLI::PositiveNumber);
  app.add_option("--hover-s", o.hover_s, "seconds hovering at the end")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--beams", o.beams, "LiDAR beams")->check(CLI::PositiveNumber);
  app.add_option("--azimuth-steps", o.azimuth_steps, "LiDAR columns")->check(CLI::PositiveNumber);
  app.add_option("--range", o.range_m, "LiDAR and map range [m]")->check(CLI::PositiveNumber);
  app.add_flag("--rounds", o.rounds, "print each share round's submap count");
  app.add_option("--merger-vehicles", o.merger_vehicles, "vehicles the merger figure replays")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  return run(o);
}
