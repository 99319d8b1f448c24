// What the generated types put on the wire: the type names a ROS 2 Jazzy peer matches on, the
// exact XCDR1 bytes of a PointCloud2, and what Fast CDR 1.0 does with truncated or corrupt
// payloads (the receive path must survive them).

#include <fastcdr/exceptions/BadParamException.h>
#include <fastcdr/exceptions/Exception.h>
#include <fastdds/rtps/common/SerializedPayload.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap_msgs/msg/Status_PubSubTypes.h"
#include "mlmap_msgs/msg/VoxelBlock_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

namespace mlmap::dds {
namespace {

using eprosima::fastrtps::rtps::SerializedPayload_t;
using Bytes = std::vector<std::uint8_t>;

TEST(WireTypes, RegisterTheTypeNamesRos2JazzyMatchesOn) {
  const auto nameOf = [](eprosima::fastdds::dds::TopicDataType&& type) {
    EXPECT_FALSE(type.m_isGetKeyDefined) << type.getName() << ": ROS 2 types have no key";
    return std::string(type.getName());
  };
  EXPECT_EQ(nameOf(sensor_msgs::PointCloud2_PubSubType()), "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_EQ(nameOf(nav_msgs::OccupancyGrid_PubSubType()), "nav_msgs::msg::dds_::OccupancyGrid_");
  EXPECT_EQ(nameOf(geometry_msgs::PoseStamped_PubSubType()),
            "geometry_msgs::msg::dds_::PoseStamped_");
  EXPECT_EQ(nameOf(nav_msgs::Odometry_PubSubType()), "nav_msgs::msg::dds_::Odometry_");
  EXPECT_EQ(nameOf(::tf2_msgs::msg::dds_::TFMessage_PubSubType()),
            "tf2_msgs::msg::dds_::TFMessage_");
  EXPECT_EQ(nameOf(sensor_msgs::Image_PubSubType()), "sensor_msgs::msg::dds_::Image_");
  EXPECT_EQ(nameOf(sensor_msgs::CameraInfo_PubSubType()), "sensor_msgs::msg::dds_::CameraInfo_");
  EXPECT_EQ(nameOf(mlmap_msgs::VoxelBlock_PubSubType()), "mlmap_msgs::msg::dds_::VoxelBlock_");
  EXPECT_EQ(nameOf(mlmap_msgs::Status_PubSubType()), "mlmap_msgs::msg::dds_::Status_");
}

/// The message whose bytes are spelled out below: 2 points of float32 x, y.
sensor_msgs::PointCloud2_ smallCloud() {
  sensor_msgs::PointCloud2_ msg;
  msg.header_().stamp_().sec_(1);
  msg.header_().stamp_().nanosec_(2);
  msg.header_().frame_id_("map");
  msg.height_(1);
  msg.width_(2);
  for (const auto& [name, offset] : {std::pair<const char*, std::uint32_t>{"x", 0}, {"y", 4}}) {
    sensor_msgs::PointField_ field;
    field.name_(name);
    field.offset_(offset);
    field.datatype_(7);  // FLOAT32
    field.count_(1);
    msg.fields_().push_back(field);
  }
  msg.is_bigendian_(false);
  msg.point_step_(8);
  msg.row_step_(16);
  // x, y of point 0 = (1.0, 2.0) and of point 1 = (-1.5, 0.5), little-endian float32 bytes.
  msg.data_({0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0xC0, 0xBF, 0x00, 0x00,
             0x00, 0x3F});
  msg.is_dense_(true);
  return msg;
}

/// smallCloud() in XCDR1 little endian, written out by hand from the CDR rules: a 4-byte
/// encapsulation header (00 01 = CDR_LE, options 00 00); then every primitive aligned to its own
/// size counted from the end of that header; a string is a uint32 length that counts the
/// terminating NUL, the characters and the NUL; a sequence is a uint32 element count and the
/// elements. `P` marks padding bytes (Fast CDR skips them; see the test).
constexpr std::uint8_t P = 0x00;
// clang-format off
const Bytes kSmallCloudLe = {
    0x00, 0x01, 0x00, 0x00,  // encapsulation: CDR_LE, options 0
    // body offset 0: header.stamp
    0x01, 0x00, 0x00, 0x00,  //  0 sec = 1
    0x02, 0x00, 0x00, 0x00,  //  4 nanosec = 2
    0x04, 0x00, 0x00, 0x00,  //  8 frame_id length 4 ("map" + NUL)
    'm', 'a', 'p', 0x00,     // 12
    0x01, 0x00, 0x00, 0x00,  // 16 height = 1
    0x02, 0x00, 0x00, 0x00,  // 20 width = 2
    0x02, 0x00, 0x00, 0x00,  // 24 fields: 2 elements
    0x02, 0x00, 0x00, 0x00,  // 28 fields[0].name length 2
    'x', 0x00, P, P,         // 32 "x" NUL, padding to 4
    0x00, 0x00, 0x00, 0x00,  // 36 fields[0].offset = 0
    0x07, P, P, P,           // 40 fields[0].datatype = FLOAT32 (octet), padding to 4
    0x01, 0x00, 0x00, 0x00,  // 44 fields[0].count = 1
    0x02, 0x00, 0x00, 0x00,  // 48 fields[1].name length 2
    'y', 0x00, P, P,         // 52
    0x04, 0x00, 0x00, 0x00,  // 56 fields[1].offset = 4
    0x07, P, P, P,           // 60 fields[1].datatype
    0x01, 0x00, 0x00, 0x00,  // 64 fields[1].count
    0x00, P, P, P,           // 68 is_bigendian = false (boolean, 1 byte), padding
    0x08, 0x00, 0x00, 0x00,  // 72 point_step = 8
    0x10, 0x00, 0x00, 0x00,  // 76 row_step = 16
    0x10, 0x00, 0x00, 0x00,  // 80 data: 16 octets
    0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00, 0x40,  // 84
    0x00, 0x00, 0xC0, 0xBF, 0x00, 0x00, 0x00, 0x3F,  // 92
    0x01,                                            // 100 is_dense = true
};
// clang-format on
/// Positions (in the whole payload) of the padding bytes of kSmallCloudLe.
const std::vector<std::size_t> kPadding = {4 + 34, 4 + 35, 4 + 41, 4 + 42, 4 + 43, 4 + 54, 4 + 55,
                                           4 + 61, 4 + 62, 4 + 63, 4 + 69, 4 + 70, 4 + 71};

/// The same rules as code, for either byte order (checked against kSmallCloudLe).
class CdrWriter {
 public:
  explicit CdrWriter(bool big_endian)
      : big_endian_(big_endian),
        bytes_{0x00, static_cast<std::uint8_t>(big_endian ? 0x00 : 0x01), 0x00, 0x00} {}
  void octet(std::uint8_t v) { bytes_.push_back(v); }
  void u32(std::uint32_t v) {
    while ((bytes_.size() - 4) % 4 != 0) bytes_.push_back(P);
    for (int i = 0; i < 4; ++i) {
      const int shift = big_endian_ ? 8 * (3 - i) : 8 * i;
      bytes_.push_back(static_cast<std::uint8_t>((v >> shift) & 0xFFu));
    }
  }
  void string(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size() + 1));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
    bytes_.push_back(0x00);
  }
  void octets(const Bytes& v) {
    u32(static_cast<std::uint32_t>(v.size()));
    bytes_.insert(bytes_.end(), v.begin(), v.end());
  }
  [[nodiscard]] const Bytes& bytes() const { return bytes_; }

 private:
  bool big_endian_;
  Bytes bytes_;
};

Bytes smallCloudBytes(bool big_endian) {
  const sensor_msgs::PointCloud2_ msg = smallCloud();
  CdrWriter w(big_endian);
  w.u32(static_cast<std::uint32_t>(msg.header_().stamp_().sec_()));
  w.u32(msg.header_().stamp_().nanosec_());
  w.string(msg.header_().frame_id_());
  w.u32(msg.height_());
  w.u32(msg.width_());
  w.u32(static_cast<std::uint32_t>(msg.fields_().size()));
  for (const sensor_msgs::PointField_& f : msg.fields_()) {
    w.string(f.name_());
    w.u32(f.offset_());
    w.octet(f.datatype_());
    w.u32(f.count_());
  }
  w.octet(msg.is_bigendian_() ? 1 : 0);
  w.u32(msg.point_step_());
  w.u32(msg.row_step_());
  w.octets(msg.data_());  // the point bytes are data: the CDR byte order does not touch them
  w.octet(msg.is_dense_() ? 1 : 0);
  return w.bytes();
}

SerializedPayload_t payloadOf(const Bytes& bytes) {
  SerializedPayload_t payload(static_cast<std::uint32_t>(bytes.size()));
  if (!bytes.empty()) std::memcpy(payload.data, bytes.data(), bytes.size());  // data: null if 0
  payload.length = static_cast<std::uint32_t>(bytes.size());
  return payload;
}

Bytes bytesOf(const SerializedPayload_t& payload) {
  return Bytes(payload.data, payload.data + payload.length);
}

TEST(WireTypes, TheHandWrittenBytesFollowTheRules) {
  EXPECT_EQ(smallCloudBytes(false), kSmallCloudLe);
  EXPECT_EQ(kSmallCloudLe.size(), 105u);
}

TEST(WireTypes, PointCloud2SerialisesToTheExactXcdr1Bytes) {
  sensor_msgs::PointCloud2_PubSubType type;
  sensor_msgs::PointCloud2_ msg = smallCloud();
  const std::uint32_t bound = type.getSerializedSizeProvider(&msg)();
  EXPECT_GE(bound, kSmallCloudLe.size());

  SerializedPayload_t payload(bound);  // zero-filled, as Fast DDS allocates its payloads
  ASSERT_TRUE(type.serialize(&msg, &payload));
  EXPECT_EQ(payload.encapsulation, CDR_LE);
  EXPECT_EQ(bytesOf(payload), kSmallCloudLe);

  // Fast CDR 1.0 does not write padding: it skips over it. In a reused buffer (Fast DDS's
  // history pools reuse payloads) padding keeps old bytes; readers ignore it, and every other
  // byte is still exact.
  SerializedPayload_t dirty(bound);
  std::memset(dirty.data, 0xEE, bound);
  ASSERT_TRUE(type.serialize(&msg, &dirty));
  Bytes got = bytesOf(dirty);
  ASSERT_EQ(got.size(), kSmallCloudLe.size());
  for (const std::size_t i : kPadding) {
    EXPECT_EQ(got[i], 0xEE) << "padding byte " << i << " is written now: update this test";
    got[i] = P;
  }
  EXPECT_EQ(got, kSmallCloudLe);
}

TEST(WireTypes, PointCloud2DeserialisesFromBothByteOrders) {
  sensor_msgs::PointCloud2_PubSubType type;
  for (const bool big_endian : {false, true}) {
    SerializedPayload_t payload = payloadOf(smallCloudBytes(big_endian));
    sensor_msgs::PointCloud2_ msg;
    ASSERT_TRUE(type.deserialize(&payload, &msg)) << big_endian;
    EXPECT_EQ(payload.encapsulation, big_endian ? CDR_BE : CDR_LE);
    EXPECT_TRUE(msg == smallCloud()) << big_endian;
  }
  // And the serialise -> deserialise round trip of a real cloud.
  std::vector<Eigen::Vector3f> points(1000);
  for (std::size_t i = 0; i < points.size(); ++i) {
    points[i] = Eigen::Vector3f(static_cast<float>(i), -0.5f * static_cast<float>(i), 3.0f);
  }
  sensor_msgs::PointCloud2_ cloud = encodePointCloud2(points, nullptr, 17.25, "base_link");
  SerializedPayload_t payload(type.getSerializedSizeProvider(&cloud)());
  ASSERT_TRUE(type.serialize(&cloud, &payload));
  sensor_msgs::PointCloud2_ back;
  ASSERT_TRUE(type.deserialize(&payload, &back));
  EXPECT_TRUE(back == cloud);
  std::vector<Eigen::Vector3f> decoded;
  ASSERT_TRUE(decodePointCloud2(back, &decoded).ok());
  EXPECT_EQ(decoded, points);
}

/// Deserialises `bytes` as a PointCloud2; returns "true", "false", or the exception's type.
std::string tryDeserialise(const Bytes& bytes, sensor_msgs::PointCloud2_* msg) {
  sensor_msgs::PointCloud2_PubSubType type;
  SerializedPayload_t payload = payloadOf(bytes);
  try {
    return type.deserialize(&payload, msg) ? "true" : "false";
  } catch (const eprosima::fastcdr::exception::BadParamException&) {
    return "BadParamException";
  } catch (const eprosima::fastcdr::exception::Exception&) {
    return "other Fast CDR exception";
  } catch (const std::exception& e) {
    return std::string("std::exception: ") + e.what();
  }
}

TEST(WireTypes, TruncatedPayloadsReturnFalse) {
  // Every prefix is missing at least the final boolean: Fast CDR throws NotEnoughMemoryException,
  // which the generated deserialize() turns into false.
  for (std::size_t length = 0; length < kSmallCloudLe.size(); ++length) {
    sensor_msgs::PointCloud2_ msg;
    EXPECT_EQ(tryDeserialise(Bytes(kSmallCloudLe.begin(), kSmallCloudLe.begin() + length), &msg),
              "false")
        << "length " << length;
  }
}

TEST(WireTypes, ForgedLengthsReturnFalseWithoutHugeAllocations) {
  // Counts far beyond the payload are refused before anything is allocated.
  for (const std::size_t at : {4 + 8, 4 + 24, 4 + 28, 4 + 80}) {  // frame_id, fields, name, data
    Bytes bytes = kSmallCloudLe;
    bytes[at] = bytes[at + 1] = bytes[at + 2] = 0xFF;
    bytes[at + 3] = 0x7F;
    sensor_msgs::PointCloud2_ msg;
    EXPECT_EQ(tryDeserialise(bytes, &msg), "false") << "count at " << at;
  }
}

TEST(WireTypes, CorruptPayloadsThrowBadParamExceptionPastTheGeneratedCatch) {
  // Fast CDR 1.0 throws BadParamException for a boolean byte other than 0 or 1 and for a
  // malformed encapsulation header; the generated deserialize() catches only
  // NotEnoughMemoryException, so it escapes to the caller (in Fast DDS: the receive thread).
  sensor_msgs::PointCloud2_ msg;
  Bytes bytes = kSmallCloudLe;
  bytes[4 + 68] = 0x02;  // is_bigendian
  EXPECT_EQ(tryDeserialise(bytes, &msg), "BadParamException");
  bytes = kSmallCloudLe;
  bytes[4 + 100] = 0xFF;  // is_dense
  EXPECT_EQ(tryDeserialise(bytes, &msg), "BadParamException");
  bytes = kSmallCloudLe;
  bytes[0] = 0x01;  // encapsulation: first byte must be 0
  EXPECT_EQ(tryDeserialise(bytes, &msg), "BadParamException");
  bytes = kSmallCloudLe;
  bytes[1] = 0x10;  // encapsulation kind Fast CDR does not know
  EXPECT_EQ(tryDeserialise(bytes, &msg), "BadParamException");
}

TEST(WireTypes, RandomCorruptionNeverCrashesAndDecodingValidatesWhatGetsThrough) {
  // Random byte changes to the valid payload and to a larger encoded cloud: the outcome is true,
  // false, or BadParamException, never anything else; whatever deserialises is then either
  // rejected by decodePointCloud2 or decoded within bounds (run under ASan to see the latter).
  std::vector<Eigen::Vector3f> points(40, Eigen::Vector3f(1.0f, 2.0f, 3.0f));
  const std::vector<float> intensity(points.size(), 0.5f);
  sensor_msgs::PointCloud2_ cloud = encodePointCloud2(points, &intensity, 1.0, "lidar");
  sensor_msgs::PointCloud2_PubSubType type;
  SerializedPayload_t payload(type.getSerializedSizeProvider(&cloud)());
  ASSERT_TRUE(type.serialize(&cloud, &payload));
  const std::vector<Bytes> seeds = {kSmallCloudLe, bytesOf(payload)};

  std::mt19937 rng(99);
  std::uniform_int_distribution<int> byte(0, 255);
  int outcomes[3] = {0, 0, 0};  // true, false, BadParamException
  int decoded = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    Bytes bytes = seeds[static_cast<std::size_t>(trial % 2)];
    const int changes = 1 + trial % 4;
    for (int c = 0; c < changes; ++c) {
      const std::size_t at = std::uniform_int_distribution<std::size_t>(0, bytes.size() - 1)(rng);
      bytes[at] = static_cast<std::uint8_t>(byte(rng));
    }
    if (trial % 7 == 0)
      bytes.resize(std::uniform_int_distribution<std::size_t>(0, bytes.size())(rng));
    sensor_msgs::PointCloud2_ msg;
    const std::string outcome = tryDeserialise(bytes, &msg);
    if (outcome == "true") {
      ++outcomes[0];
      std::vector<Eigen::Vector3f> out;
      if (decodePointCloud2(msg, &out).ok()) {
        ++decoded;
        EXPECT_EQ(out.size(), static_cast<std::size_t>(msg.width_()) * msg.height_());
      }
    } else if (outcome == "false") {
      ++outcomes[1];
    } else {
      ASSERT_EQ(outcome, "BadParamException") << "trial " << trial;
      ++outcomes[2];
    }
  }
  EXPECT_GT(outcomes[0], 0);
  EXPECT_GT(outcomes[1], 0);
  EXPECT_GT(outcomes[2], 0);
  EXPECT_GT(decoded, 0);
}

}  // namespace
}  // namespace mlmap::dds
