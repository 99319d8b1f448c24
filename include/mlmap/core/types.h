#pragma once
/// @file
/// Basic types shared by every mlmap layer.
///
/// Frames (see docs/architecture.md, "Frames and units"): W is the world (gravity-aligned, fixed),
/// B the body (vehicle, FLU), S the sensor (for cameras the optical frame: x right, y down, z
/// forward). `T_A_B` maps points expressed in frame B into frame A (p_A = T_A_B * p_B). All lengths
/// are metres, angles radians unless a name says `_deg`, times seconds.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace mlmap {

/// Integer index of a voxel on the world grid: voxel i spans [i * res, (i + 1) * res) per axis.
using VoxelIndex = Eigen::Vector3i;
/// Rigid transform; `T_W_B` maps body-frame points into the world frame.
using Transform = Eigen::Isometry3d;

/// What a planner may assume about a place. Never-observed space is `kUnknown`, not free.
enum class Occupancy : std::uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

/// Human-readable name of an occupancy state ("unknown", "free", "occupied").
const char* toString(Occupancy state);

/// floor(x) as an int, for |x| < 2^31 (no libm call on the hot path).
inline int floorToInt(double x) {
  const int i = static_cast<int>(x);
  return i - (x < static_cast<double>(i) ? 1 : 0);
}

/// ceil(x) as an int, for |x| < 2^31.
inline int ceilToInt(double x) { return -floorToInt(-x); }

/// World voxel index of a world point for a grid of resolution `resolution_m` aligned at the
/// origin: floor(p / resolution) per axis (computed as p * (1 / resolution), everywhere the same).
inline VoxelIndex voxelIndexOf(const Eigen::Vector3d& p_W, double resolution_m) {
  const double inv = 1.0 / resolution_m;
  return {floorToInt(p_W.x() * inv), floorToInt(p_W.y() * inv), floorToInt(p_W.z() * inv)};
}

/// True when world voxel `g` lies in the box [min_index, min_index + size).
inline bool boxContains(const VoxelIndex& min_index, const Eigen::Vector3i& size,
                        const VoxelIndex& g) {
  const VoxelIndex r = g - min_index;
  return static_cast<unsigned>(r.x()) < static_cast<unsigned>(size.x()) &&
         static_cast<unsigned>(r.y()) < static_cast<unsigned>(size.y()) &&
         static_cast<unsigned>(r.z()) < static_cast<unsigned>(size.z());
}

/// Position of world voxel `g` (inside the box) in a dense box stored x-major, z fastest:
/// ((x * size.y) + y) * size.z + z for g = min_index + (x, y, z). The order of every dense box
/// in mlmap (local window copies, ESDF boxes).
inline std::size_t boxOffset(const VoxelIndex& min_index, const Eigen::Vector3i& size,
                             const VoxelIndex& g) {
  const VoxelIndex r = g - min_index;
  return (static_cast<std::size_t>(r.x()) * static_cast<std::size_t>(size.y()) +
          static_cast<std::size_t>(r.y())) *
             static_cast<std::size_t>(size.z()) +
         static_cast<std::size_t>(r.z());
}

/// Centre of a world voxel in metres.
inline Eigen::Vector3d voxelCenter(const VoxelIndex& index, double resolution_m) {
  return (index.cast<double>().array() + 0.5).matrix() * resolution_m;
}

/// Pinhole camera intrinsics in pixels (no distortion).
struct PinholeIntrinsics {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  int width = 0;
  int height = 0;
};

/// How a depth image stores depth along the optical axis.
enum class DepthEncoding : std::uint8_t {
  kUint16Millimetres,  ///< 16UC1; 0 and 65535 mean "no data"
  kFloat32Metres,      ///< 32FC1; 0, NaN and Inf mean "no data"
};

/// A depth image (row-major, tightly packed) with the pose it was taken at.
struct DepthFrame {
  double stamp_s = 0.0;
  DepthEncoding encoding = DepthEncoding::kFloat32Metres;
  PinholeIntrinsics intrinsics;
  std::vector<std::uint16_t> depth_mm;  ///< used when encoding == kUint16Millimetres
  std::vector<float> depth_m;           ///< used when encoding == kFloat32Metres
  Transform T_W_B = Transform::Identity();
  Transform T_B_S = Transform::Identity();
};

/// A point cloud in the sensor frame with the pose it was taken at.
struct PointCloudFrame {
  double stamp_s = 0.0;
  std::vector<Eigen::Vector3f> points_S;
  Transform T_W_B = Transform::Identity();
  Transform T_B_S = Transform::Identity();
};

/// Builds a pose from a translation and a quaternion (w, x, y, z). Returns false, leaving `T`
/// untouched, when a value is not finite or the quaternion norm is farther than `tolerance` from 1;
/// otherwise the quaternion is normalised.
bool makePose(const Eigen::Vector3d& t, const Eigen::Quaterniond& q, Transform* T,
              double tolerance = 1e-3);

/// True when `T` is finite and its linear part is a rotation (orthonormal, det +1) within
/// `tolerance`.
bool isValidPose(const Transform& T, double tolerance = 1e-4);

/// Largest |coordinate| [m] of a body position the engine maps at, live or loaded from a file:
/// keeps every voxel index far from int overflow at the finest resolution.
inline constexpr double kMaxAbsCoordinate_m = 1e6;

/// True when `T_W_B` is a valid pose (isValidPose) within kMaxAbsCoordinate_m of the origin on
/// every axis: the bound every body pose passes, whether it comes from a sensor or a file.
inline bool isMappablePose(const Transform& T_W_B) {
  return isValidPose(T_W_B) && T_W_B.translation().cwiseAbs().maxCoeff() < kMaxAbsCoordinate_m;
}

/// Back-projects the valid pixels of a depth frame into sensor-frame points (z forward).
/// Invalid pixels (see DepthEncoding) are skipped; `skipped` (optional) counts them.
/// Returns false when the image size disagrees with the intrinsics.
bool backProject(const DepthFrame& frame, std::vector<Eigen::Vector3f>* points_S,
                 std::size_t* skipped = nullptr);

}  // namespace mlmap
