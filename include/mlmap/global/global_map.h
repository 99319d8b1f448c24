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
  /// Adds another vehicle's occupied voxels of a retired submap as prior knowledge: each voxel of
  /// `prior` (ascending offsets) that this map does not hold yet is added with its log-odds; the
  /// voxels this map holds keep theirs (the vehicle's own evidence wins). Stamps the submap when
  /// a voxel was added. Returns the number added. Not for a submap of the local window (the
  /// global map does not hold those: MapEngine::addPrior() waits until it leaves).
  std::size_t addPrior(const SubmapIndex& submap, const std::vector<VoxelRecord>& prior);
  /// Voxels of one submap, or nullptr.
  [[nodiscard]] const std::vector<VoxelRecord>* find(const SubmapIndex& submap) const;

  /// Calls f(submap index, its records) for every stored submap.
  template <typename F>
  void forEachSubmap(F&& f) const {
    for (const auto& [key, entry] : submaps_) f(unpack(key), entry.records);
  }

  /// Calls f(world voxel index, log-odds) for every stored voxel.
  template <typename F>
  void forEachVoxel(F&& f) const {
    for (const auto& [key, entry] : submaps_) {
      const SubmapIndex m = unpack(key);
      const VoxelIndex base = m.cwiseProduct(submap_cells_);
      for (const VoxelRecord& r : entry.records) {
        const int x = static_cast<int>(r.offset / plane_);
        const int rest = static_cast<int>(r.offset % plane_);
        f(VoxelIndex(base.x() + x, base.y() + rest / submap_cells_.z(),
                     base.z() + rest % submap_cells_.z()),
          dequantizeLogOdds(r.log_odds));
      }
    }
  }

  /// modifications() when submap `m`'s voxels last changed (stored, taken, hit), or 0 when they
  /// never did since the last clear(). Lets a reader that copied the map at version v find what
  /// changed since (forEachSubmapModifiedAfter()), e.g. to send only the changed submaps over a
  /// link. Storing an empty list for a submap that holds nothing changes nothing and is not
  /// stamped, so a flight through free space leaves no stamps.
  [[nodiscard]] std::uint64_t submapModifiedAt(const SubmapIndex& m) const;
  /// modifications() at the last clear() (0: never cleared). A copy made at a version before it
  /// must be dropped whole before forEachSubmapModifiedAfter() brings it up to date: clear()
  /// forgets the stamps of the submaps it removed.
  [[nodiscard]] std::uint64_t lastClearedAt() const { return cleared_at_; }
  /// Calls f(submap index, its records or nullptr when it holds none now) for every submap whose
  /// voxels changed after modifications() read `version` (submapModifiedAt(m) > version): the
  /// submaps a copy made at `version` must update, removed ones included. Visits every stored
  /// submap and every removed one still stamped (taken into the local window, or emptied), so it
  /// suits a reader that runs at a low rate.
  template <typename F>
  void forEachSubmapModifiedAfter(std::uint64_t version, F&& f) const {
    for (const auto& [key, entry] : submaps_) {
      if (entry.modified_at > version) f(unpack(key), &entry.records);
    }
    for (const auto& [key, stamp] : removed_at_) {
      if (stamp > version) f(unpack(key), static_cast<const std::vector<VoxelRecord>*>(nullptr));
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
  /// A stored submap: its records and modifications_ at their last change.
  struct Entry {
    std::vector<VoxelRecord> records;
    std::uint64_t modified_at = 0;
  };
  std::unordered_map<std::uint64_t, Entry> submaps_;
  /// Submaps removed (taken or emptied) since the last clear(): modifications_ at the removal.
  /// An entry leaves when the submap is stored again, so it holds about the local window's
  /// submaps.
  std::unordered_map<std::uint64_t, std::uint64_t> removed_at_;
  std::size_t voxel_count_ = 0;
  std::uint64_t modifications_ = 0;
  std::uint64_t cleared_at_ = 0;
};

}  // namespace mlmap
