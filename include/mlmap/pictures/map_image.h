#pragma once
/// @file
/// Pictures of occupancy maps for people: top-down and side views coloured by height, and
/// top-down accuracy comparisons. Works on plain voxel-centre lists, so it does not depend on any
/// map class. All images are 8-bit BGR (CV_8UC3) on a white background, with a title, metre
/// ticks on the map frame, a scale bar and a legend.

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace mlmap::pictures {

/// Voxels to draw: the world-frame centres of equal-size voxels on one grid.
struct VoxelList {
  double resolution_m = 0.0;               ///< voxel edge length; must be > 0 unless empty
  std::vector<Eigen::Vector3d> centers_W;  ///< voxel centres in the world frame, metres
};

/// Drawing options shared by every render function.
struct MapImageOptions {
  int pixels_per_voxel = 4;                   ///< pixel size of a voxel; reduced for large maps
  std::vector<Eigen::Vector3d> trajectory_W;  ///< vehicle positions, drawn as a polyline
  std::string title;                          ///< text on top of the image (may be empty)
  bool legend = true;                         ///< draw the colour bar / class legend
};

/// Longest side, in pixels, of the map area of a rendered image; `pixels_per_voxel` is reduced
/// (and, for very large maps, several voxels share one pixel) to stay within it.
inline constexpr int kMaxMapSide_px = 2000;

/// Where a map image puts world coordinates; optional output of the render functions.
/// "Horizontal" is world x in every view; "vertical" is world y (top-down) or z (side view).
struct MapImageGeometry {
  double horizontal_min_m = 0.0;  ///< world coordinate of the map area's left edge
  double vertical_min_m = 0.0;    ///< world coordinate of the map area's bottom edge
  double metres_per_pixel = 0.0;  ///< size of one image pixel in the world
  cv::Rect map_area_px;           ///< the map area inside the image
  int pixels_per_voxel = 0;       ///< pixels per voxel actually used (0 when voxels share pixels)
  double color_min_m = 0.0;       ///< height drawn with the first colormap colour
  double color_max_m = 0.0;       ///< height drawn with the last colormap colour

  /// Image pixel (column, row) that shows the world point (horizontal_m, vertical_m).
  [[nodiscard]] cv::Point toPixel(double horizontal_m, double vertical_m) const;
};

/// How a top-down column of a comparison image is classified.
enum class ComparisonClass {
  kTruePositive,   ///< every voxel of the column is both mapped and true
  kFalsePositive,  ///< the column holds mapped-but-not-true voxels (and no missed ones)
  kFalseNegative,  ///< the column holds true-but-not-mapped voxels (and no spurious ones)
  kBothErrors,     ///< the column holds both false-positive and false-negative voxels
};

/// Background colour of every image (white), BGR.
[[nodiscard]] cv::Vec3b mapBackgroundBgr();

/// Colour of the light metre grid drawn under the voxels, BGR.
[[nodiscard]] cv::Vec3b mapGridBgr();

/// Height colour: the TURBO colormap at `fraction` in [0, 1] (clamped), 0 = lowest, BGR.
[[nodiscard]] cv::Vec3b heightColorBgr(double fraction);

/// Colour of a comparison class: true positives grey-green, false positives red, false
/// negatives blue, both kinds of error magenta; BGR.
[[nodiscard]] cv::Vec3b comparisonColorBgr(ComparisonClass cls);

/// Top-down view (world x right, y up): each column of voxels is drawn in the colour of its
/// highest voxel's height, the trajectory as a thin dark line with a start circle and an end
/// square. An empty list gives an image saying "no occupied voxels".
/// @throws std::invalid_argument on a non-positive resolution, a non-finite centre or
///         trajectory point, voxels that are not on one grid, or pixels_per_voxel < 1.
[[nodiscard]] cv::Mat renderTopDown(const VoxelList& occupied, const MapImageOptions& options,
                                    MapImageGeometry* geometry = nullptr);

/// Side view (world x right, z up, looking along +y): each voxel is coloured by its height;
/// where several voxels line up along y the nearest (smallest y) is shown, faded towards white
/// the farther it is (the legend says so). Same decorations and errors as renderTopDown().
[[nodiscard]] cv::Mat renderSide(const VoxelList& occupied, const MapImageOptions& options,
                                 MapImageGeometry* geometry = nullptr);

/// Top-down accuracy picture of `mapped` against `truth` (same resolution and grid): voxels are
/// matched in 3D, then each column is coloured by comparisonColorBgr() of its ComparisonClass.
/// The legend shows the classes and the voxel counts, precision and recall.
/// @throws std::invalid_argument as renderTopDown(), or when the two resolutions differ.
[[nodiscard]] cv::Mat renderComparison(const VoxelList& mapped, const VoxelList& truth,
                                       const MapImageOptions& options,
                                       MapImageGeometry* geometry = nullptr);

/// Writes `image` as a PNG file at `path` (parent directory must exist), atomically
/// (writeFileAtomically(): a failed write leaves no partial file).
/// @throws std::runtime_error naming the path when the image is empty or cannot be written.
void writePng(const std::string& path, const cv::Mat& image);

}  // namespace mlmap::pictures
