#pragma once
/// @file
/// What a planner gets of the latest frame beside the map (Navigator::setRecentObstacles()):
/// the measured points near the flight height. The one-process flight (nav_flight.h) and the
/// planner peer over DDS (mlmap/dds/nav/planner_peer.h) both make them here. Frames: sensor S,
/// world W; metres.

#include "mlmap/core/types.h"

#include <Eigen/Core>

#include <vector>

namespace mlmap::nav {

/// What the planner gets of a frame beside the map (Navigator::setRecentObstacles()): its
/// measured points `points_S` (sensor frame, non-finite ones skipped) within 5 m of the sensor
/// and 0.6 m of the flight height `height_m`, in W, one per cell of `cell_m`.
[[nodiscard]] std::vector<Eigen::Vector3d> recentObstacles(
    const std::vector<Eigen::Vector3f>& points_S, const Transform& T_W_S, double height_m,
    double cell_m);

}  // namespace mlmap::nav
