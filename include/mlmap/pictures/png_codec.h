#pragma once
/// @file
/// PNG encoding and decoding through libpng, for the map pictures and the depth images of frame
/// directories. OpenCV's imgcodecs would do the same, but Debian's build of it loads about 120
/// shared libraries (GDAL, HEIF, ...) at every program start: more than a replay's writing of
/// its pictures costs.

#include <opencv2/core.hpp>

#include <cstddef>
#include <string>

namespace mlmap::pictures {

/// Encodes `image` as PNG: 8-bit gray (CV_8UC1), 8-bit BGR (CV_8UC3, stored as RGB) or 16-bit
/// gray (CV_16UC1). Lossless, compressed for speed (zlib level 1): 16-bit images with the "sub"
/// filter and zlib's run-length strategy (OpenCV imencode's default), 8-bit ones unfiltered with
/// zlib's default strategy (on a map picture a third smaller and faster).
/// @throws std::runtime_error when the image is empty, of another type, or libpng fails.
[[nodiscard]] std::string encodePng(const cv::Mat& image);

/// Decodes the PNG in `bytes` [`size` bytes]: gray as CV_8UC1 / CV_16UC1 (samples below 8 bits
/// expanded to 8), RGB as CV_8UC3 / CV_16UC3 in BGR order, as OpenCV's imdecode with
/// IMREAD_UNCHANGED gives them.
/// @throws std::runtime_error with libpng's message when the data are not a PNG, are cut off or
///         corrupted, or hold another colour type (palette, alpha).
[[nodiscard]] cv::Mat decodePng(const void* bytes, std::size_t size);

}  // namespace mlmap::pictures
