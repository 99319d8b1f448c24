#pragma once
/// @file
/// The reference planner's inputs and outputs as ROS 2 messages: what a planner that is a DDS
/// peer of mlmap_node builds its MapSnapshot from (the node's nav_msgs/OccupancyGrid and its ESDF
/// as mlmap_msgs/VoxelBlock), and what it publishes (nav_msgs/Path, setpoints as
/// geometry_msgs/PoseStamped).
///
/// The ESDF block says, voxel by voxel, what the node's local map says in its box: NaN is
/// unknown, a negative distance an obstacle voxel, a positive one a non-obstacle voxel (esdf.h:
/// an obstacle voxel has d <= -resolution, any other d >= +resolution). With the node's
/// esdf.unknown_as free (the navigation setting, nav_flight.h navMapConfig()) an obstacle voxel is
/// an occupied one, so the box's occupancy is the node's exactly; the planner's ESDF is computed
/// again from it, which gives the node's field bit for bit (the transform is exact and
/// deterministic). Outside the box the planner's map is unknown.
///
/// Frames: every point in the world frame W (the messages' frame_id, the node's world_frame),
/// metres, seconds.

#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/nav/navigator.h"
#include "mlmap/planning/map_snapshot.h"

#include "nav_msgs/msg/Path_.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace mlmap::dds {

/// The cells and geometry of an OccupancyGrid as a ProjectedGrid (toOccupancyGrid()'s inverse;
/// the band is left at zero: the message does not carry it; the float32 resolution is rounded to
/// the micrometre, which gives back the double the node had, e.g. 0.2 and not 0.20000000298).
/// kBadLayout when data.size() is not width * height, the resolution is not finite and positive,
/// the origin is not finite or is rotated (the planner reads grids aligned with W), or a cell is
/// outside -1..100; kBadStamp for a nanosec >= 1e9. On error `grid` is left untouched.
DecodeStatus decodeOccupancyGrid(const nav_msgs::OccupancyGrid_& msg, ProjectedGrid* grid);

/// The occupancy of an ESDF VoxelBlock's box (see the file comment): NaN unknown, < 0 occupied,
/// else free, on the world voxel grid (min_index = origin / resolution, rounded). kUnsupportedType
/// for a layer other than "esdf" or a version other than 1; kBadLayout when values.size() is not
/// size_x * size_y * size_z, a size is above EsdfMap::kMaxCellsPerAxis or the box above
/// EsdfMap::kMaxCells, the resolution is not finite and positive, the origin is not finite or not
/// on the voxel grid (within 1e-3 voxel), or max_value is not finite and positive; kBadStamp for
/// a nanosec >= 1e9. `max_distance_m` (optional) gets max_value. On error the outputs are left
/// untouched.
DecodeStatus decodeEsdfBlock(const mlmap_msgs::VoxelBlock_& msg, OccupancyBox* box,
                             double* max_distance_m = nullptr);

/// A local window holding `box`'s states (occupied: the clamp maximum, free: the clamp minimum of
/// the default log-odds model, unknown: unknown), for MapSnapshot's occupancy queries.
[[nodiscard]] std::shared_ptr<LocalWindow> windowFromBox(const OccupancyBox& box);

/// The planner's snapshot: the occupancy and ESDF of `box` (the ESDF computed with `esdf`, whose
/// max_distance_m should be the block's max_value and unknown_as the node's) and `grid`, numbered
/// `frame` (Navigator::update() absorbs a snapshot whose frame it has not seen), stamped
/// `stamp_s`. An empty or malformed box gives a snapshot without ESDF (the planner hovers).
[[nodiscard]] std::shared_ptr<const MapSnapshot> plannerSnapshot(const OccupancyBox& box,
                                                                 const ProjectedGrid& grid,
                                                                 const EsdfConfig& esdf,
                                                                 std::uint64_t frame,
                                                                 double stamp_s);

/// A nav_msgs/Path of `points_W` (one PoseStamped each, stamped `stamp_s`, heading along the
/// path: each pose faces the next point, the last the one before's heading; identity for a
/// single point), stamped `stamp_s` in `frame_id`.
nav_msgs::Path_ toPath(const std::vector<Eigen::Vector3d>& points_W, double stamp_s,
                       const std::string& frame_id);

/// A setpoint as the position setpoint a position controller with gain `position_gain_per_s`
/// [1/s] flies as the setpoint's velocity command: position_W + velocity_W / gain (its command
/// gain * (that - p) equals velocity_W + gain * (position_W - p), sim::Vehicle's), heading yaw_rad.
/// Throws std::invalid_argument when the gain is not finite and positive.
geometry_msgs::PoseStamped_ toSetpointPose(const nav::Setpoint& setpoint,
                                           double position_gain_per_s, double stamp_s,
                                           const std::string& frame_id);

/// Position and yaw (about W +z, radians) of a setpoint PoseStamped (decodePose()'s checks).
DecodeStatus decodeSetpointPose(const geometry_msgs::PoseStamped_& msg, double* stamp_s,
                                Eigen::Vector3d* position_W, double* yaw_rad);

}  // namespace mlmap::dds
