// mlmap_compare_octomap: the same frames, at the same resolution and maximum range, into mlmap's
// MapEngine (synchronous mode: one core, like OctoMap) and into octomap::OcTree::insertPointCloud
// (default sensor model). Prints per-frame time (median, p99) of both and their ratio, memory of
// both, and the agreement of the occupied voxels; writes the figures as JSON (and, on request,
// the voxels of both maps for pictures). Figures, not pass/fail: see docs/comparison.md.
// Exits non-zero when OctoMap's keys do not map to mlmap's voxel indices.

#include "mlmap/core/stopwatch.h"
#include "mlmap/eval/run_outputs.h"
#include "mlmap/eval/sim_flight.h"
#include "mlmap/eval/voxel_agreement.h"
#include "mlmap/core/atomic_file.h"
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/datasets/frame_source.h"
#include "mlmap/map_io/voxel_text.h"
#include "mlmap/pictures/map_image.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/pipeline/map_engine.h"
#include "mlmap/sim/lidar.h"

#include <CLI/CLI.hpp>
#include <octomap/OcTree.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using namespace mlmap;
using Clock = SteadyClock;

/// Peak and current resident set size of this process [bytes], from /proc/self/status.
std::size_t procStatusBytes(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string prefix = std::string(key) + ":";
  while (std::getline(in, line)) {
    if (line.compare(0, prefix.size(), prefix) == 0) {
      return static_cast<std::size_t>(std::stoull(line.substr(prefix.size()))) * 1024;
    }
  }
  return 0;
}

/// One frame of a dataset: a depth image or a point cloud (sensor frame), with its poses.
struct Frame {
  bool is_depth = false;
  DepthFrame depth;
  PointCloudFrame cloud;
  double path_m = 0.0;  ///< distance flown when the frame was taken (simulated walks) [m]
};

/// A dataset: its frames produced one at a time (rendering is not timed).
struct Dataset {
  std::string kind;  ///< realsense, depth, lidar, building, building-lidar
  std::string description;
  int frames = 0;
  double default_max_range_m = 10.0;
  double window_z_m = 0.0;  ///< 0: the window is 2.5 x the range along z too
  Transform T_B_S = Transform::Identity();
  std::function<Frame(int)> frame;
  std::shared_ptr<const datasets::Scenario> scenario;  ///< simulated datasets: the ground truth
  /// Simulated datasets: what every pose was moved by after rendering (the scene's offset from
  /// the world the ground truth describes).
  Eigen::Vector3d scene_offset_W = Eigen::Vector3d::Zero();
};

/// Options shared by every case.
struct Options {
  std::string realsense_dir = MLMAP_SHARED_DATA_DIR "/realsense_tabletop";
  std::string building_yaml = MLMAP_SOURCE_DIR "/config/worlds/building.yaml";
  int frames = 0;  // 0: each dataset's default
  double stream_hz =
      0.0;  // simulated flights: frames as a sensor at this rate streams them; 0: spread
  double max_range_m = 0;  // 0: each dataset's default
  std::string mappers = "both";
  std::string out_dir;
  std::vector<double> window_m;  // empty: 2.5 x the range (z: 7.5 m in the simulated worlds)
  std::vector<double>
      scene_offset_m;  // simulated datasets: every pose moved by this after rendering
  bool voxels = false;
  bool quiet = false;
};

int framesOr(int requested, int available) {
  return requested > 0 ? std::min(requested, available) : available;
}

Dataset makeDataset(const std::string& kind, const Options& o) {
  Dataset d;
  d.kind = kind;
  if (kind == "realsense") {
    auto dir = std::make_shared<datasets::FrameDirectory>(o.realsense_dir);
    const int n = framesOr(o.frames, static_cast<int>(dir->size()));
    d.description = "real RealSense frames (" + o.realsense_dir + "), 640x480 depth";
    d.frames = n;
    d.default_max_range_m = 2.0;  // the scene spans 0.27-1.8 m: every point is within range
    d.frame = [dir, n](int i) {
      Frame f;
      f.is_depth = true;
      const std::size_t index =
          static_cast<std::size_t>(i) * dir->size() / static_cast<std::size_t>(n);
      f.depth = dir->read(index);
      return f;
    };
    return d;
  }
  const bool building = kind == "building" || kind == "building-lidar";
  const bool lidar = kind == "lidar" || kind == "building-lidar";
  if (!building && kind != "depth" && !lidar) {
    throw std::runtime_error("unknown dataset '" + kind +
                             "' (known: realsense, depth, lidar, building, building-lidar)");
  }
  auto scenario = std::make_shared<datasets::Scenario>(
      building ? datasets::loadScenarioYaml(o.building_yaml) : datasets::defaultScenario());
  const int total = eval::frameCount(*scenario);
  // With --stream-hz: frames `step` camera frames apart from the start, as a sensor streams them.
  const int step =
      o.stream_hz > 0.0
          ? std::max(1, static_cast<int>(std::lround(scenario->frame_rate_hz / o.stream_hz)))
          : 0;
  const int available = step > 0 ? (total - 1) / step + 1 : total;
  // Defaults: a walk or a stream whole; spread, 60 frames (depth) or 30 scans (LiDAR).
  const int n =
      framesOr(o.frames, building || step > 0 ? available : std::min(available, lidar ? 30 : 60));
  d.frames = n;
  // The camera frame of the i-th frame of the case.
  const auto source = [n, total, step](int i) { return step > 0 ? i * step : (i * total) / n; };
  d.window_z_m = 7.5;
  d.scenario = scenario;
  if (o.scene_offset_m.size() == 3) {
    d.scene_offset_W =
        Eigen::Vector3d(o.scene_offset_m[0], o.scene_offset_m[1], o.scene_offset_m[2]);
  }
  if (lidar) {
    d.default_max_range_m = 30.0;
    d.T_B_S = Transform::Identity();  // LiDAR at the body origin, x forward, z up
    auto sensor = std::make_shared<sim::Lidar>();
    d.description = std::string(building ? "building walk" : "default room flight") +
                    ", simulated LiDAR 128 x 640 rays, 45 deg vertical, 30 m";
    d.frame = [scenario, sensor, source, T_B_S = d.T_B_S, offset = d.scene_offset_W](int i) {
      const double t = eval::frameTime(*scenario, source(i));
      Frame f;
      f.cloud.T_W_B = scenario->trajectory.poseAt(t);
      f.cloud.T_B_S = T_B_S;
      sensor->render(scenario->world, f.cloud.T_W_B * T_B_S, t, &f.cloud);
      f.cloud.T_W_B.pretranslate(offset);
      f.path_m = t * scenario->trajectory.speed_mps();
      return f;
    };
  } else {
    d.default_max_range_m = 10.0;  // mlmap's default range (the camera sees 15 m)
    d.T_B_S = SensorConfig{}.T_B_S();
    auto camera = std::make_shared<sim::DepthCamera>(scenario->camera);
    d.description = std::string(building ? "building walk" : "default room flight") +
                    ", simulated 640x480 depth camera";
    d.frame = [scenario, camera, source, T_B_S = d.T_B_S, offset = d.scene_offset_W](int i) {
      const double t = eval::frameTime(*scenario, source(i));
      Frame f;
      f.is_depth = true;
      f.depth.T_W_B = scenario->trajectory.poseAt(t);
      f.depth.T_B_S = T_B_S;
      camera->render(scenario->world, f.depth.T_W_B * T_B_S, t, &f.depth);
      f.depth.T_W_B.pretranslate(offset);
      f.path_m = t * scenario->trajectory.speed_mps();
      return f;
    };
  }
  if (building) d.description += " (" + o.building_yaml + ")";
  std::ostringstream spacing;
  if (step > 0) {
    spacing << "; frames streamed at " << scenario->frame_rate_hz / step << " Hz";
  } else {
    spacing << (n == total ? "; every frame" : "; frames spread over the flight");
  }
  d.description += spacing.str();
  if (!d.scene_offset_W.isZero()) {
    std::ostringstream offset;
    offset << "; scene moved by (" << d.scene_offset_W.transpose() << ") m, off the voxel grid";
    d.description += offset.str();
  }
  return d;
}

int roundUpTo5(double cells) { return std::max(5, static_cast<int>(std::ceil(cells / 5.0)) * 5); }

/// mlmap's configuration for a case: defaults, except the resolution, the range, and a local
/// window that holds every point within range wherever the body sits in its centre submap
/// (the body is >= 2 submaps = 0.4 x the window from its faces: 2.5 x the range). The planning
/// layers (ESDF, 2D grid) are off: OctoMap builds neither.
MapConfig configFor(const Dataset& d, double resolution_m, double max_range_m,
                    const std::vector<double>& window_m) {
  MapConfig c;
  c.local_map.resolution_m = resolution_m;
  const int xy = roundUpTo5(2.5 * max_range_m / resolution_m);
  const int z = d.window_z_m > 0.0 ? roundUpTo5(d.window_z_m / resolution_m) : xy;
  c.local_map.size_cells = {xy, xy, z};
  if (window_m.size() == 3) {
    for (int a = 0; a < 3; ++a) c.local_map.size_cells[a] = roundUpTo5(window_m[a] / resolution_m);
  }
  c.awareness.max_range_m = max_range_m;
  c.awareness.rho_cells = std::max(
      c.awareness.rho_cells, static_cast<int>(std::ceil(max_range_m / c.awareness.rho_cell_m)));
  // The frames carry T_B_S; the engine reads only the offset of the configured one (to size its
  // free-space scratch box).
  c.sensor.translation_B_m = d.T_B_S.translation();
  c.esdf.enabled = false;
  c.projected_grid.enabled = false;
  return c;
}

/// Progress on stderr: one line per 10 % (redrawn in place on a terminal).
class Progress {
 public:
  Progress(std::string label, int total, bool quiet)
      : label_(std::move(label)), total_(total), quiet_(quiet), tty_(isatty(2) != 0) {}
  void update(int done, double mlmap_ms, double octomap_ms) {
    if (quiet_ || total_ <= 0) return;
    const int decile = 10 * done / total_;
    if (!tty_ && decile == last_decile_ && done != total_) return;
    last_decile_ = decile;
    std::fprintf(
        stderr, "%s%s: %d/%d frames (%3d%%), %.0f s, last frame mlmap %.1f ms, OctoMap %.0f ms%s",
        tty_ ? "\r" : "", label_.c_str(), done, total_, 100 * done / total_,
        msSince(start_) / 1000.0, mlmap_ms, octomap_ms, (tty_ && done != total_) ? "" : "\n");
    std::fflush(stderr);
  }

 private:
  std::string label_;
  int total_;
  bool quiet_, tty_;
  int last_decile_ = -1;
  Clock::time_point start_ = Clock::now();
};

/// OctoMap's occupied leaves as voxel indices on mlmap's grid (pruned leaves expanded), and a
/// check that a depth-16 leaf's key minus 2^15 is floor(centre / resolution) per axis.
struct OctomapVoxels {
  std::vector<VoxelIndex> occupied;
  std::size_t leaves_checked = 0;
  std::size_t key_mismatches = 0;
};

OctomapVoxels octomapOccupied(const octomap::OcTree& tree) {
  OctomapVoxels r;
  const double res = tree.getResolution();
  const unsigned max_depth = tree.getTreeDepth();
  constexpr int kKeyOffset = 32768;  // octomap's tree_max_val for 16-level trees
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const octomap::point3d c = it.getCoordinate();
    if (it.getDepth() == max_depth) {
      const octomap::OcTreeKey& key = it.getKey();
      const VoxelIndex from_key(key[0] - kKeyOffset, key[1] - kKeyOffset, key[2] - kKeyOffset);
      ++r.leaves_checked;
      if (from_key != voxelIndexOf(Eigen::Vector3d(c.x(), c.y(), c.z()), res)) ++r.key_mismatches;
      r.occupied.push_back(from_key);
      continue;
    }
    // A pruned leaf: every cell it covers, from the centre of its lowest cell.
    const int n = 1 << (max_depth - it.getDepth());
    const double half = 0.5 * it.getSize() - 0.5 * res;
    const VoxelIndex lo =
        voxelIndexOf(Eigen::Vector3d(c.x() - half, c.y() - half, c.z() - half), res);
    for (int x = 0; x < n; ++x) {
      for (int y = 0; y < n; ++y) {
        for (int z = 0; z < n; ++z) r.occupied.push_back(lo + VoxelIndex(x, y, z));
      }
    }
  }
  return r;
}

/// Inserts the finite points of `points_S` at least `min_range_m` from the sensor, in W, into
/// `tree` with the sensor origin and `max_range_m` (insertPointCloud); `scan_W` is scratch.
void insertScan(const std::vector<Eigen::Vector3f>& points_S, const Transform& T_W_S,
                float min_range_m, double max_range_m, octomap::Pointcloud* scan_W,
                octomap::OcTree* tree) {
  scan_W->clear();
  scan_W->reserve(points_S.size());
  for (const Eigen::Vector3f& p : points_S) {
    if (!p.allFinite() || p.norm() < min_range_m) continue;
    const Eigen::Vector3d p_W = T_W_S * p.cast<double>();
    scan_W->push_back(static_cast<float>(p_W.x()), static_cast<float>(p_W.y()),
                      static_cast<float>(p_W.z()));
  }
  const Eigen::Vector3d o_W = T_W_S.translation();
  tree->insertPointCloud(*scan_W,
                         octomap::point3d(static_cast<float>(o_W.x()), static_cast<float>(o_W.y()),
                                          static_cast<float>(o_W.z())),
                         max_range_m);
}

/// What one case measured.
struct CaseResult {
  std::string name, kind, description;
  double resolution_m = 0.0, max_range_m = 0.0;
  Eigen::Vector3i window_cells = Eigen::Vector3i::Zero();
  int frames = 0;
  double points_per_frame = 0.0;
  std::vector<double> mlmap_ms, octomap_ms, path_m;
  std::vector<double> mlmap_mapping_ms;  ///< mlmap_ms minus the planner snapshot (window copy)
  std::vector<std::size_t> mlmap_bytes, octomap_bytes;
  std::vector<std::size_t> mlmap_map_bytes;  ///< the map layers alone: local + global
  std::size_t mlmap_peak_bytes = 0, octomap_peak_bytes = 0;
  std::size_t rss_before_bytes = 0, rss_peak_bytes = 0;
  EngineStats stats;
  bool ran_mlmap = false, ran_octomap = false;
  eval::VoxelAgreement agreement;
  /// Simulated worlds: occupied voxels that touch a solid (right to be occupied), per map and
  /// for the voxels only one map has.
  struct Truth {
    bool known = false;
    std::size_t mlmap_right = 0, octomap_right = 0;
    std::size_t only_mlmap = 0, only_mlmap_right = 0, only_octomap = 0, only_octomap_right = 0;
  } truth;
  OctomapVoxels octomap_voxels;
  std::vector<VoxelIndex> mlmap_voxels;
};

CaseResult runCase(const Dataset& d, double resolution_m, const Options& o) {
  CaseResult r;
  r.kind = d.kind;
  r.description = d.description;
  r.resolution_m = resolution_m;
  r.max_range_m = o.max_range_m > 0.0 ? o.max_range_m : d.default_max_range_m;
  char name[96];
  std::snprintf(name, sizeof(name), "%s @ %.2f m", d.kind.c_str(), resolution_m);
  r.name = name;
  r.frames = d.frames;
  r.ran_mlmap = o.mappers != "octomap";
  r.ran_octomap = o.mappers != "mlmap";
  const MapConfig config = configFor(d, resolution_m, r.max_range_m, o.window_m);
  r.window_cells = config.local_map.size_cells;
  r.rss_before_bytes = procStatusBytes("VmRSS");
  std::unique_ptr<MapEngine> engine;
  if (r.ran_mlmap) engine = std::make_unique<MapEngine>(config);
  std::unique_ptr<octomap::OcTree> tree;
  if (r.ran_octomap) tree = std::make_unique<octomap::OcTree>(resolution_m);
  const float min_range = static_cast<float>(config.awareness.min_range_m);
  Progress progress(r.name, d.frames, o.quiet);
  double points = 0.0;
  std::vector<Eigen::Vector3f> points_S;
  octomap::Pointcloud scan_W;
  std::uint64_t snapshots = 0;
  for (int i = 0; i < d.frames; ++i) {
    Frame f = d.frame(i);
    r.path_m.push_back(f.path_m);
    double octomap_ms = 0.0, mlmap_ms = 0.0;
    if (tree) {
      // OctoMap gets the points mlmap maps: mlmap's back-projection of the depth image, every
      // finite point at least min_range_m from the sensor, in W, with the sensor origin.
      const Clock::time_point t0 = Clock::now();
      const Transform T_W_S =
          f.is_depth ? f.depth.T_W_B * f.depth.T_B_S : f.cloud.T_W_B * f.cloud.T_B_S;
      if (f.is_depth) {
        backProject(f.depth, &points_S);
      } else {
        points_S = f.cloud.points_S;
      }
      insertScan(points_S, T_W_S, min_range, r.max_range_m, &scan_W, tree.get());
      octomap_ms = msSince(t0);
      r.octomap_ms.push_back(octomap_ms);
      const std::size_t bytes = tree->memoryUsage();
      r.octomap_bytes.push_back(bytes);
      r.octomap_peak_bytes = std::max(r.octomap_peak_bytes, bytes);
      points += static_cast<double>(scan_W.size());
    }
    if (engine) {
      const Clock::time_point t0 = Clock::now();
      const FrameStatus status =
          f.is_depth ? engine->submit(std::move(f.depth)) : engine->submit(std::move(f.cloud));
      mlmap_ms = msSince(t0);
      if (status != FrameStatus::kAccepted) {
        throw std::runtime_error(r.name + ": frame " + std::to_string(i) + " rejected by mlmap (" +
                                 toString(status) + ")");
      }
      r.mlmap_ms.push_back(mlmap_ms);
      const EngineStats stats = engine->stats();
      const bool snapshot = stats.planning.snapshots > snapshots;
      snapshots = stats.planning.snapshots;
      r.mlmap_mapping_ms.push_back(mlmap_ms - (snapshot ? stats.planning.last_snapshot_ms : 0.0));
      const std::size_t bytes = stats.memory.total();
      r.mlmap_bytes.push_back(bytes);
      r.mlmap_map_bytes.push_back(stats.memory.local_bytes + stats.memory.global_bytes);
      r.mlmap_peak_bytes = std::max(r.mlmap_peak_bytes, bytes);
    }
    progress.update(i + 1, mlmap_ms, octomap_ms);
  }
  r.rss_peak_bytes = eval::peakRssBytes();
  if (engine) {
    r.stats = engine->stats();
    r.mlmap_voxels = engine->occupiedVoxels();
    if (!tree) {
      points = static_cast<double>(r.stats.points.points_in - r.stats.points.rejected_non_finite);
    }
  }
  r.points_per_frame = points / std::max(1, d.frames);
  if (tree) r.octomap_voxels = octomapOccupied(*tree);
  if (engine && tree) r.agreement = eval::compareVoxels(r.mlmap_voxels, r.octomap_voxels.occupied);
  if (engine && tree && d.scenario && d.scene_offset_W.isZero()) {
    const sim::World& world = d.scenario->world;
    const eval::VoxelSet a(r.mlmap_voxels.begin(), r.mlmap_voxels.end());
    const eval::VoxelSet b(r.octomap_voxels.occupied.begin(), r.octomap_voxels.occupied.end());
    CaseResult::Truth& t = r.truth;
    t.known = true;
    // Scores `set` against the truth: all its voxels, and those the `other` map lacks.
    auto score = [&](const eval::VoxelSet& set, const eval::VoxelSet& other, std::size_t* right,
                     std::size_t* only, std::size_t* only_right) {
      for (const VoxelIndex& v : set) {
        const bool ok = eval::touchesSolid(world, v, resolution_m);
        *right += ok ? 1 : 0;
        if (other.count(v) == 0) {
          ++*only;
          *only_right += ok ? 1 : 0;
        }
      }
    };
    score(a, b, &t.mlmap_right, &t.only_mlmap, &t.only_mlmap_right);
    score(b, a, &t.octomap_right, &t.only_octomap, &t.only_octomap_right);
  }
  return r;
}

double mb(std::size_t bytes) { return static_cast<double>(bytes) / 1e6; }

void printCase(const CaseResult& r) {
  std::printf("\n== %s: %s\n", r.name.c_str(), r.description.c_str());
  std::printf("   %d frames, %.0f points/frame, max range %.1f m, mlmap window %d x %d x %d\n",
              r.frames, r.points_per_frame, r.max_range_m, r.window_cells.x(), r.window_cells.y(),
              r.window_cells.z());
  const TimingSummary a = summarizeTimings(r.mlmap_ms);
  const TimingSummary b = summarizeTimings(r.octomap_ms);
  std::printf("   time per frame [ms]   median      p99     mean\n");
  const TimingSummary m = summarizeTimings(r.mlmap_mapping_ms);
  if (r.ran_mlmap) {
    std::printf(
        "   mlmap submit()     %9.2f %8.2f %8.2f   (all of it, planner snapshot included)\n",
        a.median_ms, a.p99_ms, a.mean_ms);
    std::printf("   mlmap mapping      %9.2f %8.2f %8.2f   (without the snapshot's window copy)\n",
                m.median_ms, m.p99_ms, m.mean_ms);
  }
  if (r.ran_octomap)
    std::printf("   OctoMap            %9.1f %8.1f %8.1f\n", b.median_ms, b.p99_ms, b.mean_ms);
  if (r.ran_mlmap && r.ran_octomap) {
    std::printf("   OctoMap / submit() %8.1fx %7.1fx %7.1fx\n", b.median_ms / a.median_ms,
                b.p99_ms / a.p99_ms, b.mean_ms / a.mean_ms);
    std::printf("   OctoMap / mapping  %8.1fx %7.1fx %7.1fx\n", b.median_ms / m.median_ms,
                b.p99_ms / m.p99_ms, b.mean_ms / m.mean_ms);
  }
  std::printf(
      "   memory [MB]: mlmap accounting peak %.1f / final %.1f; OcTree::memoryUsage peak %.1f / "
      "final %.1f;"
      " process peak RSS %.1f (%.1f before mapping)\n",
      mb(r.mlmap_peak_bytes), mb(r.mlmap_bytes.empty() ? 0 : r.mlmap_bytes.back()),
      mb(r.octomap_peak_bytes), mb(r.octomap_bytes.empty() ? 0 : r.octomap_bytes.back()),
      mb(r.rss_peak_bytes), mb(r.rss_before_bytes));
  if (r.ran_mlmap) {
    std::printf(
        "   mlmap stages, median / p99 [ms]: awareness %.2f / %.2f, local-global %.2f / %.2f "
        "(the engine's recent frames)\n",
        r.stats.awareness.median_ms, r.stats.awareness.p99_ms, r.stats.local_global.median_ms,
        r.stats.local_global.p99_ms);
    std::printf(
        "   mlmap memory by layer [MB]: awareness %.1f, local %.1f, global %.1f, planning %.1f;"
        " measurements outside the window (dropped): %llu\n",
        mb(r.stats.memory.awareness_bytes), mb(r.stats.memory.local_bytes),
        mb(r.stats.memory.global_bytes), mb(r.stats.memory.planning_bytes),
        static_cast<unsigned long long>(r.stats.local.outside_window));
  }
  if (r.ran_mlmap && r.ran_octomap) {
    const eval::VoxelAgreement& g = r.agreement;
    std::printf("   occupied voxels: mlmap |A| %zu, OctoMap |B| %zu, both %zu\n", g.a, g.b,
                g.intersection);
    std::printf(
        "   exact:           IoU %.3f, precision %.3f, recall %.3f (mlmap against OctoMap)\n",
        g.iou, g.precision, g.recall);
    std::printf("   within one cell: IoU %.3f, precision %.3f, recall %.3f\n", g.iou_1,
                g.precision_1, g.recall_1);
  }
  if (r.truth.known) {
    const CaseResult::Truth& t = r.truth;
    auto pct = [](std::size_t n, std::size_t d) {
      return d ? 100.0 * static_cast<double>(n) / static_cast<double>(d) : 0.0;
    };
    std::printf(
        "   against the simulator's truth (a voxel is right when it touches a solid): mlmap %.1f "
        "%%, "
        "OctoMap %.1f %%;\n   only mlmap: %zu voxels, %.1f %% right; only OctoMap: %zu voxels, "
        "%.1f %% right\n",
        pct(t.mlmap_right, r.agreement.a), pct(t.octomap_right, r.agreement.b), t.only_mlmap,
        pct(t.only_mlmap_right, t.only_mlmap), t.only_octomap,
        pct(t.only_octomap_right, t.only_octomap));
  }
  if (r.ran_octomap) {
    std::printf(
        "   OctoMap key check: %zu leaves, %zu whose key is not floor(centre / resolution)\n",
        r.octomap_voxels.leaves_checked, r.octomap_voxels.key_mismatches);
  }
}

void writeArray(std::ostream& out, const std::vector<double>& v, int precision) {
  out << "[";
  char buf[32];
  for (std::size_t i = 0; i < v.size(); ++i) {
    std::snprintf(buf, sizeof(buf), "%.*f", precision, v[i]);
    out << (i ? ", " : "") << buf;
  }
  out << "]";
}

void writeArray(std::ostream& out, const std::vector<std::size_t>& v) {
  out << "[";
  for (std::size_t i = 0; i < v.size(); ++i) out << (i ? ", " : "") << v[i];
  out << "]";
}

void writeTiming(std::ostream& out, const std::vector<double>& ms) {
  const TimingSummary s = summarizeTimings(ms);
  out << "{\"median\": " << s.median_ms << ", \"p99\": " << s.p99_ms << ", \"mean\": " << s.mean_ms
      << ", \"max\": " << s.max_ms << "}";
}

void writeJson(std::ostream& out, const std::vector<CaseResult>& results,
               const std::string& mappers) {
  out.precision(6);
  out << "{\n  \"program\": \"mlmap_compare_octomap\",\n  \"mlmap_mode\": \"synchronous (one "
         "core)\",\n"
      << "  \"mappers\": \"" << mappers << "\",\n  \"cases\": [\n";
  for (std::size_t k = 0; k < results.size(); ++k) {
    const CaseResult& r = results[k];
    const eval::VoxelAgreement& g = r.agreement;
    out << "    {\"name\": " << eval::jsonString(r.name) << ", \"dataset\": \"" << r.kind
        << "\", \"description\": " << eval::jsonString(r.description) << ",\n"
        << "     \"resolution_m\": " << r.resolution_m << ", \"max_range_m\": " << r.max_range_m
        << ", \"frames\": " << r.frames << ", \"points_per_frame\": " << r.points_per_frame
        << ", \"window_cells\": [" << r.window_cells.x() << ", " << r.window_cells.y() << ", "
        << r.window_cells.z() << "],\n";
    out << "     \"mlmap\": {\"ran\": " << (r.ran_mlmap ? "true" : "false") << ", \"time_ms\": ";
    writeTiming(out, r.mlmap_ms);
    out << ", \"mapping_time_ms\": ";
    writeTiming(out, r.mlmap_mapping_ms);
    out << ", \"peak_memory_bytes\": " << r.mlmap_peak_bytes
        << ", \"memory_by_layer_bytes\": {\"awareness\": " << r.stats.memory.awareness_bytes
        << ", \"local\": " << r.stats.memory.local_bytes
        << ", \"global\": " << r.stats.memory.global_bytes
        << ", \"planning\": " << r.stats.memory.planning_bytes
        << "}, \"outside_window\": " << r.stats.local.outside_window << ",\n       \"frame_ms\": ";
    writeArray(out, r.mlmap_ms, 3);
    out << ",\n       \"memory_bytes\": ";
    writeArray(out, r.mlmap_bytes);
    out << ",\n       \"map_memory_bytes\": ";
    writeArray(out, r.mlmap_map_bytes);
    out << "},\n     \"octomap\": {\"ran\": " << (r.ran_octomap ? "true" : "false")
        << ", \"time_ms\": ";
    writeTiming(out, r.octomap_ms);
    out << ", \"peak_memory_bytes\": " << r.octomap_peak_bytes
        << ", \"key_check\": {\"leaves\": " << r.octomap_voxels.leaves_checked
        << ", \"mismatches\": " << r.octomap_voxels.key_mismatches << "},\n       \"frame_ms\": ";
    writeArray(out, r.octomap_ms, 3);
    out << ",\n       \"memory_bytes\": ";
    writeArray(out, r.octomap_bytes);
    out << "},\n     \"process_rss_bytes\": {\"before\": " << r.rss_before_bytes
        << ", \"peak\": " << r.rss_peak_bytes << "},\n     \"path_m\": ";
    writeArray(out, r.path_m, 2);
    out << ",\n     \"agreement\": {\"mlmap_voxels\": " << g.a << ", \"octomap_voxels\": " << g.b
        << ", \"intersection\": " << g.intersection << ", \"iou\": " << g.iou
        << ", \"precision\": " << g.precision << ", \"recall\": " << g.recall
        << ", \"matched_mlmap_1\": " << g.matched_a_1
        << ", \"matched_octomap_1\": " << g.matched_b_1 << ", \"iou_1\": " << g.iou_1
        << ", \"precision_1\": " << g.precision_1 << ", \"recall_1\": " << g.recall_1 << "}";
    if (r.truth.known) {
      const CaseResult::Truth& t = r.truth;
      out << ",\n     \"truth\": {\"mlmap_right\": " << t.mlmap_right
          << ", \"octomap_right\": " << t.octomap_right << ", \"only_mlmap\": " << t.only_mlmap
          << ", \"only_mlmap_right\": " << t.only_mlmap_right
          << ", \"only_octomap\": " << t.only_octomap
          << ", \"only_octomap_right\": " << t.only_octomap_right << "}";
    }
    out << "}" << (k + 1 < results.size() ? "," : "") << "\n";
  }
  out << "  ]\n}\n";
}

/// Writes `ix iy iz where` per voxel: 3 both maps, 1 only mlmap, 2 only OctoMap.
void writeVoxels(const std::string& path, const CaseResult& r) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << "# " << r.name << ": ix iy iz where (1 only mlmap, 2 only OctoMap, 3 both); voxel i = "
      << "floor(coordinate / " << r.resolution_m << ")\n";
  const eval::VoxelSet a(r.mlmap_voxels.begin(), r.mlmap_voxels.end());
  const eval::VoxelSet b(r.octomap_voxels.occupied.begin(), r.octomap_voxels.occupied.end());
  for (const VoxelIndex& v : a) {
    out << v.x() << ' ' << v.y() << ' ' << v.z() << ' ' << (b.count(v) ? 3 : 1) << '\n';
  }
  for (const VoxelIndex& v : b) {
    if (!a.count(v)) out << v.x() << ' ' << v.y() << ' ' << v.z() << " 2\n";
  }
}

/// Writes the frames of a depth dataset as an RGB-D frame directory (mlmap/datasets/
/// frame_directory.h: 16-bit millimetre PNGs, camera-to-world pose matrices, intrinsics.K.txt).
void writeFrameDirectory(const Dataset& d, const std::string& dir) {
  std::filesystem::create_directories(dir);
  for (int i = 0; i < d.frames; ++i) {
    const Frame f = d.frame(i);
    const PinholeIntrinsics& K = f.depth.intrinsics;
    if (i == 0) {
      std::ostringstream k;
      k.precision(17);
      k << K.fx << " 0 " << K.cx << "\n0 " << K.fy << " " << K.cy << "\n0 0 1\n";
      writeFileAtomically(dir + "/intrinsics.K.txt", k.str());
    }
    cv::Mat depth_mm(K.height, K.width, CV_16UC1);
    for (int v = 0; v < K.height; ++v) {
      for (int u = 0; u < K.width; ++u) {
        const float z =
            f.depth.depth_m[static_cast<std::size_t>(v) * static_cast<std::size_t>(K.width) +
                            static_cast<std::size_t>(u)];
        const double mm = std::isfinite(z) && z > 0.0f ? std::round(1000.0 * z) : 0.0;
        depth_mm.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(mm < 65535.0 ? mm : 0.0);
      }
    }
    char name[64];
    std::snprintf(name, sizeof(name), "/frame-%06d", i);
    pictures::writePng(dir + name + ".depth.png", depth_mm);
    const Eigen::Matrix4d T_W_C = (f.depth.T_W_B * f.depth.T_B_S).matrix();
    std::ostringstream pose;
    pose.precision(17);
    for (int r = 0; r < 4; ++r) {
      pose << T_W_C(r, 0) << ' ' << T_W_C(r, 1) << ' ' << T_W_C(r, 2) << ' ' << T_W_C(r, 3) << '\n';
    }
    writeFileAtomically(dir + name + ".pose.txt", pose.str());
  }
}

/// Writes the scans of a LiDAR dataset as binary PCD files (sensor frame) in `dir`/clouds and
/// their sensor poses as `dir`/poses.tum, paired by order.
void writeCloudSequence(const Dataset& d, const std::string& dir) {
  std::filesystem::create_directories(dir + "/clouds");
  std::ostringstream tum;
  tum.precision(17);
  tum << "# timestamp tx ty tz qx qy qz qw (the sensor in the world)\n";
  for (int i = 0; i < d.frames; ++i) {
    const Frame f = d.frame(i);
    const std::vector<Eigen::Vector3f>& points = f.cloud.points_S;
    std::ostringstream pcd;
    pcd << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH "
        << points.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << points.size()
        << "\nDATA binary\n";
    std::string bytes = pcd.str();
    for (const Eigen::Vector3f& p : points)
      bytes.append(reinterpret_cast<const char*>(p.data()), 3 * sizeof(float));
    char name[64];
    std::snprintf(name, sizeof(name), "/clouds/scan_%06d.pcd", i);
    writeFileAtomically(dir + name, bytes);
    const Transform T_W_S = f.cloud.T_W_B * f.cloud.T_B_S;
    const Eigen::Quaterniond q(T_W_S.linear());
    const Eigen::Vector3d t = T_W_S.translation();
    tum << 1.0 + 0.1 * i << ' ' << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.x() << ' '
        << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
  }
  writeFileAtomically(dir + "/poses.tum", tum.str());
}

/// --write-frames: the frames of `d` as files both mlmap_replay and --octomap-replay read.
void writeDatasetFiles(const Dataset& d, const std::string& dir) {
  if (d.frames == 0) return;
  if (d.frame(0).is_depth) {
    writeFrameDirectory(d, dir);
    std::printf("wrote %d frames of %s to %s (mlmap_replay --frames %s)\n", d.frames,
                d.kind.c_str(), dir.c_str(), dir.c_str());
  } else {
    writeCloudSequence(d, dir);
    std::printf(
        "wrote %d scans of %s to %s (mlmap_replay --clouds %s/clouds --poses %s/poses.tum)\n",
        d.frames, d.kind.c_str(), dir.c_str(), dir.c_str(), dir.c_str());
  }
}

/// The voxels of a voxel list as mlmap_replay and --octomap-voxels write it (`ix iy iz` per
/// line, `#` lines skipped). Throws naming the file and line when a line is not three integers.
std::vector<VoxelIndex> readVoxelList(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::vector<VoxelIndex> voxels;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    VoxelIndex v;
    if (!(fields >> v.x() >> v.y() >> v.z())) {
      throw std::runtime_error(path + ":" + std::to_string(number) + ": not 'ix iy iz': " + line);
    }
    voxels.push_back(v);
  }
  return voxels;
}

/// --agreement A B: how two voxel lists agree (A against B), exact and within one cell.
int printListAgreement(const std::vector<std::string>& paths) {
  const eval::VoxelAgreement g =
      eval::compareVoxels(readVoxelList(paths[0]), readVoxelList(paths[1]));
  std::printf("A %s: %zu voxels; B %s: %zu voxels; both %zu\n", paths[0].c_str(), g.a,
              paths[1].c_str(), g.b, g.intersection);
  std::printf("exact:           IoU %.3f, precision %.3f, recall %.3f (A against B)\n", g.iou,
              g.precision, g.recall);
  std::printf("within one cell: IoU %.3f, precision %.4f, recall %.4f\n", g.iou_1, g.precision_1,
              g.recall_1);
  return 0;
}

/// What --octomap-replay maps: the files of mlmap_replay's --frames or --clouds + --poses.
struct OctomapReplayOptions {
  std::string frames_dir;
  std::string clouds_dir;
  std::string poses_path;
  double resolution_m = 0.1;
  double max_range_m = 10.0;
  std::string voxels_out;  ///< occupied voxels as mlmap_replay's text list (empty: none)
};

/// The whole-process OctoMap counterpart of mlmap_replay: every frame of the files read in turn
/// (the same readers), back-projected as mlmap does, inserted with insertPointCloud at the
/// resolution and range; prints the frames and the time. Returns the exit status.
int octomapReplay(const OctomapReplayOptions& o) {
  const Clock::time_point start = Clock::now();
  std::unique_ptr<datasets::FrameSource> source;
  if (!o.frames_dir.empty()) {
    source = std::make_unique<datasets::FrameDirectorySource>(o.frames_dir);
  } else {
    source = std::make_unique<datasets::CloudSequenceSource>(o.clouds_dir, o.poses_path,
                                                             datasets::CloudSequenceOptions{});
  }
  octomap::OcTree tree(o.resolution_m);
  const float min_range = static_cast<float>(AwarenessConfig{}.min_range_m);
  std::vector<Eigen::Vector3f> points_S;
  octomap::Pointcloud scan_W;
  double read_ms = 0.0;
  for (std::size_t i = 0; i < source->size(); ++i) {
    const Clock::time_point read_start = Clock::now();
    datasets::SourceFrame frame = source->read(i);
    read_ms += msSince(read_start);
    Transform T_W_S;
    if (const auto* depth = std::get_if<DepthFrame>(&frame)) {
      backProject(*depth, &points_S);
      T_W_S = depth->T_W_B * depth->T_B_S;
    } else {
      const auto& cloud = std::get<PointCloudFrame>(frame);
      points_S = cloud.points_S;
      T_W_S = cloud.T_W_B * cloud.T_B_S;
    }
    insertScan(points_S, T_W_S, min_range, o.max_range_m, &scan_W, &tree);
  }
  const OctomapVoxels voxels = octomapOccupied(tree);
  if (!o.voxels_out.empty()) io::writeVoxelText(o.voxels_out, voxels.occupied, o.resolution_m);
  std::printf(
      "octomap replay: %zu frames of %s at %.3f m, range %.1f m: %zu occupied voxels, %.2f s "
      "(reading %.2f s), peak RSS %.1f MB\n",
      source->size(), source->describe().c_str(), o.resolution_m, o.max_range_m,
      voxels.occupied.size(), msSince(start) / 1000.0, read_ms / 1000.0,
      static_cast<double>(procStatusBytes("VmHWM")) / 1e6);
  return voxels.key_mismatches == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap_compare_octomap: the same frames, resolution and maximum range into mlmap "
      "(synchronous "
      "MapEngine, one core) and OctoMap (OcTree::insertPointCloud, default sensor model). Prints "
      "time per frame, memory and occupied-voxel agreement; writes JSON."};
  Options o;
  std::vector<std::string> cases = {"realsense:0.05", "realsense:0.02", "depth:0.1", "lidar:0.1"};
  app.add_option(
         "--cases", cases,
         "DATASET:RESOLUTION_M, datasets: realsense (the shared RealSense frames), depth "
         "(default room flight, 640x480 depth), lidar (same flight, 128 x 640 LiDAR, 30 m), "
         "building (the building walk, depth camera), building-lidar")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option(
         "--frames", o.frames,
         "frames per case, spread evenly or the first ones of a stream (0: realsense all 50, "
         "depth 60, lidar 30, building all; with --stream-hz the whole flight)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option(
         "--stream-hz", o.stream_hz,
         "simulated datasets: the frames as a sensor streaming at this rate gives them, "
         "from the start of the flight, at most the scenario's frame rate (0: spread evenly "
         "over the whole flight, so the vehicle moves metres between frames)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option(
         "--max-range", o.max_range_m,
         "maximum range of both mappers [m] (0: realsense 2, depth and building 10, LiDAR 30)")
      ->check(CLI::NonNegativeNumber);
  app.add_option(
         "--mappers", o.mappers,
         "both, or only mlmap / octomap (a run with one mapper gives that mapper's peak RSS)")
      ->check(CLI::IsMember({"both", "mlmap", "octomap"}))
      ->capture_default_str();
  app.add_option("--window", o.window_m,
                 "mlmap's local window X,Y,Z [m] (default: 2.5 x the range across, so that every "
                 "point in range lands in it; along z 7.5 m in the simulated worlds)")
      ->delimiter(',')
      ->expected(3)
      ->check(CLI::PositiveNumber);
  app.add_option(
         "--scene-offset", o.scene_offset_m,
         "simulated datasets: move every pose by X,Y,Z [m] after rendering, which moves the "
         "scene off the voxel grid (the simulated rooms' faces lie on voxel faces, where a "
         "point's voxel is a tie that rounding decides); no scoring against the truth then")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--realsense", o.realsense_dir, "RGB-D frame directory of the realsense dataset")
      ->capture_default_str();
  app.add_option("--building", o.building_yaml, "scenario YAML of the building walk")
      ->capture_default_str();
  app.add_option("--out", o.out_dir, "write compare.json (and voxel lists) into this directory");
  app.add_flag(
      "--voxels", o.voxels,
      "also write <out>/<dataset>_<res>.voxels.txt: both maps' occupied voxels, for pictures");
  app.add_flag("--quiet", o.quiet, "no progress lines");
  std::string write_frames_dir;
  app.add_option("--write-frames", write_frames_dir,
                 "write each case's frames as files into DIR/<dataset> (depth: an RGB-D frame "
                 "directory; LiDAR: binary PCD clouds + poses.tum) for whole-process runs of "
                 "mlmap_replay and --octomap-replay, and exit");
  OctomapReplayOptions replay;
  auto* octomap_frames =
      app.add_option("--octomap-frames", replay.frames_dir,
                     "whole-process OctoMap replay of an RGB-D frame directory, and exit")
          ->check(CLI::ExistingDirectory);
  auto* octomap_clouds = app.add_option("--octomap-clouds", replay.clouds_dir,
                                        "whole-process OctoMap replay of PCD / PLY clouds (with "
                                        "--octomap-poses), and exit")
                             ->check(CLI::ExistingDirectory);
  auto* octomap_poses =
      app.add_option("--octomap-poses", replay.poses_path, "the clouds' poses (TUM or CSV)")
          ->check(CLI::ExistingFile);
  octomap_clouds->needs(octomap_poses)->excludes(octomap_frames);
  app.add_option("--octomap-resolution", replay.resolution_m, "the OctoMap replay's resolution [m]")
      ->check(CLI::Range(0.01, 2.0))
      ->capture_default_str();
  app.add_option("--octomap-voxels", replay.voxels_out,
                 "the OctoMap replay's occupied voxels, as mlmap_replay's occupied_voxels.txt");
  std::vector<std::string> agreement_lists;
  app.add_option("--agreement", agreement_lists,
                 "print how two voxel lists agree (A B: e.g. mlmap_replay's occupied_voxels.txt "
                 "and --octomap-voxels' file), exact and within one cell, and exit")
      ->expected(2)
      ->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);
  if (!agreement_lists.empty()) {
    try {
      return printListAgreement(agreement_lists);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "mlmap_compare_octomap: %s\n", e.what());
      return 1;
    }
  }
  if (!replay.frames_dir.empty() || !replay.clouds_dir.empty()) {
    if (o.max_range_m > 0.0) replay.max_range_m = o.max_range_m;
    try {
      return octomapReplay(replay);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "mlmap_compare_octomap: %s\n", e.what());
      return 1;
    }
  }

  try {
    std::vector<std::pair<std::string, double>> parsed;
    for (const std::string& c : cases) {
      const std::size_t colon = c.find(':');
      double res = 0.0;
      try {
        if (colon != std::string::npos) res = std::stod(c.substr(colon + 1));
      } catch (const std::exception&) {
        res = 0.0;
      }
      if (colon == std::string::npos || !(res > 0.0) || !std::isfinite(res)) {
        throw std::runtime_error("--cases: '" + c +
                                 "' is not DATASET:RESOLUTION_M with a resolution > 0");
      }
      parsed.emplace_back(c.substr(0, colon), res);
    }
    if (!o.out_dir.empty()) std::filesystem::create_directories(o.out_dir);
    std::printf(
        "mlmap_compare_octomap: mlmap in synchronous mode (one core), OctoMap %s, mappers: %s\n",
        "OcTree::insertPointCloud (default sensor model, no discretization)", o.mappers.c_str());
    std::vector<CaseResult> results;
    bool keys_ok = true;
    for (const auto& [kind, res] : parsed) {
      const Dataset d = makeDataset(kind, o);
      if (!write_frames_dir.empty()) {
        writeDatasetFiles(d, write_frames_dir + "/" + kind);
        continue;
      }
      results.push_back(runCase(d, res, o));
      printCase(results.back());
      keys_ok = keys_ok && results.back().octomap_voxels.key_mismatches == 0;
      if (o.voxels && !o.out_dir.empty()) {
        char file[128];
        std::snprintf(file, sizeof(file), "/%s_%.2f.voxels.txt", kind.c_str(), res);
        writeVoxels(o.out_dir + file, results.back());
      }
    }
    if (!o.out_dir.empty()) {
      const std::string path = o.out_dir + "/compare.json";
      std::ofstream json(path);
      if (!json) throw std::runtime_error(path + ": cannot write");
      writeJson(json, results, o.mappers);
      std::printf("\nwrote %s\n", path.c_str());
    }
    if (!keys_ok) {
      std::fprintf(stderr, "error: OctoMap keys do not map to floor(coordinate / resolution)\n");
      return 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mlmap_compare_octomap: %s\n", e.what());
    return 1;
  }
  return 0;
}
