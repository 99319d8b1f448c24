#include "mlmap/local/map_state.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>

namespace mlmap {

std::vector<std::string> mapConfigDifferences(const MapState& state, const MapConfig& config) {
  std::vector<std::string> differences;
  auto compare = [&differences](const std::string& key, double map_value, double config_value) {
    if (map_value != config_value) {
      std::ostringstream m;
      m << key << " is " << map_value << " in the map, " << config_value << " in the configuration";
      differences.push_back(m.str());
    }
  };
  compare("local_map.resolution_m", state.local_map.resolution_m, config.local_map.resolution_m);
  for (int a = 0; a < 3; ++a) {
    compare("local_map.size_cells[" + std::to_string(a) + "]", state.local_map.size_cells[a],
            config.local_map.size_cells[a]);
  }
  const LogOddsConfig& m = state.log_odds;
  const LogOddsConfig& c = config.log_odds;
  compare("log_odds.hit", m.hit, c.hit);
  compare("log_odds.miss", m.miss, c.miss);
  compare("log_odds.clamp_min", m.clamp_min, c.clamp_min);
  compare("log_odds.clamp_max", m.clamp_max, c.clamp_max);
  compare("log_odds.occupied_threshold", m.occupied_threshold, c.occupied_threshold);
  return differences;
}

std::vector<std::string> mapStateProblems(const MapState& state) {
  std::vector<std::string> problems;
  // The stamp and pose pass the checks a live frame's do (MapEngine::submit()).
  if (state.has_last_stamp && !std::isfinite(state.last_stamp_s)) {
    problems.push_back("last stamp is not finite");
  }
  if (!isMappablePose(state.T_W_B)) {
    std::ostringstream m;
    m << "last body pose is not a valid pose within " << kMaxAbsCoordinate_m
      << " m of the origin (position " << state.T_W_B.translation().transpose() << ")";
    problems.push_back(m.str());
  }
  const LogOddsModel model(state.log_odds);
  const Eigen::Vector3i submap_cells = state.local_map.submap_cells();
  const LocalWindow& w = state.window;

  // The window: empty, or the configured size on the submap grid, every value in bounds.
  const std::string window_problem =
      windowProblem(w, state.local_map.size_cells, submap_cells, model);
  const bool window_ok = window_problem.empty();
  if (!window_ok) problems.push_back("local map window: " + window_problem);

  // Global submaps: in range, each once, none inside the window; records inside the submap,
  // strictly increasing, occupied and within the clamping bound.
  const std::int64_t submap_voxels =
      std::int64_t{submap_cells.x()} * submap_cells.y() * submap_cells.z();
  std::vector<SubmapIndex> seen;
  seen.reserve(state.global_submaps.size());
  for (const auto& [m, records] : state.global_submaps) {
    std::ostringstream msg;
    for (int a = 0; a < 3 && msg.str().empty(); ++a) {
      const std::int64_t first = std::int64_t{m[a]} * submap_cells[a];
      if (m[a] < -GlobalMap::kSubmapIndexLimit || m[a] >= GlobalMap::kSubmapIndexLimit ||
          first < -kMaxAbsWindowVoxelIndex || first + submap_cells[a] > kMaxAbsWindowVoxelIndex) {
        msg << "global submap (" << m.transpose() << ") is out of range";
      }
    }
    if (msg.str().empty() && window_ok && w.size.prod() != 0 &&
        boxContains(w.min_index, w.size, m.cwiseProduct(submap_cells))) {
      msg << "global submap (" << m.transpose() << ") lies inside the local window (from voxel "
          << w.min_index.transpose() << ")";
    }
    for (std::size_t k = 0; k < records.size() && msg.str().empty(); ++k) {
      const VoxelRecord& r = records[k];
      if (r.offset >= submap_voxels || (k > 0 && r.offset <= records[k - 1].offset) ||
          !model.isOccupied(r.log_odds) || r.log_odds > model.clampMax()) {
        msg << "global submap (" << m.transpose() << ") record " << k << " (offset " << r.offset
            << ", log-odds " << r.log_odds << ") is not an occupied voxel of the submap";
      }
    }
    if (!msg.str().empty()) {
      problems.push_back(msg.str());
      return problems;  // one bad submap is enough to refuse; the rest may be garbage too
    }
    seen.push_back(m);
  }
  std::sort(seen.begin(), seen.end(), [](const SubmapIndex& a, const SubmapIndex& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  });
  if (std::adjacent_find(seen.begin(), seen.end()) != seen.end()) {
    problems.push_back("a global submap is listed twice");
  }
  return problems;
}

}  // namespace mlmap
