/// @file
/// Writes the binary seeds of the fuzz corpus (tests/fuzz/corpus/): CDR samples serialised by the
/// generated types from real messages, and map files from a small map state. Run once when the
/// seeds need to change; the output is committed (docs/fuzzing.md):
///   cmake --build build-test --target mlmap_fuzz_make_seeds &&
///   build-test/tests/fuzz/mlmap_fuzz_make_seeds tests/fuzz/corpus

#include "../support/small_map_state.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/dds/fleet/submap_messages.h"
#include "mlmap/map_io/map_file.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"
#include "rcl_interfaces/srv/SetParameters_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastdds/rtps/common/SerializedPayload.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace mlmap;
namespace sensor_msgs = mlmap::dds::sensor_msgs;
namespace geometry_msgs = mlmap::dds::geometry_msgs;
namespace nav_msgs = mlmap::dds::nav_msgs;
using mlmap::dds::encodePointCloud2;
using mlmap::dds::toRosTime;

fs::path g_out;

void write(const std::string& target, const std::string& name, const std::string& bytes) {
  const fs::path dir = g_out / target;
  fs::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary) << bytes;
  std::cout << (dir / name).string() << " (" << bytes.size() << " bytes)\n";
}

/// The sample's bytes as a writer sends them (encapsulation + CDR), in either byte order.
template <typename Msg>
std::string cdr(const Msg& msg, bool big_endian = false) {
  std::vector<char> buffer(Msg::getCdrSerializedSize(msg) + 64);
  eprosima::fastcdr::FastBuffer fast(buffer.data(), buffer.size());
  eprosima::fastcdr::Cdr ser(fast,
                             big_endian ? eprosima::fastcdr::Cdr::BIG_ENDIANNESS
                                        : eprosima::fastcdr::Cdr::LITTLE_ENDIANNESS,
                             eprosima::fastcdr::Cdr::DDS_CDR);
  ser.serialize_encapsulation();
  msg.serialize(ser);
  return std::string(buffer.data(), ser.getSerializedDataLength());
}

std::string u32le(std::uint32_t v) {
  std::string s(4, '\0');
  for (int i = 0; i < 4; ++i) s[i] = static_cast<char>((v >> (8 * i)) & 0xFFu);
  return s;
}

void pointClouds() {
  const std::vector<Eigen::Vector3f> points = {
      {1.0f, 2.0f, 3.0f}, {-0.5f, 0.25f, 4.0f}, {0.0f, 0.0f, 0.1f}, {10.0f, -3.0f, 2.5f}};
  write("fuzz_cdr_point_cloud2", "xyz_float32.cdr",
        cdr(encodePointCloud2(points, nullptr, 12.5, "camera")));
  const std::vector<float> intensity = {0.1f, 0.2f, 0.3f, 0.4f};
  write("fuzz_cdr_point_cloud2", "xyzi_float32_big_endian_cdr.cdr",
        cdr(encodePointCloud2(points, &intensity, 13.0, "lidar"), true));
  std::vector<Eigen::Vector3f> with_nan = points;
  with_nan[1].y() = std::numeric_limits<float>::quiet_NaN();
  write("fuzz_cdr_point_cloud2", "nan_point.cdr",
        cdr(encodePointCloud2(with_nan, nullptr, 14.0, "camera")));
  write("fuzz_cdr_point_cloud2", "empty.cdr", cdr(encodePointCloud2({}, nullptr, 15.0, "camera")));

  // Organised 2 x 2, float64 z before x and y, big-endian data, rows padded to 40 bytes.
  sensor_msgs::PointCloud2_ msg = encodePointCloud2(points, nullptr, 16.0, "camera");
  auto field = [](const char* name, std::uint32_t offset, std::uint8_t datatype) {
    sensor_msgs::PointField_ f;
    f.name_(name);
    f.offset_(offset);
    f.datatype_(datatype);
    f.count_(1);
    return f;
  };
  msg.fields_({field("z", 0, 8), field("x", 8, 8), field("y", 16, 7), field("rgb", 20, 7)});
  msg.height_(2);
  msg.width_(2);
  msg.point_step_(24);
  msg.row_step_(56);
  msg.is_bigendian_(true);
  msg.is_dense_(true);
  std::vector<std::uint8_t> data(2 * 56, 0);
  for (std::size_t i = 0; i < 4; ++i) {
    std::uint8_t* p = data.data() + (i / 2) * 56 + (i % 2) * 24;
    auto putBe = [](std::uint8_t* at, const void* value, std::size_t n) {
      for (std::size_t b = 0; b < n; ++b)
        at[b] = static_cast<const std::uint8_t*>(value)[n - 1 - b];
    };
    const double z = points[i].z(), x = points[i].x();
    const float y = points[i].y();
    putBe(p, &z, 8);
    putBe(p + 8, &x, 8);
    putBe(p + 16, &y, 4);
  }
  msg.data_(data);
  write("fuzz_cdr_point_cloud2", "organised_float64_big_endian_padded.cdr", cdr(msg));
}

sensor_msgs::CameraInfo_ cameraInfo(std::uint32_t width, std::uint32_t height) {
  sensor_msgs::CameraInfo_ info;
  info.header_().frame_id_("camera");
  info.width_(width);
  info.height_(height);
  info.distortion_model_("plumb_bob");
  info.d_({0.0, 0.0, 0.0, 0.0, 0.0});
  info.k_({385.0, 0.0, 1.5, 0.0, 385.0, 1.0, 0.0, 0.0, 1.0});
  return info;
}

void depthImages() {
  // 16UC1 millimetres, 4 x 3, tightly packed, little endian.
  sensor_msgs::Image_ image;
  image.header_().stamp_(toRosTime(20.0));
  image.header_().frame_id_("camera");
  image.width_(4);
  image.height_(3);
  image.encoding_("16UC1");
  image.step_(8);
  std::vector<std::uint8_t> mm(24);
  for (std::size_t i = 0; i < 12; ++i) {
    const std::uint16_t v = static_cast<std::uint16_t>(i == 5 ? 0 : 500 + 100 * i);
    std::memcpy(&mm[2 * i], &v, 2);
  }
  image.data_(mm);
  const std::string info = cdr(cameraInfo(4, 3));
  write("fuzz_cdr_depth_image", "16uc1.bin",
        u32le(static_cast<std::uint32_t>(info.size())) + info + cdr(image));
  image.encoding_("mono16");
  write("fuzz_cdr_depth_image", "mono16.bin",
        u32le(static_cast<std::uint32_t>(info.size())) + info + cdr(image));

  // 32FC1 metres, 3 x 2, rows padded to 16 bytes, big-endian pixels, a NaN.
  image.width_(3);
  image.height_(2);
  image.encoding_("32FC1");
  image.is_bigendian_(1);
  image.step_(16);
  std::vector<std::uint8_t> m(32, 0);
  for (std::size_t i = 0; i < 6; ++i) {
    const float v =
        i == 4 ? std::numeric_limits<float>::quiet_NaN() : 0.5f + 0.25f * static_cast<float>(i);
    std::uint32_t bits;
    std::memcpy(&bits, &v, 4);
    bits = __builtin_bswap32(bits);
    std::memcpy(&m[(i / 3) * 16 + (i % 3) * 4], &bits, 4);
  }
  image.data_(m);
  const std::string info32 = cdr(cameraInfo(3, 2));
  write("fuzz_cdr_depth_image", "32fc1_big_endian_padded.bin",
        u32le(static_cast<std::uint32_t>(info32.size())) + info32 + cdr(image));
}

void poses() {
  geometry_msgs::PoseStamped_ pose;
  pose.header_().stamp_(toRosTime(30.25));
  pose.header_().frame_id_("map");
  pose.pose_().position_().x_(1.0);
  pose.pose_().position_().y_(-2.0);
  pose.pose_().position_().z_(1.5);
  pose.pose_().orientation_().w_(std::sqrt(0.5));
  pose.pose_().orientation_().z_(std::sqrt(0.5));
  write("fuzz_cdr_pose", "pose_stamped.bin", std::string(1, '\0') + cdr(pose));
  nav_msgs::Odometry_ odometry;
  odometry.header_() = pose.header_();
  odometry.child_frame_id_("base_link");
  odometry.pose_().pose_() = pose.pose_();
  odometry.twist_().twist_().linear_().x_(0.5);
  write("fuzz_cdr_pose", "odometry.bin", std::string(1, '\1') + cdr(odometry));
}

void submaps() {
  const mlmap::dds::SubmapGeometry grid{0.1, {16, 16, 6}};
  fleet::SubmapUpdate wall{SubmapIndex(3, -2, 0), {}};
  for (std::uint32_t o = 0; o < 600; o += 2) wall.records.push_back({o, 3500});  // zstd
  write("fuzz_cdr_submap", "wall_zstd.bin",
        cdr(mlmap::dds::toSubmapMessage(wall, grid, "uav1", 7, 12.5, "map")));
  const fleet::SubmapUpdate few{SubmapIndex(0, 0, 1), {{1, 900}, {700, -120}}};  // raw
  write("fuzz_cdr_submap", "few_raw.bin",
        cdr(mlmap::dds::toSubmapMessage(few, grid, "uav2", 8, 13.0, "map")));
  write("fuzz_cdr_submap", "empty.bin",
        cdr(mlmap::dds::toSubmapMessage({SubmapIndex(1, 1, 1), {}}, grid, "uav1", 9, 14.0, "map")));
}

/// One record of fuzz_fleet_sample's stream: the writer, the length, the sample's CDR.
std::string fleetRecord(std::uint8_t writer, const std::string& sample) {
  const auto n = static_cast<std::uint16_t>(sample.size());
  return std::string(1, static_cast<char>(writer)) + static_cast<char>(n & 0xff) +
         static_cast<char>(n >> 8) + sample;
}

/// Streams of samples for the merger's accept path (fuzz_fleet_sample.cpp): two vehicles, a
/// restart, a stranger's grid, a sequence number 2^64-1, empty newcomers; open and closed.
void fleetSamples() {
  const mlmap::dds::SubmapGeometry grid{0.1, {16, 16, 6}};
  fleet::SubmapUpdate wall{SubmapIndex(3, -2, 0), {}};
  for (std::uint32_t o = 0; o < 600; o += 2) wall.records.push_back({o, 3500});
  const fleet::SubmapUpdate few{SubmapIndex(0, 0, 1), {{1, 900}, {700, -120}}};
  const fleet::SubmapUpdate empty{SubmapIndex(3, -2, 0), {}};
  auto sample = [&](const fleet::SubmapUpdate& u, const std::string& vehicle, std::uint64_t seq,
                    const mlmap::dds::SubmapGeometry& g) {
    return cdr(mlmap::dds::toSubmapMessage(u, g, vehicle, seq, 1.0, "map"));
  };
  const std::string two_vehicles = fleetRecord(0, sample(wall, "uav1", 7, grid)) +
                                   fleetRecord(1, sample(few, "uav2", 8, grid)) +
                                   fleetRecord(0, sample(empty, "uav1", 9, grid)) +
                                   fleetRecord(2, sample(wall, "uav1", 3, grid));  // restart
  write("fuzz_fleet_sample", "open_two_vehicles_restart.bin", std::string(1, '\0') + two_vehicles);
  write("fuzz_fleet_sample", "closed_two_vehicles_restart.bin",
        std::string(1, '\1') + two_vehicles);
  const std::string attacks =
      fleetRecord(3, sample(empty, "stranger", 1, {0.123, {16, 16, 6}})) +
      fleetRecord(3, sample(empty, "ghost", 1, grid)) +
      fleetRecord(0, sample(few, "uav1", 10, grid)) +
      fleetRecord(3, sample(empty, "uav1", std::numeric_limits<std::uint64_t>::max(), grid)) +
      fleetRecord(0, sample(few, "uav1", 11, grid));
  write("fuzz_fleet_sample", "open_attacks.bin", std::string(1, '\0') + attacks);
}

/// fuzz_cdr_tf_message: a /tf sample (first byte even) and a SetParameters request (odd).
void countedSequences() {
  ::tf2_msgs::msg::dds_::TFMessage_ tf;
  tf.transforms_().resize(2);
  tf.transforms_()[0].header_().stamp_(toRosTime(40.5));
  tf.transforms_()[0].header_().frame_id_("map");
  tf.transforms_()[0].child_frame_id_("odom");
  tf.transforms_()[0].transform_().rotation_().w_(1.0);
  tf.transforms_()[1].header_() = tf.transforms_()[0].header_();
  tf.transforms_()[1].header_().frame_id_("odom");
  tf.transforms_()[1].child_frame_id_("base_link");
  tf.transforms_()[1].transform_().translation_().x_(2.5);
  tf.transforms_()[1].transform_().rotation_().z_(1.0);
  write("fuzz_cdr_tf_message", "two_transforms.bin", std::string(1, '\0') + cdr(tf));
  write("fuzz_cdr_tf_message", "two_transforms_big_endian.bin",
        std::string(1, '\2') + cdr(tf, true));
  ::rcl_interfaces::srv::dds_::SetParameters_Request_ request;
  request.parameters_().resize(3);
  request.parameters_()[0].name_("local_map.resolution_m");
  request.parameters_()[0].value_().type_(3);
  request.parameters_()[0].value_().double_value_(0.1);
  request.parameters_()[1].name_("sensor.extrinsic");
  request.parameters_()[1].value_().type_(8);
  request.parameters_()[1].value_().double_array_value_({0.1, 0.0, 0.2, 0.0, 0.0, 0.0, 1.0});
  request.parameters_()[2].name_("dds.topics.names");
  request.parameters_()[2].value_().type_(9);
  request.parameters_()[2].value_().string_array_value_({"cloud", "pose"});
  write("fuzz_cdr_tf_message", "set_parameters.bin", std::string(1, '\1') + cdr(request));
}

void mapFiles() {
  MapState placed = test::smallMapState();
  write("fuzz_map_file", "small.mlmap", io::encodeMapFile(placed));
  MapState never_placed;  // the same configuration, no window yet, no global map
  never_placed.local_map = placed.local_map;
  never_placed.log_odds = placed.log_odds;
  write("fuzz_map_file", "never_placed.mlmap", io::encodeMapFile(never_placed));
  // Valid checksums over absurd fields: the loader must refuse them (or, for the far but legal
  // body, every use of the map must still end).
  MapState far_up = placed;
  far_up.T_W_B.translation().z() = 1e300;
  write("fuzz_map_file", "body_1e300_m_up.mlmap", io::encodeMapFile(far_up));
  MapState far_legal = placed;
  far_legal.T_W_B.translation() = Eigen::Vector3d(-9.9e5, 9.9e5, 9.9e5);
  write("fuzz_map_file", "body_far_but_legal.mlmap", io::encodeMapFile(far_legal));
  MapState nan_stamp = placed;
  nan_stamp.has_last_stamp = true;
  nan_stamp.last_stamp_s = std::nan("");
  write("fuzz_map_file", "nan_stamp.mlmap", io::encodeMapFile(nan_stamp));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: " << argv[0] << " CORPUS_DIR (tests/fuzz/corpus)\n";
    return 2;
  }
  g_out = argv[1];
  pointClouds();
  depthImages();
  poses();
  submaps();
  fleetSamples();
  countedSequences();
  mapFiles();
  return 0;
}
