/// @file
/// Fuzz target: a simulation scenario (world, flight, camera) in YAML
/// (datasets::parseScenarioYaml). Errors are std::runtime_error.

#include "fuzz_support.h"

#include "mlmap/datasets/world_yaml.h"

#include <cmath>
#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const mlmap::datasets::Scenario scenario =
        mlmap::datasets::parseScenarioYaml(mlmap::fuzz::asString(data, size), "fuzz.yaml");
    mlmap::fuzz::requireThat(std::isfinite(scenario.frame_rate_hz) && scenario.frame_rate_hz > 0.0,
                             "parseScenarioYaml: frame_rate_hz not positive");
  } catch (const std::runtime_error&) {
    // the documented answer to bad input
  }
  return 0;
}
