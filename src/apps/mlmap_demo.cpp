// mlmap_demo: flies the engine through the built-in simulated room (or a folder of real RGB-D
// frames) and writes pictures of the map, its accuracy against ground truth, timings and memory.

#include "mlmap/eval/run_outputs.h"
#include "mlmap/config/config_yaml.h"
#include "mlmap/datasets/frame_source.h"
#include "mlmap/pipeline/map_engine.h"

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>

namespace {

using namespace mlmap;

/// The command line of mlmap_demo.
struct Options {
  std::string config_path;    ///< --config: engine configuration YAML (empty: defaults)
  std::string scenario_path;  ///< --scenario: simulated world + flight (empty: the built-in room)
  std::string frames_dir;     ///< --frames: map recorded RGB-D frames instead of the simulator
  std::string out_dir = "mlmap_demo_out";  ///< --out
  double resolution_m = 0.0;               ///< --resolution (0: the kind's default)
  int max_frames = 0;                      ///< --max-frames (0: all)
  double noise = -1.0;        ///< --noise: depth noise coefficient [1/m] (< 0: the scenario's)
  std::string save_map_path;  ///< --save-map (empty: not saved)
  bool overwrite = false;     ///< --overwrite: --save-map may replace an existing map
  bool threaded = false;      ///< --threaded
  bool print_config = false;  ///< --print-config
};

/// Adds every option of mlmap_demo to `app`.
void addOptions(CLI::App& app, Options& o) {
  app.add_option("--config", o.config_path,
                 "engine configuration YAML (default: built-in defaults, "
                 "see config/mlmap.yaml)")
      ->check(CLI::ExistingFile);
  app.add_option("--scenario", o.scenario_path,
                 "simulated world + flight YAML (default: the "
                 "built-in room, config/worlds/default_room.yaml)")
      ->check(CLI::ExistingFile);
  app.add_option("--frames", o.frames_dir,
                 "map a folder of RGB-D frames (frame-*.depth.png + "
                 "pose + intrinsics) instead of the simulator")
      ->check(CLI::ExistingDirectory);
  app.add_option("--out", o.out_dir, "output folder")->capture_default_str();
  app.add_option("--resolution", o.resolution_m,
                 "voxel size [m]; the local map keeps ~19x19x7 m "
                 "(default: 0.1 in the simulator, 0.02 for frames)")
      ->check(CLI::Range(0.01, 2.0));
  app.add_option("--max-frames", o.max_frames, "stop after N frames (0: all)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--noise", o.noise,
                 "simulated depth noise: sigma = K * z^2 [1/m] (default: the scenario's)")
      ->check(CLI::Range(0.0, 0.1));
  app.add_option("--save-map", o.save_map_path,
                 "save the final map (local + global layers) to this mlmap map file; "
                 "mlmap_map_tool converts it to PLY / PCD / PGM + YAML / OctoMap .bt");
  app.add_flag("--overwrite", o.overwrite, "--save-map may replace an existing mlmap map");
  app.add_flag("--threaded", o.threaded,
               "run the awareness and local-global stages on two threads");
  app.add_flag("--print-config", o.print_config,
               "print the effective engine configuration and exit");
}

/// The engine's messages to the log.
void logEngineMessage(LogLevel level, const std::string& message) {
  if (level == LogLevel::kError) {
    spdlog::error("{}", message);
  } else {
    spdlog::warn("{}", message);
  }
}

/// Maps the frames of --frames into `engine`.
void mapFrames(const Options& o, MapEngine& engine, eval::MapOutputs* outputs) {
  const datasets::FrameDirectorySource frames(o.frames_dir);
  const std::size_t n =
      o.max_frames > 0 ? std::min<std::size_t>(frames.size(), o.max_frames) : frames.size();
  spdlog::info("mapping {} frames of {} at {} m", n, o.frames_dir,
               engine.config().local_map.resolution_m);
  eval::ProgressBar bar("mapping");
  for (std::size_t i = 0; i < n; ++i) {
    datasets::SourceFrame frame = frames.read(i);
    outputs->trajectory_W.push_back(datasets::bodyPoseOf(frame).translation());
    std::visit([&engine](auto& f) { engine.submit(std::move(f)); }, frame);
    bar.update(static_cast<int>(i + 1), static_cast<int>(n));
  }
  engine.flush();
  outputs->source = o.frames_dir;
  // Frame-directory worlds are the first camera's optical frame (z forward, y down).
  outputs->optical_world = true;
}

/// Flies the simulator through --scenario (or the built-in room) into `engine` and scores it.
eval::ScoredFlight flySimulator(const Options& o, MapEngine& engine) {
  datasets::Scenario scenario = o.scenario_path.empty()
                                    ? datasets::defaultScenario()
                                    : datasets::loadScenarioYaml(o.scenario_path);
  if (o.noise >= 0.0) scenario.camera.noise_coeff_per_m = o.noise;
  eval::FlightOptions options;
  if (o.max_frames > 0) options.max_frames = o.max_frames;
  eval::ProgressBar bar("flying ");
  options.progress = [&](int done, int total) { bar.update(done, total); };
  spdlog::info("flying the {} scenario: {} frames at {} Hz, {} m voxels",
               o.scenario_path.empty() ? "built-in room" : o.scenario_path,
               std::min(eval::frameCount(scenario), options.max_frames), scenario.frame_rate_hz,
               engine.config().local_map.resolution_m);
  return eval::flyAndScore(scenario, engine, options);
}

/// Maps the frames or flies the simulator, then writes the outputs and the summary.
void mapAndReport(const Options& o, const MapConfig& config) {
  MapEngine engine(config, logEngineMessage);
  const double res = config.local_map.resolution_m;
  eval::MapOutputs outputs;
  outputs.out_dir = o.out_dir;
  eval::ScoredFlight scored;
  if (!o.frames_dir.empty()) {
    mapFrames(o, engine, &outputs);
  } else {
    scored = flySimulator(o, engine);
    outputs.trajectory_W = scored.flight.trajectory_W;
    outputs.scored = &scored;
    outputs.source = o.scenario_path.empty() ? "built-in room" : o.scenario_path;
  }
  const EngineStats s = engine.stats();
  const std::vector<std::string> written =
      eval::writeMapOutputs(outputs, s, engine.occupiedVoxels(), res);
  eval::printSummary(s, res, outputs.scored != nullptr ? &scored.accuracy : nullptr);
  std::string names;
  for (const std::string& name : written) names += (names.empty() ? "" : ", ") + name;
  std::printf("\n  wrote %s/{%s}\n", o.out_dir.c_str(), names.c_str());
  if (!o.save_map_path.empty()) eval::saveMap(engine, o.save_map_path);
}

/// Runs the demo the options describe; returns the exit status (1: an error, 2: an invalid
/// configuration, both logged).
int run(const Options& o) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("mlmap"));  // stdout carries the results
  try {
    MapConfig config = eval::runConfig(
        o.config_path,
        o.frames_dir.empty() ? eval::DataKind::kSimulator : eval::DataKind::kFrameDirectory,
        o.resolution_m);
    if (o.threaded) config.pipeline.threaded = true;
    if (o.print_config) {
      std::cout << config::toYaml(config);
      return 0;
    }
    const std::vector<std::string> problems = config.validate();
    if (!problems.empty()) {
      for (const auto& p : problems) spdlog::error("{}", p);
      return 2;
    }
    std::filesystem::create_directories(o.out_dir);
    if (!o.save_map_path.empty())
      eval::checkSaveMapTarget(o.save_map_path, o.overwrite);  // before the flight
    mapAndReport(o, config);
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap demo: maps a simulated flight through a 30 x 20 m room (default) or a folder of\n"
      "RGB-D frames, and writes map pictures, accuracy, timings and memory to --out."};
  Options options;
  addOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  return run(options);
}
