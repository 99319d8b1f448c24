#include "mlmap/planning/esdf_change_tracker.h"

#include <array>

namespace mlmap {

void EsdfLineMarks::take(int nx, int per_slab, std::vector<EsdfMarkedLine>* marked,
                         std::vector<EsdfMarkedLine>* sorted, std::vector<int>* starts) {
  marked->clear();
  // Most lines are unmarked: looked at kScan at a time without a branch first (it vectorises).
  constexpr int kScan = 16;
  int* const lo_at = lo_.data();
  int* const hi_at = hi_.data();
  const int length = length_;  // (a local: the stores through lo_at cannot change it)
  for (int x = 0; x < nx; ++x) {
    const std::size_t first = static_cast<std::size_t>(x) * static_cast<std::size_t>(per_slab);
    for (int a0 = 0; a0 < per_slab; a0 += kScan) {
      const int a_end = std::min(per_slab, a0 + kScan);
      int any = 0;
      for (int a = a0; a < a_end; ++a) any |= static_cast<int>(hi_at[first + a] >= 0);
      if (any == 0) continue;
      for (int a = a0; a < a_end; ++a) {
        const std::size_t i = first + static_cast<std::size_t>(a);
        if (hi_at[i] < 0) continue;
        marked->push_back({x, a, lo_at[i], hi_at[i]});
        lo_at[i] = length;
        hi_at[i] = -1;
      }
    }
  }
  std::vector<int>& at = *starts;
  at.assign(static_cast<std::size_t>(length) + 1, 0);
  for (const EsdfMarkedLine& l : *marked) ++at[static_cast<std::size_t>(l.lo) + 1];
  for (std::size_t i = 1; i < at.size(); ++i) at[i] += at[i - 1];
  sorted->resize(marked->size());
  for (const EsdfMarkedLine& l : *marked) {
    (*sorted)[static_cast<std::size_t>(at[static_cast<std::size_t>(l.lo)]++)] = l;
  }
}

void EsdfChangeTracker::reset(const Eigen::Vector3i& size) {
  size_ = size;
  const auto nx = static_cast<std::size_t>(size_.x());
  const auto ny = static_cast<std::size_t>(size_.y());
  const auto nz = static_cast<std::size_t>(size_.z());
  kept_states_.resize(nx * ny * nz);
  y_marks_.reset(nx * nz, size_.y());
  z_marks_.reset(nx * ny, size_.z());
}

bool EsdfChangeTracker::collectChangedStates(const std::uint8_t* now, std::size_t budget,
                                             const std::vector<EsdfRegion>* regions) {
  const std::uint8_t* kept = kept_states_.data();
  changed_states_.clear();
  // Appends the changed voxels of [i, end), 64 at a time.
  const auto compare = [&](std::size_t i, std::size_t end) {
    while (i < end) {
      const std::size_t n = std::min<std::size_t>(64, end - i);
      if (std::memcmp(now + i, kept + i, n) != 0) {
        for (std::size_t j = i; j < i + n; ++j) {
          if (now[j] != kept[j]) changed_states_.push_back(static_cast<std::uint32_t>(j));
        }
      }
      i += n;
    }
  };
  if (regions == nullptr) {
    const std::size_t cells = kept_states_.size();
    for (std::size_t i = 0; i < cells; i += 4096) {
      compare(i, std::min(cells, i + 4096));
      if (changed_states_.size() > budget) return false;
    }
    return true;
  }
  const auto ny = static_cast<std::size_t>(size_.y());
  const auto nz = static_cast<std::size_t>(size_.z());
  // Clipped, and regions stacked along z over the same x and y extents merged (submaps one
  // above the other): a column is then compared in one run instead of several short ones.
  std::vector<EsdfRegion>& merged = merged_regions_;
  merged.clear();
  for (const EsdfRegion& r : *regions) {
    const EsdfRegion clipped{r.lo.cwiseMax(0), r.hi.cwiseMin(size_)};
    if ((clipped.hi.array() > clipped.lo.array()).all()) merged.push_back(clipped);
  }
  const auto key = [](const EsdfRegion& r) {
    return std::array<int, 5>{r.lo.x(), r.lo.y(), r.hi.x(), r.hi.y(), r.lo.z()};
  };
  std::sort(merged.begin(), merged.end(),
            [&](const EsdfRegion& a, const EsdfRegion& b) { return key(a) < key(b); });
  std::size_t merged_count = 0;
  for (const EsdfRegion& r : merged) {
    EsdfRegion* last = merged_count > 0 ? &merged[merged_count - 1] : nullptr;
    if (last != nullptr && last->lo.head<2>() == r.lo.head<2>() &&
        last->hi.head<2>() == r.hi.head<2>() && r.lo.z() <= last->hi.z()) {
      last->hi.z() = std::max(last->hi.z(), r.hi.z());
    } else {
      merged[merged_count++] = r;
    }
  }
  merged.resize(merged_count);
  for (const EsdfRegion& r : merged) {
    const Eigen::Vector3i& lo = r.lo;
    const Eigen::Vector3i& hi = r.hi;
    for (int x = lo.x(); x < hi.x(); ++x) {
      for (int y = lo.y(); y < hi.y(); ++y) {
        const std::size_t column =
            (static_cast<std::size_t>(x) * ny + static_cast<std::size_t>(y)) * nz;
        compare(column + static_cast<std::size_t>(lo.z()),
                column + static_cast<std::size_t>(hi.z()));
      }
    }
    if (changed_states_.size() > budget) return false;
  }
  // Overlapping regions list a voxel once (most callers' regions are disjoint submaps: then
  // there is nothing to sort).
  const auto overlap = [](const EsdfRegion& a, const EsdfRegion& b) {
    return (a.lo.array() < b.hi.array()).all() && (b.lo.array() < a.hi.array()).all();
  };
  bool any_overlap = false;
  for (std::size_t i = 0; i < merged.size() && !any_overlap; ++i) {
    for (std::size_t j = i + 1; j < merged.size() && !any_overlap; ++j) {
      any_overlap = overlap(merged[i], merged[j]);
    }
  }
  if (any_overlap) {
    std::sort(changed_states_.begin(), changed_states_.end());
    changed_states_.erase(std::unique(changed_states_.begin(), changed_states_.end()),
                          changed_states_.end());
  }
  return true;
}

std::size_t EsdfChangeTracker::memoryBytes() const {
  return kept_states_.capacity() + changed_states_.capacity() * sizeof(std::uint32_t) +
         merged_regions_.capacity() * sizeof(EsdfRegion) + rows_.capacity() * sizeof(RowSpan) +
         y_marks_.memoryBytes() + z_marks_.memoryBytes() +
         (marked_.capacity() + sorted_.capacity()) * sizeof(EsdfMarkedLine) +
         starts_.capacity() * sizeof(int);
}

}  // namespace mlmap
