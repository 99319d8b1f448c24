/// @file
/// Fuzz target: PCD files (datasets::parsePcd: ascii, binary, binary_compressed). Errors are
/// std::runtime_error.

#include "point_cloud_checks.h"

#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    mlmap::fuzz::checkPointCloudFile(
        mlmap::datasets::parsePcd(mlmap::fuzz::asString(data, size), "fuzz.pcd"));
  } catch (const std::runtime_error&) {
    // the documented answer to bad input
  }
  return 0;
}
