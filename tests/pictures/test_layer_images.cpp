// The pictures of the received planning layers (layer_images.h), pixel by pixel against slow
// references that state what each pixel must show, on inputs of a few cells.

#include "mlmap/pictures/layer_images.h"

#include "mlmap/core/types.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace mlmap::pictures {
namespace {

/// The colour a grid cell of ROS value `v` must show: unknown grey, 0 white, 100 black, between
/// them 255 - 255 * v / 100 in integers.
cv::Vec3b gridColor(int v) {
  if (v < 0) return {200, 200, 200};
  const auto g = static_cast<unsigned char>(255 - 255 * v / 100);
  return {g, g, g};
}

/// Counts the pixels of `image` that differ from what each pixel's cell of the grid must show
/// (`scale` pixels a cell, the grid's last row at the top).
int gridPixelsWrong(const cv::Mat& image, int width, int height,
                    const std::vector<std::int8_t>& cells, int scale) {
  int wrong = 0;
  for (int row = 0; row < image.rows; ++row) {
    for (int col = 0; col < image.cols; ++col) {
      const int x = col / scale;
      const int y = height - 1 - row / scale;
      const cv::Vec3b expected = gridColor(cells[static_cast<std::size_t>(y * width + x)]);
      wrong += image.at<cv::Vec3b>(row, col) == expected ? 0 : 1;
    }
  }
  return wrong;
}

TEST(OccupancyGridImage, EveryPixelShowsItsCellNorthUp) {
  // 3 x 2 cells, row 0 (lowest y) first; 200 pixels a cell.
  const std::vector<std::int8_t> cells{-1, 0, 50, 100, 127, -128};
  const cv::Mat image = renderOccupancyGrid(3, 2, cells);
  ASSERT_EQ(image.type(), CV_8UC3);
  ASSERT_EQ(image.cols, 600);
  ASSERT_EQ(image.rows, 400);
  EXPECT_EQ(gridPixelsWrong(image, 3, 2, cells, 200), 0);
  // The values themselves, and north up: the first cell (x 0, y 0) is at the bottom left.
  EXPECT_EQ(image.at<cv::Vec3b>(399, 0), cv::Vec3b(200, 200, 200));
  EXPECT_EQ(image.at<cv::Vec3b>(399, 200), cv::Vec3b(255, 255, 255));
  EXPECT_EQ(image.at<cv::Vec3b>(399, 599), cv::Vec3b(128, 128, 128));
  EXPECT_EQ(image.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
}

TEST(OccupancyGridImage, LargeGridsKeepOnePixelACell) {
  std::vector<std::int8_t> cells(701 * 2);
  for (std::size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<std::int8_t>(i % 103 - 1);
  const cv::Mat image = renderOccupancyGrid(701, 2, cells);
  ASSERT_EQ(image.cols, 701);
  ASSERT_EQ(image.rows, 2);
  EXPECT_EQ(gridPixelsWrong(image, 701, 2, cells, 1), 0);
}

TEST(OccupancyGridImage, RefusesCellsThatDoNotFillTheGrid) {
  EXPECT_THROW((void)renderOccupancyGrid(3, 2, std::vector<std::int8_t>(5)), std::invalid_argument);
  EXPECT_THROW((void)renderOccupancyGrid(0, 2, {}), std::invalid_argument);
  EXPECT_THROW((void)renderOccupancyGrid(2, -1, {}), std::invalid_argument);
}

/// Counts the pixels below the title band that differ from what they must show: the colour of
/// the point whose voxel the pixel's cell is (heightColorBgr of its distance's place between the
/// lowest and the highest), else white. `lo_x`, `lo_y`: the lowest centre coordinates.
int slicePixelsWrong(const cv::Mat& image, const std::vector<Eigen::Vector3f>& points,
                     const std::vector<double>& fractions, double res, double lo_x, double lo_y,
                     int rows, int px) {
  constexpr int kTitleBand_px = 20;
  int wrong = 0;
  for (int row = kTitleBand_px; row < image.rows; ++row) {
    for (int col = 0; col < image.cols; ++col) {
      const double x = lo_x + (col / px) * res;
      const double y = lo_y + (rows - 1 - row / px) * res;
      cv::Vec3b expected(255, 255, 255);
      for (std::size_t i = 0; i < points.size(); ++i) {
        if (std::abs(points[i].x() - x) < res / 2 && std::abs(points[i].y() - y) < res / 2) {
          expected = heightColorBgr(fractions[i]);
        }
      }
      wrong += image.at<cv::Vec3b>(row, col) == expected ? 0 : 1;
    }
  }
  return wrong;
}

TEST(EsdfSliceImage, EachVoxelShowsItsDistanceOnWhite) {
  // Three voxels of 0.1 m in a 3 x 2 box (one row of z); the cell at (0.15, 0.05) stays empty.
  const double res = 0.1;
  const std::vector<Eigen::Vector3f> points{
      {0.05f, 0.05f, 1.05f}, {0.25f, 0.05f, 1.05f}, {0.05f, 0.15f, 1.05f}};
  const std::vector<float> distance_m{-1.f, 2.f, 0.5f};
  const cv::Mat image = renderEsdfSlice(points, distance_m, res);
  ASSERT_EQ(image.type(), CV_8UC3);
  ASSERT_EQ(image.cols, 600);  // 200 pixels a voxel
  ASSERT_EQ(image.rows, 400);
  EXPECT_EQ(slicePixelsWrong(image, points, {0.0, 1.0, 0.5}, res, 0.05, 0.05, 2, 200), 0);
  EXPECT_EQ(image.at<cv::Vec3b>(399, 0), heightColorBgr(0.0));         // lowest: bottom left
  EXPECT_EQ(image.at<cv::Vec3b>(399, 599), heightColorBgr(1.0));       // highest: bottom right
  EXPECT_EQ(image.at<cv::Vec3b>(300, 300), cv::Vec3b(255, 255, 255));  // no voxel
  // The title is drawn in black at the top left.
  bool dark = false;
  for (int row = 0; row < 20; ++row) {
    for (int col = 0; col < 300; ++col) dark |= image.at<cv::Vec3b>(row, col)[0] < 100;
  }
  EXPECT_TRUE(dark);
}

TEST(EsdfSliceImage, OneDistanceIsDrawnInTheFirstColourAndSmallSlicesAtTwoPixels) {
  // 399 voxels in a row: max(2, 600 / 399) = 2 pixels a voxel.
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 400; i += 2) {
    points.emplace_back(-10.05f + 0.1f * static_cast<float>(i), 3.05f, 0.f);
  }
  const std::vector<float> distance_m(points.size(), 0.7f);
  const cv::Mat image = renderEsdfSlice(points, distance_m, 0.1);
  ASSERT_EQ(image.cols, 2 * 399);
  ASSERT_EQ(image.rows, 2);
  // Every other voxel drawn; the title's glyphs lie below these two rows.
  int wrong = 0;
  for (int col = 0; col < image.cols; ++col) {
    const cv::Vec3b expected = (col / 2) % 2 == 0 ? heightColorBgr(0.0) : cv::Vec3b(255, 255, 255);
    for (int row = 0; row < 2; ++row) wrong += image.at<cv::Vec3b>(row, col) == expected ? 0 : 1;
  }
  EXPECT_EQ(wrong, 0);
}

TEST(EsdfSliceImage, RefusesWhatItCannotDraw) {
  const std::vector<Eigen::Vector3f> one{{0.05f, 0.05f, 0.f}};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW((void)renderEsdfSlice({}, {}, 0.1), std::invalid_argument);
  EXPECT_THROW((void)renderEsdfSlice(one, {1.f, 2.f}, 0.1), std::invalid_argument);
  EXPECT_THROW((void)renderEsdfSlice(one, {1.f}, 0.0), std::invalid_argument);
  EXPECT_THROW((void)renderEsdfSlice({{nan, 0.f, 0.f}}, {1.f}, 0.1), std::invalid_argument);
  // Points 1 km apart at 0.1 m: 10001 voxels a side, more than a picture holds.
  EXPECT_THROW((void)renderEsdfSlice({{0.f, 0.f, 0.f}, {1000.f, 0.f, 0.f}}, {1.f, 2.f}, 0.1),
               std::invalid_argument);
}

TEST(VoxelListOf, SnapsReceivedPointsBackToTheirVoxelCentres) {
  const double res = 0.1;
  const std::vector<Eigen::Vector3f> points{
      {0.0501f, 0.1499f, -0.0499f}, {-0.05f, 10.25f, 3.35f}, {1e-7f, -1e-7f, 0.f}};
  const VoxelList list = voxelListOf(points, res);
  EXPECT_EQ(list.resolution_m, res);
  ASSERT_EQ(list.centers_W.size(), points.size());
  const std::vector<VoxelIndex> expected{{0, 1, -1}, {-1, 102, 33}, {0, -1, 0}};
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_TRUE(list.centers_W[i].isApprox(voxelCenter(expected[i], res), 1e-12)) << i;
  }
}

}  // namespace
}  // namespace mlmap::pictures
