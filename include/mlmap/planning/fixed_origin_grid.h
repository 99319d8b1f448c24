#pragma once
/// @file
/// A 2D occupancy grid with a fixed origin that grows in whole chunks as the mapped area grows:
/// what a static layer of a global costmap (nav2) expects, where the projected grid
/// (projected_grid.h) moves with the vehicle and suits a rolling local costmap.

#include "mlmap/planning/projected_grid.h"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>

namespace mlmap {

/// Accumulates rolling grids (ProjectedGrid of the local window, moving with the vehicle) into
/// one grid whose cells stay where they are: cell (i, j) of the world lattice of the rolling
/// grids' resolution keeps the value of the latest rolling grid that knew it (occupied, free,
/// or a probability; unknown cells of a rolling grid change nothing). The grid covers whole
/// chunks of `chunk_cells` x `chunk_cells` cells, their corners at multiples of
/// chunk_cells * resolution_m in the world, so its origin moves only when it grows towards -x or
/// -y, and then by whole chunks.
class FixedOriginGrid {
 public:
  /// Default chunk edge [cells] (at 0.1 m: 6.4 m).
  static constexpr int kDefaultChunkCells = 64;
  /// Default largest grid [cells] (16 M cells = 16 MB, e.g. 400 x 400 m at 0.1 m).
  static constexpr std::size_t kDefaultMaxCells = std::size_t{1} << 24;

  /// `chunk_cells` >= 1 and `max_cells` >= chunk_cells^2, else std::invalid_argument.
  explicit FixedOriginGrid(int chunk_cells = kDefaultChunkCells,
                           std::size_t max_cells = kDefaultMaxCells);

  /// Copies the known cells of `rolling` over the grid, first growing it by whole chunks to
  /// cover `rolling` when the grown grid stays within max_cells (otherwise it keeps its size and
  /// the known cells outside it are counted in cellsDropped()). The first grid absorbed fixes
  /// the resolution; a rolling grid of another resolution, or whose origin is not on the cell
  /// lattice, is refused (false, nothing changed); an empty one changes nothing (true).
  bool absorb(const ProjectedGrid& rolling);

  /// The grid (empty before the first absorb()); its band is the last rolling grid's.
  [[nodiscard]] const ProjectedGrid& grid() const { return grid_; }
  /// Times the grid grew (its size or origin changed).
  [[nodiscard]] std::uint64_t growths() const { return growths_; }
  /// Known cells of rolling grids that fell outside the grid because it had reached max_cells.
  [[nodiscard]] std::uint64_t cellsDropped() const { return cells_dropped_; }
  /// Number of absorb() calls that changed a cell or the grid's size.
  [[nodiscard]] std::uint64_t changes() const { return changes_; }

 private:
  /// Grows grid_ to cover world cells [min_cell, max_cell] (inclusive) in whole chunks when it
  /// stays within max_cells_; false when it would not.
  bool cover(const Eigen::Vector2i& min_cell, const Eigen::Vector2i& max_cell);

  int chunk_cells_;
  std::size_t max_cells_;
  ProjectedGrid grid_;
  Eigen::Vector2i origin_cell_ = Eigen::Vector2i::Zero();  ///< world cell of grid cell (0, 0)
  std::uint64_t growths_ = 0;
  std::uint64_t cells_dropped_ = 0;
  std::uint64_t changes_ = 0;
};

}  // namespace mlmap
