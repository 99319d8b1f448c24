#include "mlmap/sim/depth_camera.h"

#include "noise.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace mlmap::sim {
namespace {

using detail::standardNormal;

/// Image tiles culled together [px].
constexpr std::size_t kTileSize_px = 16;

}  // namespace

Transform opticalToBody() {
  Eigen::Matrix3d R_B_S;
  // Columns are the optical axes expressed in the body frame.
  R_B_S << 0.0, 0.0, 1.0,  //
      -1.0, 0.0, 0.0,      //
      0.0, -1.0, 0.0;
  Transform T_B_S = Transform::Identity();
  T_B_S.linear() = R_B_S;
  return T_B_S;
}

DepthCamera::DepthCamera(const DepthCameraModel& model) : model_(model) {}

void DepthCamera::render(const World& world, const Transform& T_W_S, double time_s,
                         DepthFrame* frame) const {
  if (frame == nullptr) return;
  const PinholeIntrinsics& K = model_.intrinsics;
  frame->stamp_s = time_s;
  frame->encoding = DepthEncoding::kFloat32Metres;
  frame->intrinsics = K;
  frame->depth_mm.clear();
  const bool valid = K.width > 0 && K.height > 0 && K.fx > 0.0 && K.fy > 0.0 &&
                     std::isfinite(K.fx) && std::isfinite(K.fy) && std::isfinite(K.cx) &&
                     std::isfinite(K.cy);
  if (!valid) {
    frame->depth_m.clear();
    return;
  }
  const std::size_t width = static_cast<std::size_t>(K.width);
  const std::size_t height = static_cast<std::size_t>(K.height);
  frame->depth_m.assign(width * height, 0.0f);

  const Eigen::Matrix3d R_W_S = T_W_S.linear();
  const Eigen::Vector3d origin_W = T_W_S.translation();
  const double inv_fx = 1.0 / K.fx;
  const double inv_fy = 1.0 / K.fy;
  const bool noisy = model_.noise_coeff_per_m > 0.0;
  const std::uint64_t frame_key = detail::frameKey(model_.seed, time_s);

  // Cull the scene once per tile of pixels: the centre rays of a tile lie in the pyramid spanned
  // by the centre rays of its corner pixels.
  auto rayInS = [&](std::size_t u, std::size_t v) {
    return Eigen::Vector3d((static_cast<double>(u) - K.cx) * inv_fx,
                           (static_cast<double>(v) - K.cy) * inv_fy, 1.0);
  };
  RayCandidates candidates;
  for (std::size_t v0 = 0; v0 < height; v0 += kTileSize_px) {
    const std::size_t v1 = std::min(v0 + kTileSize_px, height) - 1;
    for (std::size_t u0 = 0; u0 < width; u0 += kTileSize_px) {
      const std::size_t u1 = std::min(u0 + kTileSize_px, width) - 1;
      const Eigen::Vector3d corners_S[4] = {rayInS(u0, v0), rayInS(u1, v0), rayInS(u1, v1),
                                            rayInS(u0, v1)};
      Eigen::Vector3d corners_W[4];
      double tile_t_max = 0.0;
      for (int i = 0; i < 4; ++i) {
        corners_W[i] = R_W_S * corners_S[i].normalized();
        // Ray length per z-depth is convex in the pixel position, so corners bound it.
        tile_t_max = std::max(tile_t_max, model_.max_depth_m * corners_S[i].norm());
      }
      world.gatherCandidates(origin_W, corners_W, tile_t_max, time_s, &candidates);
      if (candidates.size() == 0) continue;
      for (std::size_t v = v0; v <= v1; ++v) {
        for (std::size_t u = u0; u <= u1; ++u) {
          const Eigen::Vector3d ray_S = rayInS(u, v);
          // |(x, y, 1)|: ray length per metre of z-depth.
          const double length_per_z = ray_S.norm();
          const Eigen::Vector3d dir_W = R_W_S * (ray_S / length_per_z);
          double t_hit = 0.0;
          if (!world.raycast(candidates, dir_W, model_.max_depth_m * length_per_z, &t_hit)) {
            continue;
          }
          const double z = t_hit / length_per_z;
          if (z < model_.min_depth_m) continue;
          double measured = z;
          if (noisy) {
            const std::size_t index = v * width + u;
            measured += model_.noise_coeff_per_m * z * z * standardNormal(frame_key, index);
            if (!(measured > 0.0)) continue;
          }
          frame->depth_m[v * width + u] = static_cast<float>(measured);
        }
      }
    }
  }
}

}  // namespace mlmap::sim
