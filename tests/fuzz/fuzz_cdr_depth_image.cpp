/// @file
/// Fuzz target: a depth sensor_msgs/Image and the sensor_msgs/CameraInfo it is paired with, as
/// raw CDR bytes deserialised as mlmap_node does (cdr_payload.h), then decodeDepthImage().
///
/// Input: a little-endian uint32 n, then n bytes of the CameraInfo sample, then the Image sample
/// (n is cut to what is there). Checks what decodeDepthImage() documents: on success a tightly
/// packed width * height image of the encoding's type and the CameraInfo's K; on error the frame
/// untouched.

#include "cdr_payload.h"
#include "fuzz_support.h"

#include "mlmap/dds/wire/ros_conversions.h"

#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"

#include <algorithm>
#include <cstring>

namespace {
using mlmap::fuzz::requireThat;
using CameraInfo = ::sensor_msgs::msg::dds_::CameraInfo_;
using CameraInfoType = ::sensor_msgs::msg::dds_::CameraInfo_PubSubType;
using Image = ::sensor_msgs::msg::dds_::Image_;
using ImageType = ::sensor_msgs::msg::dds_::Image_PubSubType;
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 4) return 0;
  std::uint32_t info_bytes = 0;
  for (int i = 3; i >= 0; --i) info_bytes = (info_bytes << 8) | data[i];
  const std::size_t n = std::min<std::size_t>(info_bytes, size - 4);
  CameraInfo info;
  Image image;
  if (!mlmap::fuzz::deserializeAsNodeDoes<CameraInfoType>(data + 4, n, &info) ||
      !mlmap::fuzz::deserializeAsNodeDoes<ImageType>(data + 4 + n, size - 4 - n, &image)) {
    return 0;  // dropped and counted as malformed CDR
  }
  mlmap::DepthFrame frame;
  frame.stamp_s = 123.0;  // a marker: decodeDepthImage() does not set it
  const mlmap::dds::DecodeStatus status = mlmap::dds::decodeDepthImage(image, info, &frame);
  requireThat(frame.stamp_s == 123.0, "decodeDepthImage: set the stamp");
  if (!status.ok()) {
    requireThat(frame.depth_mm.empty() && frame.depth_m.empty() && frame.intrinsics.width == 0,
                "decodeDepthImage: the frame changed on an error");
    return 0;
  }
  const std::size_t pixels = std::size_t{image.width_()} * image.height_();
  const bool mm = frame.encoding == mlmap::DepthEncoding::kUint16Millimetres;
  requireThat((mm ? frame.depth_mm.size() : frame.depth_m.size()) == pixels &&
                  (mm ? frame.depth_m.empty() : frame.depth_mm.empty()),
              "decodeDepthImage: not width * height pixels of one encoding");
  requireThat(frame.intrinsics.width == static_cast<int>(image.width_()) &&
                  frame.intrinsics.height == static_cast<int>(image.height_()) &&
                  frame.intrinsics.fx > 0.0 && frame.intrinsics.fy > 0.0 &&
                  std::isfinite(frame.intrinsics.cx) && std::isfinite(frame.intrinsics.cy),
              "decodeDepthImage: intrinsics not as validated");
  // The first row, as the sender meant it: compare its bytes (host order) to the data's.
  const std::size_t bytes_per_pixel = mm ? 2 : 4;
  const bool swap = image.is_bigendian_() != 0;
  for (std::size_t x = 0; x < image.width_(); ++x) {
    std::uint8_t expected[4] = {};
    for (std::size_t b = 0; b < bytes_per_pixel; ++b) {
      const std::size_t from = swap ? bytes_per_pixel - 1 - b : b;
      expected[b] = image.data_()[x * bytes_per_pixel + from];
    }
    const void* got = mm ? static_cast<const void*>(&frame.depth_mm[x])
                         : static_cast<const void*>(&frame.depth_m[x]);
    requireThat(std::memcmp(expected, got, bytes_per_pixel) == 0,
                "decodeDepthImage: the first row differs from the data");
  }
  return 0;
}
