#pragma once
/// @file
/// Synthetic depth camera that ray casts a sim::World into a float depth image.

#include "mlmap/core/types.h"
#include "mlmap/sim/world.h"

#include <cstdint>

namespace mlmap::sim {

/// Parameters of a simulated depth camera (defaults: RealSense D435-like 640 x 480,
/// about 80 x 64 deg field of view).
struct DepthCameraModel {
  PinholeIntrinsics intrinsics{385.0, 385.0, 319.5, 239.5, 640, 480};  ///< pinhole model [px]
  double min_depth_m = 0.2;        ///< z-depths below this give no return (0) [m]
  double max_depth_m = 15.0;       ///< nothing hit within this z-depth gives no return (0) [m]
  double noise_coeff_per_m = 0.0;  ///< Gaussian depth noise sigma = coeff * z^2 [1/m]; 0 = off
  std::uint32_t seed = 1;          ///< noise seed; noise is a pure function of (seed, time, pixel)
};

/// Rotation taking optical-frame vectors (x right, y down, z forward) into a FLU body frame that
/// looks forward along body +x: z_opt -> +x_B, x_opt -> -y_B, y_opt -> -z_B. Zero translation.
/// Use as T_B_S for a forward-looking camera mounted at the body origin.
[[nodiscard]] Transform opticalToBody();

/// Renders z-depth images (distance along the optical axis, not ray length) by ray casting.
class DepthCamera {
 public:
  /// Creates a camera with the given model.
  explicit DepthCamera(const DepthCameraModel& model = {});

  /// The camera model.
  [[nodiscard]] const DepthCameraModel& model() const { return model_; }

  /// Renders `world` at `time_s` from the optical-frame pose `T_W_S` into `frame`: sets
  /// encoding = kFloat32Metres, depth_m (row-major, width x height), intrinsics and stamp_s =
  /// time_s; clears depth_mm; leaves T_W_B and T_B_S untouched. The ray through the centre of pixel
  /// (u, v) has direction ((u - cx) / fx, (v - cy) / fy, 1) in S. A pixel is 0 (no return) when
  /// nothing is hit within max_depth_m or the true z-depth is below min_depth_m; otherwise noise
  /// (if enabled) is added to the true z-depth, and a noisy value <= 0 also becomes 0. Noise is
  /// deterministic: rendering the same time twice gives the same image. Does nothing when `frame`
  /// is null; gives an empty image when the intrinsics are invalid. Never throws.
  void render(const World& world, const Transform& T_W_S, double time_s, DepthFrame* frame) const;

 private:
  DepthCameraModel model_;
};

}  // namespace mlmap::sim
