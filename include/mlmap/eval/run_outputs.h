#pragma once
/// @file
/// What the offline programs (mlmap_demo, mlmap_replay) share: the engine settings per kind of
/// data, the progress bar, the simulated flight with its scoring, and the outputs (map pictures,
/// report.json, the terminal summary).

#include "mlmap/eval/sim_flight.h"
#include "mlmap/pipeline/map_engine.h"

#include <string>
#include <vector>

namespace mlmap::eval {

/// A one-line progress bar on stderr (redrawn in place on a terminal, every 10 % otherwise).
class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  /// Shows `done` of `total` frames.
  void update(int done, int total);

 private:
  std::string label_;
  bool tty_;
  int last_decile_ = -1;
};

/// The kind of data a run maps; it picks the engine defaults of runConfig().
enum class DataKind {
  kSimulator,       ///< the simulated depth camera (camera mounted as `sensor:` says)
  kFrameDirectory,  ///< RGB-D frames whose poses are the camera's
                    ///< (mlmap/datasets/frame_directory.h)
  kPointClouds,     ///< point-cloud files with poses (mlmap/datasets/cloud_sequence.h)
};

/// Sets the voxel size and keeps the local map near the paper's 19 x 19 x 7 m (<= 250 cells).
void setResolution(MapConfig* config, double resolution_m);

/// The engine configuration both programs map `kind` with: `config_path` (empty: the defaults),
/// the resolution `resolution_m` (> 0) or, without a config file, the kind's default (0.1 m
/// simulator and clouds, 0.02 m frames). Frames: the camera is the body (sensor: identity). Not
/// validated.
/// @throws std::runtime_error when the config file is malformed.
[[nodiscard]] MapConfig runConfig(const std::string& config_path, DataKind kind,
                                  double resolution_m);

/// How an offline replay adapts the engine configuration to its data and outputs
/// (adaptReplayConfig()).
struct ReplayEngineOptions {
  /// > 0: the farthest measurement to map [m]; the awareness grid and the local window grow to
  /// reach it.
  double max_range_m = 0.0;
  /// > 0: that many awareness threads; 0: the configuration's when a file gave it, else
  /// `default_awareness_threads`.
  int awareness_threads = 0;
  bool config_file = false;           ///< the configuration came from a file
  int default_awareness_threads = 1;  ///< an offline run's default (the caller's cores)
  bool grid_out = false;              ///< the final 2D grid is written (planning layers for it)
};

/// What adaptReplayConfig() did that a user should read: `info` lines and `warnings`.
struct ConfigNotes {
  std::vector<std::string> info;      ///< changes made as asked
  std::vector<std::string> warnings;  ///< changes refused or forced
};

/// Adapts `config` for an offline replay: the range applied (the awareness grid's radius grows to
/// it; the local window grows horizontally to 2.5 x the range across, so that every hit in range
/// lies in it wherever the body is in its centre submap, unless the configuration's limits refuse
/// that window: then it is kept, and hits beyond it go to the global map as hits only), the
/// awareness threads, the engine made synchronous (every frame mapped, in order) and the planning
/// layers limited to what the outputs need (the 2D grid for `grid_out`; no ESDF). None of it
/// changes a voxel of the map but the range's. Not validated afterwards.
[[nodiscard]] ConfigNotes adaptReplayConfig(const ReplayEngineOptions& options, MapConfig* config);

/// A simulated flight with its scoring against ground truth.
struct ScoredFlight {
  FlightResult flight;
  Accuracy accuracy;
  /// Truth for pictures: observed true voxels plus mapped ones that touch a solid.
  VoxelSet truth;
};

/// Flies `scenario` into `engine` (flyScenario()) and scores the occupied voxels.
[[nodiscard]] ScoredFlight flyAndScore(const datasets::Scenario& scenario, MapEngine& engine,
                                       const FlightOptions& options);

/// What writeMapOutputs() writes about.
struct MapOutputs {
  std::string out_dir;                        ///< must exist
  std::string source;                         ///< data source, for report.json
  std::vector<Eigen::Vector3d> trajectory_W;  ///< body positions
  /// True when the world is an optical camera frame (z forward, y down; frame directories):
  /// pictures then show it turned to that camera's FLU frame, so "top" looks down.
  bool optical_world = false;
  const ScoredFlight* scored = nullptr;  ///< simulator runs: accuracy picture and figures
};

/// Writes map_top.png, map_side.png (and accuracy_top.png with `scored`) and report.json to
/// `outputs.out_dir`; returns the names written.
/// @throws std::runtime_error naming the file that cannot be written.
std::vector<std::string> writeMapOutputs(const MapOutputs& outputs, const EngineStats& stats,
                                         const std::vector<VoxelIndex>& occupied,
                                         double resolution_m);

/// Refuses a --save-map target whose folder does not exist, or that is an existing mlmap map
/// while `overwrite` (--overwrite) is false: before a run rather than after it.
/// @throws std::runtime_error naming the folder or the file.
void checkSaveMapTarget(const std::string& path, bool overwrite);
/// Saves the engine's map (local + global layers, mlmap/map_io/map_file.h) to `path` and prints its
/// size and the time taken. @throws std::runtime_error when it cannot be saved.
void saveMap(const MapEngine& engine, const std::string& path);

/// Prints the engine's figures (and the accuracy, when given) to stdout.
void printSummary(const EngineStats& stats, double resolution_m, const Accuracy* accuracy);
/// Prints the hits outside the local window to stdout: points in range beyond what the local
/// map holds around the body and hit voxels outside its window, whose occupied evidence went to
/// the global map (their free space is not mapped), and hits no layer could hold. When there are
/// any, `log` gets a warning saying how to map them whole.
void printHitsOutsideWindow(const EngineStats& stats, const LogSink& log);

/// `s` as a JSON string literal, quotes included (quotes, backslashes and control characters
/// escaped; bytes that are not UTF-8 replaced by U+FFFD).
[[nodiscard]] std::string jsonString(const std::string& s);

/// Peak resident set size of this process so far [bytes] (getrusage), 0 when unknown.
[[nodiscard]] std::size_t peakRssBytes();

}  // namespace mlmap::eval
