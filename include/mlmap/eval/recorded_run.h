#pragma once
/// @file
/// An offline run that records every frame (mlmap_replay): a synchronous engine, each frame's
/// status, size and per-stage timings, the source's description, and the run's statistics as
/// stats.json. The program reads its options and calls mapFrames() or flyRecorded(), then
/// writes the outputs.

#include "mlmap/core/stopwatch.h"
#include "mlmap/datasets/frame_source.h"
#include "mlmap/eval/json_output.h"
#include "mlmap/eval/run_outputs.h"
#include "mlmap/pipeline/map_engine.h"

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace mlmap::eval {

/// One frame of a recorded run (stats.json's `frames`).
struct FrameRecord {
  std::string name;
  double stamp_s = 0.0;
  std::size_t points = 0;              ///< points handed to the engine (depth: pixels)
  std::size_t non_finite_dropped = 0;  ///< NaN / Inf points the cloud reader dropped
  FrameStatus status = FrameStatus::kAccepted;
  double read_ms = 0.0;          ///< reading and parsing the file, or rendering (simulator)
  double read_wait_ms = 0.0;     ///< the mapping waiting for the reader thread (0 without one)
  double awareness_ms = 0.0;     ///< submit() until the awareness map is updated
  double local_global_ms = 0.0;  ///< re-centring and log-odds updates
  double planning_ms = 0.0;      ///< snapshot copy, 2D grid and ESDF when due
  double engine_ms = 0.0;        ///< the whole submit() call
  std::size_t engine_bytes = 0;  ///< the engine's own memory accounting after the frame
};

/// Times the stages of each frame of a synchronous engine through its observers.
class FrameTimer {
 public:
  /// The observers to create the engine with (this timer must outlive the engine).
  EngineObservers observers();
  /// Call right before submit().
  void begin();
  /// Fills the timings and memory of `r` after submit() returned; updates the engine's peak.
  /// Returns true when the engine mapped a frame since the previous call.
  bool end(const MapEngine& engine, FrameRecord* r);
  /// The largest engine accounting seen after a frame [bytes].
  [[nodiscard]] std::size_t peakEngineBytes() const { return peak_engine_bytes_; }

 private:
  SteadyClock::time_point start_, awareness_done_, mapped_done_;
  PlanningStats last_;
  std::uint64_t frames_mapped_ = 0;
  std::size_t peak_engine_bytes_ = 0;
};

/// A moment of a run: the steady clock and the CPU time the process (every thread) has used so
/// far, from its start: at main()'s entry that is the loading of the program and its libraries.
struct RunMark {
  SteadyClock::time_point wall{};  ///< the steady clock; its epoch when not set
  double process_cpu_s = 0.0;      ///< CLOCK_PROCESS_CPUTIME_ID [s]
  /// This moment.
  [[nodiscard]] static RunMark now();
  /// Whether the mark was taken.
  [[nodiscard]] bool set() const { return wall != SteadyClock::time_point{}; }
};

/// What stats.json says of the source besides the frames.
struct RunInfo {
  std::string source;   ///< the input, as given
  std::string kind;     ///< "frames", "clouds", "bag" or "simulator"
  std::string pairing;  ///< how frames found their poses
  std::size_t clouds_without_pose = 0;
  std::size_t points_in_files = 0;
};

/// Median, p99, mean and maximum of one of the records' timings over the accepted frames.
[[nodiscard]] TimingSummary summarizeFrames(const std::vector<FrameRecord>& frames,
                                            double FrameRecord::*field);

/// The engine of one run with what it records: frames, source, outputs.
class RecordedRun {
 public:
  /// A synchronous engine of `config` (its messages logged through `log`), outputs to `out_dir`.
  RecordedRun(const MapConfig& config, const std::string& out_dir, LogSink log);

  /// Maps `frame`, recording its status and timings in `record`.
  void submit(PointCloudFrame frame, FrameRecord record);
  /// The same for a depth image.
  void submit(DepthFrame frame, FrameRecord record);

  [[nodiscard]] double resolution_m() const { return config_.local_map.resolution_m; }
  /// The engine. @throws std::logic_error after releaseEngine().
  [[nodiscard]] MapEngine& engine();
  /// The engine. @throws std::logic_error after releaseEngine().
  [[nodiscard]] const MapEngine& engine() const;
  /// The engine's configuration (kept by releaseEngine()).
  [[nodiscard]] const MapConfig& config() const { return config_; }
  /// The engine's statistics; after releaseEngine(), the last ones it gave.
  [[nodiscard]] EngineStats stats() const;
  /// Frees the engine and its map, keeping its configuration and final statistics (config(),
  /// stats(), what stats.json and printRunSummary() read): call it once the outputs that read
  /// the map itself are written, so that the pictures and files written after it do not add
  /// their memory to the map's at the process's peak.
  void releaseEngine();
  [[nodiscard]] FrameTimer& timer() { return timer_; }
  [[nodiscard]] const FrameTimer& timer() const { return timer_; }
  [[nodiscard]] std::vector<FrameRecord>& records() { return records_; }
  [[nodiscard]] const std::vector<FrameRecord>& records() const { return records_; }
  [[nodiscard]] RunInfo& info() { return info_; }
  [[nodiscard]] const RunInfo& info() const { return info_; }
  [[nodiscard]] MapOutputs& outputs() { return outputs_; }
  [[nodiscard]] const MapOutputs& outputs() const { return outputs_; }
  /// Where the engine's and the run's messages go.
  [[nodiscard]] const LogSink& log() const { return log_; }
  /// The simulator's flight and its accuracy (flyRecorded()); nullptr for recorded data.
  [[nodiscard]] const ScoredFlight* scored() const { return outputs_.scored; }
  /// When the first frame's submit() began (not set() before any frame).
  [[nodiscard]] const RunMark& firstFrameStart() const { return first_frame_start_; }
  /// When the last frame's submit() returned (not set() before any frame).
  [[nodiscard]] const RunMark& lastFrameEnd() const { return last_frame_end_; }

  /// Flies `scenario` (at most `max_frames` frames, 0: all), recording each frame, and scores
  /// the map against the simulator's ground truth.
  void flyRecorded(const datasets::Scenario& scenario, int max_frames);

 private:
  template <typename Frame>
  void submitFrame(Frame frame, FrameRecord record);
  /// Notes the start and end of a frame's submit() for firstFrameStart() and lastFrameEnd().
  void noteFrameStart();
  void noteFrameEnd() { last_frame_end_ = RunMark::now(); }

  LogSink log_;
  FrameTimer timer_;  // before the engine: the engine holds its observers
  std::unique_ptr<MapEngine> engine_;
  MapConfig config_;         // the engine's
  EngineStats final_stats_;  // the engine's last, once released
  std::vector<FrameRecord> records_;
  RunInfo info_;
  MapOutputs outputs_;
  ScoredFlight scored_;
  RunMark first_frame_start_;
  RunMark last_frame_end_;
};

/// Maps the first `count` frames of `source` into `run` in order, recording each, with a
/// progress bar; with `read_ahead` > 0 they are read and decoded on a reader thread that many
/// frames ahead of the mapping.
void mapFrames(const datasets::FrameSource& source, std::size_t count, std::size_t read_ahead,
               RecordedRun* run);

/// stats.json: the source, the engine's settings, timings per stage (median, p99, mean, max over
/// the accepted frames), memory (process peak, engine peak and final accounting), counters, and
/// every frame.
[[nodiscard]] Json runStatsJson(const RecordedRun& run, std::size_t occupied_voxels);

/// Prints what the run adds to printSummary(): per-frame timings of the planning layers, the
/// whole submit() and the reading (`reader_thread`: read on a thread of its own), the hits
/// outside the local window (warned about through run.log() when there are any), and memory.
void printRunSummary(const RecordedRun& run, bool reader_thread);

}  // namespace mlmap::eval
