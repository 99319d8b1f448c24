/// @file
/// Fuzz target: mlmap_node's YAML configuration (dds::parseNodeConfigYaml: the engine sections,
/// `dds:` and `map_file:`). Errors are std::runtime_error. A config that parses must print
/// (toYaml) as YAML that parses back to the same config, as toYaml() documents.

#include "fuzz_support.h"

#include "mlmap/dds/node/node_config.h"

#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = mlmap::fuzz::asString(data, size);
  mlmap::dds::NodeConfig config;
  try {
    config = mlmap::dds::parseNodeConfigYaml(text, "fuzz.yaml");
  } catch (const std::runtime_error&) {
    return 0;  // the documented answer to bad input
  }
  const std::string printed = mlmap::dds::toYaml(config);
  const mlmap::dds::NodeConfig again = mlmap::dds::parseNodeConfigYaml(printed, "printed.yaml");
  mlmap::fuzz::requireThat(mlmap::dds::toYaml(again) == printed,
                           "parseNodeConfigYaml(toYaml(config)) is not the same config");
  return 0;
}
