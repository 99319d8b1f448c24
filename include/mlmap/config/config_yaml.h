#pragma once
/// @file
/// YAML <-> MapConfig. Every key is optional (the default in code applies); an unknown key, a
/// value of the wrong type and a value that fails MapConfig::validate() are errors naming the key.

#include "mlmap/core/config.h"

#include <string>
#include <vector>

namespace mlmap::config {

class Section;  // mlmap/config/yaml_section.h

/// Top-level sections of an mlmap_node configuration that are not the engine's (`dds`,
/// `map_file`): offline programs pass these as `skipped_sections` so the node's files work there.
inline const std::vector<std::string> kNodeOnlySections = {"dds", "map_file"};

/// Parses a YAML document. Top-level keys in `skipped_sections` are accepted and not read; any
/// other unknown key is an error. Throws std::runtime_error listing every problem.
MapConfig parseConfigYaml(const std::string& text, const std::string& source_name = "<string>",
                          const std::vector<std::string>& skipped_sections = {});
/// Loads a YAML file (see parseConfigYaml()). Throws std::runtime_error (file name included) on
/// any problem.
MapConfig loadConfigYaml(const std::string& path,
                         const std::vector<std::string>& skipped_sections = {});
/// Reads the engine sections (awareness, log_odds, local_map, sensor, pipeline, projected_grid,
/// esdf) of a document's top-level mapping `top` into `config`, without validating. Problems go
/// to top.errors(). Other top-level keys are left to `top`, which reports the ones nobody read
/// when it goes out of scope: a caller can so read its own sections of the same file (mlmap_node's
/// `dds`) and still reject typos. parseConfigYaml() is this plus MapConfig::validate().
void readEngineSections(Section& top, MapConfig* config);
/// The effective configuration as YAML, every key present (what `--print-config` shows).
std::string toYaml(const MapConfig& config);

/// The prose at the top of config/mlmap.yaml.
inline constexpr const char* kEngineDefaultsHeader =
    "# mlmap engine configuration. Every key is optional: a missing key takes the default shown "
    "here\n"
    "# (the paper's performance configuration). Unknown keys and bad values stop the program with "
    "a\n"
    "# message naming the key. Print the effective configuration with `mlmap_demo "
    "--print-config`.\n"
    "# Generated from the key lists in include/mlmap/core/config.h by\n"
    "# `build/mlmap_config_tool --write` (a test fails when this file differs): edit those "
    "instead.\n";
/// The text of config/mlmap.yaml: kEngineDefaultsHeader, then every engine key with its default,
/// unit and meaning, from the key lists (MapConfig::visit()).
std::string engineDefaultsYaml();
/// The Markdown table of every engine key (section.key, default, unit, meaning) for
/// docs/configuration.md, from the same key lists.
std::string engineKeyReference();

}  // namespace mlmap::config
