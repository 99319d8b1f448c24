// The bag decoders (mlmap/bag/ros_messages.h) check a message's CDR against its type's layout
// before Fast CDR reads it: a /tf message declaring millions of transforms in a few megabytes is
// refused with the reason, before anything is allocated (issue 43, item 10). In mlmap_cdr_tests,
// which counts every allocation (../support/allocation_counter.cpp).

#include "../support/allocation_counter.h"
#include "mlmap/bag/ros_messages.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlmap::bag {
namespace {

using test_support::AllocationScope;

/// A TFMessage that declares `count` transforms, then `body_bytes` zero bytes.
std::vector<std::uint8_t> tfDeclaring(std::uint32_t count, std::size_t body_bytes) {
  std::vector<std::uint8_t> bytes{0x00, 0x01, 0x00, 0x00};
  for (int i = 0; i < 4; ++i)
    bytes.push_back(static_cast<std::uint8_t>((count >> (8 * i)) & 0xFFU));
  bytes.resize(bytes.size() + body_bytes, 0);
  return bytes;
}

TEST(BagCdrBounds, TfMessageDeclaringMillionsOfTransformsIsRefusedBeforeAllocation) {
  const std::vector<std::uint8_t> bytes = tfDeclaring(16777216U, 16U * 1024 * 1024);
  tf2_msgs::TFMessage_ msg;
  std::string error;
  std::size_t peak_bytes = 0;
  {
    // Capped at 64 MB: the unchecked decoder fails here without taking its 2 GB.
    AllocationScope scope(64U * 1024 * 1024);
    try {
      decodeCdr(bytes, "run.mcap: /tf message at log time 1 ns", &msg);
    } catch (const std::runtime_error& e) {
      error = e.what();
    }
    peak_bytes = scope.peakBytes();
    EXPECT_FALSE(scope.capHit()) << "refused an allocation of " << scope.largestRefusedBytes()
                                 << " bytes";
  }
  EXPECT_EQ(
      error,
      "run.mcap: /tf message at log time 1 ns: malformed CDR (16777224 bytes): "
      "tf2_msgs::msg::dds_::TFMessage_ `transforms`: sequence declares 16777216 elements of >= 72 "
      "bytes, 16777216 bytes remain");
  EXPECT_LT(peak_bytes, 4096U);  // the message, no more
  EXPECT_TRUE(msg.transforms_().empty());
}

TEST(BagCdrBounds, EveryDecoderChecksItsCounts) {
  // An Image and a CameraInfo whose header's frame_id claims more bytes than remain, and a
  // PointCloud2 whose `fields` count the bytes cannot hold: refused with the member named.
  const std::vector<std::uint8_t> image{0x00, 0x01, 0x00, 0x00, 0,    0,    0, 0,
                                        0,    0,    0,    0,    0xFF, 0xFF, 0, 0};
  dds::sensor_msgs::Image_ img;
  try {
    decodeCdr(image, "image", &img);
    ADD_FAILURE() << "accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("`header.frame_id`: string of 65535 bytes"),
              std::string::npos)
        << e.what();
  }
  dds::sensor_msgs::CameraInfo_ info;
  EXPECT_THROW(decodeCdr(image, "camera_info", &info), std::runtime_error);
  std::vector<std::uint8_t> cloud{
      0x00, 0x01, 0x00, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0,
      0,    0,    0,    0,    1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0};  // 65536 fields
  cloud.resize(cloud.size() + 65536, 0);
  dds::CloudSample sample;
  {
    AllocationScope scope(2 * cloud.size());
    try {
      decodeCdr(cloud, "cloud", &sample);
      ADD_FAILURE() << "accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(
          std::string(e.what()).find("`fields`: sequence declares 65536 elements of >= 13 bytes"),
          std::string::npos)
          << e.what();
    }
    EXPECT_FALSE(scope.capHit());
  }
  // A valid /tf message still decodes.
  std::vector<std::uint8_t> one = tfDeclaring(1, 0);
  const std::vector<std::uint8_t> transform{0,   0, 0, 0, 0, 0, 0,   0,   4,   0,   0, 0, 'm', 'a',
                                            'p', 0, 5, 0, 0, 0, 'b', 'a', 's', 'e', 0, 0, 0,   0};
  one.insert(one.end(), transform.begin(), transform.end());
  one.resize(one.size() + 56, 0);
  tf2_msgs::TFMessage_ msg;
  decodeCdr(one, "tf", &msg);
  ASSERT_EQ(msg.transforms_().size(), 1U);
  EXPECT_EQ(msg.transforms_()[0].header_().frame_id_(), "map");
  EXPECT_EQ(msg.transforms_()[0].child_frame_id_(), "base");
}

}  // namespace
}  // namespace mlmap::bag
