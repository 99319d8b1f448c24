/// @file
/// Fuzz target: the trajectory readers of the dataset replay, on the same text: the format
/// detection + reader of readPoseFile(), both parsers (datasets::parseTumPoses,
/// datasets::parseCsvPoses; std::runtime_error), the `--extrinsic` parser
/// (datasets::parseTransformXyzQuat; std::invalid_argument) and the time stamp in a cloud file name
/// (datasets::stampFromFileName, on each line). Accepted poses must be rigid with strictly
/// increasing stamps.

#include "fuzz_support.h"

#include "mlmap/datasets/cloud_sequence.h"
#include "mlmap/datasets/pose_file.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace {

using mlmap::fuzz::requireThat;

void checkPoses(const std::vector<mlmap::datasets::StampedPose>& poses) {
  requireThat(!poses.empty(), "a trajectory without poses was accepted");
  for (std::size_t i = 0; i < poses.size(); ++i) {
    requireThat(std::isfinite(poses[i].stamp_s) && mlmap::isValidPose(poses[i].T_W_P, 1e-9),
                "an accepted pose is not a finite rigid transform");
    requireThat(i == 0 || poses[i].stamp_s > poses[i - 1].stamp_s, "stamps not increasing");
  }
}

template <typename Parse>
void parsePoses(Parse parse) {
  try {
    checkPoses(parse());
  } catch (const std::runtime_error&) {
    // the documented answer to bad input
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = mlmap::fuzz::asString(data, size);
  // readPoseFile() picks one parser by detectPoseFileFormat(); both run here.
  (void)mlmap::datasets::detectPoseFileFormat("fuzz.txt", text);
  parsePoses([&] { return mlmap::datasets::parseTumPoses(text, "fuzz.tum"); });
  parsePoses([&] { return mlmap::datasets::parseCsvPoses(text, "fuzz.csv"); });
  try {
    const mlmap::Transform T = mlmap::datasets::parseTransformXyzQuat(text);
    requireThat(mlmap::isValidPose(T, 1e-9), "parseTransformXyzQuat: not a rigid transform");
  } catch (const std::invalid_argument&) {
    // the documented answer to bad input
  }
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) (void)mlmap::datasets::stampFromFileName(line);
  return 0;
}
