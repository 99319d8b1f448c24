#include "mlmap/nav/grid_search.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <utility>

namespace mlmap::nav {

namespace {

constexpr double kSqrt2 = 1.4142135623730951;

std::size_t indexOf(const PlanningGrid& grid, int x, int y) {
  return static_cast<std::size_t>(y) * static_cast<std::size_t>(grid.width) +
         static_cast<std::size_t>(x);
}

/// Octile distance between two cells [cells]: the length of the shortest 8-connected path on an
/// empty grid, a lower bound (and consistent heuristic) for every step cost of searchGrid().
double octile(const Eigen::Vector2i& a, const Eigen::Vector2i& b) {
  const int dx = std::abs(a.x() - b.x());
  const int dy = std::abs(a.y() - b.y());
  return static_cast<double>(std::max(dx, dy) - std::min(dx, dy)) +
         kSqrt2 * static_cast<double>(std::min(dx, dy));
}

/// How near [cells] a line may pass a cell and still count as touching it: rounding of world
/// coordinates never lets a line that touches a corner slip past it.
constexpr double kTouch_cells = 1e-9;

}  // namespace

Eigen::Vector2i PlanningGrid::cellOf(const Eigen::Vector2d& p_W) const {
  const Eigen::Vector2d u = (p_W - origin_W) / resolution_m;
  return {static_cast<int>(std::floor(u.x())), static_cast<int>(std::floor(u.y()))};
}

Eigen::Vector2d PlanningGrid::cellCenter_W(const Eigen::Vector2i& cell) const {
  return origin_W + (cell.cast<double>() + Eigen::Vector2d::Constant(0.5)) * resolution_m;
}

PlanningGrid inflateGrid(const ProjectedGrid& grid, double radius_m, UnknownAs unknown,
                         int margin_cells, int occupied_threshold) {
  PlanningGrid out;
  margin_cells = std::max(margin_cells, 0);
  out.resolution_m = grid.resolution_m;
  out.origin_W = grid.origin_W - Eigen::Vector2d::Constant(margin_cells * grid.resolution_m);
  out.width = grid.width + 2 * margin_cells;
  out.height = grid.height + 2 * margin_cells;
  out.blocked.assign(static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height), 0);
  out.solid.assign(out.blocked.size(), 0);
  // The disc of cell offsets whose centres lie within radius_m of a cell's centre.
  const double r_cells = std::max(radius_m, 0.0) / grid.resolution_m;
  const int reach = static_cast<int>(std::floor(r_cells + 1e-9));
  std::vector<Eigen::Vector2i> disc;
  for (int dy = -reach; dy <= reach; ++dy) {
    for (int dx = -reach; dx <= reach; ++dx) {
      if (static_cast<double>(dx * dx + dy * dy) <= r_cells * r_cells + 1e-9)
        disc.emplace_back(dx, dy);
    }
  }
  const bool unknown_blocks = unknown == UnknownAs::kOccupied;
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      const int gx = x - margin_cells;
      const int gy = y - margin_cells;
      const bool in_grid = gx >= 0 && gy >= 0 && gx < grid.width && gy < grid.height;
      const int value = in_grid ? grid.at(gx, gy) : ProjectedGrid::kUnknown;
      const bool unknown_cell = value < 0;  // -1, and any negative value
      const bool occupied_cell = value > occupied_threshold;
      if (!(unknown_cell ? unknown_blocks : occupied_cell)) continue;
      out.solid[indexOf(out, x, y)] = 1;
      for (const Eigen::Vector2i& d : disc) {
        const int nx = x + d.x();
        const int ny = y + d.y();
        if (out.inside(nx, ny)) out.blocked[indexOf(out, nx, ny)] = 1;
      }
    }
  }
  return out;
}

GridPath searchGrid(const PlanningGrid& grid, const Eigen::Vector2i& start,
                    const Eigen::Vector2i& goal) {
  GridPath path;
  if (!grid.inside(start.x(), start.y()) || !grid.inside(goal.x(), goal.y())) return path;
  const std::size_t n = grid.blocked.size();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::vector<double> g(n, kInf);
  std::vector<std::int32_t> parent(n, -1);
  std::vector<std::uint8_t> closed(n, 0);
  using Entry = std::pair<double, std::int32_t>;  // (f in cells, cell index)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  const auto start_index = static_cast<std::int32_t>(indexOf(grid, start.x(), start.y()));
  const auto goal_index = static_cast<std::int32_t>(indexOf(grid, goal.x(), goal.y()));
  g[static_cast<std::size_t>(start_index)] = 0.0;
  open.emplace(octile(start, goal), start_index);
  static const int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static const int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  while (!open.empty()) {
    const auto [f, c] = open.top();
    open.pop();
    (void)f;
    const auto ci = static_cast<std::size_t>(c);
    if (closed[ci]) continue;
    closed[ci] = 1;
    if (c == goal_index) break;
    const int x = c % grid.width;
    const int y = c / grid.width;
    const bool from_blocked = grid.blocked[ci] != 0;
    for (int k = 0; k < 8; ++k) {
      const int nx = x + kDx[k];
      const int ny = y + kDy[k];
      if (!grid.inside(nx, ny)) continue;
      if (!from_blocked && grid.isBlocked(nx, ny)) continue;
      if (grid.isSolid(nx, ny)) continue;
      const bool diagonal = k >= 4;
      if (diagonal && (grid.isSolid(nx, y) || grid.isSolid(x, ny))) continue;
      if (diagonal && !from_blocked && (grid.isBlocked(nx, y) || grid.isBlocked(x, ny))) continue;
      const double step = (diagonal ? kSqrt2 : 1.0) * (from_blocked ? kEscapeCostFactor : 1.0);
      const std::size_t ni = indexOf(grid, nx, ny);
      if (closed[ni] || g[ci] + step >= g[ni]) continue;
      g[ni] = g[ci] + step;
      parent[ni] = c;
      open.emplace(g[ni] + octile({nx, ny}, goal), static_cast<std::int32_t>(ni));
    }
  }
  if (!closed[static_cast<std::size_t>(goal_index)]) return path;
  path.found = true;
  path.length_m = g[static_cast<std::size_t>(goal_index)] * grid.resolution_m;
  for (std::int32_t c = goal_index; c >= 0; c = parent[static_cast<std::size_t>(c)]) {
    path.cells.emplace_back(c % grid.width, c / grid.width);
  }
  std::reverse(path.cells.begin(), path.cells.end());
  return path;
}

bool isLineFree(const PlanningGrid& grid, const Eigen::Vector2d& a_W, const Eigen::Vector2d& b_W) {
  // In cell units, column by column: the part of the segment over the closed column [x, x + 1]
  // spans some y interval; every cell of that column whose closed square meets it (within
  // kTouch_cells) is checked.
  Eigen::Vector2d a = (a_W - grid.origin_W) / grid.resolution_m;
  Eigen::Vector2d b = (b_W - grid.origin_W) / grid.resolution_m;
  if (a.x() > b.x()) std::swap(a, b);
  const int x0 = static_cast<int>(std::floor(a.x() - kTouch_cells));
  const int x1 = static_cast<int>(std::floor(b.x() + kTouch_cells));
  for (int x = x0; x <= x1; ++x) {
    double ya = a.y();
    double yb = b.y();
    const double dx = b.x() - a.x();
    if (dx > 0.0) {
      const double lo = std::max(a.x(), static_cast<double>(x));
      const double hi = std::min(b.x(), static_cast<double>(x + 1));
      ya = a.y() + (b.y() - a.y()) * (lo - a.x()) / dx;
      yb = a.y() + (b.y() - a.y()) * (hi - a.x()) / dx;
    }
    const int y0 = static_cast<int>(std::floor(std::min(ya, yb) - kTouch_cells));
    const int y1 = static_cast<int>(std::floor(std::max(ya, yb) + kTouch_cells));
    for (int y = y0; y <= y1; ++y) {
      if (!grid.inside(x, y) || grid.isBlocked(x, y)) return false;
    }
  }
  return true;
}

std::vector<Eigen::Vector2d> shortenPath(const PlanningGrid& grid,
                                         const std::vector<Eigen::Vector2i>& cells) {
  std::vector<Eigen::Vector2d> out;
  std::size_t i = 0;
  // The escape from an inflated zone, cell by cell.
  while (i < cells.size() && grid.inside(cells[i].x(), cells[i].y()) &&
         grid.isBlocked(cells[i].x(), cells[i].y())) {
    out.push_back(grid.cellCenter_W(cells[i]));
    ++i;
  }
  if (i >= cells.size()) return out;
  out.push_back(grid.cellCenter_W(cells[i]));
  while (i + 1 < cells.size()) {
    // The farthest later cell seen from cell i; the next one always is (an allowed step).
    std::size_t next = i + 1;
    const Eigen::Vector2d from = grid.cellCenter_W(cells[i]);
    for (std::size_t j = cells.size() - 1; j > i + 1; --j) {
      if (isLineFree(grid, from, grid.cellCenter_W(cells[j]))) {
        next = j;
        break;
      }
    }
    out.push_back(grid.cellCenter_W(cells[next]));
    i = next;
  }
  return out;
}

double polylineLength(const std::vector<Eigen::Vector2d>& points_W) {
  double length = 0.0;
  for (std::size_t i = 1; i < points_W.size(); ++i)
    length += (points_W[i] - points_W[i - 1]).norm();
  return length;
}

}  // namespace mlmap::nav
