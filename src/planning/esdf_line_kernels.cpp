#include "esdf_line_kernels.h"

namespace mlmap::esdf_kernel {
namespace {

/// Forward sweep over `n` consecutive voxels (a run of z, and of y when rows are blocked) at x:
/// updates the last non-obstacle / obstacle x of each and writes the signed distance to the last
/// voxel of the other kind (negative for obstacles). Branch-free, so it vectorises.
inline __attribute__((always_inline)) void sweepForward(const std::uint8_t* __restrict states,
                                                        std::int32_t* __restrict a,
                                                        std::int32_t* __restrict last_free,
                                                        std::int32_t* __restrict last_obstacle,
                                                        int n, std::int32_t x,
                                                        std::int32_t unknown_is_obstacle) {
  for (int z = 0; z < n; ++z) {
    const bool obstacle = isObstacle(states[z], unknown_is_obstacle);
    const std::int32_t lf = last_free[z];
    const std::int32_t lo = last_obstacle[z];
    last_free[z] = obstacle ? lf : x;
    last_obstacle[z] = obstacle ? x : lo;
    a[z] = obstacle ? lf - x : x - lo;  // signed: negative for obstacles
  }
}

/// Backward sweep of pass 1: the same towards higher x, keeping the nearer side, capped (+-inf
/// beyond cap_d). The distance is left unsquared (the y pass squares it).
inline __attribute__((always_inline)) void sweepBackward(std::int32_t* __restrict a,
                                                         std::int32_t* __restrict next_free,
                                                         std::int32_t* __restrict next_obstacle,
                                                         int n, std::int32_t x, std::int32_t cap_d,
                                                         std::int32_t inf) {
  for (int z = 0; z < n; ++z) {
    // Branch-free so that it vectorises: m is all ones for an obstacle, 0 otherwise.
    const std::int32_t left = a[z];
    const std::int32_t m = -static_cast<std::int32_t>(left < 0);
    const std::int32_t nf = next_free[z];
    const std::int32_t no = next_obstacle[z];
    next_free[z] = (nf & m) | (x & ~m);
    next_obstacle[z] = (x & m) | (no & ~m);
    const std::int32_t from_left = (left ^ m) - m;  // |left|
    const std::int32_t from_right = ((nf & m) | (no & ~m)) - x;
    const std::int32_t d = std::min(from_left, from_right);
    const std::int32_t v = d <= cap_d ? d : inf;  // distance, not squared: the y pass squares it
    a[z] = (v ^ m) - m;                           // -v for obstacles
  }
}

}  // namespace

MLMAP_ESDF_CLONES
void sweepBlock(const std::uint8_t* states, std::size_t state_stride, std::int32_t* out,
                std::size_t out_stride, int nx, int n, std::int32_t* near_free,
                std::int32_t* near_obstacle, std::int32_t unknown_is_obstacle, std::int32_t cap_d,
                std::int32_t inf, std::int8_t* narrow, std::size_t narrow_stride) {
  constexpr std::int32_t kFar = std::int32_t{1} << 24;  // beyond any cap_d
  std::fill(near_free, near_free + n, -kFar);
  std::fill(near_obstacle, near_obstacle + n, -kFar);
  for (int x = 0; x < nx; ++x) {
    sweepForward(states + static_cast<std::size_t>(x) * state_stride,
                 out + static_cast<std::size_t>(x) * out_stride, near_free, near_obstacle, n, x,
                 unknown_is_obstacle);
  }
  std::fill(near_free, near_free + n, nx - 1 + kFar);
  std::fill(near_obstacle, near_obstacle + n, nx - 1 + kFar);
  for (int x = nx - 1; x >= 0; --x) {
    std::int32_t* a = out + static_cast<std::size_t>(x) * out_stride;
    sweepBackward(a, near_free, near_obstacle, n, x, cap_d, inf);
    if (narrow == nullptr) continue;
    std::int8_t* to = narrow + static_cast<std::size_t>(x) * narrow_stride;
    for (int z = 0; z < n; ++z) to[z] = static_cast<std::int8_t>(a[z]);
  }
}

}  // namespace mlmap::esdf_kernel
