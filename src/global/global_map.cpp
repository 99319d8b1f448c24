#include "mlmap/global/global_map.h"

#include <algorithm>

namespace mlmap {
namespace {
constexpr int kBits = 21;
constexpr std::int64_t kBias = GlobalMap::kSubmapIndexLimit;
static_assert(kBias == std::int64_t{1} << (kBits - 1));
constexpr std::uint64_t kMask = (std::uint64_t{1} << kBits) - 1;
}  // namespace

GlobalMap::GlobalMap(const Eigen::Vector3i& submap_cells, double resolution_m)
    : submap_cells_(submap_cells),
      plane_(static_cast<std::uint32_t>(submap_cells.y() * submap_cells.z())),
      resolution_m_(resolution_m) {}

std::uint64_t GlobalMap::pack(const SubmapIndex& m) {
  std::uint64_t key = 0;
  for (int a = 0; a < 3; ++a) {
    key = (key << kBits) | (static_cast<std::uint64_t>(m[a] + kBias) & kMask);
  }
  return key;
}

SubmapIndex GlobalMap::unpack(std::uint64_t key) {
  SubmapIndex m;
  for (int a = 2; a >= 0; --a) {
    m[a] = static_cast<int>(static_cast<std::int64_t>(key & kMask) - kBias);
    key >>= kBits;
  }
  return m;
}

void GlobalMap::store(const SubmapIndex& submap, std::vector<VoxelRecord>&& records) {
  ++modifications_;
  const std::uint64_t key = pack(submap);
  auto it = submaps_.find(key);
  if (it != submaps_.end()) {
    voxel_count_ -= it->second.records.size();
    if (records.empty()) {
      submaps_.erase(it);
      removed_at_[key] = modifications_;
      return;
    }
    it->second.records = std::move(records);
    it->second.modified_at = modifications_;
    voxel_count_ += it->second.records.size();
    return;
  }
  if (records.empty()) return;  // nothing held, nothing to hold: unchanged
  records.shrink_to_fit();
  voxel_count_ += records.size();
  removed_at_.erase(key);
  submaps_.emplace(key, Entry{std::move(records), modifications_});
}

bool GlobalMap::take(const SubmapIndex& submap, std::vector<VoxelRecord>* records) {
  auto it = submaps_.find(pack(submap));
  if (it == submaps_.end()) return false;
  ++modifications_;
  voxel_count_ -= it->second.records.size();
  *records = std::move(it->second.records);
  removed_at_[it->first] = modifications_;
  submaps_.erase(it);
  return true;
}

std::size_t GlobalMap::addHits(std::vector<VoxelIndex>* hits, const LogOddsModel& model,
                               std::uint64_t* lost) {
  // Sorted by (submap, offset): each submap's hits in one run, merged into its sorted records.
  struct Keyed {
    std::uint64_t submap;
    std::uint32_t offset;
    bool operator<(const Keyed& o) const {
      return submap != o.submap ? submap < o.submap : offset < o.offset;
    }
    bool operator==(const Keyed& o) const { return submap == o.submap && offset == o.offset; }
  };
  std::vector<Keyed> keyed;
  keyed.reserve(hits->size());
  for (const VoxelIndex& v : *hits) {
    SubmapIndex m;
    for (int a = 0; a < 3; ++a) {
      const int q = v[a] / submap_cells_[a];
      m[a] = v[a] % submap_cells_[a] < 0 ? q - 1 : q;
    }
    if ((m.array() < -kSubmapIndexLimit).any() || (m.array() >= kSubmapIndexLimit).any()) {
      ++*lost;
      continue;
    }
    const Eigen::Vector3i r = v - m.cwiseProduct(submap_cells_);
    keyed.push_back({pack(m), static_cast<std::uint32_t>(r.x()) * plane_ +
                                  static_cast<std::uint32_t>(r.y() * submap_cells_.z() + r.z())});
  }
  std::sort(keyed.begin(), keyed.end());
  keyed.erase(std::unique(keyed.begin(), keyed.end()), keyed.end());
  hits->clear();
  if (keyed.empty()) return 0;
  ++modifications_;
  std::vector<VoxelRecord> added;
  for (std::size_t first = 0; first < keyed.size();) {
    std::size_t last = first;
    while (last < keyed.size() && keyed[last].submap == keyed[first].submap) ++last;
    Entry& entry = submaps_[keyed[first].submap];
    if (entry.modified_at == 0) removed_at_.erase(keyed[first].submap);  // a new entry
    entry.modified_at = modifications_;
    std::vector<VoxelRecord>& records = entry.records;
    added.clear();
    for (std::size_t i = first; i < last; ++i) {
      auto it =
          std::lower_bound(records.begin(), records.end(), keyed[i].offset,
                           [](const VoxelRecord& r, std::uint32_t o) { return r.offset < o; });
      if (it != records.end() && it->offset == keyed[i].offset) {
        model.hit(it->log_odds);
      } else {
        LogOddsQ v = kUnknownLogOdds;
        model.hit(v);
        added.push_back({keyed[i].offset, v});
      }
    }
    if (!added.empty()) {
      const auto middle = static_cast<std::ptrdiff_t>(records.size());
      records.insert(records.end(), added.begin(), added.end());
      std::inplace_merge(
          records.begin(), records.begin() + middle, records.end(),
          [](const VoxelRecord& a, const VoxelRecord& b) { return a.offset < b.offset; });
      voxel_count_ += added.size();
    }
    first = last;
  }
  return keyed.size();
}

const std::vector<VoxelRecord>* GlobalMap::find(const SubmapIndex& submap) const {
  auto it = submaps_.find(pack(submap));
  return it == submaps_.end() ? nullptr : &it->second.records;
}

std::size_t GlobalMap::addPrior(const SubmapIndex& submap, const std::vector<VoxelRecord>& prior) {
  if (prior.empty()) return 0;
  const std::uint64_t key = pack(submap);
  auto it = submaps_.find(key);
  const std::vector<VoxelRecord> none;
  const std::vector<VoxelRecord>& own = it == submaps_.end() ? none : it->second.records;
  std::vector<VoxelRecord> merged;
  merged.reserve(own.size() + prior.size());
  std::size_t added = 0;
  auto o = own.begin();
  for (const VoxelRecord& p : prior) {
    while (o != own.end() && o->offset < p.offset) merged.push_back(*o++);
    if (o != own.end() && o->offset == p.offset) continue;  // the own value wins
    merged.push_back(p);
    ++added;
  }
  merged.insert(merged.end(), o, own.end());
  if (added == 0) return 0;
  ++modifications_;
  voxel_count_ += added;
  merged.shrink_to_fit();
  if (it == submaps_.end()) {
    removed_at_.erase(key);
    submaps_.emplace(key, Entry{std::move(merged), modifications_});
  } else {
    it->second.records = std::move(merged);
    it->second.modified_at = modifications_;
  }
  return added;
}

std::uint64_t GlobalMap::submapModifiedAt(const SubmapIndex& m) const {
  const std::uint64_t key = pack(m);
  const auto it = submaps_.find(key);
  if (it != submaps_.end()) return it->second.modified_at;
  const auto removed = removed_at_.find(key);
  return removed == removed_at_.end() ? 0 : removed->second;
}

std::size_t GlobalMap::memoryBytes() const {
  // Node: key + vector header + next pointer + cached hash; plus one pointer per bucket.
  constexpr std::size_t kNodeBytes = sizeof(std::uint64_t) + sizeof(Entry) + 2 * sizeof(void*);
  constexpr std::size_t kRemovedNodeBytes = 2 * sizeof(std::uint64_t) + 2 * sizeof(void*);
  std::size_t bytes = submaps_.bucket_count() * sizeof(void*) + submaps_.size() * kNodeBytes +
                      removed_at_.bucket_count() * sizeof(void*) +
                      removed_at_.size() * kRemovedNodeBytes;
  for (const auto& entry : submaps_) {
    bytes += entry.second.records.capacity() * sizeof(VoxelRecord);
  }
  return bytes;
}

}  // namespace mlmap

namespace mlmap {

void GlobalMap::clear() {
  ++modifications_;
  cleared_at_ = modifications_;
  submaps_.clear();
  removed_at_.clear();
  voxel_count_ = 0;
}

}  // namespace mlmap
