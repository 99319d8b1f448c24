/// @file
/// Fuzz target: a bag's /tf and /tf_static edges as TfTree takes them. Every 4 bytes are one edge:
/// kind (even: /tf, odd: /tf_static), parent and child (one of 8 frames, "map" the world and
/// "base_link" the body), and a value that gives the stamp and the transform. Then the poses and
/// every frame's extrinsic. Checks what TfTree documents: every walk ends (cycles and chains
/// longer than kMaxTfChainEdges refused with std::runtime_error), at most one pose per /tf edge
/// added, poses finite and sorted as their lowest edge's stamps, extrinsics finite.

#include "fuzz_support.h"

#include "mlmap/bag/tf_tree.h"

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace {

using mlmap::fuzz::requireThat;

const std::array<std::string, 8> kFrames = {"map", "base_link", "odom", "base_footprint",
                                            "f4",  "f5",        "f6",   "camera"};

mlmap::Transform transformOf(std::uint8_t value) {
  mlmap::Transform T = mlmap::Transform::Identity();
  T.linear() = Eigen::AngleAxisd(0.1 * value, Eigen::Vector3d(1.0, 0.5, 0.25).normalized())
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(value % 7 - 3.0, value % 5 - 2.0, value % 3 - 1.0);
  return T;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  mlmap::bag::TfTree tree(kFrames[0], kFrames[1]);
  std::size_t dynamic_edges = 0;
  for (std::size_t at = 0; at + 4 <= size; at += 4) {
    const std::string& parent = kFrames[data[at + 1] % kFrames.size()];
    const std::string& child = kFrames[data[at + 2] % kFrames.size()];
    const std::uint8_t value = data[at + 3];
    if (data[at] % 2 == 0) {
      tree.addDynamic(parent, child, value / 16.0, transformOf(value));
      ++dynamic_edges;
    } else {
      tree.addStatic(parent, child, transformOf(value));
    }
  }
  try {
    const std::vector<mlmap::bag::StampedTransform> poses = tree.poses();
    requireThat(poses.size() <= dynamic_edges, "TfTree: more poses than /tf edges");
    for (std::size_t k = 0; k < poses.size(); ++k) {
      requireThat(std::isfinite(poses[k].stamp_s) && poses[k].T.matrix().allFinite(),
                  "TfTree: a pose is not finite");
      requireThat(k == 0 || poses[k - 1].stamp_s <= poses[k].stamp_s, "TfTree: poses not sorted");
    }
  } catch (const std::runtime_error&) {
    // refused: a cycle, no path to the world frame, or a chain too long
  }
  for (const std::string& frame : kFrames) {
    if (const auto T_B_S = tree.staticFromBody(frame)) {
      requireThat(T_B_S->matrix().allFinite(), "TfTree: an extrinsic is not finite");
    }
  }
  return 0;
}
