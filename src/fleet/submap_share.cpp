#include "mlmap/fleet/submap_share.h"

#include <algorithm>
#include <unordered_set>

namespace mlmap::fleet {
namespace {
constexpr int kBits = 21;
constexpr std::int64_t kBias = std::int64_t{1} << (kBits - 1);
constexpr std::uint64_t kMask = (std::uint64_t{1} << kBits) - 1;

/// FNV-1a over the records' offsets and values (a change of either changes the hash).
std::uint64_t contentHash(const std::vector<VoxelRecord>& records) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](std::uint64_t v) {
    for (int i = 0; i < 8; ++i, v >>= 8) {
      h ^= v & 0xff;
      h *= 1099511628211ull;
    }
  };
  mix(records.size());
  for (const VoxelRecord& r : records) {
    mix((std::uint64_t{r.offset} << 16) | static_cast<std::uint16_t>(r.log_odds));
  }
  return h;
}
}  // namespace

std::uint64_t packSubmap(const SubmapIndex& m) {
  std::uint64_t key = 0;
  for (int a = 0; a < 3; ++a) {
    key = (key << kBits) | (static_cast<std::uint64_t>(m[a] + kBias) & kMask);
  }
  return key;
}

SubmapIndex unpackSubmap(std::uint64_t key) {
  SubmapIndex m;
  for (int a = 2; a >= 0; --a) {
    m[a] = static_cast<int>(static_cast<std::int64_t>(key & kMask) - kBias);
    key >>= kBits;
  }
  return m;
}

void GlobalMapDelta::merge(GlobalMapDelta&& later) {
  version = later.version;
  if (later.cleared) {
    changed.clear();
    cleared = true;
  }
  std::unordered_map<std::uint64_t, std::size_t> at;
  for (std::size_t i = 0; i < changed.size(); ++i) at[packSubmap(changed[i].first)] = i;
  for (auto& entry : later.changed) {
    const auto it = at.find(packSubmap(entry.first));
    if (it != at.end()) {
      changed[it->second].second = std::move(entry.second);
    } else {
      changed.push_back(std::move(entry));
    }
  }
}

GlobalMapDelta collectGlobalDelta(const GlobalMap& map, std::uint64_t since) {
  GlobalMapDelta delta;
  delta.version = map.modifications();
  if (since < map.lastClearedAt()) {
    delta.cleared = true;
    since = 0;
  }
  map.forEachSubmapModifiedAfter(
      since, [&](const SubmapIndex& m, const std::vector<VoxelRecord>* records) {
        delta.changed.emplace_back(m, records != nullptr ? *records : std::vector<VoxelRecord>{});
      });
  return delta;
}

std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> windowSubmaps(
    const LocalWindow& window, const Eigen::Vector3i& submap_cells) {
  std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> out;
  if ((window.size.array() <= 0).any()) return out;
  const Eigen::Vector3i counts = window.size.cwiseQuotient(submap_cells);
  SubmapIndex first;
  for (int a = 0; a < 3; ++a) {
    const int q = window.min_index[a] / submap_cells[a];
    first[a] = window.min_index[a] % submap_cells[a] < 0 ? q - 1 : q;
  }
  const auto ny = static_cast<std::size_t>(window.size.y());
  const auto nz = static_cast<std::size_t>(window.size.z());
  for (int sx = 0; sx < counts.x(); ++sx) {
    for (int sy = 0; sy < counts.y(); ++sy) {
      for (int sz = 0; sz < counts.z(); ++sz) {
        const SubmapIndex m = first + SubmapIndex(sx, sy, sz);
        // The submap's first voxel relative to the window's (the window starts on the grid).
        const Eigen::Vector3i t0 = m.cwiseProduct(submap_cells) - window.min_index;
        std::vector<VoxelRecord> records;
        std::uint32_t offset = 0;
        for (int x = 0; x < submap_cells.x(); ++x) {
          for (int y = 0; y < submap_cells.y(); ++y) {
            const std::size_t row =
                (static_cast<std::size_t>(t0.x() + x) * ny + static_cast<std::size_t>(t0.y() + y)) *
                    nz +
                static_cast<std::size_t>(t0.z());
            for (int z = 0; z < submap_cells.z(); ++z, ++offset) {
              const LogOddsQ v = window.log_odds[row + static_cast<std::size_t>(z)];
              if (window.model.isOccupied(v)) records.push_back({offset, v});
            }
          }
        }
        out.emplace_back(m, std::move(records));
      }
    }
  }
  return out;
}

bool SubmapShare::differs(std::uint64_t key, const std::vector<VoxelRecord>& content) {
  const auto it = sent_.find(key);
  if (content.empty()) {
    if (it == sent_.end()) return false;
    sent_.erase(it);
    return true;
  }
  const std::uint64_t h = contentHash(content);
  if (it != sent_.end() && it->second == h) return false;
  sent_[key] = h;
  return true;
}

std::vector<SubmapUpdate> SubmapShare::changes(GlobalMapDelta&& delta, const LocalWindow* window,
                                               const PriorVoxels* priors) {
  const Eigen::Vector3i cells = submap_cells_;
  auto priorsOf = [priors](const SubmapIndex& m) {
    return priors != nullptr ? priors->inSubmap(m) : nullptr;
  };
  // A prior voxel the global map does not hold: lowered below occupancy, then retired.
  auto none = [](std::uint32_t) { return 0; };
  std::vector<SubmapUpdate> out;
  std::unordered_set<std::uint64_t> in_window;
  std::vector<std::uint64_t> window_keys;
  if (window != nullptr) {
    for (auto& [m, occupied] : windowSubmaps(*window, cells)) {
      const std::uint64_t key = packSubmap(m);
      in_window.insert(key);
      window_keys.push_back(key);
      const VoxelIndex base = m.cwiseProduct(cells);
      const int plane = cells.y() * cells.z();
      // The window's value of a prior voxel below occupancy (a voxel it never observed keeps
      // none of this vehicle's evidence: the prior's own value, no change).
      auto in_window_value = [&](std::uint32_t offset) -> int {
        const int o = static_cast<int>(offset);
        const VoxelIndex g = base + VoxelIndex(o / plane, (o % plane) / cells.z(), o % cells.z());
        return window->at(g);
      };
      const std::vector<VoxelRecord>* held = priorsOf(m);
      std::vector<VoxelRecord> records;
      if (held == nullptr) {
        records = std::move(occupied);
      } else {
        records = ownEvidence(occupied, held, [&](std::uint32_t offset) {
          const int v = in_window_value(offset);
          if (v != kUnknownLogOdds) return v;
          const auto p = std::lower_bound(
              held->begin(), held->end(), VoxelRecord{offset, 0},
              [](const VoxelRecord& a, const VoxelRecord& b) { return a.offset < b.offset; });
          return static_cast<int>(p->log_odds);
        });
      }
      if (differs(key, records)) out.push_back({m, std::move(records)});
    }
  }
  std::unordered_set<std::uint64_t> seen;
  if (delta.cleared) {  // every submap sent and now neither in the window nor in the delta: empty
    std::unordered_set<std::uint64_t> in_delta;
    for (const auto& entry : delta.changed) in_delta.insert(packSubmap(entry.first));
    std::vector<std::uint64_t> gone;
    for (const auto& entry : sent_) {
      if (in_window.count(entry.first) == 0 && in_delta.count(entry.first) == 0) {
        gone.push_back(entry.first);
      }
    }
    for (const std::uint64_t key : gone) {
      sent_.erase(key);
      out.push_back({unpackSubmap(key), {}});
      seen.insert(key);
    }
  }
  for (auto& [m, occupied] : delta.changed) {
    const std::uint64_t key = packSubmap(m);
    if (in_window.count(key) != 0) continue;  // the window's content is the current one
    seen.insert(key);
    const std::vector<VoxelRecord>* held = priorsOf(m);
    std::vector<VoxelRecord> records =
        held == nullptr ? std::move(occupied) : ownEvidence(occupied, held, none);
    if (differs(key, records)) out.push_back({m, std::move(records)});
  }
  if (window == nullptr) return out;
  // Submaps that left the window with nothing occupied are not stamped in the global map.
  for (const std::uint64_t key : last_window_) {
    if (in_window.count(key) != 0 || seen.count(key) != 0) continue;
    const SubmapIndex m = unpackSubmap(key);
    std::vector<VoxelRecord> records = ownEvidence({}, priorsOf(m), none);
    if (differs(key, records)) out.push_back({m, std::move(records)});
  }
  last_window_ = std::move(window_keys);
  return out;
}

void SubmapShare::reset() {
  sent_.clear();
  last_window_.clear();
}

}  // namespace mlmap::fleet
