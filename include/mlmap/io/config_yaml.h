#pragma once
/// @file
/// YAML <-> MapConfig. Every key is optional (the default in code applies); an unknown key, a
/// value of the wrong type and a value that fails MapConfig::validate() are errors naming the key.

#include "mlmap/core/config.h"

#include <string>

namespace mlmap::io {

/// Parses a YAML document. Throws std::runtime_error listing every problem.
MapConfig parseConfigYaml(const std::string& text, const std::string& source_name = "<string>");
/// Loads a YAML file. Throws std::runtime_error (file name included) on any problem.
MapConfig loadConfigYaml(const std::string& path);
/// The effective configuration as YAML, every key present (what `--print-config` shows).
std::string toYaml(const MapConfig& config);

}  // namespace mlmap::io
