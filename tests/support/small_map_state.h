#pragma once
// A hand-made small map state: a 10 x 10 x 10 window at 0.1 m with a few known voxels and two
// global submaps. Used by the map-file tests and for the map-file seeds of the fuzz corpus.

#include "mlmap/local/map_state.h"

namespace mlmap::test {

inline MapState smallMapState() {
  MapConfig c;
  c.local_map.resolution_m = 0.1;
  c.local_map.size_cells = Eigen::Vector3i(10, 10, 10);
  MapState s;
  s.local_map = c.local_map;
  s.log_odds = c.log_odds;
  s.window.resolution_m = 0.1;
  s.window.model = LogOddsModel(c.log_odds);
  s.window.min_index = VoxelIndex(-4, 2, 6);
  s.window.size = c.local_map.size_cells;
  // Runs of unknown and observed voxels of every length from 0 to 4, values across the bounds.
  s.window.log_odds.assign(1000, kUnknownLogOdds);
  for (int i = 0; i < 1000; ++i) {
    if (i % 9 >= 4 || i % 5 == 0)
      s.window.log_odds[i] = static_cast<LogOddsQ>(-2000 + (i * 37) % 5501);
  }
  s.global_submaps.push_back({SubmapIndex(-9, 0, 1), {{0, 850}, {5, 1700}}});
  s.global_submaps.push_back({SubmapIndex(3, 4, 5), {{7, 3500}}});
  s.has_last_stamp = true;
  s.last_stamp_s = 12.5;
  s.T_W_B.translation() = Eigen::Vector3d(-0.2, 0.5, 0.9);
  s.frames_mapped = 42;
  return s;
}

}  // namespace mlmap::test
