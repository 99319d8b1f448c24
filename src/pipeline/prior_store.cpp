#include "mlmap/pipeline/prior_store.h"

#include <algorithm>
#include <iterator>

namespace mlmap {
namespace {
/// A submap index as 64 bits (21 per axis), for the pending priors' map.
std::uint64_t priorKey(const SubmapIndex& m) {
  std::uint64_t key = 0;
  for (int a = 0; a < 3; ++a)
    key = (key << 21) | (static_cast<std::uint64_t>(m[a] + (1 << 20)) & 0x1fffff);
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
  const auto it = std::lower_bound(
      held->begin(), held->end(), VoxelRecord{offset, 0},
      [](const VoxelRecord& a, const VoxelRecord& b) { return a.offset < b.offset; });
  return it != held->end() && it->offset == offset && window.at(g) == it->log_odds;
}

const std::vector<VoxelRecord>* PriorVoxels::inSubmap(const SubmapIndex& m) const {
  const auto it = submaps_.find(priorKey(m));
  return it == submaps_.end() ? nullptr : &it->second;
}

void PriorStore::add(const SubmapIndex& m, std::vector<VoxelRecord> records) {
  // Only occupied evidence is prior knowledge (a fleet sample also carries free evidence).
  records.erase(
      std::remove_if(records.begin(), records.end(),
                     [&](const VoxelRecord& r) { return !log_odds_.isOccupied(r.log_odds); }),
      records.end());
  if (records.empty()) return;
  if ((m.array() < -GlobalMap::kSubmapIndexLimit).any() ||
      (m.array() >= GlobalMap::kSubmapIndexLimit).any()) {
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  auto [it, inserted] = waiting_.try_emplace(priorKey(m), m, std::vector<VoxelRecord>{});
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

PriorStore::Applied PriorStore::apply(const LocalMap& local, GlobalMap* global) {
  Applied applied;
  std::lock_guard<std::mutex> lock(mutex_);
  if (waiting_.empty()) return applied;
  const Eigen::Vector3i cells = global->submapCells();
  std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> added;
  for (auto it = waiting_.begin(); it != waiting_.end();) {
    const SubmapIndex& m = it->second.first;
    if (local.placed() && local.contains(m.cwiseProduct(cells))) {
      ++applied.submaps_waiting;  // the window holds it: it waits until the submap leaves
      ++it;
      continue;
    }
    // A prior never reaches clamp_max, so the vehicle's own first hit changes it (and marks it
    // confirmed, PriorVoxels); it stays within the bounds the map keeps.
    for (VoxelRecord& r : it->second.second) {
      r.log_odds = static_cast<LogOddsQ>(
          std::clamp<int>(r.log_odds, log_odds_.clampMin(), log_odds_.clampMax() - 1));
    }
    // The voxels the global map does not hold yet are the ones addPrior() adds.
    const std::vector<VoxelRecord>* own = global->find(m);
    std::vector<VoxelRecord> taken;
    for (const VoxelRecord& r : it->second.second) {
      if (own != nullptr && std::binary_search(own->begin(), own->end(), r,
                                               [](const VoxelRecord& a, const VoxelRecord& b) {
                                                 return a.offset < b.offset;
                                               })) {
        continue;
      }
      taken.push_back(r);
    }
    applied.voxels_added += global->addPrior(m, it->second.second);
    if (!taken.empty()) added.emplace_back(m, std::move(taken));
    it = waiting_.erase(it);
  }
  if (!added.empty()) {
    added_ = std::make_shared<const PriorVoxels>(*added_, cells, added);
  }
  return applied;
}

std::shared_ptr<const PriorVoxels> PriorStore::published() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return added_;
}

void PriorStore::forgetAdded() {
  std::lock_guard<std::mutex> lock(mutex_);
  added_ = std::make_shared<const PriorVoxels>();
}

}  // namespace mlmap
