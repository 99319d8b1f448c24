#pragma once
/// @file
/// The reference global planner's search: an 8-connected shortest path on a 2D grid built from
/// mlmap's projected grid (ProjectedGrid, nav_msgs/OccupancyGrid values), inflated by the
/// vehicle's radius, and its any-angle shortening.
///
/// Unknown cells (-1) follow a stated policy (UnknownAs): kFree for the global route (optimistic:
/// a route may cross space nobody has seen, and the local planner never commits to it until it is
/// seen free), kOccupied for a pessimistic route. Frames: the grid's cells lie in the world frame
/// W, x and y along the world axes, metres.

#include "mlmap/core/config.h"
#include "mlmap/planning/projected_grid.h"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace mlmap::nav {

/// Which cells a vehicle's centre may occupy: a grid of the same layout as a ProjectedGrid
/// (cell (x, y) at blocked[y * width + x], cell (0, 0) with its lower corner at origin_W).
struct PlanningGrid {
  Eigen::Vector2d origin_W = Eigen::Vector2d::Zero();  ///< lower corner of cell (0, 0) in W [m]
  double resolution_m = 0.2;                           ///< cell edge [m]
  int width = 0;                                       ///< cells along x
  int height = 0;                                      ///< cells along y
  std::vector<std::uint8_t> blocked;  ///< 1: the vehicle's centre may not be there; 0: it may
  /// 1: the grid marks the cell itself as an obstacle (see inflateGrid()); no step enters it, not
  /// even one escaping an inflated zone, so that an escape never crosses a wall. Empty: none.
  std::vector<std::uint8_t> solid;

  /// True when cell (x, y) lies in the grid.
  [[nodiscard]] bool inside(int x, int y) const {
    return x >= 0 && y >= 0 && x < width && y < height;
  }
  /// True when cell (x, y), which must lie inside, is blocked.
  [[nodiscard]] bool isBlocked(int x, int y) const {
    return blocked[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                   static_cast<std::size_t>(x)] != 0;
  }
  /// True when cell (x, y), which must lie inside, is solid (false when `solid` is empty).
  [[nodiscard]] bool isSolid(int x, int y) const {
    return !solid.empty() && solid[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                                   static_cast<std::size_t>(x)] != 0;
  }
  /// The cell holding the world point p_W (may lie outside the grid).
  [[nodiscard]] Eigen::Vector2i cellOf(const Eigen::Vector2d& p_W) const;
  /// Centre of cell (x, y) in W [m].
  [[nodiscard]] Eigen::Vector2d cellCenter_W(const Eigen::Vector2i& cell) const;
};

/// The cells of `grid` whose centre lies within `radius_m` of the centre of an occupied cell (and
/// of an unknown one when `unknown` is UnknownAs::kOccupied): where the centre of a disc of that
/// radius would touch what the grid marks; `solid` holds the marked cells themselves. A cell counts
/// as occupied when its value is above `occupied_threshold` (50: nav_msgs' convention for 0..100
/// values). The result has the layout of `grid` grown by `margin_cells` on every side (the margin
/// is unknown space).
[[nodiscard]] PlanningGrid inflateGrid(const ProjectedGrid& grid, double radius_m,
                                       UnknownAs unknown, int margin_cells = 0,
                                       int occupied_threshold = 50);

/// A path of grid cells and its length.
struct GridPath {
  bool found = false;                  ///< false when the goal cannot be reached
  std::vector<Eigen::Vector2i> cells;  ///< start to goal, both included; empty when not found
  double length_m = 0.0;               ///< sum of the steps' costs (see searchGrid())
};

/// Cost factor of a step that leaves a blocked cell (see searchGrid()).
inline constexpr double kEscapeCostFactor = 4.0;

/// Shortest 8-connected path from `start` to `goal` (A* with the octile distance).
///
/// Steps: to the 8 neighbours, costing resolution_m (straight) or sqrt(2) resolution_m
/// (diagonal). A step may not enter a blocked cell, unless it leaves a blocked cell (the start
/// may lie in an inflated zone, e.g. after a gust: the path then escapes it); such a step costs
/// kEscapeCostFactor times as much, so the path leaves the zone by the shortest way. No step
/// enters a solid cell nor cuts the corner of one, escaping or not: an escape from the zone
/// beside a wall never crosses the wall (a start stuck to the wall with the goal behind it would
/// otherwise go through: 1 m of escape steps is cheaper than the way round by a door). A
/// diagonal step from a free cell may not cut the corner of a blocked cell (both cells it passes
/// by must be free). Not found when start or goal lies outside the grid, or the goal is
/// unreachable.
[[nodiscard]] GridPath searchGrid(const PlanningGrid& grid, const Eigen::Vector2i& start,
                                  const Eigen::Vector2i& goal);

/// True when no blocked cell meets the segment between the world points a_W and b_W (every cell
/// whose closed square the segment touches, corners included, to within 1e-9 cell so that
/// rounding never hides a touch); false when it leaves the grid.
[[nodiscard]] bool isLineFree(const PlanningGrid& grid, const Eigen::Vector2d& a_W,
                              const Eigen::Vector2d& b_W);

/// The path's cell centres (in W) shortened by line of sight: from each kept point, the next kept
/// one is the farthest later cell centre reached by a free line (isLineFree()). The leading cells
/// that are blocked (an escape from an inflated zone) are kept as they are. Never longer than
/// the cell path, and no kept segment outside that leading part meets a blocked cell.
[[nodiscard]] std::vector<Eigen::Vector2d> shortenPath(const PlanningGrid& grid,
                                                       const std::vector<Eigen::Vector2i>& cells);

/// Length of a polyline [m].
[[nodiscard]] double polylineLength(const std::vector<Eigen::Vector2d>& points_W);

}  // namespace mlmap::nav
