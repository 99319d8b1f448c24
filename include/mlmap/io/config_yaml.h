#pragma once
/// @file
/// YAML <-> MapConfig. Every key is optional (the default in code applies); an unknown key, a
/// value of the wrong type and a value that fails MapConfig::validate() are errors naming the key.

#include "mlmap/core/config.h"

#include <string>

namespace mlmap::io {

class Section;  // mlmap/io/yaml_section.h

/// Parses a YAML document. Throws std::runtime_error listing every problem.
MapConfig parseConfigYaml(const std::string& text, const std::string& source_name = "<string>");
/// Loads a YAML file. Throws std::runtime_error (file name included) on any problem.
MapConfig loadConfigYaml(const std::string& path);
/// Reads the engine sections (awareness, log_odds, local_map, sensor, pipeline, projected_grid,
/// esdf) of a document's top-level mapping `top` into `config`, without validating. Problems go
/// to top.errors(). Other top-level keys are left to `top`, which reports the ones nobody read
/// when it goes out of scope: a caller can so read its own sections of the same file (mlmap_node's
/// `dds`) and still reject typos. parseConfigYaml() is this plus MapConfig::validate().
void readEngineSections(Section& top, MapConfig* config);
/// The effective configuration as YAML, every key present (what `--print-config` shows).
std::string toYaml(const MapConfig& config);

}  // namespace mlmap::io
