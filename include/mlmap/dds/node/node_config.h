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
#include "mlmap/core/pose_buffer.h"
#include "mlmap/dds/transport/dds_config.h"

#include <string>
#include <vector>

namespace mlmap::dds {

/// The `map_file:` section: start from a saved map, save it on shutdown (and periodically).
/// Files are mlmap map files (mlmap/map_io/map_file.h); mlmap_map_tool converts them.
/// Keys, units and meanings: visit().
struct MapFileOptions {
  /// Its top-level section in the node's YAML file (NodeConfig::visitNodeSections()).
  static constexpr const char* kSection = "map_file";

  std::string load_path;         ///< key load_path
  bool load_missing_ok = false;  ///< key load_missing_ok
  std::string save_path;         ///< key save_path (saved after the queued frames are mapped)
  double save_period_s = 0.0;    ///< key save_period_s
  bool overwrite = false;        ///< key overwrite

  /// The keys of the `map_file` section: visitor.key(name, field, unit, doc) for each.
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("load_path", c.load_path, "",
          "map to start from (\"\": start empty); its resolution, window size and log-odds\n"
          "model must equal the engine sections, else the node refuses to start");
    v.key("load_missing_ok", c.load_missing_ok, "",
          "true: a load_path that does not exist yet starts empty (load and save one file)");
    v.key("save_path", c.save_path, "",
          "map written when the node stops on SIGINT / SIGTERM (\"\": never); the folder\n"
          "must exist; written to a temporary file there, then renamed");
    v.key("save_period_s", c.save_period_s, "s",
          "also save every this many seconds while mapping (0: only at shutdown); needs save_path");
    v.key("overwrite", c.overwrite, "",
          "true: save_path may replace an existing file the node did not load (false: such\n"
          "a file stops the node at start, so that no earlier map is lost by mistake)");
  }

  /// Appends every problem as "map_file.key: what is wrong"; nothing when valid.
  void validate(std::vector<std::string>* errors) const;
};

/// Everything mlmap_node reads from its file.
struct NodeConfig {
  mlmap::MapConfig map;     ///< the engine (same keys as config/mlmap.yaml)
  DdsConfig dds;            ///< the `dds:` section
  MapFileOptions map_file;  ///< the `map_file:` section

  /// Every top-level section: the engine's (MapConfig::visit()) then the node's own.
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    mlmap::MapConfig::visit(c.map, v);
    visitNodeSections(c, v);
  }
  /// The top-level sections that are the node's, not the engine's: `dds` and `map_file`.
  template <class Self, class V>
  static void visitNodeSections(Self& c, V& v) {
    v.section(DdsConfig::kSection, c.dds,
              "ROS 2 (Jazzy) peers over Fast DDS: topics rt/<ns>/<name>, ROS types and QoS");
    v.section(MapFileOptions::kSection, c.map_file,
              "mlmap map files (full local + global state); mlmap_map_tool converts them");
  }
};

/// Parses a YAML document. A part (engine or dds) is validated when it was read without
/// problems, so a typo in one part does not hide the bad values of the other. Throws
/// std::runtime_error "<source_name>: invalid mlmap configuration:" + one problem per line.
NodeConfig parseNodeConfigYaml(const std::string& text,
                               const std::string& source_name = "<string>");
/// Loads a YAML file. Throws std::runtime_error (file name included) on any problem.
NodeConfig loadNodeConfigYaml(const std::string& path);
/// What a program started with `--config path` runs with: loadNodeConfigYaml(path), or the
/// defaults when `path` is empty (no --config).
NodeConfig nodeConfigOrDefaults(const std::string& path);
/// The effective configuration as YAML, every key present (parses back to the same config).
std::string toYaml(const NodeConfig& config);

/// The node's pairing of clouds and depth images with poses, from the `dds` section:
/// pose_tolerance_s, pose_buffer_s, max_future_s and the pose-jump limits.
PoseBufferConfig poseBufferConfig(const DdsConfig& dds);

/// The prose at the top of config/mlmap_node.yaml.
inline constexpr const char* kNodeDefaultsHeader =
    "# mlmap_node configuration: the engine sections of config/mlmap.yaml plus the `dds:` and\n"
    "# `map_file:` sections below. Every key is optional: a missing key takes the default shown "
    "here.\n"
    "# Unknown keys and bad values stop the node with a message naming the key.\n"
    "#\n"
    "# Engine sections (awareness, log_odds, local_map, sensor, pipeline, projected_grid, esdf): "
    "same\n"
    "# keys and defaults as config/mlmap.yaml; copy the ones you change into this file (both "
    "files\n"
    "# concatenated are a valid node configuration).\n"
    "# Generated from the key lists in include/mlmap/dds/ by `build/mlmap_config_tool --write`\n"
    "# (a test fails when this file differs): edit those instead.\n";
/// The text of config/mlmap_node.yaml: kNodeDefaultsHeader, then every key of the node's own
/// sections (NodeConfig::visitNodeSections()) with its default, unit and meaning.
std::string nodeDefaultsYaml();
/// The Markdown table of every key of the node's own sections for docs/configuration.md.
std::string nodeKeyReference();

}  // namespace mlmap::dds
