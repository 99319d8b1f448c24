// mlmap_demo: flies the engine through the built-in simulated room (or a folder of real RGB-D
// frames) and writes pictures of the map, its accuracy against ground truth, timings and memory.

#include "mlmap/eval/sim_flight.h"
#include "mlmap/io/config_yaml.h"
#include "mlmap/io/frame_directory.h"
#include "mlmap/io/map_file.h"
#include "mlmap/io/map_image.h"
#include "mlmap/pipeline/map_engine.h"

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace {

using namespace mlmap;

double megabytes(std::size_t bytes) { return static_cast<double>(bytes) / 1e6; }

/// A one-line progress bar on stderr (redrawn in place on a terminal, every 10 % otherwise).
class ProgressBar {
 public:
  explicit ProgressBar(std::string label) : label_(std::move(label)), tty_(isatty(2) != 0) {}
  void update(int done, int total) {
    if (total <= 0) return;
    const int percent = 100 * done / total;
    if (!tty_ && percent / 10 == last_decile_ && done != total) return;
    last_decile_ = percent / 10;
    constexpr int kWidth = 30;
    const int filled = kWidth * done / total;
    std::fprintf(stderr, "%s%s [%s%s] %3d%% %d/%d frames%s", tty_ ? "\r" : "", label_.c_str(),
                 std::string(static_cast<std::size_t>(filled), '#').c_str(),
                 std::string(static_cast<std::size_t>(kWidth - filled), '.').c_str(), percent, done,
                 total, (tty_ && done != total) ? "" : "\n");
    std::fflush(stderr);
  }

 private:
  std::string label_;
  bool tty_;
  int last_decile_ = -1;
};

/// Sets the voxel size and keeps the local map near the paper's 19 x 19 x 7 m (<= 250 cells).
void setResolution(MapConfig* c, double resolution_m) {
  c->local_map.resolution_m = resolution_m;
  auto cells = [&](double extent_m) {
    const double n = std::min(extent_m / resolution_m, 250.0);
    return std::max(5, static_cast<int>(std::lround(n / 5.0)) * 5);
  };
  c->local_map.size_cells = {cells(19.0), cells(19.0), cells(7.0)};
}

/// Voxel centres for the pictures, turned by `R_display_W` (identity, or optical -> FLU).
io::VoxelList voxelList(const std::vector<VoxelIndex>& voxels, double res,
                        const Eigen::Matrix3d& R_display_W) {
  io::VoxelList list{res, {}};
  list.centers_W.reserve(voxels.size());
  for (const VoxelIndex& v : voxels) list.centers_W.push_back(R_display_W * voxelCenter(v, res));
  return list;
}

std::string json(const TimingSummary& t) {
  std::ostringstream o;
  o << "{\"median_ms\": " << t.median_ms << ", \"p99_ms\": " << t.p99_ms
    << ", \"mean_ms\": " << t.mean_ms << ", \"max_ms\": " << t.max_ms
    << ", \"frames\": " << t.samples << "}";
  return o.str();
}

void printSummary(const EngineStats& s, double res) {
  std::printf("\n  frames mapped        %llu (rejected: pose %llu, order %llu, empty %llu; dropped %llu)\n",
              static_cast<unsigned long long>(s.frames_mapped),
              static_cast<unsigned long long>(s.rejected_invalid_pose),
              static_cast<unsigned long long>(s.rejected_out_of_order),
              static_cast<unsigned long long>(s.rejected_empty),
              static_cast<unsigned long long>(s.frames_dropped));
  std::printf("  voxel size           %.3f m\n", res);
  std::printf("  per frame [ms]       median    p99\n");
  std::printf("    awareness          %7.2f %7.2f\n", s.awareness.median_ms, s.awareness.p99_ms);
  std::printf("    local-global       %7.2f %7.2f\n", s.local_global.median_ms, s.local_global.p99_ms);
  std::printf("    total              %7.2f %7.2f\n", s.total.median_ms, s.total.p99_ms);
  std::printf("  memory [MB]          awareness %.1f, local %.1f, global %.2f (%zu occupied voxels in %zu submaps)\n",
              megabytes(s.memory.awareness_bytes), megabytes(s.memory.local_bytes),
              megabytes(s.memory.global_bytes), s.global_voxels, s.global_submaps);
  std::printf("  points               %llu in, %llu without data/NaN, %llu too close, %llu beyond range\n",
              static_cast<unsigned long long>(s.points.points_in),
              static_cast<unsigned long long>(s.points.rejected_non_finite),
              static_cast<unsigned long long>(s.points.rejected_too_close),
              static_cast<unsigned long long>(s.points.beyond_max_range));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap demo: maps a simulated flight through a 30 x 20 m room (default) or a folder of\n"
      "RGB-D frames, and writes map pictures, accuracy, timings and memory to --out."};
  std::string config_path;
  std::string scenario_path;
  std::string frames_dir;
  std::string out_dir = "mlmap_demo_out";
  double resolution_m = 0.0;
  int max_frames = 0;
  bool threaded = false;
  bool print_config = false;
  double noise = -1.0;
  std::string save_map_path;
  app.add_option("--config", config_path, "engine configuration YAML (default: built-in defaults, "
                                          "see config/mlmap.yaml)")->check(CLI::ExistingFile);
  app.add_option("--scenario", scenario_path, "simulated world + flight YAML (default: the "
                                              "built-in room, config/worlds/default_room.yaml)")
      ->check(CLI::ExistingFile);
  app.add_option("--frames", frames_dir, "map a folder of RGB-D frames (frame-*.depth.png + "
                                         "pose + intrinsics) instead of the simulator")
      ->check(CLI::ExistingDirectory);
  app.add_option("--out", out_dir, "output folder")->capture_default_str();
  app.add_option("--resolution", resolution_m, "voxel size [m]; the local map keeps ~19x19x7 m "
                                               "(default: 0.1 in the simulator, 0.02 for frames)")
      ->check(CLI::Range(0.01, 2.0));
  app.add_option("--max-frames", max_frames, "stop after N frames (0: all)")->check(CLI::NonNegativeNumber);
  app.add_option("--noise", noise, "simulated depth noise: sigma = K * z^2 [1/m] (default: the scenario's)")
      ->check(CLI::Range(0.0, 0.1));
  app.add_option("--save-map", save_map_path,
                 "save the final map (local + global layers) to this mlmap map file; "
                 "mlmap_map_tool converts it to PLY / PCD / PGM + YAML / OctoMap .bt");
  app.add_flag("--threaded", threaded, "run the awareness and local-global stages on two threads");
  app.add_flag("--print-config", print_config, "print the effective engine configuration and exit");
  CLI11_PARSE(app, argc, argv);
  spdlog::set_default_logger(spdlog::stderr_color_mt("mlmap"));  // stdout carries the results

  try {
    MapConfig config = config_path.empty() ? MapConfig{} : io::loadConfigYaml(config_path);
    const bool use_frames = !frames_dir.empty();
    if (resolution_m > 0.0 || config_path.empty()) {
      setResolution(&config, resolution_m > 0.0 ? resolution_m : (use_frames ? 0.02 : 0.1));
    }
    if (threaded) config.pipeline.threaded = true;
    if (use_frames) {
      // The frame poses are camera poses: the camera is the body.
      config.sensor.translation_B_m.setZero();
      config.sensor.rotation_rpy_deg.setZero();
      if (config_path.empty()) config.log_odds.hit = 0.6;  // Table 1: low-precision sensor
    }
    if (print_config) {
      std::cout << io::toYaml(config);
      return 0;
    }
    const std::vector<std::string> problems = config.validate();
    if (!problems.empty()) {
      for (const auto& p : problems) spdlog::error("{}", p);
      return 2;
    }
    std::filesystem::create_directories(out_dir);
    if (!save_map_path.empty()) {  // refuse a bad target before the flight, not after it
      const std::filesystem::path target(save_map_path);
      const std::filesystem::path folder = target.has_parent_path() ? target.parent_path() : ".";
      if (!std::filesystem::is_directory(folder)) {
        throw std::runtime_error("--save-map: folder '" + folder.string() + "' does not exist");
      }
    }
    MapEngine engine(config, [](LogLevel level, const std::string& message) {
      if (level == LogLevel::kError) {
        spdlog::error("{}", message);
      } else {
        spdlog::warn("{}", message);
      }
    });
    const double res = config.local_map.resolution_m;
    io::MapImageOptions image_options;
    std::string source;
    eval::Accuracy accuracy;
    bool have_truth = false;
    io::VoxelList truth_list{res, {}};

    if (use_frames) {
      const io::FrameDirectory frames(frames_dir);
      const std::size_t n = max_frames > 0 ? std::min<std::size_t>(frames.size(), max_frames)
                                           : frames.size();
      spdlog::info("mapping {} frames of {} at {} m", n, frames_dir, res);
      ProgressBar bar("mapping");
      for (std::size_t i = 0; i < n; ++i) {
        DepthFrame frame = frames.read(i);
        image_options.trajectory_W.push_back(frame.T_W_B.translation());
        engine.submit(std::move(frame));
        bar.update(static_cast<int>(i + 1), static_cast<int>(n));
      }
      engine.flush();
      source = frames_dir;
    } else {
      io::Scenario scenario =
          scenario_path.empty() ? io::defaultScenario() : io::loadScenarioYaml(scenario_path);
      if (noise >= 0.0) scenario.camera.noise_coeff_per_m = noise;
      eval::FlightOptions options;
      if (max_frames > 0) options.max_frames = max_frames;
      ProgressBar bar("flying ");
      options.progress = [&](int done, int total) { bar.update(done, total); };
      spdlog::info("flying the {} scenario: {} frames at {} Hz, {} m voxels",
                   scenario_path.empty() ? "built-in room" : scenario_path,
                   std::min(eval::frameCount(scenario), options.max_frames), scenario.frame_rate_hz, res);
      const eval::FlightResult flight = eval::flyScenario(scenario, engine, options);
      image_options.trajectory_W = flight.trajectory_W;
      const std::vector<VoxelIndex> mapped = engine.occupiedVoxels();
      accuracy = eval::scoreOccupancy(mapped, flight.observed_truth, scenario.world, res);
      have_truth = true;
      // Truth for the picture: observed true voxels plus mapped ones that touch a solid.
      eval::VoxelSet truth = flight.observed_truth;
      for (const VoxelIndex& v : mapped) {
        if (eval::touchesSolid(scenario.world, v, res)) truth.insert(v);
      }
      for (const VoxelIndex& v : truth) truth_list.centers_W.push_back(voxelCenter(v, res));
      source = scenario_path.empty() ? "built-in room" : scenario_path;
    }

    const EngineStats s = engine.stats();
    const std::vector<VoxelIndex> occupied = engine.occupiedVoxels();
    // Frame-directory worlds are the first camera's optical frame (z forward, y down): show them
    // in that camera's FLU frame so that "top" looks down on the scene. The rotation is exact, so
    // the voxels stay on one grid.
    Eigen::Matrix3d R_display_W = Eigen::Matrix3d::Identity();
    if (use_frames) R_display_W << 0, 0, 1, -1, 0, 0, 0, -1, 0;
    for (Eigen::Vector3d& p : image_options.trajectory_W) p = R_display_W * p;
    const io::VoxelList list = voxelList(occupied, res, R_display_W);
    const std::string what = "mlmap, " + std::to_string(occupied.size()) + " occupied voxels";
    image_options.title = what + " - top view";
    io::writePng(out_dir + "/map_top.png", io::renderTopDown(list, image_options));
    image_options.title = what + " - side view";
    io::writePng(out_dir + "/map_side.png", io::renderSide(list, image_options));
    if (have_truth) {
      char title[160];
      std::snprintf(title, sizeof(title), "occupied voxels vs ground truth, F1 %.3f (report.json)",
                    accuracy.f1);
      image_options.title = title;
      io::writePng(out_dir + "/accuracy_top.png",
                   io::renderComparison(list, truth_list, image_options));
    }

    std::ofstream report(out_dir + "/report.json");
    report << "{\n  \"source\": \"" << source << "\",\n  \"resolution_m\": " << res
           << ",\n  \"frames_mapped\": " << s.frames_mapped
           << ",\n  \"frames_dropped\": " << s.frames_dropped
           << ",\n  \"frames_rejected\": "
           << s.rejected_invalid_pose + s.rejected_out_of_order + s.rejected_empty + s.rejected_bad_image
           << ",\n  \"occupied_voxels\": " << occupied.size()
           << ",\n  \"timing\": {\"awareness\": " << json(s.awareness)
           << ", \"local_global\": " << json(s.local_global) << ", \"total\": " << json(s.total)
           << "},\n  \"memory_bytes\": {\"awareness\": " << s.memory.awareness_bytes
           << ", \"local\": " << s.memory.local_bytes << ", \"global\": " << s.memory.global_bytes
           << "},\n  \"global_map\": {\"occupied_voxels\": " << s.global_voxels
           << ", \"submaps\": " << s.global_submaps << "},\n  \"local_map\": {\"shifts\": "
           << s.local.shifts << ", \"submaps_retired\": " << s.local.submaps_retired
           << ", \"submaps_restored\": " << s.local.submaps_restored
           << "},\n  \"points\": {\"in\": " << s.points.points_in
           << ", \"no_data_or_non_finite\": " << s.points.rejected_non_finite
           << ", \"too_close\": " << s.points.rejected_too_close
           << ", \"beyond_max_range\": " << s.points.beyond_max_range
           << ", \"hit_voxels\": " << s.points.hit_voxels
           << ", \"free_voxels\": " << s.points.free_voxels << "}";
    if (have_truth) {
      report << ",\n  \"accuracy\": {\"precision\": " << accuracy.precision
             << ", \"recall\": " << accuracy.recall << ", \"f1\": " << accuracy.f1
             << ", \"mapped\": " << accuracy.mapped
             << ", \"observed_truth\": " << accuracy.observed_truth << "}";
    }
    report << "\n}\n";
    if (!report) throw std::runtime_error(out_dir + "/report.json: cannot write");

    printSummary(s, res);
    if (have_truth) {
      std::printf("  accuracy             precision %.4f, recall %.4f, F1 %.4f (%zu mapped, %zu observed true voxels)\n",
                  accuracy.precision, accuracy.recall, accuracy.f1, accuracy.mapped,
                  accuracy.observed_truth);
    }
    std::printf("\n  wrote %s/{map_top.png, map_side.png%s, report.json}\n", out_dir.c_str(),
                have_truth ? ", accuracy_top.png" : "");
    if (!save_map_path.empty()) {
      const auto save_start = std::chrono::steady_clock::now();
      io::saveMapFile(engine.exportState(), save_map_path);
      const double save_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - save_start).count();
      std::printf("  saved the map to %s (%ju bytes, %.1f ms)\n", save_map_path.c_str(),
                  static_cast<std::uintmax_t>(std::filesystem::file_size(save_map_path)), save_ms);
    }
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
