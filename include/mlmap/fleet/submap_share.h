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
///
/// A vehicle that took other vehicles' submaps as priors (MapEngine::addPrior()) sends its own
/// evidence only (ownEvidence()): where its map holds a prior, the change its own measurements
/// made to it, and for a prior voxel its rays lowered below occupancy that (negative) change too.
/// So the other vehicle's evidence is not sent back (counted twice by the merger), and free
/// evidence travels exactly where the fleet claims occupancy that this vehicle saw through.

#include "mlmap/global/global_map.h"
#include "mlmap/local/local_map.h"
#include "mlmap/pipeline/map_engine.h"

#include <algorithm>
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

/// A vehicle's own evidence in one submap, from `occupied` (its occupied voxels there, ascending
/// offsets, with the values its map holds) and `priors` (the voxels of that submap other vehicles
/// gave it, with the values they came with; null: none): a voxel without a prior contributes its
/// value; a voxel holding a prior contributes its value minus the prior's (nothing when equal);
/// a prior voxel not in `occupied` contributes `value_of(offset)` (its value now, below
/// occupancy) minus the prior's. Ascending offsets; differences clamped to LogOddsQ's range.
template <typename ValueOf>
std::vector<VoxelRecord> ownEvidence(const std::vector<VoxelRecord>& occupied,
                                     const std::vector<VoxelRecord>* priors, ValueOf&& value_of) {
  if (priors == nullptr || priors->empty()) return occupied;
  auto difference = [](int value, int prior) {
    return static_cast<LogOddsQ>(std::clamp(value - prior, -32767, 32767));
  };
  std::vector<VoxelRecord> out;
  out.reserve(occupied.size());
  auto p = priors->begin();
  for (const VoxelRecord& r : occupied) {
    for (; p != priors->end() && p->offset < r.offset; ++p) {
      out.push_back({p->offset, difference(value_of(p->offset), p->log_odds)});
    }
    if (p != priors->end() && p->offset == r.offset) {
      if (r.log_odds != p->log_odds) out.push_back({r.offset, difference(r.log_odds, p->log_odds)});
      ++p;
    } else {
      out.push_back(r);
    }
  }
  for (; p != priors->end(); ++p) {
    out.push_back({p->offset, difference(value_of(p->offset), p->log_odds)});
  }
  return out;
}

/// One submap to send: its index and its content now (ownEvidence(); empty: none).
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
  /// sent only to replace earlier content. `priors`: the engine's priors as of the same frame
  /// (MapEngine::priors() read on the engine's thread with the delta and the window; null: none),
  /// so that each submap's content is the vehicle's own evidence (ownEvidence()); a prior voxel
  /// the global map no longer holds (the window lowered it below occupancy before retiring the
  /// submap) counts as 0, no evidence left.
  std::vector<SubmapUpdate> changes(GlobalMapDelta&& delta, const LocalWindow* window,
                                    const PriorVoxels* priors = nullptr);

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
