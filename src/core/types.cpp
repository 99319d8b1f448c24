#include "mlmap/core/types.h"

namespace mlmap {

const char* toString(Occupancy state) {
  switch (state) {
    case Occupancy::kUnknown:
      return "unknown";
    case Occupancy::kFree:
      return "free";
    case Occupancy::kOccupied:
      return "occupied";
  }
  return "invalid";
}

bool makePose(const Eigen::Vector3d& t, const Eigen::Quaterniond& q, Transform* T,
              double tolerance) {
  if (!t.allFinite() || !q.coeffs().allFinite()) return false;
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > tolerance) return false;
  Transform result = Transform::Identity();
  result.linear() = q.normalized().toRotationMatrix();
  result.translation() = t;
  *T = result;
  return true;
}

bool isValidPose(const Transform& T, double tolerance) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), tolerance)) return false;
  return std::abs(R.determinant() - 1.0) <= tolerance;
}

bool backProject(const DepthFrame& frame, std::vector<Eigen::Vector3f>* points_S,
                 std::size_t* skipped) {
  const PinholeIntrinsics& K = frame.intrinsics;
  const std::size_t n = static_cast<std::size_t>(std::max(K.width, 0)) *
                        static_cast<std::size_t>(std::max(K.height, 0));
  const bool is_mm = frame.encoding == DepthEncoding::kUint16Millimetres;
  const std::size_t have = is_mm ? frame.depth_mm.size() : frame.depth_m.size();
  if (n == 0 || have != n || !(K.fx > 0.0) || !(K.fy > 0.0)) return false;
  points_S->clear();
  points_S->reserve(n);
  std::size_t invalid = 0;
  const float inv_fx = static_cast<float>(1.0 / K.fx);
  const float inv_fy = static_cast<float>(1.0 / K.fy);
  const float cx = static_cast<float>(K.cx);
  const float cy = static_cast<float>(K.cy);
  for (int v = 0; v < K.height; ++v) {
    const float ray_y = (static_cast<float>(v) - cy) * inv_fy;
    const std::size_t row = static_cast<std::size_t>(v) * static_cast<std::size_t>(K.width);
    for (int u = 0; u < K.width; ++u) {
      float z = 0.0f;
      if (is_mm) {
        const std::uint16_t raw = frame.depth_mm[row + static_cast<std::size_t>(u)];
        z = (raw == 0 || raw == 0xFFFF) ? 0.0f : static_cast<float>(raw) * 0.001f;
      } else {
        z = frame.depth_m[row + static_cast<std::size_t>(u)];
      }
      if (!(z > 0.0f) || !std::isfinite(z)) {
        ++invalid;
        continue;
      }
      points_S->emplace_back((static_cast<float>(u) - cx) * inv_fx * z, ray_y * z, z);
    }
  }
  if (skipped != nullptr) *skipped = invalid;
  return true;
}

}  // namespace mlmap
