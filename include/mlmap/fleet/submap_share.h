#pragma once
/// @file
/// The sending side of the fleet: which of a vehicle's submaps changed since they last went out.
///
/// A vehicle's map is the union of its global map (retired submaps) and its local window (the
/// 5 x 5 x 5 active submaps); a submap's content is its occupied voxels with their log-odds, from
/// the window while it is active and from the global map otherwise (a submap moving between the
/// two keeps its content). The engine's thread collects what changed in the global map since the
/// last collection (GlobalMapDelta, only the changed submaps' records) together with the window
/// of the same frame; the sending thread hands both to SubmapShare, which compares each candidate
/// submap's content with what was sent last (a 64-bit hash per submap) and returns the ones that
/// differ. A hovering vehicle whose voxels saturated sends nothing.

#include "mlmap/global/global_map.h"
#include "mlmap/local/local_map.h"

#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

namespace mlmap::fleet {

/// A submap index packed into 64 bits (21 bits per axis, as GlobalMap), for hash maps.
std::uint64_t packSubmap(const SubmapIndex& m);
/// The inverse of packSubmap().
SubmapIndex unpackSubmap(std::uint64_t key);

/// What changed in a global map between two collections.
struct GlobalMapDelta {
  /// The global map's modifications() when collected (the next collection's `since`).
  std::uint64_t version = 0;
  /// Submaps whose content changed, with their records now (empty: removed, e.g. taken into
  /// the window). Later collections merged in with merge() override earlier ones.
  std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> changed;
  /// The map was cleared in between: every submap sent before and not in `changed` is empty now.
  bool cleared = false;

  /// Adds a later delta to this one (its entries win).
  void merge(GlobalMapDelta&& later);
};

/// The submaps of `map` changed after version `since` (0: every stored submap), with their
/// records. Run it on the thread that owns the map.
GlobalMapDelta collectGlobalDelta(const GlobalMap& map, std::uint64_t since);

/// The occupied voxels (by `window.model`) of each submap of the window, as GlobalMap would hold
/// them after retiring it: ascending offsets inside the submap. `submap_cells`: voxels per submap
/// and axis. Submaps without occupied voxels are listed with no records.
std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> windowSubmaps(
    const LocalWindow& window, const Eigen::Vector3i& submap_cells);

/// One submap to send: its index and its content now (empty: it holds no occupied voxel).
struct SubmapUpdate {
  SubmapIndex index = SubmapIndex::Zero();
  std::vector<VoxelRecord> records;
};

/// What has been sent, per submap, and the submaps that must be looked at again.
class SubmapShare {
 public:
  explicit SubmapShare(const Eigen::Vector3i& submap_cells) : submap_cells_(submap_cells) {}

  /// The submaps whose content differs from what was last sent, given the global changes
  /// collected since the previous call and the window of the same frame (null: none, e.g. no
  /// snapshot yet). Marks them sent. A submap never sent counts as empty, so an empty one is
  /// sent only to replace earlier content.
  std::vector<SubmapUpdate> changes(GlobalMapDelta&& delta, const LocalWindow* window);

  /// Forgets what was sent (every non-empty submap goes out again on the next changes()).
  void reset();
  /// Submaps whose last sent content was not empty.
  [[nodiscard]] std::size_t submapsHeld() const { return sent_.size(); }

 private:
  /// Records `content` of submap `key` as the one sent; true when it differs from the last one.
  bool differs(std::uint64_t key, const std::vector<VoxelRecord>& content);

  Eigen::Vector3i submap_cells_;
  std::unordered_map<std::uint64_t, std::uint64_t> sent_;  ///< key -> hash of non-empty content
  std::vector<std::uint64_t> last_window_;                 ///< the previous window's submaps
};

}  // namespace mlmap::fleet
