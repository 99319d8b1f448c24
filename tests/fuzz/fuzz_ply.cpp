/// @file
/// Fuzz target: PLY files (datasets::parsePly: ascii, binary little and big endian). Errors are
/// std::runtime_error.

#include "point_cloud_checks.h"

#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    mlmap::fuzz::checkPointCloudFile(
        mlmap::datasets::parsePly(mlmap::fuzz::asString(data, size), "fuzz.ply"));
  } catch (const std::runtime_error&) {
    // the documented answer to bad input
  }
  return 0;
}
