#pragma once
/// @file
/// The configuration file of mlmap_node: the engine sections of config/mlmap.yaml (awareness,
/// log_odds, local_map, sensor, pipeline, projected_grid, esdf) plus a top-level `dds:` section
/// (DdsConfig, with `topics:` and `rates:` as nested mappings) and a `map_file:` section
/// (MapFileOptions). See config/mlmap_node.yaml.
///
/// Every key is optional (the default in code applies). Unknown keys, values of the wrong type
/// and values that fail MapConfig::validate() / DdsConfig::validate() are errors naming the key;
/// every problem of both parts is reported in one std::runtime_error.

#include "mlmap/core/config.h"
#include "mlmap/dds/dds_config.h"

#include <string>
#include <vector>

namespace mlmap::dds {

/// The `map_file:` section: start from a saved map, save it on shutdown (and periodically).
/// Files are mlmap map files (mlmap/map_io/map_file.h); mlmap_map_tool converts them.
struct MapFileOptions {
  /// Map loaded at start ("" = start empty). Its configuration fingerprint (resolution, window
  /// size, log-odds model) must match the engine sections, else the node refuses to start.
  std::string load_path;
  /// true: a load_path that does not exist (yet) starts an empty map instead of failing (the
  /// first run of a vehicle that loads and saves the same file).
  bool load_missing_ok = false;
  /// Map saved when the node stops (SIGINT / SIGTERM, after the queued frames are mapped);
  /// "" = never saved. Written to a temporary file in the same folder, then renamed.
  std::string save_path;
  /// Also save every this many seconds while mapping (0 = only at shutdown); needs save_path.
  double save_period_s = 0.0;

  /// Appends every problem as "map_file.key: what is wrong"; nothing when valid.
  void validate(std::vector<std::string>* errors) const;
};

/// Everything mlmap_node reads from its file.
struct NodeConfig {
  mlmap::MapConfig map;  ///< the engine (same keys as config/mlmap.yaml)
  DdsConfig dds;         ///< the `dds:` section
  MapFileOptions map_file;  ///< the `map_file:` section
};

/// Parses a YAML document. A part (engine or dds) is validated when it was read without
/// problems, so a typo in one part does not hide the bad values of the other. Throws
/// std::runtime_error "<source_name>: invalid mlmap configuration:" + one problem per line.
NodeConfig parseNodeConfigYaml(const std::string& text,
                               const std::string& source_name = "<string>");
/// Loads a YAML file. Throws std::runtime_error (file name included) on any problem.
NodeConfig loadNodeConfigYaml(const std::string& path);
/// The effective configuration as YAML, every key present (parses back to the same config).
std::string toYaml(const NodeConfig& config);

}  // namespace mlmap::dds
