#pragma once
/// @file
/// The complete state of a map (local and global layers) as plain data: what the engine exports
/// for saving and takes back when a saved map is loaded (MapEngine::exportState / restoreState).
/// The file format that holds it lives in the io layer (mlmap/map_io/map_file.h).

#include "mlmap/core/config.h"
#include "mlmap/global/global_map.h"
#include "mlmap/local/local_map.h"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace mlmap {

/// Everything needed to go on mapping exactly where the map stopped.
///
/// The awareness map is not part of it: it holds what the vehicle sees right now and is rebuilt
/// by the next frame (obstacles it would have carried over from before the save are missing for
/// the frames until they are seen again; the local and global layers do not depend on it).
struct MapState {
  /// What gives the data its meaning: voxel size, window size (and so submap size).
  LocalMapConfig local_map;
  /// The sensor model the log-odds were accumulated with (clamping bounds, threshold).
  LogOddsConfig log_odds;
  /// The local map's window in box order with every voxel's stored log-odds (unknown included);
  /// an empty window (size 0) when the map was never placed.
  LocalWindow window;
  /// The global map: submap index and its occupied voxels, sorted by submap index (x, y, z).
  std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> global_submaps;
  /// Stamp of the last accepted frame (later frames must be newer), when there was one.
  bool has_last_stamp = false;
  double last_stamp_s = 0.0;
  /// Body pose of the last mapped frame (anchors the 2D grid's band and the ESDF box).
  Transform T_W_B = Transform::Identity();
  /// Frames mapped into this map so far, over every session.
  std::uint64_t frames_mapped = 0;

  /// Occupied voxels of the global map.
  [[nodiscard]] std::size_t globalVoxelCount() const {
    std::size_t n = 0;
    for (const auto& entry : global_submaps) n += entry.second.size();
    return n;
  }
};

/// The fields that give a map's data its meaning (voxel size, window size, log-odds model) and
/// differ between a map and `config`, one "key is <map value> in the map, <value> in the
/// configuration" each; empty when the map fits.
[[nodiscard]] std::vector<std::string> mapConfigDifferences(const MapState& state,
                                                            const MapConfig& config);

/// What makes `state` inconsistent in itself, judged against its own `local_map` and `log_odds`
/// (empty when it is sound): a last stamp that is not finite, a body pose that a live frame could
/// not have (isMappablePose()), a window of the wrong size, off the submap grid, beyond
/// kMaxAbsWindowVoxelIndex or with values outside the clamping bounds; global submaps listed twice,
/// inside the window or beyond GlobalMap::kSubmapIndexLimit; records that are not increasing
/// occupied voxels of their submap. Every reader of saved maps checks this before using one.
[[nodiscard]] std::vector<std::string> mapStateProblems(const MapState& state);

}  // namespace mlmap
