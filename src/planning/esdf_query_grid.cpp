#include "mlmap/planning/esdf_query_grid.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace mlmap {
namespace {

/// Offset that makes every level positive before truncation (levels lie within +-kMaxLevel).
constexpr std::int32_t kLevelOffset = EsdfQueryGrid::kMaxLevel + 1;

/// round(level) (half up) clamped to +-kMaxLevel, for |level| <= kMaxLevel + 0.5: truncation
/// of a positive value, which vectorises (std::nearbyint is a call without SSE4.1).
inline std::int32_t quantise(double level) {
  const std::int32_t q = static_cast<std::int32_t>(level + (kLevelOffset + 0.5)) - kLevelOffset;
  return std::clamp(q, -EsdfQueryGrid::kMaxLevel, EsdfQueryGrid::kMaxLevel);
}

/// out[z] = 2 * quantise(in[z] * inv_step): a row of cells' values, their unknown bits still
/// clear. Built for AVX2 / AVX-512 too (it vectorises).
MLMAP_ESDF_CLONES
void encodeRow(const float* in, int n, double inv_step, std::int16_t* out) {
  for (int z = 0; z < n; ++z) {
    out[z] = static_cast<std::int16_t>(2 * quantise(static_cast<double>(in[z]) * inv_step));
  }
}

}  // namespace

std::int16_t EsdfQueryGrid::encode(float distance_m, bool unknown) const {
  const std::int32_t q = quantise(static_cast<double>(distance_m) * inv_step_);
  return static_cast<std::int16_t>(q * 2 + (unknown ? 1 : 0));
}

void EsdfQueryGrid::build(const EsdfMap& map) {
  min_index_ = map.minIndex();
  size_ = map.size();
  cells_.clear();
  if (map.empty()) {
    size_ = Eigen::Vector3i::Zero();
    return;
  }
  inv_resolution_ = 1.0 / map.resolution_m();
  max_distance_m_ = map.config().max_distance_m;
  step_m_ = max_distance_m_ / kMaxLevel;
  inv_step_ = kMaxLevel / max_distance_m_;
  for (int a = 0; a < 3; ++a) {
    origin_[a] = static_cast<double>(min_index_[a]) - 0.5;
    limit_[a] = static_cast<double>(size_[a]) + 0.5;
  }
  const int nx = size_.x();
  const int ny = size_.y();
  const int nz = size_.z();
  stride_y_ = nz + 2;
  stride_x_ = static_cast<std::ptrdiff_t>(ny + 2) * stride_y_;
  cells_.resize(static_cast<std::size_t>(nx + 2) * static_cast<std::size_t>(stride_x_));
  const float* field = map.distances().data();
  std::int16_t* cells = cells_.data();
  // The box cells, each row's two z padding cells with them.
  for (int x = 0; x < nx; ++x) {
    for (int y = 0; y < ny; ++y) {
      const float* in = field + (static_cast<std::size_t>(x) * ny + y) * nz;
      std::int16_t* out = cells + (x + 1) * stride_x_ + (y + 1) * stride_y_;
      encodeRow(in, nz, inv_step_, out + 1);
      for (int z = 0; z < nz; ++z) {
        out[z + 1] = static_cast<std::int16_t>(out[z + 1] | (map.isUnknownCell(x, y, z) ? 1 : 0));
      }
      out[0] = out[1];
      out[nz + 1] = out[nz];
    }
  }
  // The y padding rows of each box slab, then the two x padding slabs (edges and corners
  // follow: each copies cells that already hold their nearest box cell).
  const std::size_t row_bytes = static_cast<std::size_t>(stride_y_) * sizeof(std::int16_t);
  for (int x = 1; x <= nx; ++x) {
    std::int16_t* slab = cells + x * stride_x_;
    std::memcpy(slab, slab + stride_y_, row_bytes);
    std::memcpy(slab + (ny + 1) * stride_y_, slab + ny * stride_y_, row_bytes);
  }
  const std::size_t slab_bytes = static_cast<std::size_t>(stride_x_) * sizeof(std::int16_t);
  std::memcpy(cells, cells + stride_x_, slab_bytes);
  std::memcpy(cells + (nx + 1) * stride_x_, cells + nx * stride_x_, slab_bytes);
}

void EsdfQueryGrid::writePadding(int x, int y, int z, std::int16_t value) {
  const int px[2] = {x + 1, x == 0 ? 0 : (x == size_.x() - 1 ? size_.x() + 1 : -1)};
  const int py[2] = {y + 1, y == 0 ? 0 : (y == size_.y() - 1 ? size_.y() + 1 : -1)};
  const int pz[2] = {z + 1, z == 0 ? 0 : (z == size_.z() - 1 ? size_.z() + 1 : -1)};
  // (A box of one voxel along an axis has padding on both sides of that voxel.)
  const int px_last = size_.x() == 1 ? 2 : -1;
  const int py_last = size_.y() == 1 ? 2 : -1;
  const int pz_last = size_.z() == 1 ? 2 : -1;
  const auto side = [](const int* p, int last, int i) { return i < 2 ? p[i] : last; };
  for (int a = 0; a < 3; ++a) {
    const int cx = side(px, px_last, a);
    if (cx < 0) continue;
    for (int b = 0; b < 3; ++b) {
      const int cy = side(py, py_last, b);
      if (cy < 0) continue;
      for (int c = 0; c < 3; ++c) {
        const int cz = side(pz, pz_last, c);
        if (cz < 0) continue;
        cells_[static_cast<std::size_t>(cx * stride_x_ + cy * stride_y_ + cz)] = value;
      }
    }
  }
}

bool EsdfQueryGrid::sameGeometry(const EsdfMap& map) const {
  return !empty() && !map.empty() && map.minIndex() == min_index_ && map.size() == size_ &&
         1.0 / map.resolution_m() == inv_resolution_ &&
         map.config().max_distance_m == max_distance_m_;
}

bool EsdfQueryGrid::sync(const EsdfMap& map) {
  const EsdfMap::UpdateStats& last = map.lastUpdate();
  if (last.full || last.shifted || !sameGeometry(map)) {
    build(map);
    return false;
  }
  return syncCells(map, map.changedCells());
}

bool EsdfQueryGrid::syncCells(const EsdfMap& map, const std::vector<std::uint32_t>& offsets) {
  if (!sameGeometry(map)) return false;
  const float* field = map.distances().data();
  const auto cells = static_cast<std::uint32_t>(map.distances().size());
  // 32-bit divisions (offsets are 32-bit; kMaxCells keeps the box below 2^28 voxels).
  const auto nz = static_cast<std::uint32_t>(size_.z());
  const std::uint32_t slab = static_cast<std::uint32_t>(size_.y()) * nz;
  for (const std::uint32_t offset : offsets) {
    if (offset >= cells) continue;
    const std::uint32_t x = offset / slab;
    const std::uint32_t r = offset - x * slab;
    const std::uint32_t y = r / nz;
    const std::uint32_t z = r - y * nz;
    const std::int16_t value =
        encode(field[offset],
               map.isUnknownCell(static_cast<int>(x), static_cast<int>(y), static_cast<int>(z)));
    cells_[static_cast<std::size_t>(x + 1) * static_cast<std::size_t>(stride_x_) +
           static_cast<std::size_t>(y + 1) * static_cast<std::size_t>(stride_y_) + z + 1] = value;
    if (x == 0 || y == 0 || z == 0 || static_cast<int>(x) == size_.x() - 1 ||
        static_cast<int>(y) == size_.y() - 1 || static_cast<int>(z) == size_.z() - 1) {
      writePadding(static_cast<int>(x), static_cast<int>(y), static_cast<int>(z), value);
    }
  }
  return true;
}

}  // namespace mlmap
