/// @file
/// Fuzz target: the text files of an RGB-D frame directory (datasets::FrameDirectory): the
/// intrinsics file (datasets::parseIntrinsicsK) and a pose file (datasets::parsePoseMatrix), both
/// on the same text. Errors are std::runtime_error. (The depth PNGs are OpenCV's to decode.)

#include "fuzz_support.h"

#include "mlmap/datasets/frame_directory.h"

#include <cmath>
#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using mlmap::fuzz::requireThat;
  const std::string text = mlmap::fuzz::asString(data, size);
  try {
    const mlmap::PinholeIntrinsics k = mlmap::datasets::parseIntrinsicsK(text, "intrinsics.K.txt");
    requireThat(k.fx > 0.0 && k.fy > 0.0 && std::isfinite(k.fx) && std::isfinite(k.fy) &&
                    std::isfinite(k.cx) && std::isfinite(k.cy),
                "parseIntrinsicsK: not finite or fx, fy <= 0");
  } catch (const std::runtime_error&) {
    // the documented answer to bad input
  }
  try {
    const mlmap::Transform T = mlmap::datasets::parsePoseMatrix(text, "frame-000000.pose.txt");
    requireThat(mlmap::isValidPose(T, 1e-9), "parsePoseMatrix: not a rigid transform");
  } catch (const std::runtime_error&) {
    // the documented answer to bad input
  }
  return 0;
}
