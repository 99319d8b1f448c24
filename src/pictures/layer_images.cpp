#include "mlmap/pictures/layer_images.h"

#include "mlmap/core/types.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mlmap::pictures {

cv::Mat renderOccupancyGrid(int width, int height,
                            const std::vector<std::int8_t>& cells_row_major) {
  if (width <= 0 || height <= 0) {
    throw std::invalid_argument("occupancy grid picture: size " + std::to_string(width) + " x " +
                                std::to_string(height) + " is not positive");
  }
  const auto w = static_cast<std::size_t>(width);
  if (cells_row_major.size() != w * static_cast<std::size_t>(height)) {
    throw std::invalid_argument(
        "occupancy grid picture: " + std::to_string(cells_row_major.size()) + " cells for " +
        std::to_string(width) + " x " + std::to_string(height));
  }
  cv::Mat image(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int v = cells_row_major[static_cast<std::size_t>(y) * w + static_cast<std::size_t>(x)];
      // Row 0 of the grid is its lowest y: flip so north is up.
      cv::Vec3b& px = image.at<cv::Vec3b>(height - 1 - y, x);
      if (v < 0) {
        px = cv::Vec3b(200, 200, 200);  // unknown: grey
      } else {
        const auto g = static_cast<unsigned char>(255 - 255 * v / 100);
        px = cv::Vec3b(g, g, g);  // free white .. occupied black
      }
    }
  }
  const int scale = std::max(1, kLayerImageSide_px / std::max(width, height));
  cv::Mat big;
  cv::resize(image, big, cv::Size(width * scale, height * scale), 0, 0, cv::INTER_NEAREST);
  return big;
}

namespace {

/// Throws std::invalid_argument unless renderEsdfSlice() can draw its arguments.
void checkEsdfSlice(const std::vector<Eigen::Vector3f>& points_W,
                    const std::vector<float>& distance_m, double resolution_m) {
  if (points_W.empty()) throw std::invalid_argument("ESDF slice picture: no points");
  if (points_W.size() != distance_m.size()) {
    throw std::invalid_argument("ESDF slice picture: " + std::to_string(points_W.size()) +
                                " points, " + std::to_string(distance_m.size()) + " distances");
  }
  if (!(resolution_m > 0.0) || !std::isfinite(resolution_m)) {
    throw std::invalid_argument("ESDF slice picture: resolution " + std::to_string(resolution_m) +
                                " m is not positive");
  }
  for (const Eigen::Vector3f& p : points_W) {
    if (!p.allFinite()) throw std::invalid_argument("ESDF slice picture: a point is not finite");
  }
}

}  // namespace

cv::Mat renderEsdfSlice(const std::vector<Eigen::Vector3f>& points_W,
                        const std::vector<float>& distance_m, double resolution_m) {
  checkEsdfSlice(points_W, distance_m, resolution_m);
  const double res = resolution_m;
  Eigen::Vector2f lo(1e9f, 1e9f), hi(-1e9f, -1e9f);
  float d_lo = 1e9f, d_hi = -1e9f;
  for (std::size_t i = 0; i < points_W.size(); ++i) {
    lo = lo.cwiseMin(points_W[i].head<2>());
    hi = hi.cwiseMax(points_W[i].head<2>());
    d_lo = std::min(d_lo, distance_m[i]);
    d_hi = std::max(d_hi, distance_m[i]);
  }
  const double columns = std::round((hi.x() - lo.x()) / res) + 1;
  const double rows = std::round((hi.y() - lo.y()) / res) + 1;
  if (columns > kMaxMapSide_px || rows > kMaxMapSide_px) {
    throw std::invalid_argument("ESDF slice picture: " + std::to_string(columns) + " x " +
                                std::to_string(rows) + " voxels, more than " +
                                std::to_string(kMaxMapSide_px) + " a side");
  }
  const int w = static_cast<int>(columns);
  const int h = static_cast<int>(rows);
  const int px = std::max(2, kLayerImageSide_px / std::max(w, h));
  cv::Mat image(h * px, w * px, CV_8UC3, cv::Scalar(255, 255, 255));
  for (std::size_t i = 0; i < points_W.size(); ++i) {
    const int x = static_cast<int>(std::lround((points_W[i].x() - lo.x()) / res));
    const int y = h - 1 - static_cast<int>(std::lround((points_W[i].y() - lo.y()) / res));
    const double f = d_hi > d_lo ? (distance_m[i] - d_lo) / (d_hi - d_lo) : 0.0;
    const cv::Vec3b c = heightColorBgr(f);
    cv::rectangle(image, cv::Rect(x * px, y * px, px, px), cv::Scalar(c[0], c[1], c[2]),
                  cv::FILLED);
  }
  cv::putText(image, cv::format("ESDF slice: %.2f m (blue) .. %.2f m (red)", d_lo, d_hi),
              cv::Point(4, 14), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
  return image;
}

VoxelList voxelListOf(const std::vector<Eigen::Vector3f>& points_W, double resolution_m) {
  VoxelList list{resolution_m, {}};
  list.centers_W.reserve(points_W.size());
  for (const Eigen::Vector3f& p : points_W) {
    list.centers_W.push_back(
        voxelCenter(voxelIndexOf(p.cast<double>(), resolution_m), resolution_m));
  }
  return list;
}

}  // namespace mlmap::pictures
