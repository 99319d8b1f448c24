#pragma once
/// @file
/// The reference local planner: the next few metres of the global route, pushed away from
/// obstacles along the ESDF's gradient, and the part of them the vehicle may commit to.
///
/// Unknown-space policy: the committed segment never enters unknown space. Its centre line
/// crosses only voxels the map knows free (MapSnapshot::isSegmentFree() with UnknownAs::kOccupied),
/// and each of its points keeps an ESDF distance of at least commit_clearance_m from the known
/// obstacles, and as much from the obstacles of the latest frame when the caller passes them
/// (its measured points, what the awareness map holds as the frame's hits, paper IV-A: they show
/// a walking person in the frame that sees it, where the local map's log-odds need several hits
/// to turn a free voxel occupied).
/// Frames: world frame W, metres; the flight height is the route's z.

#include "mlmap/planning/map_snapshot.h"

#include <Eigen/Core>

#include <vector>

namespace mlmap::nav {

/// Parameters of the local planner.
struct LocalPlannerConfig {
  double horizon_m = 3.0;           ///< how much of the route ahead is planned [m]
  double sample_step_m = 0.1;       ///< spacing of the planned points [m]
  double push_clearance_m = 0.8;    ///< points nearer than this to an obstacle are pushed [m]
  double max_push_m = 0.4;          ///< farthest a point moves from the route [m]
  int push_iterations = 6;          ///< gradient steps per point
  double commit_clearance_m = 0.5;  ///< ESDF distance every committed point keeps [m]
  /// Radius around the vehicle whose voxels the first committed segment does not check [m]: the
  /// vehicle's own voxel, which a forward camera may not have seen.
  double own_radius_m = 0.3;
};

/// A local plan: the planned points from the vehicle on, and how many of them are committed.
struct LocalPlan {
  std::vector<Eigen::Vector3d> points_W;  ///< vehicle position first, then every sample_step_m
  std::size_t committed = 0;  ///< points_W[0 .. committed) may be flown (0: none, hover)
  /// Length of the committed polyline [m].
  double committed_length_m = 0.0;
  /// The committed points, vehicle first (empty when nothing is committed).
  [[nodiscard]] std::vector<Eigen::Vector3d> committedPoints() const {
    return {points_W.begin(), points_W.begin() + static_cast<std::ptrdiff_t>(committed)};
  }
};

/// The points of `route_W` (a polyline) from the point nearest `p_W` on, at most `length_m` of
/// them, resampled every `step_m`, starting at `p_W` itself (at the route's height when the route
/// has points). Empty route: just p_W.
[[nodiscard]] std::vector<Eigen::Vector3d> routeAhead(const std::vector<Eigen::Vector3d>& route_W,
                                                      const Eigen::Vector3d& p_W, double length_m,
                                                      double step_m);

/// Moves each point but the first (the vehicle) horizontally along the ESDF's gradient while its
/// distance is below push_clearance_m, by at most max_push_m in all; points without a valid ESDF
/// distance stay.
void pushAwayFromObstacles(const MapSnapshot& map, const LocalPlannerConfig& config,
                           std::vector<Eigen::Vector3d>* points_W);

/// How many leading points of `points_W` (vehicle first) the vehicle may commit to under `map`:
/// each following segment must cross only known-free voxels (the part within own_radius_m of the
/// first point excepted) and reach a point whose ESDF distance is valid and at least
/// min(commit_clearance_m, the distance at the first point), so a vehicle already nearer may
/// still move away; with `recent_obstacles_W`, that point must also be as far (the same rule)
/// from each of them. Returns 0 when there is no ESDF, else at least 1 (the vehicle's point).
[[nodiscard]] std::size_t committablePrefix(
    const MapSnapshot& map, const LocalPlannerConfig& config,
    const std::vector<Eigen::Vector3d>& points_W,
    const std::vector<Eigen::Vector3d>* recent_obstacles_W = nullptr);

/// Plans: routeAhead(), pushAwayFromObstacles(), committablePrefix().
[[nodiscard]] LocalPlan planLocal(const MapSnapshot& map, const LocalPlannerConfig& config,
                                  const std::vector<Eigen::Vector3d>& route_W,
                                  const Eigen::Vector3d& p_W,
                                  const std::vector<Eigen::Vector3d>* recent_obstacles_W = nullptr);

/// Distance from p_W to the nearest of `points_W` [m] (+infinity when there is none).
[[nodiscard]] double nearestPointDistance(const std::vector<Eigen::Vector3d>& points_W,
                                          const Eigen::Vector3d& p_W);

/// Length of a polyline [m].
[[nodiscard]] double polylineLength(const std::vector<Eigen::Vector3d>& points_W);

}  // namespace mlmap::nav
