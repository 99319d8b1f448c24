#include "mlmap/planning/fixed_origin_grid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mlmap {
namespace {

/// floor(a / b) for b > 0.
int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

/// The world cell index of a grid corner coordinate that lies on the lattice (within 1e-3 cell),
/// or false.
bool latticeIndex(double coordinate_m, double resolution_m, int* index) {
  const double cells = coordinate_m / resolution_m;
  const double rounded = std::round(cells);
  if (!(std::abs(cells - rounded) <= 1e-3) || std::abs(rounded) > 1e9) return false;
  *index = static_cast<int>(rounded);
  return true;
}

}  // namespace

FixedOriginGrid::FixedOriginGrid(int chunk_cells, std::size_t max_cells)
    : chunk_cells_(chunk_cells), max_cells_(max_cells) {
  if (chunk_cells < 1 ||
      max_cells < static_cast<std::size_t>(chunk_cells) * static_cast<std::size_t>(chunk_cells)) {
    throw std::invalid_argument("FixedOriginGrid: chunk_cells must be >= 1 and max_cells >= " +
                                std::string("chunk_cells^2 (got ") + std::to_string(chunk_cells) +
                                ", " + std::to_string(max_cells) + ")");
  }
}

bool FixedOriginGrid::cover(const Eigen::Vector2i& min_cell, const Eigen::Vector2i& max_cell) {
  Eigen::Vector2i chunk_min(floorDiv(min_cell.x(), chunk_cells_),
                            floorDiv(min_cell.y(), chunk_cells_));
  Eigen::Vector2i chunk_max(floorDiv(max_cell.x(), chunk_cells_),
                            floorDiv(max_cell.y(), chunk_cells_));
  if (!grid_.cells.empty()) {
    const Eigen::Vector2i have_min(floorDiv(origin_cell_.x(), chunk_cells_),
                                   floorDiv(origin_cell_.y(), chunk_cells_));
    const Eigen::Vector2i have_max =
        have_min + Eigen::Vector2i(grid_.width / chunk_cells_ - 1, grid_.height / chunk_cells_ - 1);
    if ((chunk_min.array() >= have_min.array()).all() &&
        (chunk_max.array() <= have_max.array()).all()) {
      return true;
    }
    chunk_min = chunk_min.cwiseMin(have_min);
    chunk_max = chunk_max.cwiseMax(have_max);
  }
  const std::size_t width = static_cast<std::size_t>(chunk_max.x() - chunk_min.x() + 1) *
                            static_cast<std::size_t>(chunk_cells_);
  const std::size_t height = static_cast<std::size_t>(chunk_max.y() - chunk_min.y() + 1) *
                             static_cast<std::size_t>(chunk_cells_);
  if (width > max_cells_ / height) return false;

  const Eigen::Vector2i new_origin = chunk_min * chunk_cells_;
  std::vector<std::int8_t> cells(width * height, ProjectedGrid::kUnknown);
  for (int y = 0; y < grid_.height; ++y) {  // the old cells at their new place
    const std::size_t new_y = static_cast<std::size_t>(y + origin_cell_.y() - new_origin.y());
    const std::size_t new_x0 = static_cast<std::size_t>(origin_cell_.x() - new_origin.x());
    const auto row = grid_.cells.begin() + static_cast<std::ptrdiff_t>(y) * grid_.width;
    std::copy(row, row + grid_.width,
              cells.begin() + static_cast<std::ptrdiff_t>(new_y * width + new_x0));
  }
  grid_.cells = std::move(cells);
  grid_.width = static_cast<int>(width);
  grid_.height = static_cast<int>(height);
  origin_cell_ = new_origin;
  grid_.origin_W = origin_cell_.cast<double>() * grid_.resolution_m;
  ++growths_;
  return true;
}

bool FixedOriginGrid::absorb(const ProjectedGrid& rolling) {
  if (rolling.cells.empty() || rolling.width <= 0 || rolling.height <= 0) return true;
  if (!(rolling.resolution_m > 0.0) ||
      (!grid_.cells.empty() && rolling.resolution_m != grid_.resolution_m)) {
    return false;
  }
  Eigen::Vector2i rolling_origin;
  if (!latticeIndex(rolling.origin_W.x(), rolling.resolution_m, &rolling_origin.x()) ||
      !latticeIndex(rolling.origin_W.y(), rolling.resolution_m, &rolling_origin.y())) {
    return false;
  }
  if (grid_.cells.empty()) grid_.resolution_m = rolling.resolution_m;
  grid_.band_min_z_m = rolling.band_min_z_m;
  grid_.band_max_z_m = rolling.band_max_z_m;

  const std::uint64_t growths_before = growths_;
  const Eigen::Vector2i rolling_max =
      rolling_origin + Eigen::Vector2i(rolling.width - 1, rolling.height - 1);
  const bool covered = cover(rolling_origin, rolling_max);
  bool changed = growths_ != growths_before;
  for (int y = 0; y < rolling.height; ++y) {
    const int gy = rolling_origin.y() + y - origin_cell_.y();
    for (int x = 0; x < rolling.width; ++x) {
      const std::int8_t value = rolling.at(x, y);
      if (value == ProjectedGrid::kUnknown) continue;
      const int gx = rolling_origin.x() + x - origin_cell_.x();
      if (!covered && (gx < 0 || gy < 0 || gx >= grid_.width || gy >= grid_.height)) {
        ++cells_dropped_;
        continue;
      }
      std::int8_t& cell =
          grid_.cells[static_cast<std::size_t>(gy) * static_cast<std::size_t>(grid_.width) +
                      static_cast<std::size_t>(gx)];
      changed = changed || cell != value;
      cell = value;
    }
  }
  if (changed) ++changes_;
  return true;
}

}  // namespace mlmap
