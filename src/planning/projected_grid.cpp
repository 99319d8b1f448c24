#include "mlmap/planning/projected_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mlmap {
namespace {

std::int8_t scaledProbability(LogOddsQ v) {
  return static_cast<std::int8_t>(
      std::lround(100.0 * probabilityFromLogOdds(dequantizeLogOdds(v))));
}

/// Writes into `out` (whose cell (0, 0) is world column `lo`) the value of the window columns
/// [begin, end) (window-relative x, y) from the band's layers [k0, k1) of the window: unknown
/// where none of them was observed.
void projectWindowColumns(const LocalWindow& window, const ProjectedGridConfig& config, int k0,
                          int k1, const Eigen::Vector2i& begin, const Eigen::Vector2i& end,
                          const Eigen::Vector2i& lo, ProjectedGrid* out) {
  // Per column, the band's layers are a contiguous run of the z-fastest copy.
  const int z0 = std::max(k0, window.min_index.z()) - window.min_index.z();
  const int z1 = std::min(k1, window.min_index.z() + window.size.z()) - window.min_index.z();
  const LogOddsModel& model = window.model;
  const std::size_t nz = static_cast<std::size_t>(window.size.z());
  for (int x = begin.x(); x < end.x(); ++x) {
    for (int y = begin.y(); y < end.y(); ++y) {
      const LogOddsQ* column =
          window.log_odds.data() +
          (static_cast<std::size_t>(x) * static_cast<std::size_t>(window.size.y()) +
           static_cast<std::size_t>(y)) *
              nz;
      LogOddsQ highest = kUnknownLogOdds;  // the unknown value is the smallest
      for (int z = z0; z < z1; ++z) highest = std::max(highest, column[z]);
      std::int8_t value = ProjectedGrid::kUnknown;
      if (highest != kUnknownLogOdds) {
        value = config.probability_values
                    ? scaledProbability(highest)
                    : (model.isOccupied(highest) ? ProjectedGrid::kOccupied : ProjectedGrid::kFree);
      }
      const int gx = window.min_index.x() + x - lo.x();
      const int gy = window.min_index.y() + y - lo.y();
      out->cells[static_cast<std::size_t>(gy) * static_cast<std::size_t>(out->width) +
                 static_cast<std::size_t>(gx)] = value;
    }
  }
}

}  // namespace

void bandLayers(double z_min_m, double z_max_m, double resolution_m, int* k0, int* k1) {
  *k0 = 0;
  *k1 = 0;
  if (!(z_min_m <= z_max_m) || !(resolution_m > 0.0)) return;  // NaN included: an empty band
  // Layers beyond +-2^30 hold no voxel (kMaxAbsWindowVoxelIndex): heights are clamped there, so
  // an absurd band (1e8 m, 1e300 m from a file) is an empty or short range, never a long loop.
  constexpr double kLimit = 1 << 30;
  const double lo = std::clamp(z_min_m / resolution_m, -kLimit, kLimit);
  const double hi = std::clamp(z_max_m / resolution_m, -kLimit, kLimit);
  auto inBand = [&](int k) { return (k + 0.5) * resolution_m >= z_min_m; };
  auto belowTop = [&](int k) { return (k + 0.5) * resolution_m <= z_max_m; };
  // The first layer in the band lies within 2 of floor(lo) - 1 (a few more steps absorb the
  // rounding of the products); likewise the last one below the top.
  int a = floorToInt(lo) - 1;
  for (int step = 0; step < 4 && !inBand(a); ++step) ++a;
  int b = floorToInt(hi) + 1;
  for (int step = 0; step < 4 && !belowTop(b); ++step) --b;
  *k0 = a;
  *k1 = std::max(a, b + 1);
}

std::int8_t ProjectedGrid::valueAt(const Eigen::Vector2d& p_W) const {
  const int x = floorToInt((p_W.x() - origin_W.x()) / resolution_m);
  const int y = floorToInt((p_W.y() - origin_W.y()) / resolution_m);
  if (x < 0 || y < 0 || x >= width || y >= height) return kUnknown;
  return at(x, y);
}

void projectToGrid(const LocalWindow& window, const GlobalMap* global,
                   const ProjectedGridConfig& config, double body_z_m, ProjectedGrid* out) {
  const double res = window.resolution_m;
  const double offset = config.relative_band ? body_z_m : 0.0;
  out->band_min_z_m = config.band_min_m + offset;
  out->band_max_z_m = config.band_max_m + offset;
  out->resolution_m = res;
  int k0 = 0;
  int k1 = 0;
  bandLayers(out->band_min_z_m, out->band_max_z_m, res, &k0, &k1);

  // Extent: the window, grown to the global submaps that reach into the band.
  Eigen::Vector2i lo = window.min_index.head<2>();
  Eigen::Vector2i hi = lo + window.size.head<2>();  // exclusive
  const bool use_global = config.include_global && global != nullptr;
  if (use_global) {
    const Eigen::Vector3i& cells = global->submapCells();
    global->forEachSubmap([&](const SubmapIndex& m, const std::vector<VoxelRecord>&) {
      const int z_lo = m.z() * cells.z();
      if (z_lo + cells.z() <= k0 || z_lo >= k1) return;
      const Eigen::Vector2i a = m.head<2>().cwiseProduct(cells.head<2>());
      if (window.size.prod() == 0 && lo == hi) {
        lo = a;
        hi = a + cells.head<2>();
      } else {
        lo = lo.cwiseMin(a);
        hi = hi.cwiseMax(a + cells.head<2>());
      }
    });
  }
  out->origin_W = lo.cast<double>() * res;
  out->width = hi.x() - lo.x();
  out->height = hi.y() - lo.y();
  out->cells.assign(static_cast<std::size_t>(out->width) * static_cast<std::size_t>(out->height),
                    ProjectedGrid::kUnknown);

  projectWindowColumns(window, config, k0, k1, Eigen::Vector2i::Zero(), window.size.head<2>(), lo,
                       out);

  // Retired submaps keep only occupied voxels: they can only raise a cell to occupied.
  if (use_global) {
    global->forEachVoxel([&](const VoxelIndex& g, double log_odds) {
      if (g.z() < k0 || g.z() >= k1 || window.contains(g)) return;
      const std::size_t i =
          static_cast<std::size_t>(g.y() - lo.y()) * static_cast<std::size_t>(out->width) +
          static_cast<std::size_t>(g.x() - lo.x());
      const std::int8_t value = config.probability_values
                                    ? scaledProbability(quantizeLogOdds(log_odds))
                                    : ProjectedGrid::kOccupied;
      out->cells[i] = std::max(out->cells[i], value);
    });
  }
}

void reprojectWindowColumns(const LocalWindow& window, const ProjectedGridConfig& config,
                            const Eigen::Vector2i& begin, const Eigen::Vector2i& end,
                            ProjectedGrid* grid) {
  int k0 = 0;
  int k1 = 0;
  bandLayers(grid->band_min_z_m, grid->band_max_z_m, grid->resolution_m, &k0, &k1);
  const Eigen::Vector2i lo(static_cast<int>(std::lround(grid->origin_W.x() / grid->resolution_m)),
                           static_cast<int>(std::lround(grid->origin_W.y() / grid->resolution_m)));
  projectWindowColumns(window, config, k0, k1, begin.cwiseMax(0),
                       end.cwiseMin(window.size.head<2>()), lo, grid);
}

}  // namespace mlmap
