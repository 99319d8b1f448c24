// mlmap_replay: runs the engine offline on recorded data (an RGB-D frame directory, or PCD / PLY
// point clouds with a trajectory file) or on the simulator, and writes the demo's outputs plus
// the occupied voxels as text and per-frame statistics as JSON.

#include "mlmap/core/stopwatch.h"
#include "mlmap/eval/json_output.h"
#include "mlmap/eval/recorded_run.h"
#include "mlmap/eval/run_outputs.h"
#include "mlmap/map_io/map_file.h"
#include "mlmap/datasets/cloud_sequence.h"
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/datasets/frame_prefetcher.h"
#include "mlmap/datasets/frame_source.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/voxel_text.h"
#include "mlmap/pipeline/map_engine.h"
#if MLMAP_HAVE_BAG
#include "mlmap/bag/bag_frame_source.h"
#include "mlmap/bag/bag_reader.h"
#endif

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <future>
#include <optional>
#include <thread>

namespace {

using namespace mlmap;

/// The command line of mlmap_replay.
struct Options {
  std::string frames_dir;      ///< --frames: an RGB-D frame directory
  std::string clouds_dir;      ///< --clouds: PCD / PLY clouds, with poses_path
  std::string poses_path;      ///< --poses: the clouds' trajectory (TUM or CSV)
  std::string extrinsic_text;  ///< --extrinsic: the sensor in the pose frame, "x y z qx qy qz qw"
  std::string scenario_path;   ///< --scenario: simulator world + flight (empty: the built-in room)
  std::string bag_path;        ///< --bag: a ROS 2 bag (folder with metadata.yaml, .mcap or .db3)
#if MLMAP_HAVE_BAG
  std::vector<std::string> cloud_topics;  ///< --cloud-topic (empty: chosen from the bag)
  std::string depth_topic;                ///< --depth-topic
  std::string camera_info_topic;          ///< --camera-info-topic
  std::string pose_topic;                 ///< --pose-topic (PoseStamped or Odometry)
  std::string world_frame;  ///< --world-frame: poses from /tf, this frame to --body-frame
  std::string body_frame = "base_link";  ///< --body-frame
#endif
  std::string config_path;    ///< --config: engine configuration YAML (empty: defaults)
  double resolution_m = 0.0;  ///< --resolution (0: the config's, or the kind's default)
  double max_range_m = 0.0;   ///< --max-range (0: the config's)
  int awareness_threads = 0;  ///< --awareness-threads (0: not given, see defaultAwarenessThreads())
  int max_frames = 0;         ///< --max-frames (0: all)
  std::string out_dir = "mlmap_replay_out";  ///< --out
  std::string voxels_out;                    ///< --voxels-out (empty: OUT/occupied_voxels.txt)
  std::string stats_out;                     ///< --stats-out (empty: OUT/stats.json)
  std::string save_map_path;                 ///< --save-map (empty: not saved)
  std::string grid_out;    ///< --grid-out: the final 2D grid's PGM + YAML base (empty: none)
  int reader_threads = 1;  ///< --reader-threads: 1 reads ahead on a thread, 0 in turn
  bool overwrite = false;  ///< --overwrite: --save-map may replace an existing map
};

/// Frames the reader thread keeps decoded ahead of the mapping: enough to ride out a slow file,
/// few enough to hold little memory (a 640 x 480 depth image or an 80k-point cloud is ~1 MB).
constexpr std::size_t kReadAheadFrames = 4;

constexpr const char* kAbout =
    "mlmap_replay: runs the mapping engine offline on recorded data and writes the map.\n"
    "Sources (one of):\n"
    "  --frames DIR              an RGB-D frame directory (frame-N.depth.png, frame-N.pose.txt,\n"
    "                            intrinsics.K.txt; the poses are the camera's)\n"
    "  --clouds DIR --poses FILE PCD (ascii, binary, binary_compressed) / PLY (ascii, binary\n"
    "                            little / big endian) clouds with a TUM or CSV trajectory\n"
    "  --bag PATH                a ROS 2 bag (a folder with metadata.yaml, or one .mcap / .db3\n"
    "                            file): PointCloud2, or a depth Image with its CameraInfo; the\n"
    "                            pose from PoseStamped / Odometry or /tf (--world-frame)\n"
    "  (none)                    the simulator: the demo's built-in room flight\n"
    "Clouds whose file names are time stamps (1305031102.175304.pcd, or integer\n"
    "nanoseconds / microseconds: 19-20 / 16-17 digits)\n"
    "get the pose at their stamp, interpolated between the two poses around it when the nearer\n"
    "is within 0.05 s (never extrapolated; clouds without a pose are skipped and counted). Other\n"
    "names are paired by order (natural sort) and need exactly one pose per cloud.\n"
    "Writes to --out: map_top.png, map_side.png (accuracy_top.png for the simulator),\n"
    "report.json (as mlmap_demo), occupied_voxels.txt ('ix iy iz' per line, sorted,\n"
    "i = floor(coordinate / resolution), world grid aligned at the origin; '#' header line) and\n"
    "stats.json (per-frame timings per stage, peak memory, counters).\n"
    "The planning layers (snapshots, 2D grid, ESDF) run only for an output that needs them\n"
    "(--grid-out); otherwise the replay maps and writes the map, nothing else.";

/// Adds --bag and the options that choose its topics and frames to `app`; --bag excludes the
/// other sources `others`.
void addBagOptions(CLI::App& app, Options& o, const std::vector<CLI::Option*>& others) {
#if MLMAP_HAVE_BAG
  auto* bag_opt = app.add_option("--bag", o.bag_path,
                                 "ROS 2 bag to map: a folder with metadata.yaml, or one .mcap / "
                                 ".db3 file; with no topic named, the inputs are chosen when the "
                                 "bag leaves no doubt, else the error lists its topics")
                      ->check(CLI::ExistingPath);
  for (CLI::Option* other : others) bag_opt->excludes(other);
  const std::vector<CLI::Option*> bag_only = {
      app.add_option("--cloud-topic", o.cloud_topics, "--bag: a PointCloud2 topic (repeatable)"),
      app.add_option("--depth-topic", o.depth_topic,
                     "--bag: a depth Image topic (16UC1 mm, 32FC1 m)"),
      app.add_option("--camera-info-topic", o.camera_info_topic,
                     "--bag: the CameraInfo of --depth-topic (default: the one beside it)"),
      app.add_option("--pose-topic", o.pose_topic,
                     "--bag: a PoseStamped or Odometry topic giving the body pose"),
      app.add_option(
          "--world-frame", o.world_frame,
          "--bag: take the body pose from /tf, from this frame (e.g. map) to --body-frame"),
      app.add_option("--body-frame", o.body_frame,
                     "--bag: the body frame (/tf child; sensors' extrinsics from /tf_static)")
          ->capture_default_str()};
  for (CLI::Option* option : bag_only) option->needs(bag_opt);
#else
  (void)app;
  (void)o;
  (void)others;
#endif
}

/// Adds --frames, --clouds, --poses, --extrinsic, --scenario and --bag (one source at most) to
/// `app`.
void addSourceOptions(CLI::App& app, Options& o) {
  auto* frames_opt = app.add_option("--frames", o.frames_dir, "RGB-D frame directory to map")
                         ->check(CLI::ExistingDirectory);
  auto* clouds_opt = app.add_option("--clouds", o.clouds_dir,
                                    "directory of .pcd / .ply point clouds "
                                    "(in the sensor frame; a PCD VIEWPOINT is taken "
                                    "as the sensor's pose in the cloud's frame) to map")
                         ->check(CLI::ExistingDirectory);
  auto* poses_opt =
      app.add_option(
             "--poses", o.poses_path,
             "trajectory of the clouds: TUM ('t tx ty tz qx qy qz qw', '#' comments) or CSV "
             "with a header (t|time|timestamp|stamp[_s|_ms|_us|_ns], x|tx|px|pos_x|position_x "
             "..., qx|q_x|rot_x|orientation_x ... qw); CSV when the name ends in .csv or the "
             "first line has a comma. The poses are the sensor's unless --extrinsic is given")
          ->check(CLI::ExistingFile);
  auto* extrinsic_opt = app.add_option(
      "--extrinsic", o.extrinsic_text,
      "the sensor (cloud frame) in the pose frame, \"x y z qx qy qz qw\" (metres, unit "
      "quaternion), e.g. a LiDAR on a vehicle whose poses --poses gives (default: "
      "identity, the poses are the sensor's)");
  clouds_opt->needs(poses_opt);
  poses_opt->needs(clouds_opt);
  extrinsic_opt->needs(clouds_opt);
  frames_opt->excludes(clouds_opt);
  auto* scenario_opt = app.add_option("--scenario", o.scenario_path,
                                      "simulator: world + flight YAML (default: the built-in room)")
                           ->check(CLI::ExistingFile);
  scenario_opt->excludes(frames_opt)->excludes(clouds_opt);
  addBagOptions(app, o, {frames_opt, clouds_opt, scenario_opt});
}

/// Adds --resolution, --max-range, --awareness-threads and --config to `app`.
void addEngineOptions(CLI::App& app, Options& o) {
  app.add_option("--resolution", o.resolution_m,
                 "voxel size [m]; the local map keeps ~19x19x7 m (default: --config's, or without "
                 "--config 0.02 for --frames and 0.1 otherwise)")
      ->check(CLI::Range(0.01, 2.0));
  app.add_option(
         "--max-range", o.max_range_m,
         "maximum range [m] (awareness.max_range_m; default: --config's, 10): farther points "
         "clear their ray up to here and mark nothing; the awareness grid grows to reach it")
      ->check(CLI::Range(0.1, 400.0));
  app.add_option(
         "--awareness-threads", o.awareness_threads,
         "threads carving a frame's free space (awareness.num_threads; default: --config's, "
         "or without --config 2 on a machine with two cores or more, else 1): the same map "
         "with any count, faster where a core is free (a second core shares the reading)")
      ->check(CLI::Range(1, AwarenessConfig::kMaxThreads));
  app.add_option("--config", o.config_path,
                 "engine configuration YAML (config/mlmap.yaml documents "
                 "every key; an mlmap_node file works too, its dds and "
                 "map_file sections are skipped; the replay always runs "
                 "synchronously)")
      ->check(CLI::ExistingFile);
}

/// Adds --out, --voxels-out, --stats-out, --max-frames, --reader-threads, --save-map and
/// --grid-out to `app`.
void addOutputOptions(CLI::App& app, Options& o) {
  app.add_option("--out", o.out_dir, "output folder")->capture_default_str();
  app.add_option("--voxels-out", o.voxels_out,
                 "occupied voxels as text (default: OUT/occupied_voxels.txt)");
  app.add_option(
      "--stats-out", o.stats_out,
      "statistics JSON (default: OUT/stats.json): per-frame timings by stage (read, read_wait, "
      "awareness, local_global, planning, engine) with their median / p99, peak memory "
      "(process RSS, engine accounting) and counters");
  app.add_option("--max-frames", o.max_frames, "stop after N frames (0: all)")
      ->check(CLI::NonNegativeNumber);
  app.add_option(
         "--reader-threads", o.reader_threads,
         "--frames / --clouds: 1 reads and decodes the files on a thread of their own, a few "
         "frames ahead of the mapping; 0 reads each in turn on the mapping thread (the same "
         "map either way)")
      ->check(CLI::Range(0, 1))
      ->capture_default_str();
  app.add_option("--save-map", o.save_map_path,
                 "also save the final map (local + global layers) to this mlmap map file; "
                 "mlmap_map_tool converts it to PLY / PCD / PGM + YAML / OctoMap .bt, and "
                 "mlmap_node can start from it (map_file.load_path)");
  app.add_flag("--overwrite", o.overwrite, "--save-map may replace an existing mlmap map");
  app.add_option("--grid-out", o.grid_out,
                 "also write the final projected 2D grid (projected_grid section of --config) as "
                 "BASE.pgm + BASE.yaml (ROS map_server); turns the planning layers on, without the "
                 "ESDF");
}

/// The kind of data the options name.
eval::DataKind dataKind(const Options& o) {
  return !o.frames_dir.empty()                          ? eval::DataKind::kFrameDirectory
         : !o.clouds_dir.empty() || !o.bag_path.empty() ? eval::DataKind::kPointClouds
                                                        : eval::DataKind::kSimulator;
}

/// The cloud sequence's options: --extrinsic parsed (the cloud sequence gives T_B_S from it and
/// the viewpoints; the config's sensor is unused). Empty when --extrinsic is malformed (logged).
std::optional<datasets::CloudSequenceOptions> cloudOptions(const Options& o) {
  datasets::CloudSequenceOptions cloud_options;
  if (o.extrinsic_text.empty()) return cloud_options;
  try {
    cloud_options.T_P_C = datasets::parseTransformXyzQuat(o.extrinsic_text);
  } catch (const std::invalid_argument& e) {
    spdlog::error("--extrinsic '{}': {}", o.extrinsic_text, e.what());
    return std::nullopt;
  }
  return cloud_options;
}

/// The replay's awareness threads without --awareness-threads or --config: an offline run has
/// the machine to itself, so two where there are two cores (the map is the same with any count;
/// more than two gain little beside the reader thread), else one.
int defaultAwarenessThreads() { return std::thread::hardware_concurrency() >= 2 ? 2 : 1; }

/// The engine configuration adapted to the options (eval::adaptReplayConfig()), its notes logged.
void adjustConfig(const Options& o, MapConfig* config) {
  eval::ReplayEngineOptions replay;
  replay.max_range_m = o.max_range_m;
  replay.awareness_threads = o.awareness_threads;
  replay.config_file = !o.config_path.empty();
  replay.default_awareness_threads = defaultAwarenessThreads();
  replay.grid_out = !o.grid_out.empty();
  const eval::ConfigNotes notes = eval::adaptReplayConfig(replay, config);
  for (const std::string& line : notes.info) spdlog::info("{}", line);
  for (const std::string& line : notes.warnings) spdlog::warn("{}", line);
}

/// False (the problems logged) when `config` is invalid.
bool validConfig(const MapConfig& config) {
  const std::vector<std::string> problems = config.validate();
  for (const auto& p : problems) spdlog::error("{}", p);
  return problems.empty();
}

/// The engine's messages to the log.
void logEngineMessage(LogLevel level, const std::string& message) {
  if (level == LogLevel::kError) {
    spdlog::error("{}", message);
  } else {
    spdlog::warn("{}", message);
  }
}

/// The number of frames to map of `available`, --max-frames applied.
std::size_t frameCount(const Options& o, std::size_t available) {
  return o.max_frames > 0 ? std::min<std::size_t>(available, static_cast<std::size_t>(o.max_frames))
                          : available;
}

/// Maps the first frames of `source` (--max-frames of them), read ahead on a reader thread
/// with --reader-threads 1.
void mapFrames(const Options& o, const datasets::FrameSource& source, eval::RecordedRun* run) {
  eval::mapFrames(source, frameCount(o, source.size()), o.reader_threads > 0 ? kReadAheadFrames : 0,
                  run);
}

/// Maps the RGB-D frames of --frames.
void mapFrameDirectory(const Options& o, eval::RecordedRun* run) {
  const datasets::FrameDirectorySource frames(o.frames_dir);
  spdlog::info("mapping {} RGB-D frames of {} at {} m", frameCount(o, frames.size()), o.frames_dir,
               run->resolution_m());
  run->info() = {o.frames_dir, "frames", "frame files", 0, 0};
  mapFrames(o, frames, run);
  run->outputs().optical_world = true;  // the world is the first camera's optical frame
}

/// Maps the clouds of --clouds at the poses of --poses.
void mapCloudSequence(const Options& o, const datasets::CloudSequenceOptions& cloud_options,
                      eval::RecordedRun* run) {
  const datasets::CloudSequenceSource source(o.clouds_dir, o.poses_path, cloud_options);
  const datasets::CloudSequence& clouds = source.sequence();
  run->info() = {o.clouds_dir + " + " + o.poses_path, "clouds",
                 datasets::toString(clouds.pairing()), clouds.unpaired().size(), 0};
  if (!clouds.unpaired().empty()) {
    spdlog::warn(
        "{} of {} clouds have no pose within {} s of their stamp and are skipped (first: {})",
        clouds.unpaired().size(), clouds.size() + clouds.unpaired().size(),
        cloud_options.pose_tolerance_s, clouds.unpaired().front());
  }
  spdlog::info("mapping {} clouds of {} paired {} with {} poses at {} m, max range {} m",
               frameCount(o, clouds.size()), o.clouds_dir, datasets::toString(clouds.pairing()),
               clouds.poseCount(), run->resolution_m(),
               run->engine().config().awareness.max_range_m);
  mapFrames(o, source, run);
}

#if MLMAP_HAVE_BAG
/// Maps the frames of --bag, its inputs named by the options or chosen from the bag.
void mapBag(const Options& o, eval::RecordedRun* run) {
  std::shared_ptr<const bag::BagReader> reader =
      bag::openBag(o.bag_path);  // its errors name the file
  spdlog::info("{}: {} messages on {} topics:\n{}", o.bag_path, reader->entries().size(),
               reader->topics().size(), reader->describeTopics());
  bag::BagFrameSourceOptions options;
  options.inputs.cloud_topics = o.cloud_topics;
  options.inputs.depth_topic = o.depth_topic;
  options.inputs.camera_info_topic = o.camera_info_topic;
  options.inputs.pose_topic = o.pose_topic;
  options.inputs.pose_from_tf = !o.world_frame.empty() && o.pose_topic.empty();
  options.world_frame = o.world_frame;
  options.body_frame = o.body_frame;
  std::optional<bag::BagFrameSource> opened;
  try {
    opened.emplace(reader, options);
  } catch (const std::runtime_error& e) {  // the library names its options; say the replay's
    throw std::runtime_error(std::string(e.what()) +
                             "\n(mlmap_replay: --cloud-topic, --depth-topic, --camera-info-topic, "
                             "--pose-topic, --world-frame, --body-frame)");
  }
  const bag::BagFrameSource& source = *opened;
  for (const std::string& w : source.warnings()) spdlog::warn("{}", w);
  if (source.unpairedCount() > 0) {
    spdlog::warn("{} input messages have no pose within {} s of their stamp and are skipped",
                 source.unpairedCount(), options.pose_tolerance_s);
  }
  spdlog::info("mapping {} of {} with {} poses at {} m, max range {} m",
               frameCount(o, source.size()), source.describe(), source.poseCount(),
               run->resolution_m(), run->engine().config().awareness.max_range_m);
  run->info() = {o.bag_path, "bag", "poses at the messages' stamps", source.unpairedCount(), 0};
  mapFrames(o, source, run);
}
#endif

/// Flies the simulator through --scenario (or the built-in room) and scores the map.
void flySimulator(const Options& o, eval::RecordedRun* run) {
  const datasets::Scenario scenario = o.scenario_path.empty()
                                          ? datasets::defaultScenario()
                                          : datasets::loadScenarioYaml(o.scenario_path);
  spdlog::info("flying the {} scenario at {} m voxels",
               o.scenario_path.empty() ? "built-in room" : o.scenario_path, run->resolution_m());
  run->flyRecorded(scenario, o.max_frames);
  run->info() = {
      o.scenario_path.empty() ? "simulator: built-in room" : "simulator: " + o.scenario_path,
      "simulator", "simulated poses", 0, 0};
}

/// Prints the replay's own figures after the engine's: per-frame timings, memory, the files.
void printReplaySummary(const Options& o, const eval::RecordedRun& run,
                        const std::vector<std::string>& written, std::size_t occupied) {
  eval::printRunSummary(run, o.reader_threads > 0 && run.info().kind != "simulator");
  std::string names;
  for (const std::string& name : written) names += (names.empty() ? "" : ", ") + name;
  std::printf("\n  wrote %s/{%s}\n        %s (%zu occupied voxels)\n        %s\n",
              o.out_dir.c_str(), names.c_str(), o.voxels_out.c_str(), occupied,
              o.stats_out.c_str());
}

/// Writes the final 2D grid (--grid-out) as BASE.pgm + BASE.yaml. @throws std::runtime_error
/// naming the file when it cannot.
void writeGrid(const std::string& base, const MapEngine& engine) {
  const std::shared_ptr<const MapSnapshot> snapshot = engine.snapshot();
  if (snapshot->gridPtr() == nullptr) {
    throw std::runtime_error(base + ".pgm: no 2D grid was made (no frame mapped)");
  }
  io::writeGridMap(*snapshot->gridPtr(), base);
}

/// The run's phases (stats.json's `phases_s` in wall seconds, `phases_cpu_s` in seconds of the
/// process's CPU, every thread): from main() to the first frame's submit() (start-up: options,
/// configuration, engine, source, the first frame's reading), the frames (first submit() to the
/// last one's return), and from there to `outputs_end` (flush, every output but stats.json).
/// Without a frame, all of it is start-up.
eval::Json phasesJson(const eval::RecordedRun& run, const eval::RunMark& main_start,
                      const eval::RunMark& outputs_end, bool cpu) {
  const bool frames = run.firstFrameStart().set();
  const eval::RunMark& first = frames ? run.firstFrameStart() : outputs_end;
  const eval::RunMark& last = frames ? run.lastFrameEnd() : outputs_end;
  const auto span = [cpu](const eval::RunMark& a, const eval::RunMark& b) {
    return cpu ? b.process_cpu_s - a.process_cpu_s : secondsBetween(a.wall, b.wall);
  };
  eval::Json phases = {{"startup", span(main_start, first)},
                       {"mapping", span(first, last)},
                       {"outputs", span(last, outputs_end)}};
  if (cpu) phases["before_main"] = main_start.process_cpu_s;  // loading the program, libraries
  return phases;
}

/// Prints the run's phases (phasesJson()) and the time stats.json took to write.
void printPhases(const eval::Json& wall, const eval::Json& cpu, double stats_json_s) {
  std::printf(
      "  phases [s]           start-up %.3f (main() to the first frame), mapping %.3f, "
      "outputs %.3f (+ stats.json %.3f)\n"
      "  phases, CPU [s]      before main() %.3f, start-up %.3f, mapping %.3f, outputs %.3f\n",
      wall["startup"].get<double>(), wall["mapping"].get<double>(), wall["outputs"].get<double>(),
      stats_json_s, cpu["before_main"].get<double>(), cpu["startup"].get<double>(),
      cpu["mapping"].get<double>(), cpu["outputs"].get<double>());
}

/// Writes the outputs, the map first (--save-map; the voxel list, while the pictures are drawn),
/// then the 2D grid, the pictures with report.json and stats.json, and prints the summary. The
/// engine is released once the outputs that read it are written.
/// Returns the exit status: 0, or 3 when no frame was mapped. @throws std::runtime_error naming
/// the file it cannot write; the files written before it are complete.
int finish(const Options& o, eval::RecordedRun* run, const eval::RunMark& main_start) {
  run->engine().flush();
  run->outputs().source = run->info().source;
  const double res = run->resolution_m();
  const EngineStats s = run->engine().stats();
  const std::vector<VoxelIndex> occupied = run->engine().occupiedVoxels();
  if (!o.save_map_path.empty()) eval::saveMap(run->engine(), o.save_map_path);
  // The voxel list is sorted and written while the pictures are drawn (a second core hides it);
  // its error, if any, is passed on by get() first.
  std::future<void> voxels = std::async(std::launch::async, [&o, &occupied, res] {
    io::writeVoxelText(o.voxels_out, occupied, res);
  });
  if (!o.grid_out.empty()) writeGrid(o.grid_out, run->engine());
  run->releaseEngine();  // what follows reads `occupied` and `s`: the map's memory is freed first
  std::vector<std::string> written;
  try {
    written = eval::writeMapOutputs(run->outputs(), s, occupied, res);
  } catch (...) {
    voxels.get();  // its own error first: the files are written in this order
    throw;
  }
  voxels.get();
  const eval::RunMark stats_start = eval::RunMark::now();
  eval::Json stats = eval::runStatsJson(*run, occupied.size());
  stats["phases_s"] = phasesJson(*run, main_start, stats_start, /*cpu=*/false);
  stats["phases_cpu_s"] = phasesJson(*run, main_start, stats_start, /*cpu=*/true);
  eval::writeJsonFile(o.stats_out, stats, /*expanded_levels=*/2);
  const double stats_json_s = secondsBetween(stats_start.wall, SteadyClock::now());
  eval::printSummary(s, res, run->scored() != nullptr ? &run->scored()->accuracy : nullptr);
  printReplaySummary(o, *run, written, occupied.size());
  printPhases(stats["phases_s"], stats["phases_cpu_s"], stats_json_s);
  return s.frames_mapped > 0 ? 0 : 3;
}

/// Throws std::runtime_error naming the option when an output of the run (--save-map,
/// --voxels-out, --stats-out, --grid-out's two files) would replace one of its inputs (under any
/// spelling of the path, or a file inside an input folder) or, but for --save-map with
/// --overwrite, an existing mlmap map.
void checkOutputs(const Options& o) {
  const std::vector<std::string> inputs = {o.bag_path,   o.frames_dir,  o.clouds_dir,
                                           o.poses_path, o.config_path, o.scenario_path};
  std::vector<std::pair<std::string, std::string>> outputs = {{"--save-map", o.save_map_path},
                                                              {"--voxels-out", o.voxels_out},
                                                              {"--stats-out", o.stats_out}};
  if (!o.grid_out.empty()) {
    outputs.emplace_back("--grid-out", o.grid_out + ".pgm");
    outputs.emplace_back("--grid-out", o.grid_out + ".yaml");
  }
  for (const auto& [option, path] : outputs) {
    if (path.empty()) continue;
    const bool may_replace_map = option == "--save-map" && o.overwrite;
    const std::string conflict = io::outputConflict(path, inputs, may_replace_map, "--overwrite");
    if (!conflict.empty()) throw std::runtime_error(option + ": " + conflict);
  }
}

/// Logs the local window the engine uses (after --max-range and --config), how far from the body
/// it maps every hit with its free space, and the maximum range.
void logWindow(const MapConfig& config) {
  const Eigen::Vector3i& cells = config.local_map.size_cells;
  const double res = config.local_map.resolution_m;
  spdlog::info(
      "local window {} x {} x {} voxels ({:.1f} x {:.1f} x {:.1f} m): a hit within {:.1f} m "
      "horizontally of the body and within the window's height is mapped with its free space, "
      "others are counted (hits_beyond_local_map); max range {} m",
      cells.x(), cells.y(), cells.z(), cells.x() * res, cells.y() * res, cells.z() * res,
      config.local_map.horizontalReach_m(), config.awareness.max_range_m);
}

/// Checks the configuration, maps the source and writes the outputs. Returns the exit status:
/// 0, 2 for a bad configuration or --extrinsic, 3 when no frame was mapped. `main_start`: when
/// main() was entered, for stats.json's phases.
int replaySource(const Options& o, const eval::RunMark& main_start) {
  const eval::DataKind kind = dataKind(o);
  MapConfig config = eval::runConfig(o.config_path, kind, o.resolution_m);
  const std::optional<datasets::CloudSequenceOptions> cloud_options = cloudOptions(o);
  if (!cloud_options) return 2;
  adjustConfig(o, &config);
  if (!validConfig(config)) return 2;
  checkOutputs(o);  // before anything is written or read
  std::filesystem::create_directories(o.out_dir);
  if (!o.save_map_path.empty())
    eval::checkSaveMapTarget(o.save_map_path, o.overwrite);  // before the run

  eval::RecordedRun run(config, o.out_dir, logEngineMessage);
  logWindow(run.engine().config());
  if (kind == eval::DataKind::kFrameDirectory) {
    mapFrameDirectory(o, &run);
#if MLMAP_HAVE_BAG
  } else if (!o.bag_path.empty()) {
    mapBag(o, &run);
#endif
  } else if (kind == eval::DataKind::kPointClouds) {
    mapCloudSequence(o, *cloud_options, &run);
  } else {
    flySimulator(o, &run);
  }
  return finish(o, &run, main_start);
}

/// Runs the replay the options describe; returns the exit status (1: an error, logged).
int run(Options o, const eval::RunMark& main_start) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("mlmap"));  // stdout carries the results
  if (o.voxels_out.empty()) o.voxels_out = o.out_dir + "/occupied_voxels.txt";
  if (o.stats_out.empty()) o.stats_out = o.out_dir + "/stats.json";
  try {
    return replaySource(o, main_start);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  const mlmap::eval::RunMark main_start = mlmap::eval::RunMark::now();
  CLI::App app{kAbout};
  Options options;
  addSourceOptions(app, options);
  addEngineOptions(app, options);
  addOutputOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  return run(std::move(options), main_start);
}
