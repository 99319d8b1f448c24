// mlmap_soak: a long simulated flight through MapEngine in threaded mode (as mlmap_node runs it),
// checking that memory levels off where it should. A sparse simulated LiDAR flies a closed
// lawnmower path over a 200 x 45 m field of pillars, lap after lap over the same ground, sliding
// the local window through hundreds of submaps and revisiting every one of them.
//
// Checked (exit 1 with "FAIL: ..." otherwise):
// - the local map's bytes never change: it is the window, whatever the distance flown;
// - every voxel the global map holds was hit by a LiDAR point (during the first lap, since the
//   later laps fly the same poses), and it holds each at most once;
// - the laps after the first revisit the same ground: they add no global voxel beyond a small
//   fraction of the first lap's, and the global map's bytes follow its voxel count;
// - process RSS levels off: the last lap adds less than the engine's own accounting grew in it
//   plus a slack of 10 % of that accounting (allocator noise);
// - no frame dropped or rejected.
// Prints a table (per lap: frames, RSS, peak RSS, bytes by layer, global voxels) and writes a PNG
// of memory over frames. LeakSanitizer / valgrind see the exit: run it under them for leaks.

#include "mlmap/eval/run_outputs.h"
#include "mlmap/pictures/map_image.h"
#include "mlmap/pipeline/map_engine.h"
#include "mlmap/sim/lidar.h"
#include "mlmap/sim/trajectory.h"
#include "mlmap/sim/world.h"

#include <CLI/CLI.hpp>
#include <opencv2/imgproc.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <unordered_set>
#include <vector>

namespace {

using namespace mlmap;

// AddressSanitizer makes every frame several times slower and keeps freed memory in its
// quarantine, which RSS counts: under it the flight is shorter and RSS is not judged (its leak
// checker is the judge there).
#if defined(__SANITIZE_ADDRESS__)
#define MLMAP_SOAK_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MLMAP_SOAK_ASAN 1
#endif
#endif
#ifdef MLMAP_SOAK_ASAN
constexpr int kDefaultFramesPerLap = 1500;
constexpr bool kRssMeaningful = false;
#else
constexpr int kDefaultFramesPerLap = 5000;
constexpr bool kRssMeaningful = true;
#endif

constexpr double kFramePeriod_s = 0.1;    // a 10 Hz LiDAR
constexpr double kFieldLength_m = 200.0;  // lawnmower rows along x
constexpr double kRowSpacing_m = 15.0;    // rows at y = 0, 15, 30, 45
constexpr int kRows = 4;
constexpr double kFlightHeight_m = 1.5;
constexpr int kFlushEvery = 16;        // frames between flushes: nothing is ever dropped
constexpr double kFaceSlack_m = 1e-4;  // points this close to a voxel face hit both sides

/// Resident set size now [bytes] (/proc/self/statm), 0 when unknown.
std::size_t currentRssBytes() {
  std::ifstream in("/proc/self/statm");
  std::size_t size_pages = 0, resident_pages = 0;
  if (!(in >> size_pages >> resident_pages)) return 0;
  return resident_pages * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

double mb(std::size_t bytes) { return static_cast<double>(bytes) / 1e6; }

struct VoxelHash {
  std::size_t operator()(const VoxelIndex& v) const {
    return (static_cast<std::size_t>(v.x()) * 73856093u) ^
           (static_cast<std::size_t>(v.y()) * 19349663u) ^
           (static_cast<std::size_t>(v.z()) * 83492791u);
  }
};

/// A ground slab and rows of pillars and crates between the flight rows, at least 6 m from them.
sim::World fieldWorld() {
  sim::World world;
  world.addBox(
      {Eigen::Vector3d(-30.0, -30.0, -0.5), Eigen::Vector3d(kFieldLength_m + 30.0, 75.0, 0.0)});
  for (int row = -1; row < kRows; ++row) {
    const double y = (row + 0.5) * kRowSpacing_m;
    for (double x = 0.0; x <= kFieldLength_m; x += 10.0) {
      const int k = static_cast<int>(x / 10.0) + 7 * (row + 1);
      if (k % 3 == 0) {
        world.addBox({Eigen::Vector3d(x - 0.7, y - 0.7, 0.0),
                      Eigen::Vector3d(x + 0.7, y + 0.7, 1.0 + (k % 4))});
      } else {
        world.addCylinder({Eigen::Vector2d(x, y), 0.4 + 0.1 * (k % 3), 0.0, 2.0 + (k % 5)});
      }
    }
  }
  return world;
}

/// One lap: the rows back and forth, then back to the start along x = 0.
sim::Trajectory lapPath(double speed_mps) {
  std::vector<sim::Waypoint> w;
  for (int row = 0; row < kRows; ++row) {
    const double y = row * kRowSpacing_m;
    const bool east = row % 2 == 0;
    w.push_back({Eigen::Vector3d(east ? 0.0 : kFieldLength_m, y, kFlightHeight_m)});
    w.push_back({Eigen::Vector3d(east ? kFieldLength_m : 0.0, y, kFlightHeight_m)});
  }
  w.push_back({Eigen::Vector3d(0.0, 0.0, kFlightHeight_m)});
  return sim::Trajectory(std::move(w), speed_mps);
}

double pathLength_m() { return lapPath(1.0).length_m(); }

struct Sample {
  int frame = 0;
  std::size_t rss = 0;
  // cppcheck-suppress unusedStructMember ; read by the plot's lambdas
  MemoryUsage memory;
};

struct LapRow {
  int frames = 0;
  double seconds = 0.0;  // wall time of the lap
  std::size_t rss = 0, peak_rss = 0;
  MemoryUsage memory;
  std::size_t global_voxels = 0, occupied_voxels = 0;
  std::uint64_t submaps_retired = 0, submaps_restored = 0;
};

/// Memory over frames: RSS and the engine's layers, one line each, MB against frames.
void writeChart(const std::string& path, const std::vector<Sample>& samples, int frames_per_lap) {
  const int w = 1000, h = 500, left = 70, right = 200, top = 30, bottom = 50;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double max_mb = 1.0;
  for (const Sample& s : samples) max_mb = std::max(max_mb, static_cast<double>(s.rss) / 1e6);
  max_mb *= 1.1;
  const int last = samples.empty() ? 1 : std::max(1, samples.back().frame);
  auto px = [&](int frame, double mb) {
    return cv::Point(
        left + static_cast<int>((w - left - right) * static_cast<double>(frame) / last),
        h - bottom - static_cast<int>((h - top - bottom) * mb / max_mb));
  };
  cv::rectangle(img, px(0, 0.0), px(last, max_mb), cv::Scalar(0, 0, 0));
  for (int f = frames_per_lap; f < last; f += frames_per_lap) {
    cv::line(img, px(f, 0.0), px(f, max_mb), cv::Scalar(200, 200, 200));
  }
  for (int k = 0; k <= 4; ++k) {
    const double mb = max_mb * k / 4.0;
    cv::putText(img, cv::format("%.0f MB", mb), px(0, mb) + cv::Point(-65, 5),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
  }
  cv::putText(img, cv::format("frames (0 .. %d; a grey line per lap)", last),
              cv::Point(left, h - 15), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0));
  cv::putText(img, "* with the test's set of hit voxels (lap 1)",
              cv::Point(w - right + 10, h - bottom), cv::FONT_HERSHEY_SIMPLEX, 0.35,
              cv::Scalar(0, 0, 0));
  struct Series {
    const char* name;
    cv::Scalar bgr;
    std::size_t (*bytes)(const Sample&);
  };
  const Series series[] = {
      {"process RSS *", cv::Scalar(0, 0, 0), [](const Sample& s) { return s.rss; }},
      {"engine total", cv::Scalar(200, 0, 0), [](const Sample& s) { return s.memory.total(); }},
      {"planning", cv::Scalar(0, 150, 0), [](const Sample& s) { return s.memory.planning_bytes; }},
      {"awareness", cv::Scalar(0, 140, 255),
       [](const Sample& s) { return s.memory.awareness_bytes; }},
      {"local map", cv::Scalar(200, 0, 200), [](const Sample& s) { return s.memory.local_bytes; }},
      {"global map", cv::Scalar(0, 0, 230), [](const Sample& s) { return s.memory.global_bytes; }},
  };
  int legend_y = top + 10;
  for (const Series& s : series) {
    for (std::size_t i = 1; i < samples.size(); ++i) {
      cv::line(img, px(samples[i - 1].frame, static_cast<double>(s.bytes(samples[i - 1])) / 1e6),
               px(samples[i].frame, static_cast<double>(s.bytes(samples[i])) / 1e6), s.bgr, 2);
    }
    cv::line(img, cv::Point(w - right + 15, legend_y), cv::Point(w - right + 40, legend_y), s.bgr,
             2);
    cv::putText(img, s.name, cv::Point(w - right + 45, legend_y + 5), cv::FONT_HERSHEY_SIMPLEX,
                0.45, cv::Scalar(0, 0, 0));
    legend_y += 22;
  }
  pictures::writePng(path, img);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap_soak: a long simulated LiDAR flight, lap after lap over the same ground, through "
      "the threaded MapEngine; checks that memory levels off"};
  int laps = 4;
  int frames_per_lap = kDefaultFramesPerLap;
  int beams = 8, azimuth_steps = 120;
  std::string png_path = "soak_memory.png";
  bool check_rss = kRssMeaningful;
  app.add_option("--laps", laps, "laps of the lawnmower path (>= 2 for the revisit checks)")
      ->check(CLI::Range(1, 1000));
  app.add_option("--frames-per-lap", frames_per_lap,
                 "LiDAR scans per lap, at 10 Hz (the speed follows); 1500 under AddressSanitizer")
      ->check(CLI::Range(100, 1000000));
  app.add_option("--beams", beams, "LiDAR beams")->check(CLI::Range(1, 128));
  app.add_option("--azimuth-steps", azimuth_steps, "LiDAR columns over 360 deg")
      ->check(CLI::Range(1, 2048));
  app.add_option("--png", png_path, "memory over frames (empty: none)");
  app.add_flag(
      "!--no-rss-check", check_rss,
      "skip the RSS check (valgrind has its own allocator; skipped under AddressSanitizer)");
  CLI11_PARSE(app, argc, argv);

  MapConfig config;  // 0.2 m voxels, the paper's 19 x 19 x 7 m window
  config.pipeline.threaded = true;
  config.pipeline.input_queue_capacity = 2 * kFlushEvery;
  config.esdf.box_size_m = Eigen::Vector3d(8.0, 8.0, 3.0);  // keeps the ESDF cheap
  sim::LidarModel model;
  model.beams = beams;
  model.azimuth_steps = azimuth_steps;
  model.vertical_min_deg = -15.0;
  model.vertical_max_deg = 15.0;
  model.max_range_m = config.awareness.max_range_m;
  const sim::Lidar lidar(model);
  const sim::World world = fieldWorld();
  const double lap_duration_s = frames_per_lap * kFramePeriod_s;
  const sim::Trajectory path = lapPath(pathLength_m() / lap_duration_s);
  const double res = config.local_map.resolution_m;

  std::printf(
      "soak: %d laps x %d LiDAR scans (%d x %d rays, %.0f m range) over a %.0f m lawnmower path "
      "at %.2f m/s, %.1f m voxels, window %d x %d x %d, threaded engine\n",
      laps, frames_per_lap, beams, azimuth_steps, model.max_range_m, path.length_m(),
      path.speed_mps(), res, config.local_map.size_cells.x(), config.local_map.size_cells.y(),
      config.local_map.size_cells.z());

  std::vector<Sample> samples;
  std::vector<LapRow> rows;
  std::unordered_set<VoxelIndex, VoxelHash> hit_voxels;  // every voxel a point fell in, lap 1
  eval::ProgressBar progress("soak");
  const int total = laps * frames_per_lap;
  int failures = 0;
  auto fail = [&](const std::string& what) {
    std::printf("FAIL: %s\n", what.c_str());
    ++failures;
  };
  {
    MapEngine engine(config);  // the defaults: no configuration error possible here
    std::size_t local_bytes_first = 0;
    PointCloudFrame frame;
    for (int lap = 0; lap < laps; ++lap) {
      const auto lap_start = std::chrono::steady_clock::now();
      for (int i = 0; i < frames_per_lap; ++i) {
        const int n = lap * frames_per_lap + i;
        const double t_lap = i * kFramePeriod_s;
        frame.T_W_B = path.poseAt(t_lap);
        frame.T_B_S = Transform::Identity();
        lidar.render(world, frame.T_W_B, n * kFramePeriod_s, &frame);
        if (lap == 0) {
          for (const Eigen::Vector3f& p_S : frame.points_S) {
            // A point on a voxel face (the ground is at z = 0) may fall on either side by the
            // last bit of rounding, which the engine does in its own order: both sides count.
            const Eigen::Vector3d p_W = frame.T_W_B * p_S.cast<double>();
            const VoxelIndex lo = ((p_W.array() - kFaceSlack_m) / res).floor().cast<int>().matrix();
            const VoxelIndex hi = ((p_W.array() + kFaceSlack_m) / res).floor().cast<int>().matrix();
            for (int x = lo.x(); x <= hi.x(); ++x) {
              for (int y = lo.y(); y <= hi.y(); ++y) {
                for (int z = lo.z(); z <= hi.z(); ++z) hit_voxels.insert(VoxelIndex(x, y, z));
              }
            }
          }
        }
        if (engine.submit(frame) != FrameStatus::kAccepted)
          fail("frame " + std::to_string(n) + " refused");
        if ((n + 1) % kFlushEvery == 0) engine.flush();
        if ((n + 1) % 200 == 0) {
          engine.flush();
          const EngineStats s = engine.stats();
          samples.push_back({n + 1, currentRssBytes(), s.memory});
          if (local_bytes_first == 0) local_bytes_first = s.memory.local_bytes;
          if (s.memory.local_bytes != local_bytes_first) {
            fail("local map bytes changed from " + std::to_string(local_bytes_first) + " to " +
                 std::to_string(s.memory.local_bytes) + " at frame " + std::to_string(n + 1));
          }
        }
        progress.update(n + 1, total);
      }
      engine.flush();
      const EngineStats s = engine.stats();
      LapRow row;
      row.frames = (lap + 1) * frames_per_lap;
      row.seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - lap_start).count();
      row.rss = currentRssBytes();
      row.peak_rss = eval::peakRssBytes();
      row.memory = s.memory;
      row.global_voxels = s.global_voxels;
      row.submaps_retired = s.local.submaps_retired;
      row.submaps_restored = s.local.submaps_restored;
      const std::vector<VoxelIndex> occupied = engine.occupiedVoxels();
      row.occupied_voxels = occupied.size();
      const std::unordered_set<VoxelIndex, VoxelHash> distinct(occupied.begin(), occupied.end());
      if (distinct.size() != occupied.size()) {
        fail("lap " + std::to_string(lap + 1) + ": " +
             std::to_string(occupied.size() - distinct.size()) +
             " voxels are stored twice (local and global, or twice in the global map)");
      }
      std::size_t never_hit = 0;
      for (const VoxelIndex& v : occupied) never_hit += hit_voxels.count(v) == 0 ? 1 : 0;
      if (never_hit > 0)
        fail(std::to_string(never_hit) + " occupied voxels were never hit by a point");
      rows.push_back(row);
      if (s.frames_mapped != static_cast<std::uint64_t>(row.frames) || s.frames_dropped != 0) {
        fail("mapped " + std::to_string(s.frames_mapped) + " of " + std::to_string(row.frames) +
             " frames, " + std::to_string(s.frames_dropped) + " dropped");
      }
    }
  }  // the engine's threads join and every layer is freed here; LeakSanitizer checks at exit

  std::printf("\n%-5s %7s %8s %9s %9s %10s %9s %10s %11s %10s %12s %9s\n", "lap", "time s",
              "frames", "RSS MB", "peak MB", "engine MB", "local MB", "global MB", "planning MB",
              "awareness", "global vox", "submaps");
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const LapRow& r = rows[k];
    std::printf("%-5zu %7.1f %8d %9.1f %9.1f %10.2f %9.2f %10.2f %11.2f %10.2f %12zu %9llu\n",
                k + 1, r.seconds, r.frames, mb(r.rss), mb(r.peak_rss), mb(r.memory.total()),
                mb(r.memory.local_bytes), mb(r.memory.global_bytes), mb(r.memory.planning_bytes),
                mb(r.memory.awareness_bytes), r.global_voxels,
                static_cast<unsigned long long>(r.submaps_retired + r.submaps_restored));
  }
  const LapRow& first = rows.front();
  std::printf(
      "distinct voxels hit in lap 1: %zu; occupied at the end: %zu (%zu in the global map, "
      "%.1f B per global voxel)\n",
      hit_voxels.size(), rows.back().occupied_voxels, rows.back().global_voxels,
      rows.back().global_voxels ? static_cast<double>(rows.back().memory.global_bytes) /
                                      static_cast<double>(rows.back().global_voxels)
                                : 0.0);

  if (rows.size() >= 2) {
    const LapRow& prev = rows[rows.size() - 2];
    const LapRow& last = rows.back();
    // Revisits: the same ground seen again from the same poses. Voxels on the edge of what the
    // window kept may flip, so a few may come and go, but nothing like a lap's worth.
    const double added =
        static_cast<double>(last.global_voxels) - static_cast<double>(prev.global_voxels);
    if (added > 0.01 * static_cast<double>(first.global_voxels)) {
      fail("the last lap added " + std::to_string(added) +
           " global voxels, more than 1 % of the first lap's " +
           std::to_string(first.global_voxels));
    }
    const double bytes_per_voxel_first = static_cast<double>(first.memory.global_bytes) /
                                         std::max(1.0, static_cast<double>(first.global_voxels));
    const double bytes_per_voxel_last = static_cast<double>(last.memory.global_bytes) /
                                        std::max(1.0, static_cast<double>(last.global_voxels));
    if (bytes_per_voxel_last > 1.05 * bytes_per_voxel_first) {
      fail("global map bytes per voxel grew from " + std::to_string(bytes_per_voxel_first) +
           " to " + std::to_string(bytes_per_voxel_last));
    }
    const double rss_growth = static_cast<double>(last.rss) - static_cast<double>(prev.rss);
    const double engine_growth = std::max(
        0.0, static_cast<double>(last.memory.total()) - static_cast<double>(prev.memory.total()));
    const double bound = engine_growth + 0.1 * static_cast<double>(last.memory.total());
    std::printf(
        "last lap: RSS %+.2f MB, engine accounting %+.2f MB; bound %.2f MB%s\n", rss_growth / 1e6,
        (static_cast<double>(last.memory.total()) - static_cast<double>(prev.memory.total())) / 1e6,
        bound / 1e6, check_rss ? "" : " (not checked)");
    if (check_rss && rss_growth > bound) {
      fail("RSS grew by " + std::to_string(rss_growth / 1e6) + " MB in the last lap, bound " +
           std::to_string(bound / 1e6) + " MB");
    }
  }
  if (!png_path.empty()) {
    writeChart(png_path, samples, frames_per_lap);
    std::printf("memory over frames: %s\n", png_path.c_str());
  }
  if (failures > 0) return 1;
  std::printf("PASS\n");
  return 0;
}
