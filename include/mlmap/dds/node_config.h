#pragma once
/// @file
/// The configuration file of mlmap_node: the engine sections of config/mlmap.yaml (awareness,
/// log_odds, local_map, sensor, pipeline, projected_grid, esdf) plus a top-level `dds:` section
/// (DdsConfig, with `topics:` and `rates:` as nested mappings). See config/mlmap_node.yaml.
///
/// Every key is optional (the default in code applies). Unknown keys, values of the wrong type
/// and values that fail MapConfig::validate() / DdsConfig::validate() are errors naming the key;
/// every problem of both parts is reported in one std::runtime_error.

#include "mlmap/core/config.h"
#include "mlmap/dds/dds_config.h"

#include <string>

namespace mlmap::dds {

/// Everything mlmap_node reads from its file.
struct NodeConfig {
  mlmap::MapConfig map;  ///< the engine (same keys as config/mlmap.yaml)
  DdsConfig dds;         ///< the `dds:` section
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
