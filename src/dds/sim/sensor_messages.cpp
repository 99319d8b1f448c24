#include "mlmap/dds/sim/sensor_messages.h"

#include <cmath>
#include <cstring>
#include <limits>

namespace mlmap::dds {

/// An organised cloud (width x height) of float32 x, y, z, intensity (16 bytes per point, as a
/// depth camera driver publishes it); pixels without a return are NaN (is_dense false).
sensor_msgs::PointCloud2_ organisedCloud(const DepthFrame& frame, double stamp_s,
                                         const std::string& frame_id) {
  sensor_msgs::PointCloud2_ msg;
  msg.header_().stamp_(toRosTime(stamp_s));
  msg.header_().frame_id_(frame_id);
  const PinholeIntrinsics& k = frame.intrinsics;
  msg.width_(static_cast<std::uint32_t>(k.width));
  msg.height_(static_cast<std::uint32_t>(k.height));
  const char* names[] = {"x", "y", "z", "intensity"};
  for (std::uint32_t i = 0; i < 4; ++i) {
    sensor_msgs::PointField_ f;
    f.name_(names[i]);
    f.offset_(4 * i);
    f.datatype_(7);  // FLOAT32
    f.count_(1);
    msg.fields_().push_back(f);
  }
  msg.is_bigendian_(false);
  msg.point_step_(16);
  msg.row_step_(16u * msg.width_());
  msg.is_dense_(false);
  std::vector<std::uint8_t>& data = msg.data_();
  data.resize(static_cast<std::size_t>(msg.row_step_()) * msg.height_());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::size_t i = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u, ++i) {
      const double z = frame.encoding == DepthEncoding::kFloat32Metres ? frame.depth_m[i]
                                                                       : frame.depth_mm[i] * 1e-3;
      float p[4] = {nan, nan, nan, nan};
      if (std::isfinite(z) && z > 0.0 &&
          !(frame.encoding == DepthEncoding::kUint16Millimetres && frame.depth_mm[i] == 65535)) {
        p[0] = static_cast<float>((u - k.cx) * z / k.fx);
        p[1] = static_cast<float>((v - k.cy) * z / k.fy);
        p[2] = static_cast<float>(z);
        p[3] = static_cast<float>(z);
      }
      std::memcpy(data.data() + 16 * i, p, sizeof(p));
    }
  }
  return msg;
}

/// The depth image of `frame` (16UC1 millimetres or 32FC1 metres, as it was captured).
sensor_msgs::Image_ depthImage(const DepthFrame& frame, double stamp_s,
                               const std::string& frame_id) {
  sensor_msgs::Image_ msg;
  msg.header_().stamp_(toRosTime(stamp_s));
  msg.header_().frame_id_(frame_id);
  msg.width_(static_cast<std::uint32_t>(frame.intrinsics.width));
  msg.height_(static_cast<std::uint32_t>(frame.intrinsics.height));
  msg.is_bigendian_(0);
  const bool mm = frame.encoding == DepthEncoding::kUint16Millimetres;
  msg.encoding_(mm ? "16UC1" : "32FC1");
  msg.step_(msg.width_() * (mm ? 2u : 4u));
  const std::size_t bytes = static_cast<std::size_t>(msg.step_()) * msg.height_();
  msg.data_().resize(bytes);
  std::memcpy(msg.data_().data(),
              mm ? static_cast<const void*>(frame.depth_mm.data())
                 : static_cast<const void*>(frame.depth_m.data()),
              bytes);
  return msg;
}

/// The CameraInfo of a pinhole camera without distortion.
sensor_msgs::CameraInfo_ cameraInfo(const PinholeIntrinsics& k, double stamp_s,
                                    const std::string& frame_id) {
  sensor_msgs::CameraInfo_ msg;
  msg.header_().stamp_(toRosTime(stamp_s));
  msg.header_().frame_id_(frame_id);
  msg.width_(static_cast<std::uint32_t>(k.width));
  msg.height_(static_cast<std::uint32_t>(k.height));
  msg.distortion_model_("plumb_bob");
  msg.d_(std::vector<double>(5, 0.0));
  msg.k_({k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1});
  msg.r_({1, 0, 0, 0, 1, 0, 0, 0, 1});
  msg.p_({k.fx, 0, k.cx, 0, 0, k.fy, k.cy, 0, 0, 0, 1, 0});
  return msg;
}

}  // namespace mlmap::dds
