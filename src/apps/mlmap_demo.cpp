// mlmap_demo: flies the engine through the built-in simulated room (or a folder of real RGB-D
// frames) and writes pictures of the map, its accuracy against ground truth, timings and memory.

#include "mlmap/eval/run_outputs.h"
#include "mlmap/config/config_yaml.h"
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/pipeline/map_engine.h"

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <iostream>

using namespace mlmap;

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
    const bool use_frames = !frames_dir.empty();
    MapConfig config = eval::runConfig(
        config_path, use_frames ? eval::DataKind::kFrameDirectory : eval::DataKind::kSimulator,
        resolution_m);
    if (threaded) config.pipeline.threaded = true;
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
    if (!save_map_path.empty()) eval::checkSaveMapTarget(save_map_path);  // before the flight
    MapEngine engine(config, [](LogLevel level, const std::string& message) {
      if (level == LogLevel::kError) {
        spdlog::error("{}", message);
      } else {
        spdlog::warn("{}", message);
      }
    });
    const double res = config.local_map.resolution_m;
    eval::MapOutputs outputs;
    outputs.out_dir = out_dir;
    eval::ScoredFlight scored;

    if (use_frames) {
      const io::FrameDirectory frames(frames_dir);
      const std::size_t n = max_frames > 0 ? std::min<std::size_t>(frames.size(), max_frames)
                                           : frames.size();
      spdlog::info("mapping {} frames of {} at {} m", n, frames_dir, res);
      eval::ProgressBar bar("mapping");
      for (std::size_t i = 0; i < n; ++i) {
        DepthFrame frame = frames.read(i);
        outputs.trajectory_W.push_back(frame.T_W_B.translation());
        engine.submit(std::move(frame));
        bar.update(static_cast<int>(i + 1), static_cast<int>(n));
      }
      engine.flush();
      outputs.source = frames_dir;
      // Frame-directory worlds are the first camera's optical frame (z forward, y down).
      outputs.optical_world = true;
    } else {
      io::Scenario scenario =
          scenario_path.empty() ? io::defaultScenario() : io::loadScenarioYaml(scenario_path);
      if (noise >= 0.0) scenario.camera.noise_coeff_per_m = noise;
      eval::FlightOptions options;
      if (max_frames > 0) options.max_frames = max_frames;
      eval::ProgressBar bar("flying ");
      options.progress = [&](int done, int total) { bar.update(done, total); };
      spdlog::info("flying the {} scenario: {} frames at {} Hz, {} m voxels",
                   scenario_path.empty() ? "built-in room" : scenario_path,
                   std::min(eval::frameCount(scenario), options.max_frames), scenario.frame_rate_hz, res);
      scored = eval::flyAndScore(scenario, engine, options);
      outputs.trajectory_W = scored.flight.trajectory_W;
      outputs.scored = &scored;
      outputs.source = scenario_path.empty() ? "built-in room" : scenario_path;
    }

    const EngineStats s = engine.stats();
    const std::vector<std::string> written =
        eval::writeMapOutputs(outputs, s, engine.occupiedVoxels(), res);
    eval::printSummary(s, res, outputs.scored != nullptr ? &scored.accuracy : nullptr);
    std::string names;
    for (const std::string& name : written) names += (names.empty() ? "" : ", ") + name;
    std::printf("\n  wrote %s/{%s}\n", out_dir.c_str(), names.c_str());
    if (!save_map_path.empty()) eval::saveMap(engine, save_map_path);
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
