#pragma once
/// @file
/// The global map (paper IV-C, VI-D): the inactive area. A submap that leaves the local map keeps
/// only its occupied voxels (with their log-odds), filed under its submap index in a hash map, so
/// memory grows with occupied voxels and not with the area flown. Flying back hands them back.

#include "mlmap/core/log_odds.h"
#include "mlmap/core/types.h"

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace mlmap {

/// Index of a submap on the world grid: submap m holds voxels [m * submap_cells, (m+1) * ...).
using SubmapIndex = Eigen::Vector3i;

/// One occupied voxel of a retired submap: its offset inside the submap (x-major) and log-odds.
struct VoxelRecord {
  std::uint32_t offset;
  LogOddsQ log_odds;
};

/// Occupied voxels of retired submaps. Not thread-safe: owned by the local-global stage.
class GlobalMap {
 public:
  /// Submap indices are stored in 21 bits per axis: each must lie in [-kSubmapIndexLimit,
  /// kSubmapIndexLimit).
  static constexpr int kSubmapIndexLimit = 1 << 20;

  /// `submap_cells`: voxels per submap and axis; `resolution_m`: voxel size.
  GlobalMap(const Eigen::Vector3i& submap_cells, double resolution_m);

  /// Files the occupied voxels of a retired submap (replacing what was there). An empty list
  /// removes the entry.
  void store(const SubmapIndex& submap, std::vector<VoxelRecord>&& records);
  /// Moves a submap's voxels out (for the local map when the submap becomes active again).
  /// Returns false when nothing is stored for it.
  bool take(const SubmapIndex& submap, std::vector<VoxelRecord>* records);
  /// Removes every stored submap.
  void clear();
  /// Applies one hit (`model`) to each distinct voxel of `hits` (world voxel indices; sorted and
  /// made unique in place): hits outside the local window, whose submaps are retired. A voxel not
  /// stored yet starts unknown. Returns the number of voxels updated; hits whose submap index
  /// lies beyond kSubmapIndexLimit are left out and added to `*lost`.
  std::size_t addHits(std::vector<VoxelIndex>* hits, const LogOddsModel& model,
                      std::uint64_t* lost);
  /// Voxels of one submap, or nullptr.
  [[nodiscard]] const std::vector<VoxelRecord>* find(const SubmapIndex& submap) const;

  /// Calls f(submap index, its records) for every stored submap.
  template <typename F>
  void forEachSubmap(F&& f) const {
    for (const auto& [key, records] : submaps_) f(unpack(key), records);
  }

  /// Calls f(world voxel index, log-odds) for every stored voxel.
  template <typename F>
  void forEachVoxel(F&& f) const {
    for (const auto& [key, records] : submaps_) {
      const SubmapIndex m = unpack(key);
      const VoxelIndex base = m.cwiseProduct(submap_cells_);
      for (const VoxelRecord& r : records) {
        const int x = static_cast<int>(r.offset / plane_);
        const int rest = static_cast<int>(r.offset % plane_);
        f(VoxelIndex(base.x() + x, base.y() + rest / submap_cells_.z(),
                     base.z() + rest % submap_cells_.z()),
          dequantizeLogOdds(r.log_odds));
      }
    }
  }

  [[nodiscard]] std::size_t submapCount() const { return submaps_.size(); }
  /// Number of store(), successful take() and clear() calls so far: equal values mean an
  /// unchanged map (for readers that cache something derived from it).
  [[nodiscard]] std::uint64_t modifications() const { return modifications_; }
  [[nodiscard]] std::size_t voxelCount() const { return voxel_count_; }
  /// Bytes held: records plus an estimate of the hash map's own nodes and buckets.
  [[nodiscard]] std::size_t memoryBytes() const;
  [[nodiscard]] const Eigen::Vector3i& submapCells() const { return submap_cells_; }
  [[nodiscard]] double resolution_m() const { return resolution_m_; }

 private:
  static std::uint64_t pack(const SubmapIndex& m);
  static SubmapIndex unpack(std::uint64_t key);

  Eigen::Vector3i submap_cells_;
  std::uint32_t plane_;  // voxels per x-slice of a submap
  double resolution_m_;
  std::unordered_map<std::uint64_t, std::vector<VoxelRecord>> submaps_;
  std::size_t voxel_count_ = 0;
  std::uint64_t modifications_ = 0;
};

}  // namespace mlmap
