// mlmap_bench: per-frame cost of the engine (synchronous mode, one core) on simulated 640x480
// depth frames, on the shared real RealSense frames and on simulated 360-degree LiDAR scans.
// Prints median and p99 per stage and the memory by layer. With --files, maps recorded files
// (an RGB-D frame directory, or clouds with --poses) at the engine's defaults instead and prints
// each frame's wall and thread CPU time, as a peer library is timed on the same files.
// Figures, not pass/fail: see docs/performance.md.

#include "mlmap/core/stopwatch.h"
#include "mlmap/eval/run_outputs.h"
#include "mlmap/eval/sim_flight.h"
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/datasets/frame_source.h"
#include "mlmap/map_io/voxel_text.h"
#include "mlmap/pipeline/map_engine.h"
#include "mlmap/sim/lidar.h"

#include <CLI/CLI.hpp>

#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <type_traits>

namespace {

using namespace mlmap;

double megabytes(std::size_t bytes) { return static_cast<double>(bytes) / 1e6; }

struct Case {
  std::string name;
  MapConfig config;
};

/// awareness.num_threads of every case (--awareness-threads).
int g_awareness_threads = 1;
/// pipeline.threaded of every case (--threaded): the stages on threads of their own, the frames
/// queued without a drop and the throughput timed (the whole stream's wall time / frames).
bool g_threaded = false;
/// pipeline.planning_layers of the simulated cases (--no-planning: off).
bool g_planning_layers = true;
/// Synchronous: every frame of a pass copied before the pass, as --threaded queues them
/// (--copy-ahead), not each just before its submit() (which leaves the image in the cache).
bool g_copy_ahead = false;
/// pipeline.batch_queue_capacity of every case (--batch-queue).
int g_batch_queue = 2;

MapConfig at(double res, const Eigen::Vector3i& cells) {
  MapConfig c;
  c.awareness.num_threads = g_awareness_threads;
  c.pipeline.threaded = g_threaded;
  c.pipeline.input_queue_capacity = 1000;  // --threaded: every frame queued, none dropped
  c.pipeline.batch_queue_capacity = g_batch_queue;
  c.pipeline.planning_layers = g_planning_layers;
  c.local_map.resolution_m = res;
  c.local_map.size_cells = cells;
  return c;
}

struct Row {
  std::string name;
  double points;
  EngineStats stats;
  std::vector<double> snapshot_ms, grid_ms, esdf_ms;  // planning layers, per update
  /// Wall time of the stream: from the first submit() to the last frame mapped (threaded), or
  /// the submit() times summed (synchronous).
  double stream_ms = 0.0;
};

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)))];
}

/// Maps `frames` (depth images or clouds) `repeats` times in order, stamped 0.1 s apart.
template <typename FrameT>
Row run(const Case& c, const std::vector<FrameT>& frames, int repeats) {
  MapEngine engine(c.config);
  double points = 0.0;
  double stamp = 0.0;
  Row row;
  PlanningStats last;
  auto prepared = [&](FrameT f) {
    f.stamp_s = (stamp += 0.1);
    if constexpr (std::is_same_v<FrameT, DepthFrame>) f.T_B_S = c.config.sensor.T_B_S();
    return f;
  };
  for (int r = 0; r < repeats; ++r) {
    if (c.config.pipeline.threaded || g_copy_ahead) {
      // Every frame queued at once (copied before, untimed), none dropped: the stream's wall
      // time is what the two threads sustain (synchronous: the same frames, one after another).
      std::vector<FrameT> copies;
      for (const FrameT& f : frames) copies.push_back(prepared(f));
      const SteadyClock::time_point start = SteadyClock::now();
      for (FrameT& f : copies) engine.submit(std::move(f));
      engine.flush();
      row.stream_ms += msSince(start);
      continue;
    }
    for (const FrameT& frame : frames) {
      FrameT f = prepared(frame);  // copied untimed: submit() takes the frame
      const SteadyClock::time_point start = SteadyClock::now();
      engine.submit(std::move(f));
      row.stream_ms += msSince(start);
      const PlanningStats p = engine.stats().planning;
      if (p.snapshots > last.snapshots) row.snapshot_ms.push_back(p.last_snapshot_ms);
      if (p.grid_updates > last.grid_updates) row.grid_ms.push_back(p.last_grid_ms);
      if (p.esdf_updates > last.esdf_updates) row.esdf_ms.push_back(p.last_esdf_ms);
      last = p;
    }
  }
  const EngineStats s = engine.stats();
  points = static_cast<double>(s.points.points_in - s.points.rejected_non_finite) /
           static_cast<double>(std::max<std::uint64_t>(s.frames_mapped, 1));
  row.name = c.name;
  row.points = points;
  row.stats = s;
  return row;
}

void print(const Row& r, std::FILE* json, bool last) {
  const EngineStats& s = r.stats;
  if (json == nullptr)
    std::printf("%-34s %8.0f %7.2f %7.2f %7.2f %7.2f %7.2f %7.2f %7.1f %7.1f\n", r.name.c_str(),
                r.points, s.awareness.median_ms, s.awareness.p99_ms, s.local_global.median_ms,
                s.local_global.p99_ms, s.total.median_ms, s.total.p99_ms,
                megabytes(s.memory.local_bytes),
                megabytes(s.memory.awareness_bytes + s.memory.global_bytes));
  if (json != nullptr) {
    std::fprintf(json,
                 "  {\"case\": \"%s\", \"points_per_frame\": %.0f, \"frames\": %zu, "
                 "\"awareness_ms\": {\"median\": %.3f, \"p99\": %.3f}, "
                 "\"local_global_ms\": {\"median\": %.3f, \"p99\": %.3f}, "
                 "\"total_ms\": {\"median\": %.3f, \"p99\": %.3f}, "
                 "\"memory_bytes\": {\"awareness\": %zu, \"local\": %zu, \"global\": %zu}}%s\n",
                 r.name.c_str(), r.points, s.total.samples, s.awareness.median_ms,
                 s.awareness.p99_ms, s.local_global.median_ms, s.local_global.p99_ms,
                 s.total.median_ms, s.total.p99_ms, s.memory.awareness_bytes, s.memory.local_bytes,
                 s.memory.global_bytes, last ? "" : ",");
  }
}

/// What --files maps: recorded frames at the engine's defaults but for the resolution, the range
/// and a window that holds every point within range.
struct FilesOptions {
  std::string dir;    ///< an RGB-D frame directory, or a folder of clouds (with `poses`)
  std::string poses;  ///< the clouds' trajectory (TUM or CSV); empty: `dir` is a frame directory
  double resolution_m = 0.02;
  double max_range_m = 2.0;
  double window_z_m = 0.0;  ///< the window's height [m]; 0: 2.5 x the range, as across
  int passes = 5;
  std::string voxels_out;  ///< the first pass's occupied voxels (empty: none)
};

/// CPU time of the calling thread [ms].
double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

/// --files: every frame of the files read first (untimed), then mapped `passes` times, each pass
/// by a fresh engine (so each is the same work, as one pass of a peer library over the files).
/// Each submit() is timed by the wall clock and by the thread's CPU time: on a shared machine the
/// CPU time leaves out the time the thread waited for a core.
int runFiles(const FilesOptions& o) {
  std::unique_ptr<datasets::FrameSource> source;
  if (o.poses.empty()) {
    source = std::make_unique<datasets::FrameDirectorySource>(o.dir);
  } else {
    source = std::make_unique<datasets::CloudSequenceSource>(o.dir, o.poses,
                                                             datasets::CloudSequenceOptions{});
  }
  std::vector<datasets::SourceFrame> frames;
  for (std::size_t i = 0; i < source->size(); ++i) frames.push_back(source->read(i));
  auto cells = [&](double m) {
    return std::max(5, static_cast<int>(std::ceil(m / o.resolution_m / 5.0)) * 5);
  };
  const int across = cells(2.5 * o.max_range_m);
  MapConfig c =
      at(o.resolution_m, {across, across, o.window_z_m > 0.0 ? cells(o.window_z_m) : across});
  c.awareness.max_range_m = o.max_range_m;
  c.awareness.rho_cells = std::max(
      c.awareness.rho_cells, static_cast<int>(std::ceil(o.max_range_m / c.awareness.rho_cell_m)));
  c.sensor.translation_B_m.setZero();  // the frames carry their own sensor pose
  c.sensor.rotation_rpy_deg.setZero();
  c.pipeline.planning_layers = false;  // mapping only, as a peer library maps
  std::vector<double> wall_ms, cpu_ms, stream_ms;
  double points = 0.0;
  std::size_t occupied = 0;
  for (int pass = 0; pass < o.passes; ++pass) {
    MapEngine engine(c);
    double stream_wall = 0.0;  // synchronous: the frames' wall times summed
    if (c.pipeline.threaded) {
      // Every frame queued at once (none dropped): the stream's wall time is the throughput of
      // the two stages running side by side.
      std::vector<datasets::SourceFrame> copies = frames;  // copied untimed
      const SteadyClock::time_point t0 = SteadyClock::now();
      for (datasets::SourceFrame& f : copies) {
        const FrameStatus status =
            std::visit([&](auto& x) { return engine.submit(std::move(x)); }, f);
        if (status != FrameStatus::kAccepted) {
          std::fprintf(stderr, "mlmap_bench: a frame was rejected (%s)\n", toString(status));
          return 1;
        }
      }
      engine.flush();
      stream_ms.push_back(msSince(t0) / static_cast<double>(frames.size()));
      if (engine.stats().frames_dropped != 0) {
        std::fprintf(stderr, "mlmap_bench: frames were dropped\n");
        return 1;
      }
    }
    // Copied untimed (submit() takes the frame): just before it, or all before the pass.
    std::vector<datasets::SourceFrame> ahead;
    if (g_copy_ahead && !c.pipeline.threaded) ahead = frames;
    for (std::size_t i = 0; !c.pipeline.threaded && i < frames.size(); ++i) {
      datasets::SourceFrame f = ahead.empty() ? frames[i] : std::move(ahead[i]);
      const double cpu0 = threadCpuMs();
      const SteadyClock::time_point t0 = SteadyClock::now();
      const FrameStatus status =
          std::visit([&](auto& x) { return engine.submit(std::move(x)); }, f);
      wall_ms.push_back(msSince(t0));
      cpu_ms.push_back(threadCpuMs() - cpu0);
      if (status != FrameStatus::kAccepted) {
        std::fprintf(stderr, "mlmap_bench: a frame was rejected (%s)\n", toString(status));
        return 1;
      }
      stream_wall += wall_ms.back();
    }
    if (!c.pipeline.threaded) stream_ms.push_back(stream_wall / static_cast<double>(frames.size()));
    const EngineStats s = engine.stats();
    points = static_cast<double>(s.points.points_in - s.points.rejected_non_finite) /
             static_cast<double>(std::max<std::uint64_t>(s.frames_mapped, 1));
    if (pass == 0) {
      const std::vector<VoxelIndex> voxels = engine.occupiedVoxels();
      occupied = voxels.size();
      if (!o.voxels_out.empty()) io::writeVoxelText(o.voxels_out, voxels, o.resolution_m);
    }
  }
  std::printf(
      "%s: %zu frames, %.0f valid points / frame, %.3f m, range %.1f m, window %d x %d x %d, "
      "%d passes (a fresh engine each), %zu occupied voxels\n",
      source->describe().c_str(), frames.size(), points, o.resolution_m, o.max_range_m,
      c.local_map.size_cells.x(), c.local_map.size_cells.y(), c.local_map.size_cells.z(), o.passes,
      occupied);
  if (!c.pipeline.threaded) {  // threaded, submit() only queues: its times say nothing
    std::printf(
        "submit() per frame [ms]: wall median %.3f p99 %.3f; thread CPU median %.3f p99 %.3f\n",
        quantile(wall_ms, 0.5), quantile(wall_ms, 0.99), quantile(cpu_ms, 0.5),
        quantile(cpu_ms, 0.99));
  }
  std::printf(
      "stream (%s) [ms]: wall per frame, a pass's wall time / frames: median %.3f "
      "min %.3f max %.3f over %d passes\n",
      c.pipeline.threaded ? "pipeline.threaded, every frame queued" : "synchronous",
      quantile(stream_ms, 0.5), quantile(stream_ms, 0.0), quantile(stream_ms, 1.0), o.passes);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap benchmark: per-frame engine cost (synchronous, one core) on simulated and real depth "
      "frames"};
  int frame_count = 60;
  int repeats = 2;
  std::string real_dir = MLMAP_SHARED_DATA_DIR "/realsense_tabletop";
  std::string json_path;
  std::string only;
  bool stream = false;
  CLI::Option* frames_option =
      app.add_option("--frames", frame_count, "simulated frames (spread over the default flight)")
          ->check(CLI::Range(1, 10000))
          ->capture_default_str();
  app.add_flag("--stream", stream,
               "every frame of the flight in order, as the camera streams them (631 at 10 Hz), "
               "instead of --frames spread over it (where the vehicle moves 1 m between frames)")
      ->excludes(frames_option);
  app.add_option("--repeats", repeats, "passes over the frames")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  app.add_option("--real", real_dir, "RGB-D frame folder ('' to skip)")->capture_default_str();
  app.add_option("--json", json_path, "also write the figures as JSON");
  app.add_option("--only", only, "run only the cases whose name contains this text (e.g. '0.1 m')");
  app.add_option("--awareness-threads", g_awareness_threads,
                 "awareness.num_threads of every case: threads carving a frame (the caller's "
                 "included); with 2 or more the thread CPU time printed is the caller's only")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_flag("--threaded", g_threaded,
               "pipeline.threaded: the awareness and local-global stages on threads of their own; "
               "every frame is queued (none dropped) and the stream's wall time per frame printed "
               "(with --files: no per-frame figures)");
  app.add_option("--batch-queue", g_batch_queue,
                 "pipeline.batch_queue_capacity: --threaded, batches the first thread may be ahead")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  bool no_planning = false;
  app.add_flag("--no-planning", no_planning,
               "pipeline.planning_layers off (the mapping alone, as --files maps)");
  int lidar_scans = 60;
  app.add_option("--lidar-scans", lidar_scans,
                 "consecutive 10 Hz scans of the simulated 360-degree LiDAR (128 x 640 rays, 30 m) "
                 "from the start of the flight, mapped at 0.1 m (0: skip)")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();
  FilesOptions files;
  auto* files_option =
      app.add_option("--files", files.dir,
                     "map these files instead (an RGB-D frame directory, or a folder "
                     "of PCD / PLY clouds with --poses) at the engine's defaults, "
                     "and print each frame's wall and thread CPU time");
  app.add_option("--poses", files.poses, "--files: the clouds' trajectory (TUM or CSV)")
      ->needs(files_option);
  app.add_option("--resolution", files.resolution_m, "--files: voxel size [m]")
      ->needs(files_option)
      ->check(CLI::Range(0.01, 2.0))
      ->capture_default_str();
  app.add_option("--max-range", files.max_range_m,
                 "--files: maximum range [m]; the window is 2.5 x it across")
      ->needs(files_option)
      ->check(CLI::Range(0.1, 400.0))
      ->capture_default_str();
  app.add_option("--window-z", files.window_z_m,
                 "--files: the window's height [m] (0: 2.5 x the range)")
      ->needs(files_option)
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--passes", files.passes, "--files: passes over the files, each by a fresh engine")
      ->needs(files_option)
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--voxels-out", files.voxels_out,
                 "--files: write the first pass's occupied voxels here (as mlmap_replay's "
                 "occupied_voxels.txt)")
      ->needs(files_option);
  app.add_flag("--copy-ahead", g_copy_ahead,
               "synchronous: copy a pass's frames before it, as --threaded queues them (not each "
               "just before its submit(), which leaves the image in the cache)");
  CLI11_PARSE(app, argc, argv);
  g_planning_layers = !no_planning;
  if (!files.dir.empty()) {
    try {
      return runFiles(files);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "mlmap_bench: %s\n", e.what());
      return 1;
    }
  }

  // Render the simulated frames once (the simulator's cost is not measured).
  const datasets::Scenario scenario = datasets::defaultScenario();
  const sim::DepthCamera camera(scenario.camera);
  const Transform T_B_S = SensorConfig{}.T_B_S();
  std::vector<DepthFrame> sim_frames;
  const int total = eval::frameCount(scenario);
  if (stream) frame_count = total;
  for (int i = 0; i < frame_count; ++i) {
    const double t = eval::frameTime(scenario, (i * total) / frame_count);
    DepthFrame f;
    f.T_W_B = scenario.trajectory.poseAt(t);
    camera.render(scenario.world, f.T_W_B * T_B_S, t, &f);
    sim_frames.push_back(std::move(f));
  }
  MapConfig sampled = at(0.2, {95, 95, 35});
  sampled.awareness.sample_count = 500;
  const std::vector<Case> sim_cases = {
      {"sim 640x480, 0.2 m, 95x95x35 (T2)", at(0.2, {95, 95, 35})},
      {"sim 640x480, 0.1 m, 165x165x75", at(0.1, {165, 165, 75})},
      {"sim 640x480, 0.2 m, 500 samples", sampled},
  };
  std::FILE* json = json_path.empty() ? nullptr : std::fopen(json_path.c_str(), "w");
  if (json != nullptr) std::fprintf(json, "[\n");
  std::printf("%-34s %8s %15s %15s %15s %15s\n", "", "points", "awareness ms", "local-global ms",
              "total ms", "memory MB");
  std::printf("%-34s %8s %7s %7s %7s %7s %7s %7s %7s %7s\n", "case", "/frame", "median", "p99",
              "median", "p99", "median", "p99", "local", "other");
  std::vector<Row> rows;
  auto selected = [&](const std::string& name) { return name.find(only) != std::string::npos; };
  for (const Case& c : sim_cases) {
    if (!selected(c.name)) continue;
    rows.push_back(run(c, sim_frames, repeats));
    print(rows.back(), nullptr, false);
  }
  if (!real_dir.empty() && std::filesystem::exists(real_dir)) {
    const datasets::FrameDirectory dir(real_dir);
    std::vector<DepthFrame> real;
    for (std::size_t i = 0; i < dir.size(); ++i) real.push_back(dir.read(i));
    for (double res : {0.05, 0.02}) {
      MapConfig c = at(res, {200, 200, 200});
      c.sensor.translation_B_m.setZero();
      c.sensor.rotation_rpy_deg.setZero();
      c.log_odds.hit = 0.6;
      char name[64];
      std::snprintf(name, sizeof(name), "real RealSense 640x480, %.2f m", res);
      if (!selected(name)) continue;
      rows.push_back(run({name, c}, real, repeats));
      print(rows.back(), nullptr, false);
    }
  }
  // The LiDAR as mlmap_replay maps it with tests/benchmarks/replay_lidar_30m.yaml: a window that
  // holds every hit within 30 m, no planning layers (issue 27: <= 15 ms median a scan).
  const std::string lidar_name = "sim LiDAR 128x640, 0.1 m, 30 m";
  if (lidar_scans > 0 && selected(lidar_name)) {
    MapConfig c = at(0.1, {750, 750, 75});
    c.awareness.max_range_m = 30.0;
    c.awareness.rho_cells = 300;
    c.sensor.translation_B_m.setZero();
    c.pipeline.planning_layers = false;
    const sim::Lidar lidar;
    std::vector<PointCloudFrame> scans;
    for (int i = 0; i < std::min(lidar_scans, total); ++i) {
      const double t = eval::frameTime(scenario, i);
      PointCloudFrame f;
      f.T_W_B = scenario.trajectory.poseAt(t);
      lidar.render(scenario.world, f.T_W_B, t, &f);
      scans.push_back(std::move(f));
    }
    rows.push_back(run({lidar_name, c}, scans, repeats));
    print(rows.back(), nullptr, false);
  }
  std::printf("\nplanning layers after each frame (ms; snapshot = window copy + publish):\n");
  std::printf("%-34s %15s %15s %15s %8s\n", "case", "snapshot", "2D grid", "ESDF", "ESDF");
  std::printf("%-34s %7s %7s %7s %7s %7s %7s %8s\n", "", "median", "p99", "median", "p99", "median",
              "p99", "updates");
  for (const Row& r : rows) {
    std::printf("%-34s %7.3f %7.3f %7.3f %7.3f %7.2f %7.2f %8zu\n", r.name.c_str(),
                quantile(r.snapshot_ms, 0.5), quantile(r.snapshot_ms, 0.99),
                quantile(r.grid_ms, 0.5), quantile(r.grid_ms, 0.99), quantile(r.esdf_ms, 0.5),
                quantile(r.esdf_ms, 0.99), r.esdf_ms.size());
  }
  std::printf("\nwhole stream, wall time per frame (%s):\n",
              g_threaded ? "pipeline.threaded: every frame queued, from the first submit() to the "
                           "last frame mapped"
                         : "synchronous: the submit() times summed");
  for (const Row& r : rows) {
    std::printf(
        "%-34s %7.3f ms per frame\n", r.name.c_str(),
        r.stream_ms / static_cast<double>(std::max<std::uint64_t>(r.stats.frames_mapped, 1)));
  }
  std::printf("peak resident memory of the benchmark process: %.0f MB\n",
              static_cast<double>(eval::peakRssBytes()) / (1024.0 * 1024.0));
  if (json != nullptr) {
    for (std::size_t i = 0; i < rows.size(); ++i) print(rows[i], json, i + 1 == rows.size());
    std::fprintf(json, "]\n");
    std::fclose(json);
  }
  return 0;
}
