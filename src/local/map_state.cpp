#include "mlmap/local/map_state.h"

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

}  // namespace mlmap
