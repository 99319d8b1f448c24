#pragma once
/// @file
/// Pictures of the planning layers as a ground station receives them: the 2D occupancy grid
/// (ROS's cell values) and an ESDF slice (voxel centres with their distances), and received
/// points snapped back onto the voxel grid for the map pictures of map_image.h. Plain inputs, so
/// it depends on no message type. Images are 8-bit BGR (CV_8UC3).

#include "mlmap/pictures/map_image.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace mlmap::pictures {

/// Side, in pixels, that the grid and ESDF slice pictures are scaled up to (about).
inline constexpr int kLayerImageSide_px = 600;

/// A 2D occupancy grid as ROS's nav_msgs/OccupancyGrid holds it: `width` x `height` cells, row
/// major, row 0 at the lowest y; -1 unknown, 0 free .. 100 occupied.
/// Each cell becomes a square of max(1, kLayerImageSide_px / max(width, height)) pixels, north
/// (the last row) up: unknown grey (200), known cells from white (0) to black (100), as
/// 255 - 255 * value / 100 in integers (values above 100 darker still, wrapping as bytes do).
/// @throws std::invalid_argument when `cells_row_major` does not hold width x height cells, or
///         either side is not positive.
[[nodiscard]] cv::Mat renderOccupancyGrid(int width, int height,
                                          const std::vector<std::int8_t>& cells_row_major);

/// An ESDF slice seen from above (x right, y up): each voxel of centre `points_W[i]` is a square
/// coloured by `distance_m[i]` on heightColorBgr() (lowest distance blue, highest red), on white,
/// with the range written at the top left. The picture spans the points' x-y box at
/// max(2, kLayerImageSide_px / max(columns, rows)) pixels per voxel of `resolution_m`.
/// @throws std::invalid_argument when the points are empty, not as many as the distances, or
///         not finite, or when the resolution is not positive.
[[nodiscard]] cv::Mat renderEsdfSlice(const std::vector<Eigen::Vector3f>& points_W,
                                      const std::vector<float>& distance_m, double resolution_m);

/// Points received as voxel centres (float transport rounds a little), snapped back to the
/// centres of their voxels of `resolution_m`, for renderTopDown() and renderSide().
[[nodiscard]] VoxelList voxelListOf(const std::vector<Eigen::Vector3f>& points_W,
                                    double resolution_m);

}  // namespace mlmap::pictures
