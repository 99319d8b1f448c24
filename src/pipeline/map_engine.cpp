#include "mlmap/pipeline/map_engine.h"

#include "mlmap/core/stopwatch.h"
#include "listing_place.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace mlmap {
namespace {

using Clock = std::chrono::steady_clock;

// A running average of the milliseconds per frame of a part that either thread may run (the
// awareness map, the steps of the cone listing; the last 4 frames or so), -1 before the first.
double mapAverage(double average_ms, double frame_ms) {
  return average_ms < 0.0 ? frame_ms : average_ms + (frame_ms - average_ms) / 4.0;
}

// Adds a frame's listing steps on one thread to their running averages (those it did).
void addListingMs(const AwarenessStage::ListingMs& ms, std::atomic<double>* bins_ms,
                  std::atomic<double>* cones_ms) {
  if (ms.bins > 0.0) {
    bins_ms->store(mapAverage(bins_ms->load(std::memory_order_relaxed), ms.bins),
                   std::memory_order_relaxed);
  }
  if (ms.cones > 0.0) {
    cones_ms->store(mapAverage(cones_ms->load(std::memory_order_relaxed), ms.cones),
                    std::memory_order_relaxed);
  }
}

const MapConfig& validated(const MapConfig& config) {
  throwIfInvalid(config.validate(), "mlmap configuration");
  return config;
}

}  // namespace

const char* toString(FrameStatus status) {
  switch (status) {
    case FrameStatus::kAccepted:
      return "accepted";
    case FrameStatus::kInvalidPose:
      return "invalid pose";
    case FrameStatus::kOutOfOrder:
      return "out-of-order stamp";
    case FrameStatus::kEmpty:
      return "empty frame";
    case FrameStatus::kBadImage:
      return "bad depth image";
    case FrameStatus::kStopped:
      return "engine stopped";
  }
  return "invalid";
}

double MapEngine::RecentMinimum::add(double frame_ms) {
  ms[count++ % ms.size()] = frame_ms;
  return *std::min_element(ms.begin(), ms.begin() + std::min(count, ms.size()));
}

MapEngine::MapEngine(const MapConfig& config, LogSink log, EngineObservers observers)
    : config_(validated(config)),
      log_(std::move(log), 8),
      observers_(std::move(observers)),
      awareness_(config_),
      local_(config_.local_map, config_.log_odds),
      global_(config_.local_map.submap_cells(), config_.local_map.resolution_m),
      log_odds_model_(config_.log_odds),
      planning_(config_, config_.pipeline.threaded && config_.pipeline.planning_layers,
                [this](std::uint64_t frame, double stamp_s) {
                  if (observers_.esdf) observers_.esdf(frame, stamp_s);
                }),
      priors_(log_odds_model_) {
  if (config_.pipeline.threaded) {
    stages_ = std::make_unique<StageThreads>(
        config_.pipeline.input_queue_capacity, config_.pipeline.batch_queue_capacity,
        [this](Input& input, MeasurementBatch* batch) { awarenessStep(input, batch); },
        [this](MeasurementBatch& batch) {
          const Clock::time_point start = Clock::now();
          std::swap(batch.free, carve_free_);  // lent for the carving and the local map
          const double map_ms = carveStep(&batch);
          localStep(batch);
          std::swap(batch.free, carve_free_);
          const AwarenessStage::ListingMs listing_ms = awareness_.lastCarveListingMs();
          const double ms = msSince(start) - map_ms - listing_ms.bins - listing_ms.cones;
          local_half_ms_.store(local_recent_.add(ms), std::memory_order_relaxed);
          if (local_recent_.full()) local_recent_full_.store(true, std::memory_order_relaxed);
          if (map_ms > 0.0) {
            map_half_ms_.store(mapAverage(map_half_ms_.load(std::memory_order_relaxed), map_ms),
                               std::memory_order_relaxed);
          }
          addListingMs(listing_ms, &bins_half_ms_, &cones_half_ms_);
        });
  }
}

MapEngine::~MapEngine() { stages_.reset(); }  // the threads stop before the layers go

FrameStatus MapEngine::admit(double stamp_s, const Transform& T_W_B, const Transform& T_B_S) {
  double loaded_stamp_s = 0.0;  ///< set when this frame restarts the stamp order after a load
  bool restarted = false;
  const FrameStatus status = stats_.update([&](EngineStatsRecorder::Record& r) {
    ++r.stats.frames_in;
    const bool pose_ok =
        isMappablePose(T_W_B) && isValidPose(T_B_S) && T_B_S.translation().norm() < 100.0;
    if (!pose_ok) {
      ++r.stats.rejected_invalid_pose;
      return FrameStatus::kInvalidPose;
    }
    StampOrder& order = r.stamps;
    const bool in_order =
        !config_.pipeline.reject_out_of_order || !order.have_stamp || stamp_s > order.last_stamp_s;
    if (!std::isfinite(stamp_s) || (!in_order && !order.from_load)) {
      ++r.stats.rejected_out_of_order;
      return FrameStatus::kOutOfOrder;
    }
    if (!in_order) {  // the first frame after a load, older than the map: another time base
      restarted = true;
      loaded_stamp_s = order.last_stamp_s;
      ++r.stats.stamp_order_restarts;
    }
    order.last_stamp_s = stamp_s;
    order.have_stamp = true;
    order.from_load = false;
    return FrameStatus::kAccepted;
  });
  if (status != FrameStatus::kAccepted) return status;
  if (restarted) {
    std::ostringstream m;
    m.precision(15);
    m << "the first frame after loading the map has stamp " << stamp_s
      << " s, older than the map's last stamp " << loaded_stamp_s << " s by "
      << loaded_stamp_s - stamp_s
      << " s: the map was saved on another time base (wall-clock time against sim time, or a "
         "clock reset at boot); the stamp order restarts from this frame";
    log_.log(LogLevel::kWarning, 7, m.str());
  }
  return FrameStatus::kAccepted;
}

FrameStatus MapEngine::submit(PointCloudFrame frame) {
  FrameStatus status = admit(frame.stamp_s, frame.T_W_B, frame.T_B_S);
  if (status == FrameStatus::kAccepted && frame.points_S.empty()) {
    stats_.update([](EngineStatsRecorder::Record& r) { ++r.stats.rejected_empty; });
    status = FrameStatus::kEmpty;
  }
  if (status != FrameStatus::kAccepted) {
    std::ostringstream m;
    m << "rejected point cloud at t=" << frame.stamp_s << " s: " << toString(status);
    log_.log(LogLevel::kWarning, static_cast<int>(status), m.str());
    return status;
  }
  return enqueue(std::move(frame));
}

FrameStatus MapEngine::submit(DepthFrame frame) {
  FrameStatus status = admit(frame.stamp_s, frame.T_W_B, frame.T_B_S);
  if (status == FrameStatus::kAccepted) {
    const PinholeIntrinsics& K = frame.intrinsics;
    const std::size_t n = static_cast<std::size_t>(std::max(K.width, 0)) *
                          static_cast<std::size_t>(std::max(K.height, 0));
    const std::size_t have = frame.encoding == DepthEncoding::kUint16Millimetres
                                 ? frame.depth_mm.size()
                                 : frame.depth_m.size();
    if (n == 0 || have != n || !(K.fx > 0.0) || !(K.fy > 0.0) || !std::isfinite(K.cx) ||
        !std::isfinite(K.cy)) {
      stats_.update([](EngineStatsRecorder::Record& r) { ++r.stats.rejected_bad_image; });
      status = FrameStatus::kBadImage;
    }
  }
  if (status != FrameStatus::kAccepted) {
    std::ostringstream m;
    m << "rejected depth image at t=" << frame.stamp_s << " s: " << toString(status);
    log_.log(LogLevel::kWarning, static_cast<int>(status), m.str());
    return status;
  }
  return enqueue(std::move(frame));
}

FrameStatus MapEngine::enqueue(Input input) {
  if (!config_.pipeline.threaded) {
    process(input, &sync_batch_);
    return FrameStatus::kAccepted;
  }
  const StageThreads::Queued queued = stages_->push(std::move(input));
  if (queued == StageThreads::Queued::kStopped) return FrameStatus::kStopped;
  if (queued == StageThreads::Queued::kDroppedOldest) {
    stats_.update([](EngineStatsRecorder::Record& r) { ++r.stats.frames_dropped; });
    log_.log(LogLevel::kWarning, 6, "input queue full: dropped the oldest waiting frame");
  }
  return FrameStatus::kAccepted;
}

void MapEngine::awarenessStep(Input& input, MeasurementBatch* batch) {
  const Clock::time_point start = Clock::now();
  PointCounters counters;
  // Threaded: only the first half here; the carving runs on the local-global thread, beside the
  // next frame's first half (carveStep()). The awareness map goes to the half that is shorter
  // without it (the point loop is the longer half of a depth frame at a fine resolution, the
  // carving of a LiDAR scan).
  const bool split = config_.pipeline.threaded;
  if (split) {
    // With a margin of a quarter of the map's time, so that the place does not flip with every
    // frame (moving the map back to this half waits for the other to finish the maps it holds).
    const double local_ms = local_half_ms_.load(std::memory_order_relaxed);
    const double map_ms = std::max(map_half_ms_.load(std::memory_order_relaxed), 0.0);
    const double margin_ms = 0.25 * map_ms;
    if (!map_in_carve_ && local_ms >= 0.0 && local_ms < awareness_half_ms_ - margin_ms) {
      map_in_carve_ = true;
    } else if (map_in_carve_ && local_ms > awareness_half_ms_ + margin_ms) {
      map_in_carve_ = false;
    }
    awareness_.placeAwarenessMap(map_in_carve_);
    // Then the cone listing's steps, the map counted where it now is (placeConeListing()): to
    // this half while it stays the shorter with them (the streamed flight's carving half is the
    // longer one even without the map; the point loop is the longer half of a tabletop frame).
    // Further only once both halves have a full window of frames: a fresh engine's first frames
    // (its window's fresh pages) would move it for nothing.
    const bool settled =
        awareness_recent_.full() && local_recent_full_.load(std::memory_order_relaxed);
    HalvesMs halves;
    halves.awareness_ms = awareness_half_ms_ + (map_in_carve_ ? 0.0 : map_ms);
    halves.local_ms = local_ms + (map_in_carve_ ? map_ms : 0.0);
    halves.bins_ms = std::max(bins_half_ms_.load(std::memory_order_relaxed), 0.0);
    halves.cones_ms = std::max(cones_half_ms_.load(std::memory_order_relaxed), 0.0);
    listing_in_awareness_ = placeConeListing(listing_in_awareness_, halves, settled);
    awareness_.placeConeListing(listing_in_awareness_);
  }
  if (auto* points = std::get_if<PointCloudFrame>(&input)) {
    if (split) {
      awareness_.collect(*points, batch, &counters);
    } else {
      awareness_.process(*points, batch, &counters);
    }
  } else if (split) {
    awareness_.collect(std::get<DepthFrame>(input), batch, &counters);  // checked in submit()
  } else {
    awareness_.process(std::get<DepthFrame>(input), batch, &counters);
  }
  batch->awareness_ms = msSince(start);
  if (split) {
    const double map_ms = awareness_.lastCollectMapMs();
    const AwarenessStage::ListingMs listing_ms = awareness_.lastCollectListingMs();
    awareness_half_ms_ =
        awareness_recent_.add(batch->awareness_ms - map_ms - listing_ms.bins - listing_ms.cones);
    if (awareness_.lastCollectUpdatedMap()) {
      map_half_ms_.store(mapAverage(map_half_ms_.load(std::memory_order_relaxed), map_ms),
                         std::memory_order_relaxed);
    }
    addListingMs(listing_ms, &bins_half_ms_, &cones_half_ms_);
  }
  // Threaded, where carve() updates the awareness map, it calls the observer.
  if ((!split || awareness_.lastCollectUpdatedMap()) && observers_.awareness) {
    observers_.awareness(awareness_.map(), batch->stamp_s, batch->T_W_B);
  }
  const std::size_t free_bytes =
      split ? carve_free_bytes_.load(std::memory_order_relaxed) : batch->free.memoryBytes();
  const std::size_t bytes =
      awareness_.memoryBytes() + free_bytes + batch->hits.capacity() * sizeof(HitMeasurement);
  stats_.update([&](EngineStatsRecorder::Record& r) {
    r.stats.points += counters;
    r.stats.memory.awareness_bytes = bytes;
    if (!split) r.awareness_ms.add(batch->awareness_ms);  // threaded: with the carving's
  });
}

double MapEngine::carveStep(MeasurementBatch* batch) {
  const Clock::time_point start = Clock::now();
  PointCounters counters;
  const double map_ms = awareness_.carve(batch, &counters, [&](const AwarenessMap& map) {
    if (observers_.awareness) observers_.awareness(map, batch->stamp_s, batch->T_W_B);
  });
  batch->awareness_ms += msSince(start);
  carve_free_bytes_.store(batch->free.memoryBytes(), std::memory_order_relaxed);
  stats_.update([&](EngineStatsRecorder::Record& r) {
    r.stats.points += counters;
    r.awareness_ms.add(batch->awareness_ms);
  });
  return map_ms;
}

std::shared_ptr<const PriorVoxels> MapEngine::priors() const { return priors_.published(); }

void MapEngine::addPrior(const SubmapIndex& m, std::vector<VoxelRecord> records) {
  priors_.add(m, std::move(records));
}

void MapEngine::applyPriors() {
  const PriorStore::Applied applied = priors_.apply(local_, &global_);
  prior_voxels_added_ += applied.voxels_added;
  priors_waiting_ = applied.submaps_waiting;
}

void MapEngine::localStep(const MeasurementBatch& batch) {
  const Clock::time_point start = Clock::now();
  {
    std::lock_guard<std::mutex> lock(layers_mutex_);
    applyPriors();  // before re-centring: a submap entering the window now comes with them
    local_.recenter(batch.T_W_B.translation(), &global_);
    local_.integrate(batch);
    // Hits the window cannot hold keep their occupied evidence in the global map.
    beyond_window_.assign(batch.far_hits.begin(), batch.far_hits.end());
    for (const HitMeasurement& h : batch.hits) {
      if (!local_.contains(h.index)) beyond_window_.push_back(h.index);
    }
    std::uint64_t lost = 0;
    const std::size_t to_global =
        beyond_window_.empty() ? 0 : global_.addHits(&beyond_window_, log_odds_model_, &lost);
    hits_to_global_ += to_global;
    hits_lost_ += lost;
    has_mapped_stamp_ = true;
    last_mapped_stamp_s_ = batch.stamp_s;
    last_T_W_B_ = batch.T_W_B;
    ++frames_integrated_;
  }
  const double ms = msSince(start);
  if (config_.pipeline.planning_layers) {
    planning_.update(local_, global_, frames_integrated_, batch.stamp_s, batch.T_W_B);
    if (observers_.snapshot) observers_.snapshot(frames_integrated_, batch.stamp_s);
  }
  if (observers_.global) observers_.global(global_, batch.stamp_s, global_.modifications());
  const std::size_t global_bytes = global_.memoryBytes();
  const std::size_t planning_bytes = planning_.memoryBytes();
  stats_.update([&](EngineStatsRecorder::Record& r) {
    EngineStats& s = r.stats;
    s.memory.planning_bytes = planning_bytes;
    ++s.frames_mapped;
    s.local = local_.counters();
    s.memory.local_bytes = local_.memoryBytes();
    s.memory.global_bytes = global_bytes;
    s.global_voxels = global_.voxelCount();
    s.global_submaps = global_.submapCount();
    s.hits_to_global = hits_to_global_;
    s.hits_lost = hits_lost_;
    s.prior_voxels_added = prior_voxels_added_;
    s.prior_submaps_waiting = priors_waiting_;
    r.local_ms.add(ms);
    r.total_ms.add(ms + batch.awareness_ms);
  });
}

void MapEngine::process(Input& input, MeasurementBatch* batch) {
  awarenessStep(input, batch);
  localStep(*batch);
}

void MapEngine::flush() {
  if (!config_.pipeline.threaded) return;
  stages_->waitIdle();
  planning_.flush();
}

EngineStats MapEngine::stats() const {
  EngineStats s = stats_.stats();
  s.planning = planning_.stats();
  return s;
}

Occupancy MapEngine::state(const VoxelIndex& index) const {
  if (local_.contains(index)) return local_.state(index);
  const SubmapIndex m = local_.submapOf(index);
  const std::vector<VoxelRecord>* records = global_.find(m);
  if (records == nullptr) return Occupancy::kUnknown;
  const Eigen::Vector3i s = global_.submapCells();
  const VoxelIndex r = index - m.cwiseProduct(s);
  const std::uint32_t offset = static_cast<std::uint32_t>((r.x() * s.y() + r.y()) * s.z() + r.z());
  for (const VoxelRecord& rec : *records) {
    if (rec.offset == offset) return Occupancy::kOccupied;
  }
  return Occupancy::kUnknown;
}

std::vector<VoxelIndex> MapEngine::occupiedVoxels() const {
  std::vector<VoxelIndex> out;
  out.reserve(global_.voxelCount());
  global_.forEachVoxel([&](const VoxelIndex& g, double) { out.push_back(g); });
  local_.forEachOccupied([&](const VoxelIndex& g, double) { out.push_back(g); });
  return out;
}

MapState MapEngine::exportState() const {
  MapState state;
  state.local_map = config_.local_map;
  state.log_odds = config_.log_odds;
  std::lock_guard<std::mutex> lock(layers_mutex_);
  local_.copyWindow(&state.window);
  state.global_submaps.reserve(global_.submapCount());
  global_.forEachSubmap([&](const SubmapIndex& m, const std::vector<VoxelRecord>& records) {
    state.global_submaps.emplace_back(m, records);
  });
  std::sort(state.global_submaps.begin(), state.global_submaps.end(),
            [](const auto& a, const auto& b) {
              return std::lexicographical_compare(a.first.data(), a.first.data() + 3,
                                                  b.first.data(), b.first.data() + 3);
            });
  state.has_last_stamp = has_mapped_stamp_;
  state.last_stamp_s = last_mapped_stamp_s_;
  state.T_W_B = last_T_W_B_;
  state.frames_mapped = frames_restored_ + frames_integrated_;
  return state;
}

void MapEngine::restoreState(const MapState& state) {
  std::vector<std::string> errors = mapConfigDifferences(state, config_);
  if (errors.empty()) {  // judged against its own configuration, which must be this one
    for (std::string& problem : mapStateProblems(state)) errors.push_back(std::move(problem));
  }

  throwIfInvalid(errors, "map state");

  {
    std::lock_guard<std::mutex> lock(layers_mutex_);
    global_.clear();
    priors_.forgetAdded();  // the loaded map holds none of them
    for (const auto& [m, records] : state.global_submaps) {
      global_.store(m, std::vector<VoxelRecord>(records));
    }
    local_.restoreWindow(state.window);
    has_mapped_stamp_ = state.has_last_stamp;
    last_mapped_stamp_s_ = state.last_stamp_s;
    last_T_W_B_ = state.T_W_B;
    frames_restored_ = state.frames_mapped - std::min(state.frames_mapped, frames_integrated_);
  }
  stats_.update([&](EngineStatsRecorder::Record& r) {
    r.stamps.have_stamp = state.has_last_stamp;
    r.stamps.last_stamp_s = state.has_last_stamp ? state.last_stamp_s : -1e300;
    r.stamps.from_load = state.has_last_stamp;
    r.stats.global_voxels = global_.voxelCount();
    r.stats.global_submaps = global_.submapCount();
    r.stats.memory.global_bytes = global_.memoryBytes();
  });
  if (!config_.pipeline.planning_layers) return;
  planning_.update(local_, global_, frames_integrated_, state.last_stamp_s, state.T_W_B);
  planning_.flush();
}

void MapEngine::clear() {
  // Threaded: wait until no frame is queued or in flight, and keep the queue locked so that
  // neither stage starts one while the layers are emptied (both take this lock first).
  std::unique_lock<std::mutex> idle;
  if (config_.pipeline.threaded) idle = stages_->holdIdle();
  double stamp_s = 0.0;
  Transform T_W_B;  // set under the lock below
  std::uint64_t version = 0;
  {
    std::lock_guard<std::mutex> lock(layers_mutex_);
    global_.clear();
    local_.restoreWindow(LocalWindow{});  // an empty window unplaces the map
    // The priors added are gone with the map (ones still waiting are added later as usual).
    priors_.forgetAdded();
    stamp_s = last_mapped_stamp_s_;
    T_W_B = last_T_W_B_;
    version = global_.modifications();  // clear() counts as a modification
  }
  stats_.update([&](EngineStatsRecorder::Record& r) {
    r.stats.global_voxels = 0;
    r.stats.global_submaps = 0;
    r.stats.memory.global_bytes = global_.memoryBytes();
    r.stats.memory.local_bytes = local_.memoryBytes();
  });
  if (config_.pipeline.planning_layers) {
    planning_.update(local_, global_, frames_integrated_, stamp_s, T_W_B);
    planning_.flush();
    if (observers_.snapshot) observers_.snapshot(frames_integrated_, stamp_s);
  }
  if (observers_.global) observers_.global(global_, stamp_s, version);
}

}  // namespace mlmap
