#pragma once
/// @file
/// The projected 2D occupancy grid (paper Fig. 6): the voxels of a height band projected to the
/// ground plane, with the cell values of nav_msgs/OccupancyGrid.
///
/// A cell (column of voxels) is
/// - occupied (100) when a voxel of the band in it is occupied,
/// - free (0) when none is occupied and at least one is observed free,
/// - unknown (-1) when no voxel of the band in it was observed.
/// With `probability_values` the known cells hold instead the highest occupancy probability of
/// the band's observed voxels, scaled to 0..100 (rounded).
/// A voxel belongs to the band when its centre height lies in [band_min, band_max].

#include "mlmap/core/config.h"
#include "mlmap/global/global_map.h"
#include "mlmap/local/local_map.h"

#include <cstdint>
#include <vector>

namespace mlmap {

/// A 2D grid in nav_msgs/OccupancyGrid layout: cell (x, y) is cells[y * width + x], cell (0, 0)
/// has its lower corner at origin_W, x and y along the world axes.
struct ProjectedGrid {
  static constexpr std::int8_t kUnknown = -1;
  static constexpr std::int8_t kFree = 0;
  static constexpr std::int8_t kOccupied = 100;

  Eigen::Vector2d origin_W = Eigen::Vector2d::Zero();  ///< lower corner of cell (0, 0) [m]
  double resolution_m = 0.2;                           ///< cell edge [m]
  int width = 0;                                       ///< cells along x
  int height = 0;                                      ///< cells along y
  double band_min_z_m = 0.0;                           ///< the band used, absolute heights in W [m]
  double band_max_z_m = 0.0;
  std::vector<std::int8_t> cells;  ///< width * height values, row-major in y

  /// Value of cell (x, y), which must lie inside.
  [[nodiscard]] std::int8_t at(int x, int y) const {
    return cells[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                 static_cast<std::size_t>(x)];
  }
  /// Value at a world point (x, y); unknown outside the grid.
  [[nodiscard]] std::int8_t valueAt(const Eigen::Vector2d& p_W) const;
};

/// World z layers [k0, k1) of the band [z_min_m, z_max_m]: those whose centre (k + 0.5) * res
/// lies in it (k1 == k0 when none does, or when a bound is NaN or z_min_m > z_max_m). Layers
/// beyond +-2^30 are never in it, so the range stays short for any heights.
void bandLayers(double z_min_m, double z_max_m, double resolution_m, int* k0, int* k1);

/// Builds the grid of the local window (and, when configured, of the global map's occupied voxels
/// in the band) into `out`, reusing its memory. `body_z_m` anchors a relative band.
///
/// The local part reads only the band's voxels of the window (a few layers); with
/// `include_global` the grid grows to the global map's extent, whose occupied voxels in the band
/// are added on top. PlanningLayers rebuilds it whole only when the window or the band moved, and
/// otherwise updates the columns of the submaps that changed (reprojectWindowColumns()).
void projectToGrid(const LocalWindow& window, const GlobalMap* global,
                   const ProjectedGridConfig& config, double body_z_m, ProjectedGrid* out);

/// Recomputes the cells of the window columns [begin, end) (window-relative x, y; clipped to
/// the window) of `grid` from `window`, for an incremental update after only those columns
/// changed. `grid` must come from projectToGrid() with the same config, a window at the same
/// place and the same band, and its cells over the window must depend on the window alone:
/// true unless the global map is included and the band reaches beyond the window's z range.
void reprojectWindowColumns(const LocalWindow& window, const ProjectedGridConfig& config,
                            const Eigen::Vector2i& begin, const Eigen::Vector2i& end,
                            ProjectedGrid* grid);

}  // namespace mlmap
