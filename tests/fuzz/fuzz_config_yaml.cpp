/// @file
/// Fuzz target: the engine's YAML configuration (config::parseConfigYaml, as the offline programs
/// read a node's file: `dds` and `map_file` skipped). Errors are std::runtime_error. A config
/// that parses must print (toYaml) as YAML that parses back to the same config.

#include "fuzz_support.h"

#include "mlmap/config/config_yaml.h"

#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = mlmap::fuzz::asString(data, size);
  mlmap::MapConfig config;
  try {
    config = mlmap::config::parseConfigYaml(text, "fuzz.yaml", mlmap::config::kNodeOnlySections);
  } catch (const std::runtime_error&) {
    return 0;  // the documented answer to bad input
  }
  const std::string printed = mlmap::config::toYaml(config);
  const mlmap::MapConfig again = mlmap::config::parseConfigYaml(printed, "printed.yaml");
  mlmap::fuzz::requireThat(mlmap::config::toYaml(again) == printed,
                           "parseConfigYaml(toYaml(config)) is not the same config");
  return 0;
}
