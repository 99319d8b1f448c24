// Conversions between the ROS 2 wire types and mlmap's types. PointCloud2 decoding is checked
// against a slow reference decoder written here (byte by byte, per point, per field) on random
// layouts, and against every malformed message the decoder must refuse.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "mlmap/dds/wire/cloud_sample.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include <fastdds/rtps/common/SerializedPayload.h>

namespace mlmap::dds {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// sensor_msgs/PointField datatypes.
constexpr std::uint8_t kInt8 = 1;
constexpr std::uint8_t kUint8 = 2;
constexpr std::uint8_t kInt16 = 3;
constexpr std::uint8_t kUint16 = 4;
constexpr std::uint8_t kUint32 = 6;
constexpr std::uint8_t kFloat32 = 7;
constexpr std::uint8_t kFloat64 = 8;

std::size_t typeSize(std::uint8_t datatype) {
  switch (datatype) {
    case 1:
    case 2:
      return 1;
    case 3:
    case 4:
      return 2;
    case 5:
    case 6:
    case 7:
      return 4;
    case 8:
      return 8;
    default:
      return 0;
  }
}

// ---- Byte-level helpers, independent of the host's byte order --------------------------------

/// Writes the low `size` bytes of `bits` at `p`, most significant first when `big_endian`.
void putBits(std::uint8_t* p, std::uint64_t bits, std::size_t size, bool big_endian) {
  for (std::size_t i = 0; i < size; ++i) {
    const auto byte = static_cast<std::uint8_t>((bits >> (8 * i)) & 0xFFu);
    p[big_endian ? size - 1 - i : i] = byte;
  }
}

/// Reads `size` bytes at `p` as an unsigned number, most significant first when `big_endian`.
std::uint64_t getBits(const std::uint8_t* p, std::size_t size, bool big_endian) {
  std::uint64_t bits = 0;
  for (std::size_t i = 0; i < size; ++i) {
    const std::uint64_t byte = p[big_endian ? size - 1 - i : i];
    bits |= byte << (8 * i);
  }
  return bits;
}

std::uint64_t bitsOf(float v) {
  std::uint32_t u = 0;
  std::memcpy(&u, &v, 4);
  return u;
}
std::uint64_t bitsOf(double v) {
  std::uint64_t u = 0;
  std::memcpy(&u, &v, 8);
  return u;
}
float floatFromBits(std::uint64_t bits) {
  const auto u = static_cast<std::uint32_t>(bits);
  float v = 0.0f;
  std::memcpy(&v, &u, 4);
  return v;
}
double doubleFromBits(std::uint64_t bits) {
  double v = 0.0;
  std::memcpy(&v, &bits, 8);
  return v;
}

/// Writes `value` as a FLOAT32 or FLOAT64 field at `p`.
void putReal(std::uint8_t* p, double value, std::uint8_t datatype, bool big_endian) {
  if (datatype == kFloat32) {
    putBits(p, bitsOf(static_cast<float>(value)), 4, big_endian);
  } else {
    putBits(p, bitsOf(value), 8, big_endian);
  }
}

// ---- PointCloud2 construction and the reference decoder --------------------------------------

struct FieldSpec {
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = kFloat32;
  std::uint32_t count = 1;
};

sensor_msgs::PointCloud2_ makeCloud(const std::vector<FieldSpec>& fields, std::uint32_t width,
                                    std::uint32_t height, std::uint32_t point_step,
                                    std::uint32_t row_step, bool big_endian,
                                    std::size_t data_size) {
  sensor_msgs::PointCloud2_ msg;
  msg.header_().frame_id_("lidar");
  msg.width_(width);
  msg.height_(height);
  for (const FieldSpec& spec : fields) {
    sensor_msgs::PointField_ field;
    field.name_(spec.name);
    field.offset_(spec.offset);
    field.datatype_(spec.datatype);
    field.count_(spec.count);
    msg.fields_().push_back(field);
  }
  msg.is_bigendian_(big_endian);
  msg.point_step_(point_step);
  msg.row_step_(row_step);
  msg.data_().assign(data_size, 0);
  msg.is_dense_(false);
  return msg;
}

/// A valid little-endian float32 cloud of `points` (x, y, z at 0, 4, 8; point_step 16).
sensor_msgs::PointCloud2_ makeXyzCloud(const std::vector<Eigen::Vector3f>& points) {
  const auto n = static_cast<std::uint32_t>(points.size());
  sensor_msgs::PointCloud2_ msg =
      makeCloud({{"x", 0}, {"y", 4}, {"z", 8}, {"intensity", 12}}, n, 1, 16, n * 16, false, n * 16);
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      putReal(msg.data_().data() + i * 16 + 4 * a, points[i][a], kFloat32, false);
    }
  }
  return msg;
}

/// The obvious reading of a (valid) PointCloud2: for every point and every axis, look the field
/// up by name, assemble its bytes in the message's byte order, convert to float. A point with a
/// non-finite coordinate becomes all NaN.
std::vector<Eigen::Vector3f> referenceDecode(const sensor_msgs::PointCloud2_& msg) {
  std::vector<Eigen::Vector3f> out;
  const char* names[3] = {"x", "y", "z"};
  for (std::uint32_t row = 0; row < msg.height_(); ++row) {
    for (std::uint32_t col = 0; col < msg.width_(); ++col) {
      const std::size_t base = static_cast<std::size_t>(row) * msg.row_step_() +
                               static_cast<std::size_t>(col) * msg.point_step_();
      Eigen::Vector3f p;
      for (int a = 0; a < 3; ++a) {
        for (const sensor_msgs::PointField_& f : msg.fields_()) {
          if (f.name_() != names[a]) continue;
          const std::size_t size = typeSize(f.datatype_());
          const std::uint64_t bits =
              getBits(msg.data_().data() + base + f.offset_(), size, msg.is_bigendian_());
          p[a] = f.datatype_() == kFloat32 ? floatFromBits(bits)
                                           : static_cast<float>(doubleFromBits(bits));
        }
      }
      if (!p.allFinite()) p.setConstant(kNaN);
      out.push_back(p);
    }
  }
  return out;
}

/// Same point: equal coordinates, or all NaN on both sides.
::testing::AssertionResult samePoint(const Eigen::Vector3f& got, const Eigen::Vector3f& want) {
  const bool want_nan = want.array().isNaN().all();
  if (want_nan ? got.array().isNaN().all() : got == want) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "got (" << got.transpose() << "), want (" << want.transpose() << ")";
}

struct RandomCloud {
  sensor_msgs::PointCloud2_ msg;
  std::vector<Eigen::Vector3f> expected;
  bool big_endian = false;
  bool organised = false;
  bool row_padding = false;
  bool has_float64 = false;
  bool has_nan_point = false;
};

/// A random but valid layout: x, y, z as FLOAT32 or FLOAT64 among extra fields, in random order
/// at unaligned offsets with gaps, trailing point padding, row padding, either byte order. Every
/// byte that is not x, y or z is random garbage.
RandomCloud makeRandomCloud(std::mt19937* rng) {
  std::uniform_int_distribution<int> coin(0, 1);
  std::uniform_int_distribution<int> gap(0, 3);
  std::uniform_int_distribution<int> percent(0, 99);
  std::uniform_real_distribution<double> coord(-100.0, 100.0);
  std::uniform_int_distribution<int> byte(0, 255);

  RandomCloud c;
  c.big_endian = coin(*rng) == 1;
  const auto height = static_cast<std::uint32_t>(std::uniform_int_distribution<int>(1, 4)(*rng));
  const auto width = static_cast<std::uint32_t>(std::uniform_int_distribution<int>(0, 17)(*rng));
  c.organised = height > 1;

  std::vector<FieldSpec> fields = {{"x", 0, coin(*rng) ? kFloat32 : kFloat64},
                                   {"y", 0, coin(*rng) ? kFloat32 : kFloat64},
                                   {"z", 0, coin(*rng) ? kFloat32 : kFloat64}};
  const std::vector<FieldSpec> extras = {{"intensity", 0, kFloat32}, {"rgb", 0, kFloat32},
                                         {"ring", 0, kUint16},       {"t", 0, kFloat64},
                                         {"label", 0, kInt8},        {"reflectivity", 0, kUint8},
                                         {"range", 0, kUint32}};
  for (const FieldSpec& e : extras) {
    if (coin(*rng)) fields.push_back(e);
  }
  std::shuffle(fields.begin(), fields.end(), *rng);
  std::uint32_t offset = 0;
  for (FieldSpec& f : fields) {
    offset += static_cast<std::uint32_t>(gap(*rng));
    f.offset = offset;
    offset += static_cast<std::uint32_t>(typeSize(f.datatype));
    c.has_float64 = c.has_float64 ||
                    ((f.name == "x" || f.name == "y" || f.name == "z") && f.datatype == kFloat64);
  }
  const std::uint32_t point_step = offset + static_cast<std::uint32_t>(gap(*rng));
  const std::uint32_t row_pad = coin(*rng) ? static_cast<std::uint32_t>(gap(*rng) * 3 + 1) : 0;
  c.row_padding = row_pad > 0;
  const std::uint32_t row_step = width * point_step + row_pad;
  c.msg = makeCloud(fields, width, height, point_step, row_step, c.big_endian,
                    static_cast<std::size_t>(height) * row_step);
  for (std::uint8_t& b : c.msg.data_()) b = static_cast<std::uint8_t>(byte(*rng));

  for (std::uint32_t row = 0; row < height; ++row) {
    for (std::uint32_t col = 0; col < width; ++col) {
      std::uint8_t* point = c.msg.data_().data() + static_cast<std::size_t>(row) * row_step +
                            static_cast<std::size_t>(col) * point_step;
      Eigen::Vector3f want;
      for (const FieldSpec& f : fields) {
        const int a = f.name == "x" ? 0 : f.name == "y" ? 1 : f.name == "z" ? 2 : -1;
        if (a < 0) continue;
        double v = coord(*rng);
        const int roll = percent(*rng);
        if (roll < 3) v = std::numeric_limits<double>::quiet_NaN();
        if (roll == 3) v = -std::numeric_limits<double>::infinity();
        if (roll == 4 && f.datatype == kFloat64) v = 1e300;  // finite, but not as a float
        putReal(point + f.offset, v, f.datatype, c.big_endian);
        want[a] = static_cast<float>(v);
      }
      if (!want.allFinite()) {
        want.setConstant(kNaN);
        c.has_nan_point = true;
      }
      c.expected.push_back(want);
    }
  }
  return c;
}

TEST(DecodePointCloud2, RandomLayoutsMatchTheReferenceDecoder) {
  std::mt19937 rng(20240611);
  int big_endian = 0;
  int organised = 0;
  int row_padding = 0;
  int float64 = 0;
  int nan_points = 0;
  std::vector<Eigen::Vector3f> points;  // reused across calls, as the node does
  for (int trial = 0; trial < 600; ++trial) {
    const RandomCloud c = makeRandomCloud(&rng);
    const DecodeStatus status = decodePointCloud2(c.msg, &points);
    ASSERT_TRUE(status.ok()) << "trial " << trial << ": " << status.detail;
    const std::vector<Eigen::Vector3f> reference = referenceDecode(c.msg);
    ASSERT_EQ(points.size(), c.expected.size()) << "trial " << trial;
    ASSERT_EQ(reference.size(), c.expected.size()) << "trial " << trial;
    for (std::size_t i = 0; i < points.size(); ++i) {
      ASSERT_TRUE(samePoint(reference[i], c.expected[i])) << "reference, trial " << trial;
      ASSERT_TRUE(samePoint(points[i], reference[i])) << "trial " << trial << " point " << i;
    }
    big_endian += c.big_endian;
    organised += c.organised;
    row_padding += c.row_padding;
    float64 += c.has_float64;
    nan_points += c.has_nan_point;
  }
  // The generator really produced every kind of layout.
  EXPECT_GT(big_endian, 100);
  EXPECT_GT(organised, 100);
  EXPECT_GT(row_padding, 100);
  EXPECT_GT(float64, 100);
  EXPECT_GT(nan_points, 50);
}

TEST(DecodePointCloud2, BigEndianFloat64OrganisedWithRowPadding) {
  // 2 rows x 2 points: intensity (float32) at 0, z at 4, x at 12, y at 20 (float64, unaligned
  // relative to 8), point_step 28, 5 bytes of row padding.
  sensor_msgs::PointCloud2_ msg = makeCloud(
      {{"intensity", 0, kFloat32}, {"z", 4, kFloat64}, {"x", 12, kFloat64}, {"y", 20, kFloat64}}, 2,
      2, 28, 61, true, 122);
  std::fill(msg.data_().begin(), msg.data_().end(), std::uint8_t{0xFF});  // NaN if misread
  const double values[4][3] = {
      {1.0, 2.0, 3.0}, {-4.5, 5.25, 6.0}, {7.0, 8.0, 9.0}, {0.0, -1.0, 1e3}};
  for (int i = 0; i < 4; ++i) {
    std::uint8_t* p = msg.data_().data() + (i / 2) * 61 + (i % 2) * 28;
    putReal(p + 12, values[i][0], kFloat64, true);
    putReal(p + 20, values[i][1], kFloat64, true);
    putReal(p + 4, values[i][2], kFloat64, true);
  }
  std::vector<Eigen::Vector3f> points;
  ASSERT_TRUE(decodePointCloud2(msg, &points).ok());
  ASSERT_EQ(points.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(points[i], Eigen::Vector3d(values[i][0], values[i][1], values[i][2]).cast<float>())
        << i;
  }
}

TEST(DecodePointCloud2, NonFinitePointsAreKeptAsNaN) {
  const std::vector<Eigen::Vector3f> in = {
      {1, 2, 3}, {kNaN, 0, 0}, {0, kInf, 0}, {0, 0, -kInf}, {4, 5, 6}};
  std::vector<Eigen::Vector3f> points;
  ASSERT_TRUE(decodePointCloud2(makeXyzCloud(in), &points).ok());
  ASSERT_EQ(points.size(), 5u);  // kept: an organised cloud keeps its indices
  EXPECT_EQ(points[0], Eigen::Vector3f(1, 2, 3));
  for (int i = 1; i < 4; ++i) EXPECT_TRUE(points[i].array().isNaN().all()) << i;
  EXPECT_EQ(points[4], Eigen::Vector3f(4, 5, 6));

  // A FLOAT64 beyond the float range is not a usable float coordinate either.
  sensor_msgs::PointCloud2_ msg = makeCloud(
      {{"x", 0, kFloat64}, {"y", 8, kFloat64}, {"z", 16, kFloat64}}, 2, 1, 24, 48, false, 48);
  const double v[6] = {1.0, 1e300, 2.0, 1.0, 2.0, 3.0};
  for (int i = 0; i < 6; ++i) putReal(msg.data_().data() + 8 * i, v[i], kFloat64, false);
  ASSERT_TRUE(decodePointCloud2(msg, &points).ok());
  ASSERT_EQ(points.size(), 2u);
  EXPECT_TRUE(points[0].array().isNaN().all());
  EXPECT_EQ(points[1], Eigen::Vector3f(1, 2, 3));
}

TEST(DecodePointCloud2, EmptyCloudIsValid) {
  std::vector<Eigen::Vector3f> points = {{1, 2, 3}};
  ASSERT_TRUE(decodePointCloud2(makeXyzCloud({}), &points).ok());
  EXPECT_TRUE(points.empty());
}

// ---- Malformed clouds -------------------------------------------------------------------------

/// Decodes `msg` into a vector that holds stale points; expects `error`, an explanation, and no
/// points left (and none allocated when the vector started empty).
void expectRejected(const sensor_msgs::PointCloud2_& msg, DecodeError error,
                    const std::string& detail_part) {
  std::vector<Eigen::Vector3f> points = {{1, 2, 3}, {4, 5, 6}};
  const DecodeStatus status = decodePointCloud2(msg, &points);
  EXPECT_EQ(status.error, error) << toString(status.error) << ": " << status.detail;
  EXPECT_NE(status.detail.find(detail_part), std::string::npos) << status.detail;
  EXPECT_TRUE(points.empty());
  std::vector<Eigen::Vector3f> fresh;
  EXPECT_EQ(decodePointCloud2(msg, &fresh).error, error);
  EXPECT_EQ(fresh.capacity(), 0u) << "allocated for a rejected message";
}

sensor_msgs::PointCloud2_ validOrganisedCloud() {
  // 3 x 2 points, point_step 16, row_step 52 (4 bytes of row padding), 104 bytes.
  return makeCloud({{"x", 0}, {"y", 4}, {"z", 8}, {"intensity", 12}}, 3, 2, 16, 52, false, 104);
}

TEST(DecodePointCloud2, TheValidBaseCaseDecodes) {
  std::vector<Eigen::Vector3f> points;
  EXPECT_TRUE(decodePointCloud2(validOrganisedCloud(), &points).ok());
  EXPECT_EQ(points.size(), 6u);
}

TEST(DecodePointCloud2, RejectsDataSizeThatDisagreesWithHeightTimesRowStep) {
  sensor_msgs::PointCloud2_ msg = validOrganisedCloud();
  msg.data_().resize(103);
  expectRejected(msg, DecodeError::kBadLayout, "data size 103 != height 2 * row_step 52");
  msg.data_().resize(105);  // longer is a disagreement too: the sizes are not to be trusted
  expectRejected(msg, DecodeError::kBadLayout, "data size 105");
  msg.data_().resize(100);  // enough for the last row without its padding: still not ROS
  expectRejected(msg, DecodeError::kBadLayout, "data size 100");
  msg.data_().clear();
  expectRejected(msg, DecodeError::kBadLayout, "data size 0");
}

TEST(DecodePointCloud2, RejectsRowStepShorterThanARow) {
  sensor_msgs::PointCloud2_ msg = validOrganisedCloud();
  msg.row_step_(47);
  msg.data_().resize(94);  // consistent with row_step, so only row_step is wrong
  expectRejected(msg, DecodeError::kBadLayout, "row_step 47 < width 3 * point_step 16");
}

TEST(DecodePointCloud2, RejectsPointStepThatFieldsDoNotFit) {
  sensor_msgs::PointCloud2_ msg = validOrganisedCloud();
  msg.point_step_(0);
  expectRejected(msg, DecodeError::kBadLayout, "point_step 0");

  msg = makeCloud({{"x", 0}, {"y", 4}, {"z", 8}}, 2, 1, 11, 22, false, 22);  // z ends at 12
  expectRejected(msg, DecodeError::kBadLayout,
                 "field 'z' at offset 8 (4 bytes) ends past point_step 11");

  msg = makeCloud({{"x", 0}, {"y", 4}, {"z", 12, kFloat64}}, 2, 1, 16, 32, false, 32);
  expectRejected(msg, DecodeError::kBadLayout, "field 'z' at offset 12 (8 bytes)");

  // An offset near 2^32: offset + size wraps in 32-bit arithmetic.
  msg = makeCloud({{"x", 0xFFFFFFFEu}, {"y", 4}, {"z", 8}}, 2, 1, 16, 32, false, 32);
  expectRejected(msg, DecodeError::kBadLayout, "field 'x' at offset 4294967294");
}

TEST(DecodePointCloud2, RejectsOverlappingCoordinateFields) {
  sensor_msgs::PointCloud2_ msg =
      makeCloud({{"x", 0}, {"y", 2}, {"z", 8}}, 2, 1, 16, 32, false, 32);
  expectRejected(msg, DecodeError::kBadLayout, "overlap");
  msg = makeCloud({{"x", 0, kFloat64}, {"y", 8}, {"z", 4}}, 2, 1, 16, 32, false, 32);
  expectRejected(msg, DecodeError::kBadLayout, "overlap");
}

TEST(DecodePointCloud2, RejectsMissingCoordinateFields) {
  expectRejected(makeCloud({{"y", 4}, {"z", 8}}, 1, 1, 12, 12, false, 12),
                 DecodeError::kMissingField, "no 'x' field");
  expectRejected(makeCloud({{"x", 0}, {"z", 8}}, 1, 1, 12, 12, false, 12),
                 DecodeError::kMissingField, "no 'y' field");
  expectRejected(makeCloud({{"x", 0}, {"y", 4}, {"Z", 8}}, 1, 1, 12, 12, false, 12),
                 DecodeError::kMissingField, "no 'z' field");
  expectRejected(makeCloud({}, 1, 1, 12, 12, false, 12), DecodeError::kMissingField, "no 'x'");
}

TEST(DecodePointCloud2, RejectsDuplicateCoordinateFields) {
  expectRejected(makeCloud({{"x", 0}, {"y", 4}, {"z", 8}, {"x", 12}}, 1, 1, 16, 16, false, 16),
                 DecodeError::kBadLayout, "two fields named 'x'");
}

TEST(DecodePointCloud2, RejectsUnsupportedDatatypesAndCounts) {
  expectRejected(makeCloud({{"x", 0, kInt16}, {"y", 4}, {"z", 8}}, 1, 1, 12, 12, false, 12),
                 DecodeError::kUnsupportedType, "field 'x' has datatype 3 (INT16)");
  expectRejected(makeCloud({{"x", 0}, {"y", 4, kUint16}, {"z", 8}}, 1, 1, 12, 12, false, 12),
                 DecodeError::kUnsupportedType, "field 'y' has datatype 4");
  expectRejected(makeCloud({{"x", 0}, {"y", 4}, {"z", 8, 0}}, 1, 1, 12, 12, false, 12),
                 DecodeError::kUnsupportedType, "field 'z' has datatype 0");
  expectRejected(makeCloud({{"x", 0}, {"y", 4}, {"z", 8, 9}}, 1, 1, 12, 12, false, 12),
                 DecodeError::kUnsupportedType, "datatype 9");
  expectRejected(makeCloud({{"x", 0, kFloat32, 3}, {"y", 12}, {"z", 16}}, 1, 1, 20, 20, false, 20),
                 DecodeError::kUnsupportedType, "field 'x' has count 3");
  expectRejected(makeCloud({{"x", 0}, {"y", 4, kFloat32, 0}, {"z", 8}}, 1, 1, 12, 12, false, 12),
                 DecodeError::kUnsupportedType, "field 'y' has count 0");
  // Other fields may have any type and count: they are not read.
  std::vector<Eigen::Vector3f> points;
  EXPECT_TRUE(decodePointCloud2(makeCloud({{"x", 0}, {"y", 4}, {"z", 8}, {"ring", 12, kInt16, 2}},
                                          1, 1, 16, 16, false, 16),
                                &points)
                  .ok());
}

TEST(DecodePointCloud2, AbsurdSizesAreRejectedWithoutAllocating) {
  // 2^31 x 2^31 points: width * point_step does not even fit row_step.
  sensor_msgs::PointCloud2_ msg = validOrganisedCloud();
  msg.width_(1u << 31);
  msg.height_(1u << 31);
  msg.row_step_(0xFFFFFFFFu);
  expectRejected(msg, DecodeError::kBadLayout, "row_step 4294967295 < width 2147483648");

  // Consistent steps, but height * row_step (~9e18 bytes) is not the data size.
  msg.width_(0x0FFFFFFFu);
  msg.point_step_(16);
  msg.row_step_(0xFFFFFFF0u);
  expectRejected(msg, DecodeError::kBadLayout, "data size 104 != height 2147483648");

  // Products that wrap to 0 in 32-bit arithmetic: 2^28 * 16 = 2^32, 2^20 * 4096 = 2^32.
  msg = makeCloud({{"x", 0}, {"y", 4}, {"z", 8}}, 1u << 28, 1, 16, 0, false, 0);
  expectRejected(msg, DecodeError::kBadLayout, "row_step 0 < width 268435456 * point_step 16");
  msg = makeCloud({{"x", 0}, {"y", 4}, {"z", 8}}, 256, 1u << 20, 16, 4096, false, 0);
  expectRejected(msg, DecodeError::kBadLayout, "data size 0 != height 1048576 * row_step 4096");
}

// ---- The node's PointCloud2 type: decoded in place, as decodePointCloud2() decodes -------------

/// `msg` serialised by the generated type (its first `keep` bytes, all when 0), then taken as
/// the node takes it: CheckedType<CloudSamplePubSubType>. Returns its deserialize()'s verdict.
bool takeAsNode(const sensor_msgs::PointCloud2_& msg, CloudSample* sample, std::size_t keep = 0) {
  sensor_msgs::PointCloud2_PubSubType generated;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(
      generated.getSerializedSizeProvider(const_cast<sensor_msgs::PointCloud2_*>(&msg))());
  EXPECT_TRUE(generated.serialize(const_cast<sensor_msgs::PointCloud2_*>(&msg), &payload));
  if (keep > 0) payload.length = static_cast<std::uint32_t>(keep);
  CheckedType<CloudSamplePubSubType> type;
  return type.deserialize(&payload, sample);
}

/// The sample holds `msg` without data_, and decodePointCloud2(msg)'s points and status.
::testing::AssertionResult sameAsReference(const CloudSample& sample,
                                           const sensor_msgs::PointCloud2_& msg) {
  std::vector<Eigen::Vector3f> points;
  const DecodeStatus status = decodePointCloud2(msg, &points);
  if (sample.status.error != status.error || sample.status.detail != status.detail) {
    return ::testing::AssertionFailure()
           << "status '" << sample.status.detail << "', want '" << status.detail << "'";
  }
  if (sample.points_S.size() != points.size()) {
    return ::testing::AssertionFailure()
           << sample.points_S.size() << " points, want " << points.size();
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    ::testing::AssertionResult same = samePoint(sample.points_S[i], points[i]);
    if (!same) return same << " at point " << i;
  }
  sensor_msgs::PointCloud2_ without_data = msg;
  without_data.data_().clear();
  if (!(static_cast<const sensor_msgs::PointCloud2_&>(sample) == without_data)) {
    return ::testing::AssertionFailure() << "the fields other than data_ differ";
  }
  return ::testing::AssertionSuccess();
}

TEST(CloudSampleType, DecodesRandomLayoutsInPlaceAsTheReferenceDoes) {
  std::mt19937 rng(20261122);
  CloudSample sample;  // reused, as TakeListener's are not: stale points must not survive
  for (int trial = 0; trial < 300; ++trial) {
    const RandomCloud c = makeRandomCloud(&rng);
    ASSERT_TRUE(takeAsNode(c.msg, &sample)) << "trial " << trial;
    ASSERT_TRUE(sample.status.ok()) << "trial " << trial << ": " << sample.status.detail;
    ASSERT_TRUE(sameAsReference(sample, c.msg)) << "trial " << trial;
  }
}

TEST(CloudSampleType, ReportsTheReferenceDecodeErrors) {
  std::vector<sensor_msgs::PointCloud2_> bad;
  bad.push_back(validOrganisedCloud());
  bad.back().data_().resize(103);
  bad.push_back(validOrganisedCloud());
  bad.back().row_step_(47);
  bad.push_back(validOrganisedCloud());
  bad.back().point_step_(0);
  bad.push_back(makeCloud({{"x", 0}, {"y", 2}, {"z", 8}}, 2, 1, 16, 32, false, 32));
  bad.push_back(makeCloud({{"y", 4}, {"z", 8}}, 1, 1, 12, 12, false, 12));
  bad.push_back(makeCloud({{"x", 0, kInt16}, {"y", 4}, {"z", 8}}, 1, 1, 12, 12, false, 12));
  bad.push_back(makeCloud({{"x", 0}, {"y", 4}, {"z", 8}}, 256, 1u << 20, 16, 4096, false, 0));
  std::mt19937 rng(5);
  CloudSample sample;
  for (std::size_t i = 0; i < bad.size(); ++i) {
    ASSERT_TRUE(takeAsNode(makeRandomCloud(&rng).msg, &sample));  // leaves points behind
    ASSERT_TRUE(takeAsNode(bad[i], &sample)) << "case " << i;     // valid CDR, bad layout
    EXPECT_FALSE(sample.status.ok()) << "case " << i;
    EXPECT_TRUE(sample.points_S.empty()) << "case " << i;
    EXPECT_TRUE(sameAsReference(sample, bad[i])) << "case " << i;
  }
}

TEST(CloudSampleType, RefusesEveryTruncatedPayloadAsTheGeneratedTypeDoes) {
  const sensor_msgs::PointCloud2_ msg = validOrganisedCloud();
  sensor_msgs::PointCloud2_PubSubType generated;
  const std::size_t full =
      generated.getSerializedSizeProvider(const_cast<sensor_msgs::PointCloud2_*>(&msg))();
  CloudSample sample;
  for (std::size_t keep = 1; keep < full; ++keep) {
    EXPECT_FALSE(takeAsNode(msg, &sample, keep)) << keep << " of " << full << " bytes";
  }
  ASSERT_TRUE(takeAsNode(msg, &sample, full));
  EXPECT_TRUE(sameAsReference(sample, msg));
}

// ---- Encoding -----------------------------------------------------------------------------------

TEST(EncodePointCloud2, RoundTripsThroughTheDecoder) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(-50.0f, 50.0f);
  std::vector<Eigen::Vector3f> in(1000);
  std::vector<float> intensity(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    in[i] = {coord(rng), coord(rng), coord(rng)};
    intensity[i] = coord(rng);
  }
  for (const bool with_intensity : {false, true}) {
    const sensor_msgs::PointCloud2_ msg =
        encodePointCloud2(in, with_intensity ? &intensity : nullptr, 1234.5, "base_link");
    EXPECT_EQ(msg.header_().frame_id_(), "base_link");
    EXPECT_EQ(msg.header_().stamp_().sec_(), 1234);
    EXPECT_EQ(msg.header_().stamp_().nanosec_(), 500000000u);
    EXPECT_EQ(msg.height_(), 1u);
    EXPECT_EQ(msg.width_(), in.size());
    const std::uint32_t step = with_intensity ? 16 : 12;
    EXPECT_EQ(msg.point_step_(), step);
    EXPECT_EQ(msg.row_step_(), step * in.size());
    EXPECT_EQ(msg.data_().size(), step * in.size());
    EXPECT_FALSE(msg.is_bigendian_());
    EXPECT_TRUE(msg.is_dense_());
    ASSERT_EQ(msg.fields_().size(), with_intensity ? 4u : 3u);
    const char* names[4] = {"x", "y", "z", "intensity"};
    for (std::size_t f = 0; f < msg.fields_().size(); ++f) {
      EXPECT_EQ(msg.fields_()[f].name_(), names[f]);
      EXPECT_EQ(msg.fields_()[f].offset_(), 4 * f);
      EXPECT_EQ(msg.fields_()[f].datatype_(), kFloat32);
      EXPECT_EQ(msg.fields_()[f].count_(), 1u);
    }
    std::vector<Eigen::Vector3f> out;
    ASSERT_TRUE(decodePointCloud2(msg, &out).ok());
    ASSERT_EQ(out.size(), in.size());
    for (std::size_t i = 0; i < in.size(); ++i) ASSERT_EQ(out[i], in[i]) << i;
    // The bytes are little endian whatever the host: read them back by hand.
    EXPECT_EQ(floatFromBits(getBits(msg.data_().data() + 4, 4, false)), in[0].y());
    if (with_intensity) {
      for (std::size_t i = 0; i < in.size(); ++i) {
        ASSERT_EQ(floatFromBits(getBits(msg.data_().data() + 16 * i + 12, 4, false)), intensity[i]);
      }
    }
  }
}

TEST(EncodePointCloud2, NonFinitePointsClearIsDenseAndSurvive) {
  const sensor_msgs::PointCloud2_ msg =
      encodePointCloud2({{1, 2, 3}, {kNaN, kNaN, kNaN}}, nullptr, 0.0, "map");
  EXPECT_FALSE(msg.is_dense_());
  std::vector<Eigen::Vector3f> out;
  ASSERT_TRUE(decodePointCloud2(msg, &out).ok());
  ASSERT_EQ(out.size(), 2u);
  EXPECT_TRUE(out[1].array().isNaN().all());
}

TEST(EncodePointCloud2, RejectsIntensityOfTheWrongLength) {
  const std::vector<float> intensity = {1.0f};
  EXPECT_THROW(encodePointCloud2({{1, 2, 3}, {4, 5, 6}}, &intensity, 0.0, "map"),
               std::invalid_argument);
}

// ---- Time -------------------------------------------------------------------------------------

void expectTime(double stamp_s, std::int32_t sec, std::uint32_t nanosec) {
  const ros_time::Time_ t = toRosTime(stamp_s);
  EXPECT_EQ(t.sec_(), sec) << stamp_s;
  EXPECT_EQ(t.nanosec_(), nanosec) << stamp_s;
}

TEST(RosTime, ConvertsBothWaysIncludingNegativeStampsAndCarry) {
  expectTime(0.0, 0, 0);
  expectTime(1.5, 1, 500000000);
  expectTime(-1.5, -2, 500000000);  // ROS: sec + nanosec * 1e-9 with nanosec in [0, 1e9)
  expectTime(-0.25, -1, 750000000);
  expectTime(2.0 - 1e-10, 2, 0);  // rounds to 1e9 ns, which carries into the seconds
  expectTime(-1e-10, 0, 0);
  expectTime(1.000000001, 1, 1);
  expectTime(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  expectTime(1e12, std::numeric_limits<std::int32_t>::max(), 999999999);
  expectTime(-1e12, std::numeric_limits<std::int32_t>::min(), 0);

  ros_time::Time_ t;
  t.sec_(-2);
  t.nanosec_(500000000);
  EXPECT_DOUBLE_EQ(toSeconds(t), -1.5);
  // A realistic epoch stamp survives a round trip to within the double's resolution.
  t.sec_(1718000000);
  t.nanosec_(123456789);
  const ros_time::Time_ back = toRosTime(toSeconds(t));
  EXPECT_EQ(back.sec_(), t.sec_());
  EXPECT_NEAR(static_cast<double>(back.nanosec_()), 123456789.0, 300.0);
}

// ---- Depth images -----------------------------------------------------------------------------

sensor_msgs::CameraInfo_ makeInfo(std::uint32_t width, std::uint32_t height) {
  sensor_msgs::CameraInfo_ info;
  info.width_(width);
  info.height_(height);
  info.k_() = {500.0, 0.0, 2.5, 0.0, 400.0, 1.5, 0.0, 0.0, 1.0};
  return info;
}

/// A depth image whose pixel (u, v) holds `value(u, v)` in the encoding's unit, rows padded to
/// `step`, with `extra` bytes after the last row. With a step too short for a row (a malformed
/// image), the pixels that would not fit are not written.
template <typename Value>
sensor_msgs::Image_ makeImage(const std::string& encoding, std::uint32_t width,
                              std::uint32_t height, std::uint32_t step, bool big_endian,
                              std::size_t extra, Value value) {
  sensor_msgs::Image_ image;
  image.encoding_(encoding);
  image.width_(width);
  image.height_(height);
  image.step_(step);
  image.is_bigendian_(big_endian ? 1 : 0);
  image.data_().assign(static_cast<std::size_t>(step) * height + extra, 0xEE);
  const bool is_float = encoding == "32FC1";
  const std::size_t bytes_per_pixel = is_float ? 4 : 2;
  for (std::uint32_t v = 0; v < height; ++v) {
    for (std::uint32_t u = 0; u < width; ++u) {
      const std::size_t at = static_cast<std::size_t>(v) * step + u * bytes_per_pixel;
      if (at + bytes_per_pixel > image.data_().size()) continue;
      std::uint8_t* p = image.data_().data() + static_cast<std::size_t>(v) * step;
      if (is_float) {
        putBits(p + 4 * u, bitsOf(static_cast<float>(value(u, v))), 4, big_endian);
      } else {
        putBits(p + 2 * u, static_cast<std::uint64_t>(value(u, v)), 2, big_endian);
      }
    }
  }
  return image;
}

TEST(DecodeDepthImage, ReadsBothEncodingsBothByteOrdersAndPaddedRows) {
  const std::uint32_t w = 5;
  const std::uint32_t h = 3;
  const auto mm = [](std::uint32_t u, std::uint32_t v) { return 1000 + 257 * u + 10 * v; };
  const auto metres = [](std::uint32_t u, std::uint32_t v) { return 0.5 + 0.25 * u + 1.0 * v; };
  for (const bool big_endian : {false, true}) {
    for (const std::uint32_t pad : {0u, 6u}) {
      for (const std::string encoding : {"16UC1", "mono16"}) {
        SCOPED_TRACE(encoding + (big_endian ? " big endian" : " little endian") + " pad " +
                     std::to_string(pad));
        const sensor_msgs::Image_ image =
            makeImage(encoding, w, h, w * 2 + pad, big_endian, pad, mm);
        DepthFrame frame;
        frame.depth_m = {1.0f};  // stale data of the other encoding
        ASSERT_TRUE(decodeDepthImage(image, makeInfo(w, h), &frame).ok());
        EXPECT_EQ(frame.encoding, DepthEncoding::kUint16Millimetres);
        EXPECT_TRUE(frame.depth_m.empty());
        ASSERT_EQ(frame.depth_mm.size(), w * h);
        for (std::uint32_t v = 0; v < h; ++v) {
          for (std::uint32_t u = 0; u < w; ++u) {
            ASSERT_EQ(frame.depth_mm[v * w + u], mm(u, v)) << u << "," << v;
          }
        }
        EXPECT_EQ(frame.intrinsics.width, 5);
        EXPECT_EQ(frame.intrinsics.height, 3);
        EXPECT_EQ(frame.intrinsics.fx, 500.0);
        EXPECT_EQ(frame.intrinsics.fy, 400.0);
        EXPECT_EQ(frame.intrinsics.cx, 2.5);
        EXPECT_EQ(frame.intrinsics.cy, 1.5);
      }
      SCOPED_TRACE(std::string("32FC1") + (big_endian ? " big endian" : " little endian") +
                   " pad " + std::to_string(pad));
      const sensor_msgs::Image_ image =
          makeImage("32FC1", w, h, w * 4 + pad, big_endian, 0, metres);
      DepthFrame frame;
      frame.depth_mm = {1};
      ASSERT_TRUE(decodeDepthImage(image, makeInfo(w, h), &frame).ok());
      EXPECT_EQ(frame.encoding, DepthEncoding::kFloat32Metres);
      EXPECT_TRUE(frame.depth_mm.empty());
      ASSERT_EQ(frame.depth_m.size(), w * h);
      for (std::uint32_t v = 0; v < h; ++v) {
        for (std::uint32_t u = 0; u < w; ++u) {
          ASSERT_EQ(frame.depth_m[v * w + u], static_cast<float>(metres(u, v))) << u << "," << v;
        }
      }
    }
  }
}

TEST(DecodeDepthImage, TheDecodedFrameBackProjects) {
  const sensor_msgs::Image_ image =
      makeImage("16UC1", 6, 4, 12, false, 0, [](std::uint32_t, std::uint32_t) { return 2000; });
  DepthFrame frame;
  ASSERT_TRUE(decodeDepthImage(image, makeInfo(6, 4), &frame).ok());
  std::vector<Eigen::Vector3f> points;
  ASSERT_TRUE(backProject(frame, &points));
  ASSERT_EQ(points.size(), 24u);
  // Pixel (u, v) = (5, 3): ((5 - 2.5) / 500 * 2, (3 - 1.5) / 400 * 2, 2).
  EXPECT_NEAR(points.back().x(), 0.01f, 1e-6f);
  EXPECT_NEAR(points.back().y(), 0.0075f, 1e-6f);
  EXPECT_FLOAT_EQ(points.back().z(), 2.0f);
}

void expectImageRejected(const sensor_msgs::Image_& image, const sensor_msgs::CameraInfo_& info,
                         DecodeError error, const std::string& detail_part) {
  DepthFrame frame;
  frame.depth_mm = {7, 8};
  frame.intrinsics.fx = 99.0;
  const DecodeStatus status = decodeDepthImage(image, info, &frame);
  EXPECT_EQ(status.error, error) << toString(status.error) << ": " << status.detail;
  EXPECT_NE(status.detail.find(detail_part), std::string::npos) << status.detail;
  EXPECT_EQ(frame.depth_mm, (std::vector<std::uint16_t>{7, 8})) << "frame touched on error";
  EXPECT_EQ(frame.intrinsics.fx, 99.0) << "frame touched on error";
}

TEST(DecodeDepthImage, RejectsMalformedImagesAndMismatchedCameraInfo) {
  const auto one = [](std::uint32_t, std::uint32_t) { return 1; };
  const sensor_msgs::CameraInfo_ info = makeInfo(4, 3);
  for (const std::string encoding : {"rgb8", "16SC1", "32FC3", "8UC1", ""}) {
    expectImageRejected(makeImage(encoding, 4, 3, 8, false, 0, one), info,
                        DecodeError::kUnsupportedType, "depth encoding '" + encoding + "'");
  }
  expectImageRejected(makeImage("16UC1", 4, 3, 7, false, 0, one), info, DecodeError::kBadLayout,
                      "step 7 < width 4 * 2 bytes");
  expectImageRejected(makeImage("32FC1", 4, 3, 12, false, 0, one), info, DecodeError::kBadLayout,
                      "step 12 < width 4 * 4 bytes");
  sensor_msgs::Image_ short_data = makeImage("16UC1", 4, 3, 10, false, 0, one);
  short_data.data_().pop_back();
  expectImageRejected(short_data, info, DecodeError::kBadLayout,
                      "data size 29 < step 10 * height 3");
  // Absurd sizes: checked in 64 bits before anything is allocated.
  sensor_msgs::Image_ huge = makeImage("32FC1", 4, 3, 16, false, 0, one);
  huge.width_(0x40000000u);
  huge.height_(0x40000000u);
  huge.step_(0xFFFFFFFFu);
  expectImageRejected(huge, info, DecodeError::kBadLayout, "step 4294967295 < width 1073741824");
  huge.width_(1);
  expectImageRejected(huge, info, DecodeError::kBadLayout, "data size 48 < step 4294967295");
  expectImageRejected(makeImage("16UC1", 0, 3, 0, false, 0, one), makeInfo(0, 3),
                      DecodeError::kBadLayout, "image size 0 x 3");

  const sensor_msgs::Image_ good = makeImage("16UC1", 4, 3, 8, false, 0, one);
  expectImageRejected(good, makeInfo(5, 3), DecodeError::kBadLayout,
                      "CameraInfo 5 x 3 != image 4 x 3");
  expectImageRejected(good, makeInfo(4, 2), DecodeError::kBadLayout, "CameraInfo 4 x 2");
  for (const int index : {0, 2, 4, 5}) {
    sensor_msgs::CameraInfo_ bad = info;
    bad.k_()[static_cast<std::size_t>(index)] = std::numeric_limits<double>::quiet_NaN();
    expectImageRejected(good, bad, DecodeError::kBadLayout, "CameraInfo K");
  }
  for (const int index : {0, 4}) {
    sensor_msgs::CameraInfo_ bad = info;
    bad.k_()[static_cast<std::size_t>(index)] = 0.0;
    expectImageRejected(good, bad, DecodeError::kBadLayout, "CameraInfo K");
    bad.k_()[static_cast<std::size_t>(index)] = -300.0;
    expectImageRejected(good, bad, DecodeError::kBadLayout, "CameraInfo K");
  }
  DepthFrame frame;
  EXPECT_TRUE(decodeDepthImage(good, info, &frame).ok());  // the base case is valid
}

// ---- Poses ------------------------------------------------------------------------------------

geometry_msgs::PoseStamped_ makePoseStamped(const Eigen::Vector3d& t, double qw, double qx,
                                            double qy, double qz, std::int32_t sec,
                                            std::uint32_t nanosec) {
  geometry_msgs::PoseStamped_ msg;
  msg.header_().stamp_().sec_(sec);
  msg.header_().stamp_().nanosec_(nanosec);
  msg.pose_().position_().x_(t.x());
  msg.pose_().position_().y_(t.y());
  msg.pose_().position_().z_(t.z());
  msg.pose_().orientation_().w_(qw);
  msg.pose_().orientation_().x_(qx);
  msg.pose_().orientation_().y_(qy);
  msg.pose_().orientation_().z_(qz);
  return msg;
}

TEST(DecodePose, ReadsStampAndPoseOfPoseStampedAndOdometry) {
  const Eigen::Quaterniond q =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Vector3d t(1.0, -2.0, 3.5);
  const geometry_msgs::PoseStamped_ msg =
      makePoseStamped(t, q.w(), q.x(), q.y(), q.z(), 100, 250000000);
  double stamp_s = 0.0;
  Transform T = Transform::Identity();
  ASSERT_TRUE(decodePose(msg, &stamp_s, &T).ok());
  EXPECT_DOUBLE_EQ(stamp_s, 100.25);
  EXPECT_TRUE(T.translation().isApprox(t));
  EXPECT_TRUE(T.linear().isApprox(q.toRotationMatrix(), 1e-12));

  nav_msgs::Odometry_ odom;
  odom.header_().stamp_().sec_(-3);
  odom.header_().stamp_().nanosec_(999999999);
  odom.pose_().pose_() = msg.pose_();
  odom.twist_().twist_().linear_().x_(std::numeric_limits<double>::quiet_NaN());  // ignored
  ASSERT_TRUE(decodePose(odom, &stamp_s, &T).ok());
  EXPECT_DOUBLE_EQ(stamp_s, -3.0 + 0.999999999);
  EXPECT_TRUE(T.linear().isApprox(q.toRotationMatrix(), 1e-12));
}

TEST(DecodePose, NormalisesANearlyUnitQuaternion) {
  const double s = 1.0 + 8e-4;  // norm within the 1e-3 tolerance
  double stamp_s = 0.0;
  Transform T = Transform::Identity();
  ASSERT_TRUE(decodePose(makePoseStamped({0, 0, 0}, 0.0, 0.0, 0.0, s, 1, 0), &stamp_s, &T).ok());
  EXPECT_TRUE(T.linear().isApprox(Eigen::Vector3d(-1, -1, 1).asDiagonal().toDenseMatrix(), 1e-12));
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
}

void expectPoseRejected(const geometry_msgs::PoseStamped_& msg, DecodeError error) {
  double stamp_s = -7.0;
  Transform T = Transform::Identity();
  T.translation() = Eigen::Vector3d(9, 9, 9);
  const DecodeStatus status = decodePose(msg, &stamp_s, &T);
  EXPECT_EQ(status.error, error) << toString(status.error) << ": " << status.detail;
  EXPECT_FALSE(status.detail.empty());
  EXPECT_EQ(stamp_s, -7.0) << "output touched on error";
  EXPECT_EQ(T.translation(), Eigen::Vector3d(9, 9, 9)) << "output touched on error";

  nav_msgs::Odometry_ odom;
  odom.header_() = msg.header_();
  odom.pose_().pose_() = msg.pose_();
  EXPECT_EQ(decodePose(odom, &stamp_s, &T).error, error);
}

TEST(DecodePose, RejectsNonUnitQuaternionsNonFiniteValuesAndBadStamps) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  expectPoseRejected(makePoseStamped({0, 0, 0}, 1.002, 0, 0, 0, 1, 0), DecodeError::kBadPose);
  expectPoseRejected(makePoseStamped({0, 0, 0}, 0.5, 0, 0, 0, 1, 0), DecodeError::kBadPose);
  expectPoseRejected(makePoseStamped({0, 0, 0}, 0, 0, 0, 0, 1, 0), DecodeError::kBadPose);
  expectPoseRejected(makePoseStamped({nan, 0, 0}, 1, 0, 0, 0, 1, 0), DecodeError::kBadPose);
  expectPoseRejected(makePoseStamped({0, 0, inf}, 1, 0, 0, 0, 1, 0), DecodeError::kBadPose);
  expectPoseRejected(makePoseStamped({0, 0, 0}, nan, 0, 0, 0, 1, 0), DecodeError::kBadPose);
  expectPoseRejected(makePoseStamped({0, 0, 0}, 1, 0, inf, 0, 1, 0), DecodeError::kBadPose);
  expectPoseRejected(makePoseStamped({0, 0, 0}, 1, 0, 0, 0, 1, 1000000000u),
                     DecodeError::kBadStamp);
  expectPoseRejected(makePoseStamped({0, 0, 0}, 1, 0, 0, 0, 1, 0xFFFFFFFFu),
                     DecodeError::kBadStamp);
  double stamp_s = 0.0;
  Transform T;
  EXPECT_TRUE(decodePose(makePoseStamped({0, 0, 0}, 1, 0, 0, 0, 1, 999999999u), &stamp_s, &T).ok());
}

TEST(DecodeError, HasNames) {
  EXPECT_STREQ(toString(DecodeError::kOk), "ok");
  EXPECT_STREQ(toString(DecodeError::kBadLayout), "bad layout");
  EXPECT_STREQ(toString(DecodeError::kMissingField), "missing field");
  EXPECT_STREQ(toString(DecodeError::kUnsupportedType), "unsupported type");
  EXPECT_STREQ(toString(DecodeError::kBadStamp), "bad stamp");
  EXPECT_STREQ(toString(DecodeError::kBadPose), "bad pose");
}

// ---- Outputs ----------------------------------------------------------------------------------

TEST(ToTransformStamped, CarriesFramesStampAndTransform) {
  Transform T = Transform::Identity();
  T.linear() =
      Eigen::AngleAxisd(-2.0, Eigen::Vector3d(0.2, -1, 0.5).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(4, 5, -6);
  const geometry_msgs::TransformStamped_ msg = toTransformStamped(T, 42.75, "map", "odom");
  EXPECT_EQ(msg.header_().frame_id_(), "map");
  EXPECT_EQ(msg.child_frame_id_(), "odom");
  EXPECT_EQ(msg.header_().stamp_().sec_(), 42);
  EXPECT_EQ(msg.header_().stamp_().nanosec_(), 750000000u);
  const auto& tr = msg.transform_();
  EXPECT_EQ(Eigen::Vector3d(tr.translation_().x_(), tr.translation_().y_(), tr.translation_().z_()),
            T.translation());
  const Eigen::Quaterniond q(tr.rotation_().w_(), tr.rotation_().x_(), tr.rotation_().y_(),
                             tr.rotation_().z_());
  EXPECT_NEAR(q.norm(), 1.0, 1e-12);
  EXPECT_TRUE(q.toRotationMatrix().isApprox(T.linear(), 1e-12));
}

TEST(ToOccupancyGrid, KeepsLayoutOriginAndValues) {
  ProjectedGrid grid;
  grid.origin_W = {-1.5, 2.0};
  grid.resolution_m = 0.25;
  grid.width = 3;
  grid.height = 2;
  grid.cells = {0, 100, -1, 37, 0, 100};  // row y = 0 first
  const nav_msgs::OccupancyGrid_ msg = toOccupancyGrid(grid, 1.2, 10.5, "map");
  EXPECT_EQ(msg.header_().frame_id_(), "map");
  EXPECT_EQ(msg.header_().stamp_().sec_(), 10);
  EXPECT_EQ(msg.header_().stamp_().nanosec_(), 500000000u);
  const nav_msgs::MapMetaData_& info = msg.info_();
  EXPECT_EQ(info.map_load_time_().sec_(), 10);
  EXPECT_EQ(info.map_load_time_().nanosec_(), 500000000u);
  EXPECT_EQ(info.resolution_(), 0.25f);
  EXPECT_EQ(info.width_(), 3u);
  EXPECT_EQ(info.height_(), 2u);
  EXPECT_EQ(info.origin_().position_().x_(), -1.5);
  EXPECT_EQ(info.origin_().position_().y_(), 2.0);
  EXPECT_EQ(info.origin_().position_().z_(), 1.2);
  EXPECT_EQ(info.origin_().orientation_().w_(), 1.0);
  EXPECT_EQ(info.origin_().orientation_().x_(), 0.0);
  EXPECT_EQ(info.origin_().orientation_().y_(), 0.0);
  EXPECT_EQ(info.origin_().orientation_().z_(), 0.0);
  ASSERT_EQ(msg.data_().size(), 6u);
  // nav_msgs: cell (x, y) at data[y * width + x], its lower corner at origin + (x, y) * res.
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 3; ++x) {
      EXPECT_EQ(msg.data_()[static_cast<std::size_t>(y * 3 + x)], grid.at(x, y));
      const Eigen::Vector2d centre(
          info.origin_().position_().x_() + (x + 0.5) * info.resolution_(),
          info.origin_().position_().y_() + (y + 0.5) * info.resolution_());
      EXPECT_EQ(msg.data_()[static_cast<std::size_t>(y * 3 + x)], grid.valueAt(centre));
    }
  }
  EXPECT_EQ(msg.data_()[2], -1);
  EXPECT_EQ(msg.data_()[3], 37);

  grid.cells.pop_back();
  EXPECT_THROW(toOccupancyGrid(grid, 0.0, 0.0, "map"), std::invalid_argument);
}

/// A 4 x 3 x 5 box at world index (-2, 1, 3), resolution 0.5: free everywhere except one
/// occupied voxel and an unknown column at box (3, 2, *) and one unknown voxel at box (0, 0, 4).
OccupancyBox makeBox() {
  OccupancyBox box;
  box.reset(VoxelIndex(-2, 1, 3), Eigen::Vector3i(4, 3, 5), 0.5, Occupancy::kFree);
  box.at(VoxelIndex(-1, 2, 5)) = Occupancy::kOccupied;  // box (1, 1, 2)
  for (int z = 3; z < 8; ++z) box.at(VoxelIndex(1, 3, z)) = Occupancy::kUnknown;
  box.at(VoxelIndex(-2, 1, 7)) = Occupancy::kUnknown;
  return box;
}

EsdfMap makeEsdf(const OccupancyBox& box) {
  EsdfConfig config;
  config.max_distance_m = 1.25;
  config.unknown_as = UnknownAs::kFree;
  EsdfMap esdf(config);
  EXPECT_TRUE(esdf.compute(box));
  return esdf;
}

TEST(ToVoxelBlock, DenseBoxInBoxOrderWithNaNForUnknown) {
  const OccupancyBox box = makeBox();
  const EsdfMap esdf = makeEsdf(box);
  const mlmap_msgs::VoxelBlock_ msg = toVoxelBlock(esdf, 3.0, "map");
  EXPECT_EQ(msg.header_().frame_id_(), "map");
  EXPECT_EQ(msg.header_().stamp_().sec_(), 3);
  EXPECT_EQ(msg.version_(), 1u);
  EXPECT_EQ(msg.layer_(), "esdf");
  EXPECT_EQ(msg.resolution_(), 0.5);
  EXPECT_EQ(msg.origin_().x_(), -1.0);
  EXPECT_EQ(msg.origin_().y_(), 0.5);
  EXPECT_EQ(msg.origin_().z_(), 1.5);
  EXPECT_EQ(msg.size_x_(), 4u);
  EXPECT_EQ(msg.size_y_(), 3u);
  EXPECT_EQ(msg.size_z_(), 5u);
  EXPECT_EQ(msg.max_value_(), 1.25f);
  ASSERT_EQ(msg.values_().size(), 60u);
  int unknown = 0;
  for (int x = 0; x < 4; ++x) {
    for (int y = 0; y < 3; ++y) {
      for (int z = 0; z < 5; ++z) {
        const VoxelIndex g = box.min_index + VoxelIndex(x, y, z);
        const float value = msg.values_()[static_cast<std::size_t>((x * 3 + y) * 5 + z)];
        if (box.at(g) == Occupancy::kUnknown) {
          EXPECT_TRUE(std::isnan(value)) << x << y << z;
          ++unknown;
        } else {
          EXPECT_EQ(value, esdf.distanceAt(g)) << x << y << z;
          EXPECT_FALSE(std::isnan(value));
        }
      }
    }
  }
  EXPECT_EQ(unknown, 6);
  // Spot values from the definition: the occupied voxel at box (1, 1, 2) is -0.5 (a free
  // neighbour), its face neighbour +0.5, a voxel two steps away along x and one along y
  // sqrt(5) * 0.5 = 1.118, and a far one clamped to 1.25.
  const auto at = [&](int x, int y, int z) {
    return msg.values_()[static_cast<std::size_t>((x * 3 + y) * 5 + z)];
  };
  EXPECT_FLOAT_EQ(at(1, 1, 2), -0.5f);
  EXPECT_FLOAT_EQ(at(1, 1, 3), 0.5f);
  EXPECT_NEAR(at(3, 0, 2), std::sqrt(5.0) * 0.5, 1e-5);
  EXPECT_FLOAT_EQ(at(3, 0, 0), 1.25f);
}

TEST(ToVoxelBlock, EmptyEsdfGivesAnEmptyBlock) {
  EsdfMap esdf{EsdfConfig{}};
  const mlmap_msgs::VoxelBlock_ msg = toVoxelBlock(esdf, 0.0, "map");
  EXPECT_EQ(msg.size_x_() * msg.size_y_() * msg.size_z_(), 0u);
  EXPECT_TRUE(msg.values_().empty());
  EXPECT_EQ(msg.version_(), 1u);
}

TEST(EsdfSliceCloud, HoldsTheKnownVoxelsOfTheLayerWithTheirDistance) {
  const OccupancyBox box = makeBox();
  const EsdfMap esdf = makeEsdf(box);
  // z = 2.6 m lies in world layer 5 (box z 2): 12 voxels, one of them unknown.
  const sensor_msgs::PointCloud2_ msg = esdfSliceCloud(esdf, 2.6, 5.0, "map");
  EXPECT_EQ(msg.header_().frame_id_(), "map");
  EXPECT_EQ(msg.header_().stamp_().sec_(), 5);
  ASSERT_EQ(msg.fields_().size(), 4u);
  EXPECT_EQ(msg.fields_()[3].name_(), "intensity");
  std::vector<Eigen::Vector3f> points;
  ASSERT_TRUE(decodePointCloud2(msg, &points).ok());
  ASSERT_EQ(points.size(), 11u);
  std::vector<bool> seen(12, false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const float distance = floatFromBits(getBits(msg.data_().data() + 16 * i + 12, 4, false));
    const VoxelIndex g = voxelIndexOf(points[i].cast<double>(), 0.5);
    EXPECT_EQ(g.z(), 5);
    ASSERT_TRUE(box.contains(g));
    EXPECT_NE(box.at(g), Occupancy::kUnknown);
    EXPECT_TRUE(points[i].cast<double>().isApprox(voxelCenter(g, 0.5)));
    EXPECT_EQ(distance, esdf.distanceAt(g));
    const VoxelIndex r = g - box.min_index;
    const std::size_t cell = static_cast<std::size_t>(r.x() * 3 + r.y());
    EXPECT_FALSE(seen[cell]) << "voxel twice";
    seen[cell] = true;
  }
  EXPECT_FALSE(seen[3 * 3 + 2]);  // the unknown column

  // Layer 7 holds the second unknown voxel; outside the box there is nothing.
  ASSERT_TRUE(decodePointCloud2(esdfSliceCloud(esdf, 3.9, 5.0, "map"), &points).ok());
  EXPECT_EQ(points.size(), 10u);
  EXPECT_EQ(esdfSliceCloud(esdf, 4.0, 5.0, "map").width_(), 0u);   // layer 8: just above
  EXPECT_EQ(esdfSliceCloud(esdf, 1.49, 5.0, "map").width_(), 0u);  // layer 2: just below
  EXPECT_EQ(esdfSliceCloud(esdf, std::numeric_limits<double>::quiet_NaN(), 5.0, "map").width_(),
            0u);
  EXPECT_EQ(esdfSliceCloud(EsdfMap{EsdfConfig{}}, 0.0, 5.0, "map").width_(), 0u);
}

}  // namespace
}  // namespace mlmap::dds
