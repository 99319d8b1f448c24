#include "mlmap/pictures/map_image.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace mlmap::pictures {
namespace {

constexpr double kRes = 0.1;

/// Centre of voxel (i, j, k) of the origin-aligned grid.
Eigen::Vector3d center(int i, int j, int k) {
  return (Eigen::Vector3d(i, j, k).array() + 0.5).matrix() * kRes;
}

cv::Vec3b pixelAt(const cv::Mat& image, const MapImageGeometry& g, double h_m, double v_m) {
  const cv::Point p = g.toPixel(h_m, v_m);
  EXPECT_TRUE(g.map_area_px.contains(p)) << "point " << p << " outside the map area";
  return image.at<cv::Vec3b>(p);
}

/// True for the white background or the light metre grid.
bool isBackground(const cv::Vec3b& c) { return c == mapBackgroundBgr() || c == mapGridBgr(); }

/// Every pixel of voxel cell (h, v) has `expected`.
void expectCellColor(const cv::Mat& image, const MapImageGeometry& g, double h_m, double v_m,
                     const cv::Vec3b& expected) {
  ASSERT_GT(g.pixels_per_voxel, 0);
  const cv::Point corner = g.toPixel(h_m - 0.49 * kRes, v_m + 0.49 * kRes);  // top-left pixel
  for (int dy = 0; dy < g.pixels_per_voxel; ++dy) {
    for (int dx = 0; dx < g.pixels_per_voxel; ++dx) {
      EXPECT_EQ(image.at<cv::Vec3b>(corner + cv::Point(dx, dy)), expected)
          << "at (" << h_m << ", " << v_m << ") + (" << dx << ", " << dy << ")";
    }
  }
}

/// A low single voxel at the origin, a 10-voxel column at x = 1 m, and a floating voxel above a
/// low one at x = 2 m (the higher must cover the lower in the top view).
VoxelList knownVoxels() {
  VoxelList voxels{kRes, {}};
  voxels.centers_W.push_back(center(0, 0, 0));
  for (int k = 0; k < 10; ++k) voxels.centers_W.push_back(center(10, 0, k));
  voxels.centers_W.push_back(center(20, 0, 5));
  voxels.centers_W.push_back(center(20, 0, 0));
  return voxels;
}

TEST(MapImage, HeightColorsFollowTurbo) {
  cv::Mat ramp(256, 1, CV_8UC1);
  for (int i = 0; i < 256; ++i) ramp.at<std::uint8_t>(i) = static_cast<std::uint8_t>(i);
  cv::Mat turbo;
  cv::applyColorMap(ramp, turbo, cv::COLORMAP_TURBO);
  const auto inTurbo = [&](const cv::Vec3b& c) {
    for (int i = 0; i < 256; ++i) {
      if (turbo.at<cv::Vec3b>(i) == c) return true;
    }
    return false;
  };
  EXPECT_TRUE(inTurbo(heightColorBgr(0.0)));
  EXPECT_TRUE(inTurbo(heightColorBgr(0.5)));
  EXPECT_TRUE(inTurbo(heightColorBgr(1.0)));
  EXPECT_EQ(heightColorBgr(-3.0), heightColorBgr(0.0));
  EXPECT_EQ(heightColorBgr(7.0), heightColorBgr(1.0));
  // Low is blue-ish, high is red-ish.
  EXPECT_GT(heightColorBgr(0.0)[0], heightColorBgr(0.0)[2]);
  EXPECT_GT(heightColorBgr(1.0)[2], heightColorBgr(1.0)[0]);
}

TEST(MapImage, TopDownColoursColumnsByTheirHighestVoxel) {
  MapImageOptions options;
  options.title = "known voxels";
  MapImageGeometry g;
  const cv::Mat image = renderTopDown(knownVoxels(), options, &g);
  ASSERT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(g.pixels_per_voxel, 4);
  EXPECT_DOUBLE_EQ(g.metres_per_pixel, kRes / 4);
  EXPECT_DOUBLE_EQ(g.color_min_m, 0.05);
  EXPECT_DOUBLE_EQ(g.color_max_m, 0.95);

  const cv::Vec3b low = heightColorBgr(0.0);
  const cv::Vec3b high = heightColorBgr(1.0);
  const cv::Vec3b middle = heightColorBgr((0.55 - 0.05) / 0.9);
  EXPECT_NE(low, high);
  expectCellColor(image, g, 0.05, 0.05, low);
  expectCellColor(image, g, 1.05, 0.05, high);
  expectCellColor(image, g, 2.05, 0.05, middle);  // the z = 0.55 voxel hides the z = 0.05 one
  // Elsewhere: background.
  EXPECT_TRUE(isBackground(pixelAt(image, g, 0.55, 0.05)));
  EXPECT_TRUE(isBackground(pixelAt(image, g, 1.05, 0.35)));
  EXPECT_TRUE(isBackground(pixelAt(image, g, 1.05, -0.25)));
  EXPECT_TRUE(isBackground(pixelAt(image, g, 0.15, 0.05)));  // the next cell is empty
  // Decorations sit outside the map area: the image is larger than it.
  EXPECT_GT(image.cols, g.map_area_px.br().x + 50);  // legend on the right
  EXPECT_GT(g.map_area_px.y, 30);                    // title on top
}

TEST(MapImage, TopDownIsNorthUp) {
  VoxelList voxels{kRes, {center(0, 0, 0), center(0, 10, 0)}};
  MapImageGeometry g;
  const cv::Mat image = renderTopDown(voxels, {}, &g);
  EXPECT_LT(g.toPixel(0.05, 1.05).y, g.toPixel(0.05, 0.05).y);  // +y is up
  EXPECT_LT(g.toPixel(0.05, 0.05).x, g.toPixel(1.05, 0.05).x);  // +x is right
  EXPECT_FALSE(isBackground(pixelAt(image, g, 0.05, 1.05)));
}

TEST(MapImage, SideViewShowsHeightsAndNearestVoxel) {
  VoxelList voxels = knownVoxels();
  // Two voxels on one line of sight at x = 3 m: the nearer (smaller y) one is drawn unfaded.
  voxels.centers_W.push_back(center(30, 5, 3));
  voxels.centers_W.push_back(center(30, -5, 3));
  MapImageGeometry g;
  const cv::Mat image = renderSide(voxels, {}, &g);
  const double z_range = g.color_max_m - g.color_min_m;
  EXPECT_LT(g.toPixel(1.05, 0.95).y, g.toPixel(1.05, 0.05).y);  // +z is up
  expectCellColor(image, g, 3.05, 0.35, heightColorBgr((0.35 - 0.05) / z_range));
  EXPECT_TRUE(isBackground(pixelAt(image, g, 0.05, 0.95)));
  EXPECT_TRUE(isBackground(pixelAt(image, g, 3.05, 0.55)));
  // The tall column is at y = 0.05, i.e. neither nearest nor farthest: lighter than the pure
  // colour.
  const cv::Vec3b top = pixelAt(image, g, 1.05, 0.95);
  const cv::Vec3b pure = heightColorBgr(1.0);
  EXPECT_GE(top[0] + top[1] + top[2], pure[0] + pure[1] + pure[2]);
  EXPECT_FALSE(isBackground(top));
}

TEST(MapImage, TrajectoryIsDrawnDark) {
  MapImageOptions options;
  const double x = -1.0 + kRes / 8;  // the centre of a pixel column (4 pixels per voxel)
  options.trajectory_W = {{x, -1.0, 1.0}, {x, 1.0, 1.0}};
  MapImageGeometry g;
  const cv::Mat image = renderTopDown(knownVoxels(), options, &g);
  const cv::Vec3b on_line = image.at<cv::Vec3b>(g.toPixel(x, 0.3));
  EXPECT_LT(on_line[0] + on_line[1] + on_line[2], 3 * 128) << on_line;
}

TEST(MapImage, ComparisonColoursTruePositivesFalsePositivesAndFalseNegatives) {
  VoxelList mapped{kRes, {center(0, 0, 0), center(10, 0, 0), center(20, 0, 3)}};
  VoxelList truth{kRes, {center(0, 0, 0), center(0, 10, 2), center(20, 0, 0)}};
  MapImageGeometry g;
  const cv::Mat image = renderComparison(mapped, truth, {}, &g);
  expectCellColor(image, g, 0.05, 0.05, comparisonColorBgr(ComparisonClass::kTruePositive));
  expectCellColor(image, g, 1.05, 0.05, comparisonColorBgr(ComparisonClass::kFalsePositive));
  expectCellColor(image, g, 0.05, 1.05, comparisonColorBgr(ComparisonClass::kFalseNegative));
  expectCellColor(image, g, 2.05, 0.05, comparisonColorBgr(ComparisonClass::kBothErrors));
  EXPECT_TRUE(isBackground(pixelAt(image, g, 1.05, 1.05)));
  // The documented colours: FP red, FN blue, all four distinct.
  const cv::Vec3b fp = comparisonColorBgr(ComparisonClass::kFalsePositive);
  const cv::Vec3b fn = comparisonColorBgr(ComparisonClass::kFalseNegative);
  EXPECT_GT(fp[2], 150);
  EXPECT_LT(fp[0], 100);
  EXPECT_GT(fn[0], 150);
  EXPECT_LT(fn[2], 100);
  EXPECT_NE(comparisonColorBgr(ComparisonClass::kTruePositive),
            comparisonColorBgr(ComparisonClass::kBothErrors));
}

TEST(MapImage, ComparisonNeedsEqualResolutions) {
  VoxelList mapped{0.1, {center(0, 0, 0)}};
  VoxelList truth{0.2, {Eigen::Vector3d(0.1, 0.1, 0.1)}};
  EXPECT_THROW((void)renderComparison(mapped, truth, {}), std::invalid_argument);
}

TEST(MapImage, EmptyInputGivesAMessageImage) {
  for (const cv::Mat& image : {renderTopDown(VoxelList{}, {}), renderSide(VoxelList{}, {}),
                               renderComparison(VoxelList{}, VoxelList{}, {})}) {
    ASSERT_FALSE(image.empty());
    EXPECT_EQ(image.type(), CV_8UC3);
    // Some dark text pixels in the middle band.
    const cv::Mat band = image.rowRange(image.rows / 3, 2 * image.rows / 3);
    cv::Mat gray;
    cv::cvtColor(band, gray, cv::COLOR_BGR2GRAY);
    EXPECT_GT(cv::countNonZero(gray < 160), 50);
  }
  // Empty truth, non-empty map: everything is a false positive.
  MapImageGeometry g;
  const cv::Mat image = renderComparison(VoxelList{kRes, {center(3, 3, 3)}}, VoxelList{}, {}, &g);
  expectCellColor(image, g, 0.35, 0.35, comparisonColorBgr(ComparisonClass::kFalsePositive));
  // Only a trajectory.
  MapImageOptions options;
  options.trajectory_W = {{0, 0, 0}, {3, 4, 0}};
  EXPECT_FALSE(renderTopDown(VoxelList{}, options).empty());
}

TEST(MapImage, LargeMapsAreCappedInSize) {
  VoxelList line{kRes, {}};
  for (int i = 0; i < 600; ++i) line.centers_W.push_back(center(i, 0, 0));
  MapImageGeometry g;
  EXPECT_FALSE(renderTopDown(line, {}, &g).empty());
  EXPECT_EQ(g.pixels_per_voxel, 3);
  EXPECT_LE(g.map_area_px.width, kMaxMapSide_px);

  for (int i = 600; i < 5000; ++i) line.centers_W.push_back(center(i, i % 7, 0));
  const cv::Mat image = renderTopDown(line, {}, &g);
  EXPECT_EQ(g.pixels_per_voxel, 0);  // several voxels per pixel
  EXPECT_LE(g.map_area_px.width, kMaxMapSide_px);
  EXPECT_LE(image.cols, kMaxMapSide_px + 400);
  EXPECT_FALSE(isBackground(pixelAt(image, g, 250.05, 0.05)));
}

TEST(MapImage, RejectsInvalidInput) {
  MapImageOptions options;
  options.pixels_per_voxel = 0;
  EXPECT_THROW((void)renderTopDown(knownVoxels(), options), std::invalid_argument);
  EXPECT_THROW((void)renderTopDown(VoxelList{0.0, {center(0, 0, 0)}}, {}), std::invalid_argument);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)renderSide(VoxelList{kRes, {Eigen::Vector3d(nan, 0, 0)}}, {}),
               std::invalid_argument);
  EXPECT_THROW(
      (void)renderTopDown(VoxelList{kRes, {center(0, 0, 0), Eigen::Vector3d(0.1, 0, 0)}}, {}),
      std::invalid_argument);  // off the grid by half a voxel
  MapImageOptions bad_trajectory;
  bad_trajectory.trajectory_W = {{0, 0, nan}};
  EXPECT_THROW((void)renderTopDown(knownVoxels(), bad_trajectory), std::invalid_argument);
}

TEST(MapImage, LegendCanBeTurnedOff) {
  MapImageOptions with;
  MapImageOptions without;
  without.legend = false;
  EXPECT_GT(renderTopDown(knownVoxels(), with).cols, renderTopDown(knownVoxels(), without).cols);
}

TEST(MapImage, WritePngRoundTripsAndReportsFailures) {
  const cv::Mat image = renderTopDown(knownVoxels(), {});
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("mlmap_map_image_" + std::to_string(::getpid()) + ".png"))
                               .string();
  writePng(path, image);
  const cv::Mat back = cv::imread(path, cv::IMREAD_UNCHANGED);
  std::filesystem::remove(path);
  ASSERT_EQ(back.size(), image.size());
  EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0.0);

  const std::string unwritable = "/nonexistent-mlmap-dir/sub/map.png";
  try {
    writePng(unwritable, image);
    ADD_FAILURE() << "writing to " << unwritable << " should throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(unwritable), std::string::npos) << e.what();
  }
  EXPECT_THROW(writePng(path, cv::Mat()), std::runtime_error);
}

}  // namespace
}  // namespace mlmap::pictures
