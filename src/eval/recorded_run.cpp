#include "mlmap/eval/recorded_run.h"

#include "mlmap/datasets/frame_prefetcher.h"

#include <time.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <utility>
#include <variant>

namespace mlmap::eval {

using Clock = SteadyClock;

RunMark RunMark::now() {
  timespec cpu{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &cpu);
  return {Clock::now(), static_cast<double>(cpu.tv_sec) + 1e-9 * static_cast<double>(cpu.tv_nsec)};
}

EngineObservers FrameTimer::observers() {
  EngineObservers o;
  o.awareness = [this](const AwarenessMap&, double, const Transform&) {
    awareness_done_ = Clock::now();
  };
  // After the local-global update and the planning layers, if any, of every mapped frame.
  o.global = [this](const GlobalMap&, double, std::uint64_t) { mapped_done_ = Clock::now(); };
  return o;
}

void FrameTimer::begin() {
  start_ = Clock::now();
  awareness_done_ = mapped_done_ = Clock::time_point{};
}

bool FrameTimer::end(const MapEngine& engine, FrameRecord* r) {
  const Clock::time_point now = Clock::now();
  r->engine_ms = msBetween(start_, now);
  const EngineStats s = engine.stats();
  if (awareness_done_ != Clock::time_point{} && mapped_done_ != Clock::time_point{}) {
    r->awareness_ms = msBetween(start_, awareness_done_);
    const PlanningStats& p = s.planning;
    r->planning_ms = p.last_snapshot_ms +
                     (p.grid_updates != last_.grid_updates ? p.last_grid_ms : 0.0) +
                     (p.esdf_updates != last_.esdf_updates ? p.last_esdf_ms : 0.0);
    r->local_global_ms = std::max(0.0, msBetween(awareness_done_, mapped_done_) - r->planning_ms);
  }
  last_ = s.planning;
  r->engine_bytes = s.memory.total();
  peak_engine_bytes_ = std::max(peak_engine_bytes_, r->engine_bytes);
  const bool mapped = s.frames_mapped != frames_mapped_;
  frames_mapped_ = s.frames_mapped;
  return mapped;
}

TimingSummary summarizeFrames(const std::vector<FrameRecord>& frames, double FrameRecord::*field) {
  std::vector<double> values;
  for (const FrameRecord& f : frames) {
    if (f.status == FrameStatus::kAccepted) values.push_back(f.*field);
  }
  return summarizeTimings(values);
}

RecordedRun::RecordedRun(const MapConfig& config, const std::string& out_dir, LogSink log)
    : log_(std::move(log)),
      engine_(std::make_unique<MapEngine>(config, log_, timer_.observers())),
      config_(engine_->config()) {
  outputs_.out_dir = out_dir;
}

MapEngine& RecordedRun::engine() {
  if (!engine_) throw std::logic_error("RecordedRun: the engine was released");
  return *engine_;
}

const MapEngine& RecordedRun::engine() const {
  if (!engine_) throw std::logic_error("RecordedRun: the engine was released");
  return *engine_;
}

EngineStats RecordedRun::stats() const { return engine_ ? engine_->stats() : final_stats_; }

void RecordedRun::releaseEngine() {
  if (!engine_) return;
  final_stats_ = engine_->stats();
  engine_.reset();
}

template <typename Frame>
void RecordedRun::submitFrame(Frame frame, FrameRecord record) {
  outputs_.trajectory_W.push_back(frame.T_W_B.translation());
  record.stamp_s = frame.stamp_s;
  noteFrameStart();
  timer_.begin();
  record.status = engine().submit(std::move(frame));
  (void)timer_.end(engine(), &record);
  noteFrameEnd();
  records_.push_back(std::move(record));
}

void RecordedRun::noteFrameStart() {
  if (!first_frame_start_.set()) first_frame_start_ = RunMark::now();
}

void RecordedRun::submit(PointCloudFrame frame, FrameRecord record) {
  submitFrame(std::move(frame), std::move(record));
}

void RecordedRun::submit(DepthFrame frame, FrameRecord record) {
  submitFrame(std::move(frame), std::move(record));
}

void RecordedRun::flyRecorded(const datasets::Scenario& scenario, int max_frames) {
  FlightOptions options;
  if (max_frames > 0) options.max_frames = max_frames;
  ProgressBar bar("flying ");
  Clock::time_point frame_start = Clock::now();
  FrameRecord record;
  options.before_submit = [&](int i) {
    record = FrameRecord{};
    record.name = "sim-" + std::to_string(i);
    record.read_ms = msSince(frame_start);
    record.points = static_cast<std::size_t>(scenario.camera.intrinsics.width) *
                    static_cast<std::size_t>(scenario.camera.intrinsics.height);
    noteFrameStart();
    timer_.begin();
  };
  options.progress = [&](int done, int total) {
    // Called right after submit(): the frame's status is the engine's last counters'.
    record.status = timer_.end(engine(), &record) ? FrameStatus::kAccepted : FrameStatus::kEmpty;
    noteFrameEnd();
    record.stamp_s = frameTime(scenario, done - 1);
    records_.push_back(record);
    bar.update(done, total);
    frame_start = Clock::now();
  };
  scored_ = flyAndScore(scenario, engine(), options);
  outputs_.trajectory_W = scored_.flight.trajectory_W;
  outputs_.scored = &scored_;
}

void mapFrames(const datasets::FrameSource& source, std::size_t count, std::size_t read_ahead,
               RecordedRun* run) {
  datasets::FramePrefetcher reader(source, count, read_ahead);
  ProgressBar bar("mapping");
  datasets::PrefetchedFrame read;
  for (std::size_t i = 0; i < count; ++i) {
    const Clock::time_point wait_start = Clock::now();
    if (!reader.next(&read)) break;
    FrameRecord record;
    record.read_wait_ms = msSince(wait_start);
    record.read_ms = read.read_ms;
    record.name = read.info.name;
    if (std::holds_alternative<PointCloudFrame>(read.frame)) {
      record.points = std::get<PointCloudFrame>(read.frame).points_S.size();
      record.non_finite_dropped = read.info.non_finite_dropped;
      run->info().points_in_files += read.info.points_in_file;
    } else {
      record.points = read.info.points_in_file;  // the image's pixels
    }
    std::visit([&](auto& f) { run->submit(std::move(f), std::move(record)); }, read.frame);
    bar.update(static_cast<int>(i + 1), static_cast<int>(count));
  }
}

namespace {

/// stats.json's timing_ms.
Json timingJson(const std::vector<FrameRecord>& frames) {
  return {{"read", toJson(summarizeFrames(frames, &FrameRecord::read_ms))},
          {"read_wait", toJson(summarizeFrames(frames, &FrameRecord::read_wait_ms))},
          {"awareness", toJson(summarizeFrames(frames, &FrameRecord::awareness_ms))},
          {"local_global", toJson(summarizeFrames(frames, &FrameRecord::local_global_ms))},
          {"planning", toJson(summarizeFrames(frames, &FrameRecord::planning_ms))},
          {"engine", toJson(summarizeFrames(frames, &FrameRecord::engine_ms))}};
}

/// stats.json's memory_bytes: the process's peak, the engine's peak and its final accounting.
Json memoryJson(const EngineStats& s, std::size_t peak_engine_bytes) {
  return {{"peak_rss", peakRssBytes()},
          {"engine_peak", peak_engine_bytes},
          {"engine_final",
           {{"awareness", s.memory.awareness_bytes},
            {"local", s.memory.local_bytes},
            {"global", s.memory.global_bytes},
            {"planning", s.memory.planning_bytes},
            {"total", s.memory.total()}}}};
}

/// stats.json's counters: the run's frames and points, then the engine's counters as
/// report.json names them (engineCountersJson()).
Json countersJson(const RunInfo& info, const EngineStats& s, const std::vector<FrameRecord>& frames,
                  std::size_t occupied) {
  std::size_t reader_dropped = 0;
  for (const FrameRecord& f : frames) reader_dropped += f.non_finite_dropped;
  Json counters = {{"frames", frames.size()},
                   {"clouds_without_pose", info.clouds_without_pose},
                   {"points_in_files", info.points_in_files},
                   {"non_finite_dropped_by_reader", reader_dropped},
                   {"occupied_voxels", occupied}};
  counters.update(engineCountersJson(s));
  return counters;
}

/// One entry of stats.json's frames.
Json frameJson(const FrameRecord& f) {
  return {{"name", f.name},
          {"stamp_s", f.stamp_s},  // printed to full double precision: epoch stamps keep their ns
          {"status", toString(f.status)},
          {"points", f.points},
          {"non_finite_dropped", f.non_finite_dropped},
          {"read_ms", f.read_ms},
          {"read_wait_ms", f.read_wait_ms},
          {"awareness_ms", f.awareness_ms},
          {"local_global_ms", f.local_global_ms},
          {"planning_ms", f.planning_ms},
          {"engine_ms", f.engine_ms},
          {"engine_bytes", f.engine_bytes}};
}

}  // namespace

Json runStatsJson(const RecordedRun& run, std::size_t occupied_voxels) {
  const MapConfig& config = run.config();
  const EngineStats s = run.stats();
  Json stats;
  stats["source"] = run.info().source;
  stats["kind"] = run.info().kind;
  stats["pairing"] = run.info().pairing;
  stats["resolution_m"] = config.local_map.resolution_m;
  stats["max_range_m"] = config.awareness.max_range_m;
  stats["awareness_threads"] = config.awareness.num_threads;
  stats["timing_ms"] = timingJson(run.records());
  stats["memory_bytes"] = memoryJson(s, run.timer().peakEngineBytes());
  stats["counters"] = countersJson(run.info(), s, run.records(), occupied_voxels);
  stats["frames"] = Json::array();
  for (const FrameRecord& f : run.records()) stats["frames"].push_back(frameJson(f));
  return stats;
}

void printRunSummary(const RecordedRun& run, bool reader_thread) {
  const std::vector<FrameRecord>& records = run.records();
  const TimingSummary read = summarizeFrames(records, &FrameRecord::read_ms);
  const TimingSummary planning = summarizeFrames(records, &FrameRecord::planning_ms);
  const TimingSummary whole = summarizeFrames(records, &FrameRecord::engine_ms);
  std::printf("  replay per frame [ms] median   p99\n");
  if (run.config().pipeline.planning_layers) {
    std::printf("    planning layers    %7.2f %7.2f   (snapshot, 2D grid)\n", planning.median_ms,
                planning.p99_ms);
  } else {
    std::printf("    planning layers       off          (no output needs them)\n");
  }
  std::printf("    submit() in all    %7.2f %7.2f\n", whole.median_ms, whole.p99_ms);
  std::printf("    reading the input  %7.2f %7.2f   (%s)\n", read.median_ms, read.p99_ms,
              reader_thread ? "on the reader thread" : "on the mapping thread");
  if (reader_thread) {
    const TimingSummary wait = summarizeFrames(records, &FrameRecord::read_wait_ms);
    std::printf("    waiting for it     %7.2f %7.2f\n", wait.median_ms, wait.p99_ms);
  }
  printHitsOutsideWindow(run.stats(), run.log());
  std::printf("  peak memory          %.1f MB resident (process), %.1f MB engine accounting\n",
              static_cast<double>(peakRssBytes()) / 1e6,
              static_cast<double>(run.timer().peakEngineBytes()) / 1e6);
}

}  // namespace mlmap::eval
