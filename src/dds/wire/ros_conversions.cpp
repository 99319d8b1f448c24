#include "mlmap/dds/wire/ros_conversions.h"

#include <algorithm>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <type_traits>

namespace mlmap::dds {
namespace {

// sensor_msgs/PointField datatypes.
constexpr std::uint8_t kInt8 = 1;
constexpr std::uint8_t kFloat32 = 7;
constexpr std::uint8_t kFloat64 = 8;

#if defined(__BYTE_ORDER__) && defined(__ORDER_BIG_ENDIAN__) && \
    __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
constexpr bool kHostBigEndian = true;
#else
constexpr bool kHostBigEndian = false;
#endif

constexpr double kNanosecPerSecond = 1e9;
constexpr std::uint32_t kMaxNanosec = 999999999u;

inline std::uint16_t byteSwap(std::uint16_t v) { return __builtin_bswap16(v); }
inline std::uint32_t byteSwap(std::uint32_t v) { return __builtin_bswap32(v); }
inline std::uint64_t byteSwap(std::uint64_t v) { return __builtin_bswap64(v); }

/// Unsigned integer of the same size as the floating type T.
template <typename T>
using BitsOf = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;

/// Reads a T stored at `p` (any alignment), swapping its bytes when kSwap, as a float.
template <typename T, bool kSwap>
inline float loadAsFloat(const std::uint8_t* p) {
  BitsOf<T> bits;
  std::memcpy(&bits, p, sizeof(bits));
  if constexpr (kSwap) bits = byteSwap(bits);
  T value;
  std::memcpy(&value, &bits, sizeof(value));
  // A finite double beyond the float range becomes +-inf here, hence a NaN point below.
  return static_cast<float>(value);
}

/// Writes a float at `p` in little-endian byte order.
inline void storeFloatLe(float value, std::uint8_t* p) {
  std::uint32_t bits;
  std::memcpy(&bits, &value, sizeof(bits));
  if constexpr (kHostBigEndian) bits = byteSwap(bits);
  std::memcpy(p, &bits, sizeof(bits));
}

const char* pointFieldTypeName(std::uint8_t datatype) {
  static constexpr const char* kNames[] = {"INT8",  "UINT8",  "INT16",   "UINT16",
                                           "INT32", "UINT32", "FLOAT32", "FLOAT64"};
  if (datatype < kInt8 || datatype > kFloat64) return "unknown";
  return kNames[datatype - kInt8];
}

/// Where x, y and z live in a validated PointCloud2.
struct CloudLayout {
  std::uint32_t height = 0;
  std::uint32_t width = 0;
  std::size_t point_step = 0;
  std::size_t row_step = 0;
  std::size_t offset[3] = {0, 0, 0};
  std::uint8_t datatype[3] = {0, 0, 0};
  bool swap = false;
};

/// The decode loop for one layout: types and byte order are template parameters, so the
/// per-point work is three unaligned loads, a finiteness test and a store, with no branch.
template <bool kSwap, typename TX, typename TY, typename TZ>
void decodePoints(const CloudLayout& layout, const std::uint8_t* data, Eigen::Vector3f* out) {
  const std::size_t ox = layout.offset[0];
  const std::size_t oy = layout.offset[1];
  const std::size_t oz = layout.offset[2];
  const std::size_t point_step = layout.point_step;
  for (std::uint32_t row = 0; row < layout.height; ++row) {
    const std::uint8_t* p = data + static_cast<std::size_t>(row) * layout.row_step;
    for (std::uint32_t i = 0; i < layout.width; ++i, p += point_step, ++out) {
      const float x = loadAsFloat<TX, kSwap>(p + ox);
      const float y = loadAsFloat<TY, kSwap>(p + oy);
      const float z = loadAsFloat<TZ, kSwap>(p + oz);
      // v - v is +0 for a finite v and NaN for NaN or +-inf (IEEE; mlmap never builds with
      // -ffinite-math-only), so adding the sum leaves a finite point as it is (bar the sign of a
      // zero) and turns a point with any non-finite coordinate into an all-NaN point.
      const float poison = (x - x) + (y - y) + (z - z);
      *out = Eigen::Vector3f(x + poison, y + poison, z + poison);
    }
  }
}

/// Picks the decodePoints() instance for the layout's datatypes, one axis at a time.
template <bool kSwap, typename... Known>
void dispatchDecode(const CloudLayout& layout, const std::uint8_t* data, Eigen::Vector3f* out) {
  if constexpr (sizeof...(Known) == 3) {
    decodePoints<kSwap, Known...>(layout, data, out);
  } else {
    if (layout.datatype[sizeof...(Known)] == kFloat32) {
      dispatchDecode<kSwap, Known..., float>(layout, data, out);
    } else {
      dispatchDecode<kSwap, Known..., double>(layout, data, out);
    }
  }
}

DecodeStatus fail(DecodeError error, std::string detail) {
  return DecodeStatus{error, std::move(detail)};
}

std::string str(std::uint64_t v) { return std::to_string(v); }

/// Decodes a stamp; kBadStamp when nanosec >= 1e9.
DecodeStatus decodeStamp(const ros_time::Time_& stamp, double* stamp_s) {
  if (stamp.nanosec_() > kMaxNanosec) {
    return fail(DecodeError::kBadStamp, "stamp nanosec " + str(stamp.nanosec_()) + " >= 1e9");
  }
  *stamp_s = toSeconds(stamp);
  return {};
}

DecodeStatus decodePoseFields(const ros_time::Time_& stamp, const geometry_msgs::Pose_& pose,
                              double* stamp_s, Transform* T_W_B) {
  double stamp_value = 0.0;
  DecodeStatus status = decodeStamp(stamp, &stamp_value);
  if (!status.ok()) return status;
  const geometry_msgs::Point_& p = pose.position_();
  const geometry_msgs::Quaternion_& q = pose.orientation_();
  const Eigen::Vector3d t(p.x_(), p.y_(), p.z_());
  const Eigen::Quaterniond rotation(q.w_(), q.x_(), q.y_(), q.z_());
  Transform T = Transform::Identity();
  if (!makePose(t, rotation, &T, 1e-3)) {
    if (!t.allFinite() || !rotation.coeffs().allFinite()) {
      return fail(DecodeError::kBadPose, "pose is not finite");
    }
    return fail(DecodeError::kBadPose,
                "quaternion norm " + std::to_string(rotation.norm()) + " is not within 1e-3 of 1");
  }
  *stamp_s = stamp_value;
  *T_W_B = T;
  return {};
}

std_msgs::msg::dds_::Header_ makeHeader(double stamp_s, const std::string& frame_id) {
  std_msgs::msg::dds_::Header_ header;
  header.stamp_(toRosTime(stamp_s));
  header.frame_id_(frame_id);
  return header;
}

sensor_msgs::PointField_ makeField(const char* name, std::uint32_t offset) {
  sensor_msgs::PointField_ field;
  field.name_(name);
  field.offset_(offset);
  field.datatype_(kFloat32);
  field.count_(1);
  return field;
}

}  // namespace

double wallClockNow_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

double toSeconds(const ros_time::Time_& stamp) {
  return static_cast<double>(stamp.sec_()) + static_cast<double>(stamp.nanosec_()) * 1e-9;
}

ros_time::Time_ toRosTime(double stamp_s) {
  ros_time::Time_ t;
  t.sec_(0);
  t.nanosec_(0);
  if (!std::isfinite(stamp_s)) return t;
  constexpr double kLimit = 2147483648.0;  // 2^31
  if (stamp_s < -kLimit) {
    t.sec_(std::numeric_limits<std::int32_t>::min());
    return t;
  }
  double sec = std::floor(stamp_s);
  // stamp_s - sec is exact (both are within a factor 2 or sec is 0), so the only rounding is
  // to the nanosecond; that may give 1e9, which carries into the seconds.
  double nanosec = std::nearbyint((stamp_s - sec) * kNanosecPerSecond);
  if (nanosec >= kNanosecPerSecond) {
    sec += 1.0;
    nanosec -= kNanosecPerSecond;
  }
  if (sec >= kLimit) {
    t.sec_(std::numeric_limits<std::int32_t>::max());
    t.nanosec_(kMaxNanosec);
    return t;
  }
  t.sec_(static_cast<std::int32_t>(sec));
  t.nanosec_(static_cast<std::uint32_t>(nanosec));
  return t;
}

const char* toString(DecodeError error) {
  switch (error) {
    case DecodeError::kOk:
      return "ok";
    case DecodeError::kBadLayout:
      return "bad layout";
    case DecodeError::kMissingField:
      return "missing field";
    case DecodeError::kUnsupportedType:
      return "unsupported type";
    case DecodeError::kBadStamp:
      return "bad stamp";
    case DecodeError::kBadPose:
      return "bad pose";
  }
  return "invalid";
}

DecodeStatus decodePointCloud2(const sensor_msgs::PointCloud2_& msg,
                               std::vector<Eigen::Vector3f>* points_S) {
  return decodePointCloud2(msg, msg.data_().data(), msg.data_().size(), points_S);
}

DecodeStatus decodePointCloud2(const sensor_msgs::PointCloud2_& msg, const std::uint8_t* data,
                               std::size_t data_size, std::vector<Eigen::Vector3f>* points_S) {
  points_S->clear();
  static constexpr const char* kAxisNames[3] = {"x", "y", "z"};

  // x, y and z: exactly one field each, FLOAT32 or FLOAT64, count 1.
  const sensor_msgs::PointField_* axis[3] = {nullptr, nullptr, nullptr};
  for (const sensor_msgs::PointField_& field : msg.fields_()) {
    for (int a = 0; a < 3; ++a) {
      if (field.name_() != kAxisNames[a]) continue;
      if (axis[a] != nullptr) {
        return fail(DecodeError::kBadLayout,
                    std::string("two fields named '") + kAxisNames[a] + "'");
      }
      axis[a] = &field;
    }
  }
  CloudLayout layout;
  std::uint64_t field_bytes[3] = {0, 0, 0};
  for (int a = 0; a < 3; ++a) {
    const std::string name = kAxisNames[a];
    if (axis[a] == nullptr) return fail(DecodeError::kMissingField, "no '" + name + "' field");
    const std::uint8_t type = axis[a]->datatype_();
    if (type != kFloat32 && type != kFloat64) {
      return fail(DecodeError::kUnsupportedType,
                  "field '" + name + "' has datatype " + str(type) + " (" +
                      pointFieldTypeName(type) + "); x, y, z must be FLOAT32 (7) or FLOAT64 (8)");
    }
    if (axis[a]->count_() != 1) {
      return fail(
          DecodeError::kUnsupportedType,
          "field '" + name + "' has count " + str(axis[a]->count_()) + "; x, y, z need count 1");
    }
    layout.datatype[a] = type;
    layout.offset[a] = axis[a]->offset_();
    field_bytes[a] = type == kFloat32 ? 4 : 8;
  }

  // Sizes, all in 64 bits: each factor is below 2^32, so no product overflows.
  const std::uint64_t point_step = msg.point_step_();
  const std::uint64_t row_step = msg.row_step_();
  const std::uint64_t width = msg.width_();
  const std::uint64_t height = msg.height_();
  if (point_step == 0) return fail(DecodeError::kBadLayout, "point_step 0");
  for (int a = 0; a < 3; ++a) {
    const std::uint64_t end = static_cast<std::uint64_t>(layout.offset[a]) + field_bytes[a];
    if (end > point_step) {
      return fail(DecodeError::kBadLayout, std::string("field '") + kAxisNames[a] + "' at offset " +
                                               str(layout.offset[a]) + " (" + str(field_bytes[a]) +
                                               " bytes) ends past point_step " + str(point_step));
    }
  }
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3;
    const std::uint64_t a_begin = layout.offset[a];
    const std::uint64_t b_begin = layout.offset[b];
    if (a_begin < b_begin + field_bytes[b] && b_begin < a_begin + field_bytes[a]) {
      return fail(DecodeError::kBadLayout, std::string("fields '") + kAxisNames[a] + "' and '" +
                                               kAxisNames[b] + "' overlap");
    }
  }
  if (row_step < width * point_step) {
    return fail(DecodeError::kBadLayout, "row_step " + str(row_step) + " < width " + str(width) +
                                             " * point_step " + str(point_step));
  }
  // ROS defines data as exactly height rows of row_step bytes; anything else means the sender's
  // sizes are wrong, and guessing which one is right would read garbage.
  if (data_size != height * row_step) {
    return fail(DecodeError::kBadLayout, "data size " + str(data_size) + " != height " +
                                             str(height) + " * row_step " + str(row_step));
  }

  // Validated: every point lies inside data, and width * height <= data_size / 12, so the
  // output is no bigger than the input message.
  layout.height = msg.height_();
  layout.width = msg.width_();
  layout.point_step = static_cast<std::size_t>(point_step);
  layout.row_step = static_cast<std::size_t>(row_step);
  layout.swap = msg.is_bigendian_() != kHostBigEndian;
  points_S->resize(static_cast<std::size_t>(width * height));
  if (points_S->empty()) return {};
  if (layout.swap) {
    dispatchDecode<true>(layout, data, points_S->data());
  } else {
    dispatchDecode<false>(layout, data, points_S->data());
  }
  return {};
}

sensor_msgs::PointCloud2_ encodePointCloud2(const std::vector<Eigen::Vector3f>& points,
                                            const std::vector<float>* intensity, double stamp_s,
                                            const std::string& frame_id) {
  if (intensity != nullptr && intensity->size() != points.size()) {
    throw std::invalid_argument("encodePointCloud2: " + str(intensity->size()) +
                                " intensities for " + str(points.size()) + " points");
  }
  const std::uint32_t point_step = intensity != nullptr ? 16u : 12u;
  if (points.size() > std::numeric_limits<std::uint32_t>::max() / point_step) {
    throw std::length_error("encodePointCloud2: " + str(points.size()) +
                            " points do not fit a PointCloud2 (row_step is 32 bits)");
  }
  const auto width = static_cast<std::uint32_t>(points.size());

  sensor_msgs::PointCloud2_ msg;
  msg.header_(makeHeader(stamp_s, frame_id));
  msg.height_(1);
  msg.width_(width);
  std::vector<sensor_msgs::PointField_> fields = {makeField("x", 0), makeField("y", 4),
                                                  makeField("z", 8)};
  if (intensity != nullptr) fields.push_back(makeField("intensity", 12));
  msg.fields_(std::move(fields));
  msg.is_bigendian_(false);
  msg.point_step_(point_step);
  msg.row_step_(width * point_step);

  std::vector<std::uint8_t> data(static_cast<std::size_t>(width) * point_step);
  bool dense = true;
  std::uint8_t* p = data.data();
  for (std::size_t i = 0; i < points.size(); ++i, p += point_step) {
    const Eigen::Vector3f& v = points[i];
    dense = dense && v.allFinite();
    storeFloatLe(v.x(), p);
    storeFloatLe(v.y(), p + 4);
    storeFloatLe(v.z(), p + 8);
    if (intensity != nullptr) storeFloatLe((*intensity)[i], p + 12);
  }
  msg.data_(std::move(data));
  msg.is_dense_(dense);
  return msg;
}

DecodeStatus decodeDepthImage(const sensor_msgs::Image_& image,
                              const sensor_msgs::CameraInfo_& info, DepthFrame* frame) {
  const std::string& encoding = image.encoding_();
  DepthEncoding depth_encoding = DepthEncoding::kFloat32Metres;
  std::uint64_t bytes_per_pixel = 0;
  if (encoding == "16UC1" || encoding == "mono16") {
    depth_encoding = DepthEncoding::kUint16Millimetres;
    bytes_per_pixel = 2;
  } else if (encoding == "32FC1") {
    bytes_per_pixel = 4;
  } else {
    return fail(DecodeError::kUnsupportedType,
                "depth encoding '" + encoding + "' (mlmap reads 16UC1, mono16 or 32FC1)");
  }

  const std::uint64_t width = image.width_();
  const std::uint64_t height = image.height_();
  const std::uint64_t step = image.step_();
  constexpr std::uint64_t kMaxSide = static_cast<std::uint64_t>(std::numeric_limits<int>::max());
  if (width == 0 || height == 0 || width > kMaxSide || height > kMaxSide) {
    return fail(DecodeError::kBadLayout, "image size " + str(width) + " x " + str(height));
  }
  const std::uint64_t row_bytes = width * bytes_per_pixel;
  if (step < row_bytes) {
    return fail(DecodeError::kBadLayout, "step " + str(step) + " < width " + str(width) + " * " +
                                             str(bytes_per_pixel) + " bytes");
  }
  const std::uint64_t data_size = image.data_().size();
  if (data_size < step * height) {
    return fail(DecodeError::kBadLayout, "data size " + str(data_size) + " < step " + str(step) +
                                             " * height " + str(height));
  }
  if (info.width_() != width || info.height_() != height) {
    return fail(DecodeError::kBadLayout, "CameraInfo " + str(info.width_()) + " x " +
                                             str(info.height_()) + " != image " + str(width) +
                                             " x " + str(height));
  }
  const double fx = info.k_()[0];
  const double cx = info.k_()[2];
  const double fy = info.k_()[4];
  const double cy = info.k_()[5];
  if (!(std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) && std::isfinite(cy) &&
        fx > 0.0 && fy > 0.0)) {
    return fail(DecodeError::kBadLayout, "CameraInfo K: fx " + std::to_string(fx) + ", fy " +
                                             std::to_string(fy) + ", cx " + std::to_string(cx) +
                                             ", cy " + std::to_string(cy) +
                                             " (need finite values, fx and fy > 0)");
  }

  // Validated: copy the rows tightly packed, in host byte order.
  const bool swap = (image.is_bigendian_() != 0) != kHostBigEndian;
  const auto w = static_cast<std::size_t>(width);
  const auto h = static_cast<std::size_t>(height);
  const auto pitch = static_cast<std::size_t>(step);
  const std::uint8_t* src = image.data_().data();
  const auto copyRows = [&](auto* dst) {
    using Pixel = std::remove_pointer_t<decltype(dst)>;
    const std::size_t packed = w * sizeof(Pixel);
    if (pitch == packed) {
      std::memcpy(dst, src, packed * h);
    } else {
      for (std::size_t row = 0; row < h; ++row) {
        std::memcpy(dst + row * w, src + row * pitch, packed);
      }
    }
    if (swap) {
      using Bits = std::conditional_t<sizeof(Pixel) == 2, std::uint16_t, std::uint32_t>;
      for (std::size_t i = 0; i < w * h; ++i) {
        Bits bits;
        std::memcpy(&bits, dst + i, sizeof(bits));
        bits = byteSwap(bits);
        std::memcpy(dst + i, &bits, sizeof(bits));
      }
    }
  };
  frame->encoding = depth_encoding;
  if (depth_encoding == DepthEncoding::kUint16Millimetres) {
    frame->depth_m.clear();
    frame->depth_mm.resize(w * h);
    copyRows(frame->depth_mm.data());
  } else {
    frame->depth_mm.clear();
    frame->depth_m.resize(w * h);
    copyRows(frame->depth_m.data());
  }
  frame->intrinsics.fx = fx;
  frame->intrinsics.fy = fy;
  frame->intrinsics.cx = cx;
  frame->intrinsics.cy = cy;
  frame->intrinsics.width = static_cast<int>(width);
  frame->intrinsics.height = static_cast<int>(height);
  return {};
}

DecodeStatus decodePose(const geometry_msgs::PoseStamped_& msg, double* stamp_s, Transform* T_W_B) {
  return decodePoseFields(msg.header_().stamp_(), msg.pose_(), stamp_s, T_W_B);
}

DecodeStatus decodePose(const nav_msgs::Odometry_& msg, double* stamp_s, Transform* T_W_B) {
  return decodePoseFields(msg.header_().stamp_(), msg.pose_().pose_(), stamp_s, T_W_B);
}

DecodeStatus decodeTransform(const geometry_msgs::TransformStamped_& msg, double* stamp_s,
                             Transform* T_parent_child) {
  const std::string& parent = msg.header_().frame_id_();
  const std::string& child = msg.child_frame_id_();
  if (parent.empty() || child.empty() || parent == child) {
    return fail(DecodeError::kBadPose,
                "transform '" + parent + "' -> '" + child + "': frames must be set and differ");
  }
  geometry_msgs::Pose_ pose;
  const auto& t = msg.transform_().translation_();
  pose.position_().x_(t.x_());
  pose.position_().y_(t.y_());
  pose.position_().z_(t.z_());
  pose.orientation_(msg.transform_().rotation_());
  return decodePoseFields(msg.header_().stamp_(), pose, stamp_s, T_parent_child);
}

namespace {
/// Writes T's translation and (normalised) rotation into a ROS Point / Vector3 and Quaternion.
template <typename XyzMsg, typename QuaternionMsg>
void setRigid(const Transform& T, XyzMsg* t_msg, QuaternionMsg* q_msg) {
  const Eigen::Vector3d t = T.translation();
  t_msg->x_(t.x());
  t_msg->y_(t.y());
  t_msg->z_(t.z());
  const Eigen::Quaterniond q = Eigen::Quaterniond(T.linear()).normalized();
  q_msg->x_(q.x());
  q_msg->y_(q.y());
  q_msg->z_(q.z());
  q_msg->w_(q.w());
}
}  // namespace

geometry_msgs::PoseStamped_ toPoseStamped(const Transform& T_W_B, double stamp_s,
                                          const std::string& frame_id) {
  geometry_msgs::PoseStamped_ msg;
  msg.header_(makeHeader(stamp_s, frame_id));
  setRigid(T_W_B, &msg.pose_().position_(), &msg.pose_().orientation_());
  return msg;
}

geometry_msgs::TransformStamped_ toTransformStamped(const Transform& T_parent_child, double stamp_s,
                                                    const std::string& parent_frame,
                                                    const std::string& child_frame) {
  geometry_msgs::TransformStamped_ msg;
  msg.header_(makeHeader(stamp_s, parent_frame));
  msg.child_frame_id_(child_frame);
  setRigid(T_parent_child, &msg.transform_().translation_(), &msg.transform_().rotation_());
  return msg;
}

nav_msgs::OccupancyGrid_ toOccupancyGrid(const ProjectedGrid& grid, double z_m, double stamp_s,
                                         const std::string& frame_id) {
  if (grid.width < 0 || grid.height < 0 ||
      grid.cells.size() !=
          static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height)) {
    throw std::invalid_argument("toOccupancyGrid: " + str(grid.cells.size()) + " cells for " +
                                std::to_string(grid.width) + " x " + std::to_string(grid.height));
  }
  nav_msgs::OccupancyGrid_ msg;
  msg.header_(makeHeader(stamp_s, frame_id));
  nav_msgs::MapMetaData_& info = msg.info_();
  info.map_load_time_(toRosTime(stamp_s));
  info.resolution_(static_cast<float>(grid.resolution_m));
  info.width_(static_cast<std::uint32_t>(grid.width));
  info.height_(static_cast<std::uint32_t>(grid.height));
  info.origin_().position_().x_(grid.origin_W.x());
  info.origin_().position_().y_(grid.origin_W.y());
  info.origin_().position_().z_(z_m);
  info.origin_().orientation_().x_(0.0);
  info.origin_().orientation_().y_(0.0);
  info.origin_().orientation_().z_(0.0);
  info.origin_().orientation_().w_(1.0);
  msg.data_(grid.cells);  // same layout: row-major in y, cell (0, 0) at the origin
  return msg;
}

mlmap_msgs::VoxelBlock_ toVoxelBlock(const EsdfMap& esdf, double stamp_s,
                                     const std::string& frame_id) {
  mlmap_msgs::VoxelBlock_ msg;
  msg.header_(makeHeader(stamp_s, frame_id));
  msg.version_(1);
  msg.layer_("esdf");
  msg.resolution_(esdf.resolution_m());
  msg.max_value_(static_cast<float>(esdf.config().max_distance_m));
  if (esdf.empty()) {
    msg.size_x_(0);
    msg.size_y_(0);
    msg.size_z_(0);
    return msg;
  }
  const Eigen::Vector3d origin = esdf.minCorner_W();
  msg.origin_().x_(origin.x());
  msg.origin_().y_(origin.y());
  msg.origin_().z_(origin.z());
  const Eigen::Vector3i& size = esdf.size();
  msg.size_x_(static_cast<std::uint32_t>(size.x()));
  msg.size_y_(static_cast<std::uint32_t>(size.y()));
  msg.size_z_(static_cast<std::uint32_t>(size.z()));
  std::vector<float> values = esdf.distances();
  const VoxelIndex& min_index = esdf.minIndex();
  std::size_t i = 0;
  for (int x = 0; x < size.x(); ++x) {
    for (int y = 0; y < size.y(); ++y) {
      for (int z = 0; z < size.z(); ++z, ++i) {  // box order: x-major, z fastest
        if (esdf.isUnknown(min_index + VoxelIndex(x, y, z))) {
          values[i] = std::numeric_limits<float>::quiet_NaN();
        }
      }
    }
  }
  msg.values_(std::move(values));
  return msg;
}

sensor_msgs::PointCloud2_ esdfSliceCloud(const EsdfMap& esdf, double z_m, double stamp_s,
                                         const std::string& frame_id) {
  std::vector<Eigen::Vector3f> points;
  std::vector<float> distance_m;
  const double resolution_m = esdf.resolution_m();
  const double layer = z_m * (1.0 / resolution_m);  // as voxelIndexOf() computes it
  const VoxelIndex& min_index = esdf.minIndex();
  const VoxelIndex max_index = esdf.maxIndex();
  // Range test first: it also rejects NaN before the float -> int conversion.
  if (!esdf.empty() && layer >= static_cast<double>(min_index.z()) &&
      layer < static_cast<double>(max_index.z())) {
    const int k = floorToInt(layer);
    const std::size_t slice =
        static_cast<std::size_t>(esdf.size().x()) * static_cast<std::size_t>(esdf.size().y());
    points.reserve(slice);
    distance_m.reserve(slice);
    for (int x = min_index.x(); x < max_index.x(); ++x) {
      for (int y = min_index.y(); y < max_index.y(); ++y) {
        const VoxelIndex g(x, y, k);
        if (esdf.isUnknown(g)) continue;
        points.push_back(voxelCenter(g, resolution_m).cast<float>());
        distance_m.push_back(esdf.distanceAt(g));
      }
    }
  }
  return encodePointCloud2(points, &distance_m, stamp_s, frame_id);
}

}  // namespace mlmap::dds
