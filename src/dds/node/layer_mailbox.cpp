#include "layer_mailbox.h"

#include "mlmap/core/stopwatch.h"

#include <utility>

namespace mlmap::dds::node {

RateGate::RateGate(double rate_hz)
    : period_s_(rate_hz > 0 ? 1.0 / rate_hz : 0.0), enabled_(rate_hz > 0) {}

bool RateGate::due() const {
  return enabled_ &&
         (last_ == Clock::time_point::min() || secondsBetween(last_, Clock::now()) >= period_s_);
}

void RateGate::mark() { last_ = Clock::now(); }

LayerMailbox::LayerMailbox(const PublishRates& rates, double fleet_rate_hz)
    : awareness_gate_(rates.awareness_hz),
      global_gate_(rates.global_map_hz),
      fleet_gate_(fleet_rate_hz) {}

void LayerMailbox::copyAwareness(const AwarenessMap& map, double stamp_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!awareness_gate_.due()) return;
  awareness_gate_.mark();
  awareness_.points_W.clear();
  AwarenessCell cell;
  for (const Eigen::Vector3d& p : map.occupiedPoints()) {
    if (map.cellOf(p, &cell)) awareness_.points_W.push_back(map.cellCenter(cell).cast<float>());
  }
  awareness_.stamp_s = stamp_s;
  awareness_.fresh = true;
  cv_.notify_one();
}

void LayerMailbox::copyGlobal(const GlobalMap& map, double stamp_s, std::uint64_t version,
                              bool force) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (version == global_version_ || (!force && !global_gate_.due())) return;
  global_gate_.mark();
  global_version_ = version;
  global_.points_W.clear();
  global_.points_W.reserve(map.voxelCount());
  const double res = map.resolution_m();
  map.forEachVoxel([&](const VoxelIndex& g, double) {
    global_.points_W.push_back(voxelCenter(g, res).cast<float>());
  });
  global_.stamp_s = stamp_s;
  global_.fresh = true;
  cv_.notify_one();
}

void LayerMailbox::copyFleet(const GlobalMap& map, std::shared_ptr<const MapSnapshot> snap,
                             std::shared_ptr<const PriorVoxels> priors, bool force) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!(force || fleet_gate_.due())) return;
  fleet_gate_.mark();
  fleet::GlobalMapDelta delta = fleet::collectGlobalDelta(map, fleet_version_);
  fleet_version_ = delta.version;
  fleet_.delta.merge(std::move(delta));
  fleet_.snap = std::move(snap);
  fleet_.priors = std::move(priors);
  fleet_.fresh = true;
  cv_.notify_one();
}

void LayerMailbox::announceSnapshot() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    snapshot_fresh_ = true;
  }
  cv_.notify_one();
}

void LayerMailbox::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  cv_.notify_all();
}

LayerMailbox::News LayerMailbox::take(std::chrono::milliseconds poll) {
  News news;
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait_for(lock, poll, [this] {
    return closed_ || snapshot_fresh_ || awareness_.fresh || global_.fresh || fleet_.fresh;
  });
  news.last = closed_;
  snapshot_fresh_ = false;
  if (awareness_.fresh) std::swap(news.awareness, awareness_);
  if (global_.fresh) std::swap(news.global, global_);
  if (fleet_.fresh) std::swap(news.fleet, fleet_);
  awareness_.fresh = global_.fresh = fleet_.fresh = false;
  fleet_.delta = fleet::GlobalMapDelta{};
  fleet_.snap.reset();
  fleet_.priors.reset();
  return news;
}

}  // namespace mlmap::dds::node
