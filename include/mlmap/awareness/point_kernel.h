#pragma once
/// @file
/// The awareness stage's per-point kernel (pass 1 of its point loop): sensor-frame points, in
/// blocks of structure-of-arrays form, to the key of the scratch-box voxel they fall in (or why
/// there is none) and their box-relative coordinates. Public for its tests; the awareness stage
/// is its only user.
///
/// Two implementations give the same bits: a portable one (plain C++ the compiler vectorises)
/// and, on x86-64 CPUs that have it, an AVX2 one (the same IEEE operations in the same order,
/// four points at a time, no fused multiply-add). classifyPoints() takes the AVX2 one when the
/// CPU runs it.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace mlmap {

/// Set in a key when the point's ray was cut at the maximum range (the point is no hit).
constexpr std::uint32_t kPointCutFlag = 0x80000000u;
/// Keys of points that are not in a box voxel (box keys stay far below these).
constexpr std::uint32_t kPointOutsideCutKey = 0xFFFFFFFCu;  ///< outside the box, ray cut
constexpr std::uint32_t kPointOutsideHitKey = 0xFFFFFFFDu;  ///< outside the box, a hit
constexpr std::uint32_t kPointTooCloseKey = 0xFFFFFFFEu;    ///< within the minimum range
constexpr std::uint32_t kPointNonFiniteKey = 0xFFFFFFFFu;   ///< NaN or infinite coordinate

/// One frame's constants for the kernel.
struct PointKernel {
  std::array<double, 9> m{};            ///< R_W_S / resolution, row-major
  std::array<double, 3> o{};            ///< sensor origin in world voxel units
  std::array<double, 3> box_origin{};   ///< scratch box origin (world voxel index)
  std::array<std::uint32_t, 3> dims{};  ///< scratch box size in voxels (each below 2^31)
  double min_range2 = 0.0;              ///< squared minimum range [m^2]
  double max_range = 0.0;               ///< maximum range [m]
};

/// Which implementation classifyPoints() runs.
enum class PointKernelIsa { kPortable, kAvx2 };

/// Whether this build and CPU run the AVX2 implementation.
bool pointKernelAvx2Supported();

/// For each of the `n` points (xs[i], ys[i], zs[i]) in the sensor frame [m]:
/// - the world voxel units w = o + M p, with a point beyond the maximum range first moved onto
///   it along its ray, and b = w - box_origin;
/// - keys[i]: kPointNonFiniteKey for NaN / Inf, kPointTooCloseKey within the minimum range,
///   otherwise the box voxel floor(b) as (ix * dims[1] + iy) * dims[2] + iz, or
///   kPointOutsideHitKey when it lies outside the box; kPointCutFlag is or-ed into a box key and
///   kPointOutsideHitKey becomes kPointOutsideCutKey when the ray was cut;
/// - coords[4 i .. 4 i + 3] = (b rounded to float, 0); a non-finite point gets the sensor
///   origin's b.
/// `isa` must be supported (kAvx2 only when pointKernelAvx2Supported()).
void classifyPoints(const PointKernel& kernel, const float* xs, const float* ys, const float* zs,
                    std::size_t n, std::uint32_t* keys, float* coords, PointKernelIsa isa);

/// The same with the fastest implementation this CPU runs.
void classifyPoints(const PointKernel& kernel, const float* xs, const float* ys, const float* zs,
                    std::size_t n, std::uint32_t* keys, float* coords);

/// A block's runs of equal keys (pass 2 of the point loop): consecutive points in one voxel,
/// which depth images give along a row. Run r covers points first[r] .. first[r + 1] - 1; its
/// points' coordinates span box[8 r .. 8 r + 3] (minimum of each of the four floats) to
/// box[8 r + 4 .. 8 r + 7] (maximum). A run starts at point 0 and wherever a key differs from
/// the one before.
struct PointRuns {
  /// Extra entries a block's keys and coordinates (four floats a point) must have after the
  /// last point, readable (their values do not matter): the AVX2 form reads whole groups.
  static constexpr std::size_t kPadding = 8;
  std::vector<std::uint32_t> first;  ///< one more than the runs (first[count] = n), + padding
  std::vector<float> box;            ///< eight floats a run
  std::size_t count = 0;             ///< runs of the last groupPointRuns()

  /// Room for blocks of up to `max_points` points.
  explicit PointRuns(std::size_t max_points)
      : first(max_points + 1 + kPadding), box(8 * max_points) {}
};

/// Splits points 0 .. n - 1 (n >= 1, at most the size `runs` was made for) into runs of equal
/// keys[i], with each run's box of coords[4 i .. 4 i + 3]. keys and coords must be readable
/// PointRuns::kPadding points past n. The minima and maxima are exact, so both forms give the
/// same floats for finite coordinates (a zero of either sign may come out as the other where a
/// run holds both). `isa` must be supported (kAvx2 only when
/// pointKernelAvx2Supported()): the AVX2 form finds run starts eight keys at a time and takes
/// a run's box over eight points a step, without a branch per point.
void groupPointRuns(const std::uint32_t* keys, const float* coords, std::size_t n, PointRuns* runs,
                    PointKernelIsa isa);

/// The same with the fastest implementation this CPU runs.
void groupPointRuns(const std::uint32_t* keys, const float* coords, std::size_t n, PointRuns* runs);

/// The pixels with data among `count` consecutive pixels of one row of a depth image in
/// millimetres (data: neither 0 nor 0xFFFF), as sensor-frame points packed in pixel order:
/// z = raw * 0.001f [m], x = ray_x[k] z, y = ray_y z (backProject()'s float arithmetic).
/// Writes xs, ys, zs below index `count` only (also past the returned count); returns how many
/// pixels had data. `isa` must be supported (kAvx2 only when pointKernelAvx2Supported()): the
/// AVX2 form packs eight pixels at a time through a permutation table, the same bits.
std::size_t packDepthPixelsMm(const std::uint16_t* raw, const float* ray_x, float ray_y,
                              std::size_t count, float* xs, float* ys, float* zs,
                              PointKernelIsa isa);

/// The same with the fastest implementation this CPU runs.
std::size_t packDepthPixelsMm(const std::uint16_t* raw, const float* ray_x, float ray_y,
                              std::size_t count, float* xs, float* ys, float* zs);

}  // namespace mlmap
