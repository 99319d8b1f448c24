#pragma once
/// @file
/// Part of the ESDF (EsdfMap, esdf.h): the field's storage and its queries. EsdfField holds the
/// clamped signed distance of every voxel of a box [m] and one bit per voxel that was unknown,
/// and answers the trilinear queries; EsdfMap computes what it holds.

#include "mlmap/core/types.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace mlmap {

/// A trilinear interpolation: its value and its partial derivatives per unit of the fractions.
struct Trilinear {
  double value = 0.0;  ///< the interpolated value
  double d_dtx = 0.0;  ///< d value / d tx
  double d_dty = 0.0;  ///< d value / d ty
  double d_dtz = 0.0;  ///< d value / d tz
};

/// Interpolates the corner values c<x><y><z> of a cell at fractions (tx, ty, tz) in [0, 1]^3:
/// z first, then y, then x, with the derivatives of the same lines (the one arithmetic of
/// EsdfMap::query() and EsdfQueryGrid::query()).
inline Trilinear trilinear(double c000, double c001, double c010, double c011, double c100,
                           double c101, double c110, double c111, double tx, double ty, double tz) {
  const double dz00 = c001 - c000;
  const double dz01 = c011 - c010;
  const double dz10 = c101 - c100;
  const double dz11 = c111 - c110;
  const double c00 = c000 + tz * dz00;
  const double c01 = c010 + tz * dz01;
  const double c10 = c100 + tz * dz10;
  const double c11 = c110 + tz * dz11;
  const double dy0 = c01 - c00;
  const double dy1 = c11 - c10;
  const double c0 = c00 + ty * dy0;
  const double c1 = c10 + ty * dy1;
  const double dz0 = dz00 + ty * (dz01 - dz00);
  const double dz1 = dz10 + ty * (dz11 - dz10);
  return {c0 + tx * (c1 - c0), c1 - c0, dy0 + tx * (dy1 - dy0), dz0 + tx * (dz1 - dz0)};
}

/// Answers `count` queries in order into `out` while prefetching the cells of the point `ahead`
/// places later (the one loop of EsdfMap::queryBatch() and EsdfQueryGrid::queryBatch()), so the
/// memory latencies of many queries overlap.
template <typename Result, typename Prefetch, typename Query>
void prefetchedQueries(const Eigen::Vector3d* points_W, std::size_t count, std::size_t ahead,
                       Result* out, const Prefetch& prefetch, const Query& query) {
  ahead = std::min(count, ahead);
  for (std::size_t i = 0; i < ahead; ++i) prefetch(points_W[i]);
  for (std::size_t i = 0; i < count; ++i) {
    if (i + ahead < count) prefetch(points_W[i + ahead]);
    out[i] = query(points_W[i]);
  }
}

/// Result of a distance query (EsdfMap::Query): distance, gradient and whether they may be
/// trusted.
struct EsdfQuery {
  /// Interpolated signed distance [m]; 0 outside the box.
  double distance_m = 0.0;
  /// d distance_m / d p_W (dimensionless); zero outside the box.
  Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
  /// True when p_W is inside the box and its voxel is known (free or occupied). Inside the box
  /// but in an unknown voxel, distance_m and gradient are still filled in, with valid = false.
  bool valid = false;
};

/// The stored field of a box of the world voxel grid: a value per voxel [m] in box order
/// (x-major, z fastest, as OccupancyBox) and an unknown bit per voxel, with the box's geometry.
/// The const members may be called concurrently from any number of threads; the others must not
/// run concurrently with anything else on the same object. Distinct x slabs may be written from
/// distinct threads (each slab's unknown bits start on a new 64-bit word).
class EsdfField {
 public:
  /// How many points ahead queryBatch() prefetches.
  static constexpr std::size_t kQueryPrefetchAhead = 12;

  /// Takes the geometry of a box (first voxel `min_index`, `size` voxels per axis, each at least
  /// 1, voxels of `resolution_m` [m]) and sizes the values and bits for it (grown only; their
  /// contents are left to the caller to write).
  void reset(const VoxelIndex& min_index, const Eigen::Vector3i& size, double resolution_m);
  /// Empties the field (size 0, every query invalid); keeps the buffers' capacity.
  void clear();
  /// Moves the box to start at world voxel `min_index` (same size), leaving the values and bits
  /// to the caller.
  void setMinIndex(const VoxelIndex& min_index) { min_index_ = min_index; }

  /// Trilinear distance and its analytic gradient at a world point (metres): see
  /// EsdfMap::query().
  [[nodiscard]] EsdfQuery query(const Eigen::Vector3d& p_W) const;
  /// query() at `count` points into `out`, prefetching kQueryPrefetchAhead points ahead: see
  /// EsdfMap::queryBatch().
  void queryBatch(const Eigen::Vector3d* points_W, std::size_t count, EsdfQuery* out) const {
    prefetchedQueries(
        points_W, count, kQueryPrefetchAhead, out,
        [this](const Eigen::Vector3d& p_W) { prefetchQuery(p_W); },
        [this](const Eigen::Vector3d& p_W) { return query(p_W); });
  }
  /// Cell value of a world voxel [m] (the value at its centre); NaN outside the box.
  [[nodiscard]] float distanceAt(const VoxelIndex& world_index) const;
  /// True when the world voxel lies inside the box.
  [[nodiscard]] bool contains(const VoxelIndex& world_index) const {
    return boxContains(min_index_, size_, world_index);
  }
  /// True when box-relative voxel (x, y, z) (inside the box, unchecked) has its unknown bit set.
  [[nodiscard]] bool isUnknownCell(int x, int y, int z) const {
    const std::size_t bit = static_cast<std::size_t>(x) * slab_bits_ +
                            static_cast<std::size_t>(y) * static_cast<std::size_t>(size_.z()) +
                            static_cast<std::size_t>(z);
    return ((unknown_bits_[bit >> 6] >> (bit & 63)) & 1u) != 0;
  }
  /// True when the world voxel is inside the box and has its unknown bit set.
  [[nodiscard]] bool isUnknown(const VoxelIndex& world_index) const {
    if (!contains(world_index)) return false;
    const VoxelIndex r = world_index - min_index_;
    return isUnknownCell(r.x(), r.y(), r.z());
  }
  /// True when the box is empty (size 0).
  [[nodiscard]] bool empty() const { return size_.prod() == 0; }
  /// First voxel of the box (world index, inclusive).
  [[nodiscard]] const VoxelIndex& minIndex() const { return min_index_; }
  /// One past the last voxel of the box (world index).
  [[nodiscard]] VoxelIndex maxIndex() const { return min_index_ + size_; }
  /// Box size in voxels.
  [[nodiscard]] const Eigen::Vector3i& size() const { return size_; }
  /// Voxel edge length [m].
  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  /// Cell values [m] in box order (x-major, z fastest).
  [[nodiscard]] const std::vector<float>& values_m() const { return values_m_; }
  /// The same, to be written by the ESDF's passes (the size is reset()'s).
  [[nodiscard]] std::vector<float>& mutableValues_m() { return values_m_; }

  /// Sets the unknown bits of x slab `x` from the box states `states` (the whole box's,
  /// OccupancyBox order, as bytes: Occupancy::kUnknown is 0).
  void writeUnknownBits(const std::uint8_t* states, int x);
  /// Flips the unknown bit of the cell at `in_slab` = y * nz + z of x slab `x`.
  void flipUnknownBit(std::size_t x, std::size_t in_slab) {
    const std::size_t bit = x * slab_bits_ + in_slab;
    unknown_bits_[bit >> 6] ^= std::uint64_t{1} << (bit & 63);
  }
  /// Copies the unknown bits of x slab `from_x` to x slab `to_x`.
  void copyUnknownSlab(int from_x, int to_x);
  /// Copies from `source` the cells at `offsets` (value and unknown bit); see
  /// EsdfMap::copyCells(). False, nothing copied, when the geometries differ.
  bool copyCells(const EsdfField& source, const std::vector<std::uint32_t>& offsets);
  /// Bytes held by the values and the unknown bits.
  [[nodiscard]] std::size_t memoryBytes() const {
    return values_m_.capacity() * sizeof(float) + unknown_bits_.capacity() * sizeof(std::uint64_t);
  }
  /// Prefetches what query(p_W) reads (nothing outside the box).
  void prefetchQuery(const Eigen::Vector3d& p_W) const;

 private:
  VoxelIndex min_index_ = VoxelIndex::Zero();
  Eigen::Vector3i size_ = Eigen::Vector3i::Zero();
  double resolution_m_ = 1.0;
  double inv_resolution_ = 1.0;  ///< 1 / resolution_m_ [1/m]
  std::ptrdiff_t step_x_ = 0;    ///< query stencil: offset of the +1 neighbour in x (0 if nx = 1)
  std::ptrdiff_t step_y_ = 0;    ///< ... in y
  std::ptrdiff_t step_z_ = 0;    ///< ... in z
  std::vector<float> values_m_;  ///< clamped signed distance per voxel [m]
  /// One bit per voxel, set where the box voxel was unknown; each x slab starts on a new
  /// 64-bit word (slab_bits_ apart) so that threads never share a word.
  std::vector<std::uint64_t> unknown_bits_;
  std::size_t slab_bits_ = 0;
};

inline EsdfQuery EsdfField::query(const Eigen::Vector3d& p_W) const {
  EsdfQuery q;
  // Continuous grid coordinates; the range test also rejects NaN before any float->int cast.
  constexpr double kMaxGrid = 1073741824.0;  // 2^30
  const double gx = p_W.x() * inv_resolution_;
  const double gy = p_W.y() * inv_resolution_;
  const double gz = p_W.z() * inv_resolution_;
  if (!(std::abs(gx) < kMaxGrid && std::abs(gy) < kMaxGrid && std::abs(gz) < kMaxGrid)) return q;
  const int vx = floorToInt(gx) - min_index_.x();
  const int vy = floorToInt(gy) - min_index_.y();
  const int vz = floorToInt(gz) - min_index_.z();
  if (static_cast<unsigned>(vx) >= static_cast<unsigned>(size_.x()) ||
      static_cast<unsigned>(vy) >= static_cast<unsigned>(size_.y()) ||
      static_cast<unsigned>(vz) >= static_cast<unsigned>(size_.z())) {
    return q;
  }
  const std::ptrdiff_t ny = size_.y();
  const std::ptrdiff_t nz = size_.z();
  q.valid = !isUnknownCell(vx, vy, vz);

  // Cell-centre coordinates: cell i has its centre at i. Lower stencil corner clamped to
  // [0, n - 2] (0 when n = 1), fraction clamped to [0, 1].
  const double ux = gx - (static_cast<double>(min_index_.x()) + 0.5);
  const double uy = gy - (static_cast<double>(min_index_.y()) + 0.5);
  const double uz = gz - (static_cast<double>(min_index_.z()) + 0.5);
  const int ix = std::clamp(floorToInt(ux), 0, std::max(size_.x() - 2, 0));
  const int iy = std::clamp(floorToInt(uy), 0, std::max(size_.y() - 2, 0));
  const int iz = std::clamp(floorToInt(uz), 0, std::max(size_.z() - 2, 0));
  const double rx = ux - ix;
  const double ry = uy - iy;
  const double rz = uz - iz;
  const double tx = std::clamp(rx, 0.0, 1.0);
  const double ty = std::clamp(ry, 0.0, 1.0);
  const double tz = std::clamp(rz, 0.0, 1.0);
  const double kx = rx == tx ? inv_resolution_ : 0.0;  // d t / d p, 0 where held constant
  const double ky = ry == ty ? inv_resolution_ : 0.0;
  const double kz = rz == tz ? inv_resolution_ : 0.0;

  const float* c = values_m_.data() + (ix * ny + iy) * nz + iz;
  const Trilinear t = trilinear(c[0], c[step_z_], c[step_y_], c[step_y_ + step_z_], c[step_x_],
                                c[step_x_ + step_z_], c[step_x_ + step_y_],
                                c[step_x_ + step_y_ + step_z_], tx, ty, tz);
  q.distance_m = t.value;
  q.gradient.x() = t.d_dtx * kx;
  q.gradient.y() = t.d_dty * ky;
  q.gradient.z() = t.d_dtz * kz;
  return q;
}

inline void EsdfField::prefetchQuery(const Eigen::Vector3d& p_W) const {
  constexpr double kMaxGrid = 1073741824.0;  // 2^30 (as query())
  const double gx = p_W.x() * inv_resolution_;
  const double gy = p_W.y() * inv_resolution_;
  const double gz = p_W.z() * inv_resolution_;
  if (!(std::abs(gx) < kMaxGrid && std::abs(gy) < kMaxGrid && std::abs(gz) < kMaxGrid)) return;
  const int vx = floorToInt(gx) - min_index_.x();
  const int vy = floorToInt(gy) - min_index_.y();
  const int vz = floorToInt(gz) - min_index_.z();
  if (static_cast<unsigned>(vx) >= static_cast<unsigned>(size_.x()) ||
      static_cast<unsigned>(vy) >= static_cast<unsigned>(size_.y()) ||
      static_cast<unsigned>(vz) >= static_cast<unsigned>(size_.z())) {
    return;
  }
  // The stencil's lower corner (as query(), within a voxel of the point's own).
  const int ix = std::clamp(floorToInt(gx - (static_cast<double>(min_index_.x()) + 0.5)), 0,
                            std::max(size_.x() - 2, 0));
  const int iy = std::clamp(floorToInt(gy - (static_cast<double>(min_index_.y()) + 0.5)), 0,
                            std::max(size_.y() - 2, 0));
  const int iz = std::clamp(floorToInt(gz - (static_cast<double>(min_index_.z()) + 0.5)), 0,
                            std::max(size_.z() - 2, 0));
  const float* c =
      values_m_.data() + (static_cast<std::ptrdiff_t>(ix) * size_.y() + iy) * size_.z() + iz;
#if defined(__GNUC__)
  __builtin_prefetch(c);
  __builtin_prefetch(c + step_z_);
  __builtin_prefetch(c + step_y_ + step_z_);
  __builtin_prefetch(c + step_x_ + step_z_);
  __builtin_prefetch(c + step_x_ + step_y_ + step_z_);
  const std::size_t bit = static_cast<std::size_t>(vx) * slab_bits_ +
                          static_cast<std::size_t>(vy) * static_cast<std::size_t>(size_.z()) +
                          static_cast<std::size_t>(vz);
  __builtin_prefetch(unknown_bits_.data() + (bit >> 6));
#else
  (void)c;
#endif
}

}  // namespace mlmap
