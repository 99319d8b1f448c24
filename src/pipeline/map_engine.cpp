#include "mlmap/pipeline/map_engine.h"

#include "mlmap/core/stopwatch.h"

#include <algorithm>
#include <chrono>
#include <iterator>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace mlmap {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t kTimingWindow = 2000;   // frames kept for median / p99

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

void MapEngine::Samples::add(double v) {
  if (values.size() < kTimingWindow) {
    values.push_back(v);
  } else {
    values[next] = v;
  }
  next = (next + 1) % kTimingWindow;
}

double sortedQuantile(const std::vector<double>& sorted, double q) {
  const auto i = static_cast<std::size_t>(std::lround(q * static_cast<double>(sorted.size() - 1)));
  return sorted[std::min(i, sorted.size() - 1)];
}

TimingSummary summarizeTimings(std::vector<double> values_ms) {
  TimingSummary s;
  s.samples = values_ms.size();
  if (values_ms.empty()) return s;
  std::sort(values_ms.begin(), values_ms.end());
  s.median_ms = sortedQuantile(values_ms, 0.5);
  s.p99_ms = sortedQuantile(values_ms, 0.99);
  s.max_ms = values_ms.back();
  double sum = 0.0;
  for (double v : values_ms) sum += v;
  s.mean_ms = sum / static_cast<double>(values_ms.size());
  return s;
}

TimingSummary MapEngine::Samples::summary() const { return summarizeTimings(values); }

MapEngine::MapEngine(const MapConfig& config, LogSink log, EngineObservers observers)
    : config_(validated(config)),
      log_(std::move(log), 8),
      observers_(std::move(observers)),
      awareness_(config_),
      local_(config_.local_map, config_.log_odds),
      global_(config_.local_map.submap_cells(), config_.local_map.resolution_m),
      log_odds_model_(config_.log_odds),
      planning_(config_, config_.pipeline.threaded && config_.pipeline.planning_layers) {
  if (config_.pipeline.threaded) {
    for (int i = 0; i < config_.pipeline.batch_queue_capacity + 1; ++i) {
      batch_pool_.push_back(std::make_unique<MeasurementBatch>());
    }
    awareness_thread_ = std::thread([this] { awarenessLoop(); });
    local_thread_ = std::thread([this] { localLoop(); });
  }
}

MapEngine::~MapEngine() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stopping_ = true;
  }
  queue_cv_.notify_all();
  if (awareness_thread_.joinable()) awareness_thread_.join();
  if (local_thread_.joinable()) local_thread_.join();
}

FrameStatus MapEngine::admit(double stamp_s, const Transform& T_W_B, const Transform& T_B_S) {
  double loaded_stamp_s = 0.0;  ///< set when this frame restarts the stamp order after a load
  bool restarted = false;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.frames_in;
    const bool pose_ok =
        isMappablePose(T_W_B) && isValidPose(T_B_S) && T_B_S.translation().norm() < 100.0;
    if (!pose_ok) {
      ++stats_.rejected_invalid_pose;
      return FrameStatus::kInvalidPose;
    }
    const bool in_order = !config_.pipeline.reject_out_of_order || !have_stamp_ || stamp_s > last_stamp_s_;
    if (!std::isfinite(stamp_s) || (!in_order && !stamp_from_load_)) {
      ++stats_.rejected_out_of_order;
      return FrameStatus::kOutOfOrder;
    }
    if (!in_order) {  // the first frame after a load, older than the map: another time base
      restarted = true;
      loaded_stamp_s = last_stamp_s_;
      ++stats_.stamp_order_restarts;
    }
    last_stamp_s_ = stamp_s;
    have_stamp_ = true;
    stamp_from_load_ = false;
  }
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
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.rejected_empty;
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
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.rejected_bad_image;
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
  bool dropped = false;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (stopping_) return FrameStatus::kStopped;
    if (inputs_.size() >= static_cast<std::size_t>(config_.pipeline.input_queue_capacity)) {
      inputs_.pop_front();  // the oldest waiting frame gives way to the newest
      dropped = true;
    }
    inputs_.push_back(std::move(input));
  }
  queue_cv_.notify_all();
  if (dropped) {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.frames_dropped;
    }
    log_.log(LogLevel::kWarning, 6, "input queue full: dropped the oldest waiting frame");
  }
  return FrameStatus::kAccepted;
}

void MapEngine::awarenessStep(Input& input, MeasurementBatch* batch) {
  const Clock::time_point start = Clock::now();
  PointCounters counters;
  if (auto* points = std::get_if<PointCloudFrame>(&input)) {
    awareness_.process(*points, batch, &counters);
  } else {
    awareness_.process(std::get<DepthFrame>(input), batch, &counters);  // checked in submit()
  }
  batch->awareness_ms = msSince(start);
  if (observers_.awareness) observers_.awareness(awareness_.map(), batch->stamp_s, batch->T_W_B);
  const std::size_t bytes = awareness_.memoryBytes() + batch->free.memoryBytes() +
                            batch->hits.capacity() * sizeof(HitMeasurement);
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.points += counters;
  stats_.memory.awareness_bytes = bytes;
  awareness_ms_.add(batch->awareness_ms);
}

namespace {
/// A submap index as 64 bits (21 per axis), for the pending priors' map.
std::uint64_t priorKey(const SubmapIndex& m) {
  std::uint64_t key = 0;
  for (int a = 0; a < 3; ++a) key = (key << 21) | (static_cast<std::uint64_t>(m[a] + (1 << 20)) & 0x1fffff);
  return key;
}

/// The submap holding world voxel `g` (floor division per axis).
SubmapIndex submapOfVoxel(const VoxelIndex& g, const Eigen::Vector3i& submap_cells) {
  SubmapIndex m;
  for (int a = 0; a < 3; ++a) {
    const int q = g[a] / submap_cells[a];
    m[a] = g[a] % submap_cells[a] < 0 ? q - 1 : q;
  }
  return m;
}
}  // namespace

PriorVoxels::PriorVoxels(const PriorVoxels& earlier, const Eigen::Vector3i& submap_cells,
                         const std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>>& added)
    : submap_cells_(submap_cells), submaps_(earlier.submaps_), size_(earlier.size_) {
  auto by_offset = [](const VoxelRecord& a, const VoxelRecord& b) { return a.offset < b.offset; };
  for (const auto& [m, records] : added) {
    std::vector<VoxelRecord>& held = submaps_[priorKey(m)];
    std::vector<VoxelRecord> merged;  // a voxel added again takes its new value
    merged.reserve(held.size() + records.size());
    std::set_union(records.begin(), records.end(), held.begin(), held.end(),
                   std::back_inserter(merged), by_offset);
    size_ += merged.size() - held.size();
    held = std::move(merged);
  }
}

bool PriorVoxels::isPrior(const VoxelIndex& g, const LocalWindow& window) const {
  if (!window.contains(g)) return false;
  const SubmapIndex m = submapOfVoxel(g, submap_cells_);
  const std::vector<VoxelRecord>* held = inSubmap(m);
  if (held == nullptr) return false;
  const VoxelIndex t = g - m.cwiseProduct(submap_cells_);
  const auto offset =
      static_cast<std::uint32_t>((t.x() * submap_cells_.y() + t.y()) * submap_cells_.z() + t.z());
  const auto it = std::lower_bound(held->begin(), held->end(), VoxelRecord{offset, 0},
                                   [](const VoxelRecord& a, const VoxelRecord& b) {
                                     return a.offset < b.offset;
                                   });
  return it != held->end() && it->offset == offset && window.at(g) == it->log_odds;
}

const std::vector<VoxelRecord>* PriorVoxels::inSubmap(const SubmapIndex& m) const {
  const auto it = submaps_.find(priorKey(m));
  return it == submaps_.end() ? nullptr : &it->second;
}

std::shared_ptr<const PriorVoxels> MapEngine::priors() const {
  std::lock_guard<std::mutex> lock(prior_mutex_);
  return prior_voxels_;
}

void MapEngine::addPrior(const SubmapIndex& m, std::vector<VoxelRecord> records) {
  // Only occupied evidence is prior knowledge (a fleet sample also carries free evidence).
  records.erase(std::remove_if(records.begin(), records.end(),
                               [&](const VoxelRecord& r) { return !log_odds_model_.isOccupied(r.log_odds); }),
                records.end());
  if (records.empty()) return;
  if ((m.array() < -GlobalMap::kSubmapIndexLimit).any() ||
      (m.array() >= GlobalMap::kSubmapIndexLimit).any()) {
    return;
  }
  std::lock_guard<std::mutex> lock(prior_mutex_);
  auto [it, inserted] = priors_.try_emplace(priorKey(m), m, std::vector<VoxelRecord>{});
  if (inserted) {
    it->second.second = std::move(records);
    return;
  }
  // Merged with the one waiting: the union, the higher log-odds where both hold a voxel.
  std::vector<VoxelRecord>& waiting = it->second.second;
  std::vector<VoxelRecord> merged;
  merged.reserve(waiting.size() + records.size());
  auto a = waiting.begin();
  auto b = records.begin();
  while (a != waiting.end() || b != records.end()) {
    if (b == records.end() || (a != waiting.end() && a->offset < b->offset)) {
      merged.push_back(*a++);
    } else if (a == waiting.end() || b->offset < a->offset) {
      merged.push_back(*b++);
    } else {
      merged.push_back({a->offset, std::max(a->log_odds, b->log_odds)});
      ++a;
      ++b;
    }
  }
  waiting = std::move(merged);
}

void MapEngine::applyPriors() {
  std::lock_guard<std::mutex> lock(prior_mutex_);
  priors_waiting_ = 0;
  if (priors_.empty()) return;
  const Eigen::Vector3i cells = global_.submapCells();
  std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> added;
  for (auto it = priors_.begin(); it != priors_.end();) {
    const SubmapIndex& m = it->second.first;
    if (local_.placed() && local_.contains(m.cwiseProduct(cells))) {
      ++priors_waiting_;  // the window holds it: it waits until the submap leaves
      ++it;
      continue;
    }
    // A prior never reaches clamp_max, so the vehicle's own first hit changes it (and marks it
    // confirmed, PriorVoxels); it stays within the bounds the map keeps.
    for (VoxelRecord& r : it->second.second) {
      r.log_odds = static_cast<LogOddsQ>(std::clamp<int>(r.log_odds, log_odds_model_.clampMin(),
                                                         log_odds_model_.clampMax() - 1));
    }
    // The voxels the global map does not hold yet are the ones addPrior() adds.
    const std::vector<VoxelRecord>* own = global_.find(m);
    std::vector<VoxelRecord> taken;
    for (const VoxelRecord& r : it->second.second) {
      if (own != nullptr &&
          std::binary_search(own->begin(), own->end(), r,
                             [](const VoxelRecord& a, const VoxelRecord& b) { return a.offset < b.offset; })) {
        continue;
      }
      taken.push_back(r);
    }
    prior_voxels_added_ += global_.addPrior(m, it->second.second);
    if (!taken.empty()) added.emplace_back(m, std::move(taken));
    it = priors_.erase(it);
  }
  if (!added.empty()) {
    prior_voxels_ = std::make_shared<const PriorVoxels>(*prior_voxels_, cells, added);
  }
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
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.memory.planning_bytes = planning_bytes;
  ++stats_.frames_mapped;
  stats_.local = local_.counters();
  stats_.memory.local_bytes = local_.memoryBytes();
  stats_.memory.global_bytes = global_bytes;
  stats_.global_voxels = global_.voxelCount();
  stats_.global_submaps = global_.submapCount();
  stats_.hits_to_global = hits_to_global_;
  stats_.hits_lost = hits_lost_;
  stats_.prior_voxels_added = prior_voxels_added_;
  stats_.prior_submaps_waiting = priors_waiting_;
  local_ms_.add(ms);
  total_ms_.add(ms + batch.awareness_ms);
}

void MapEngine::process(Input& input, MeasurementBatch* batch) {
  awarenessStep(input, batch);
  localStep(*batch);
}

void MapEngine::awarenessLoop() {
  for (;;) {
    Input input;
    std::unique_ptr<MeasurementBatch> batch;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [&] { return stopping_ || (!inputs_.empty() && !batch_pool_.empty()); });
      if (stopping_) return;
      input = std::move(inputs_.front());
      inputs_.pop_front();
      batch = std::move(batch_pool_.back());
      batch_pool_.pop_back();
      ++in_flight_;
    }
    awarenessStep(input, batch.get());
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      // Back-pressure: wait for room rather than drop computed measurements.
      queue_cv_.wait(lock, [&] {
        return stopping_ ||
               batches_.size() < static_cast<std::size_t>(config_.pipeline.batch_queue_capacity);
      });
      if (stopping_) return;
      batches_.push_back(std::move(batch));
    }
    queue_cv_.notify_all();
  }
}

void MapEngine::localLoop() {
  for (;;) {
    std::unique_ptr<MeasurementBatch> batch;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [&] { return stopping_ || !batches_.empty(); });
      if (stopping_) return;
      batch = std::move(batches_.front());
      batches_.pop_front();
    }
    localStep(*batch);
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      batch_pool_.push_back(std::move(batch));
      --in_flight_;
    }
    queue_cv_.notify_all();
  }
}

void MapEngine::flush() {
  if (!config_.pipeline.threaded) return;
  {
    std::unique_lock<std::mutex> lock(queue_mutex_);
    queue_cv_.wait(lock, [&] { return stopping_ || (inputs_.empty() && in_flight_ == 0); });
  }
  planning_.flush();
}

EngineStats MapEngine::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  EngineStats s = stats_;
  s.awareness = awareness_ms_.summary();
  s.local_global = local_ms_.summary();
  s.total = total_ms_.summary();
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
    {
      std::lock_guard<std::mutex> prior_lock(prior_mutex_);  // the loaded map holds none of them
      prior_voxels_ = std::make_shared<const PriorVoxels>();
    }
    for (const auto& [m, records] : state.global_submaps) {
      global_.store(m, std::vector<VoxelRecord>(records));
    }
    local_.restoreWindow(state.window);
    has_mapped_stamp_ = state.has_last_stamp;
    last_mapped_stamp_s_ = state.last_stamp_s;
    last_T_W_B_ = state.T_W_B;
    frames_restored_ = state.frames_mapped - std::min(state.frames_mapped, frames_integrated_);
  }
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    have_stamp_ = state.has_last_stamp;
    last_stamp_s_ = state.has_last_stamp ? state.last_stamp_s : -1e300;
    stamp_from_load_ = state.has_last_stamp;
    stats_.global_voxels = global_.voxelCount();
    stats_.global_submaps = global_.submapCount();
    stats_.memory.global_bytes = global_.memoryBytes();
  }
  if (!config_.pipeline.planning_layers) return;
  planning_.update(local_, global_, frames_integrated_, state.last_stamp_s, state.T_W_B);
  planning_.flush();
}

void MapEngine::clear() {
  // Threaded: wait until no frame is queued or in flight, and keep the queue locked so that
  // neither stage starts one while the layers are emptied (both take this lock first).
  std::unique_lock<std::mutex> idle;
  if (config_.pipeline.threaded) {
    idle = std::unique_lock<std::mutex>(queue_mutex_);
    queue_cv_.wait(idle, [&] { return stopping_ || (inputs_.empty() && in_flight_ == 0); });
  }
  double stamp_s = 0.0;
  Transform T_W_B;  // set under the lock below
  std::uint64_t version = 0;
  {
    std::lock_guard<std::mutex> lock(layers_mutex_);
    global_.clear();
    local_.restoreWindow(LocalWindow{});  // an empty window unplaces the map
    {
      // The priors added are gone with the map (ones still waiting are added later as usual).
      std::lock_guard<std::mutex> prior_lock(prior_mutex_);
      prior_voxels_ = std::make_shared<const PriorVoxels>();
    }
    stamp_s = last_mapped_stamp_s_;
    T_W_B = last_T_W_B_;
    version = global_.modifications();  // clear() counts as a modification
  }
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.global_voxels = 0;
    stats_.global_submaps = 0;
    stats_.memory.global_bytes = global_.memoryBytes();
    stats_.memory.local_bytes = local_.memoryBytes();
  }
  if (config_.pipeline.planning_layers) {
    planning_.update(local_, global_, frames_integrated_, stamp_s, T_W_B);
    planning_.flush();
    if (observers_.snapshot) observers_.snapshot(frames_integrated_, stamp_s);
  }
  if (observers_.global) observers_.global(global_, stamp_s, version);
}

}  // namespace mlmap
