#include "mlmap/datasets/point_cloud_file.h"

#include "../support/expect_throw.h"
#include "../support/cloud_file_writers.h"
#include "../support/random_draws.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

namespace mlmap::datasets {
namespace {

using mlmap::testing::makePcd;
using mlmap::testing::makePly;
using mlmap::testing::PcdData;
using mlmap::testing::PcdOptions;
using mlmap::testing::PlyFormat;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// 60 points (a 10 x 6 organised grid) with NaN "no return" points at 7 of them; coordinates
/// need a double to be exact (so F4 files round them, F8 files keep them).
std::vector<Eigen::Vector3d> samplePoints() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-40.0, 40.0);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < 60; ++i) {
    p.push_back(test::draw3(u, rng).cwiseProduct(Eigen::Vector3d(1.0, 1.0, 0.1)));
    if (i % 9 == 4) p.back().y() = kNaN;
  }
  return p;
}

/// The finite points of `points`, as the reader must return them (float, file order).
std::vector<Eigen::Vector3f> expected(const std::vector<Eigen::Vector3d>& points) {
  std::vector<Eigen::Vector3f> out;
  for (const Eigen::Vector3d& p : points) {
    if (p.allFinite()) out.push_back(p.cast<float>());
  }
  return out;
}

void expectCloud(const PointCloudFile& cloud, const std::vector<Eigen::Vector3d>& points) {
  const std::vector<Eigen::Vector3f> want = expected(points);
  EXPECT_EQ(cloud.points_in_file, points.size());
  EXPECT_EQ(cloud.non_finite_dropped, points.size() - want.size());
  ASSERT_EQ(cloud.points_C.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(cloud.points_C[i], want[i]) << "point " << i;  // bit-exact
  }
}

void expectError(const std::function<void()>& fn, const std::vector<std::string>& parts) {
  mlmap::testing::expectThrowWith<std::runtime_error>(fn, parts);
}

TEST(PcdReader, AsciiBinaryAndCompressedReadTheSame) {
  const std::vector<Eigen::Vector3d> points = samplePoints();
  for (const bool f8 : {false, true}) {
    for (const bool extra : {false, true}) {
      for (const PcdData data : {PcdData::kAscii, PcdData::kBinary, PcdData::kBinaryCompressed}) {
        PcdOptions o;
        o.data = data;
        o.f8 = f8;
        o.extra_fields = extra;
        o.height = 6;
        SCOPED_TRACE("f8 " + std::to_string(f8) + " extra " + std::to_string(extra) + " data " +
                     std::to_string(static_cast<int>(data)));
        const PointCloudFile cloud = parsePcd(makePcd(points, o), "mem.pcd");
        expectCloud(cloud, points);
        EXPECT_EQ(cloud.width, 10u);
        EXPECT_EQ(cloud.height, 6u);
        EXPECT_TRUE(cloud.T_C_V.matrix().isIdentity(0.0));
      }
    }
  }
}

TEST(PcdReader, F8CoordinatesAreReadAsDoublesThenRounded) {
  // 1 + 2^-40 is not a float: an F8 reader that took the bytes as F4 would read garbage.
  const std::vector<Eigen::Vector3d> points = {{1.0 + std::ldexp(1.0, -40), -2.5, 3.25}};
  PcdOptions o;
  o.f8 = true;
  o.data = PcdData::kBinary;
  const PointCloudFile cloud = parsePcd(makePcd(points, o), "mem.pcd");
  ASSERT_EQ(cloud.points_C.size(), 1u);
  EXPECT_EQ(cloud.points_C[0], Eigen::Vector3f(1.0f, -2.5f, 3.25f));
}

TEST(PcdReader, ViewpointIsReturned) {
  PcdOptions o;
  o.viewpoint = "1 2 3 0.7071067811865476 0 0 0.7071067811865476";  // qw qx qy qz: 90 deg about z
  const PointCloudFile cloud = parsePcd(makePcd({{1, 0, 0}}, o), "mem.pcd");
  EXPECT_TRUE(cloud.T_C_V.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(
      (cloud.T_C_V.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
}

TEST(PcdReader, LzfBackReferencesDecode) {
  // A repetitive block gives long, overlapping back references.
  std::string raw;
  for (int i = 0; i < 500; ++i) raw += static_cast<char>("abcab"[i % 5]);
  raw += "0123456789abcdefghijklmnopqrstuvwxyz0123456789";
  const std::string packed = mlmap::testing::lzfCompress(raw);
  ASSERT_LT(packed.size(), raw.size() / 4);
  std::vector<unsigned char> out;
  ASSERT_TRUE(lzfDecompress(reinterpret_cast<const unsigned char*>(packed.data()), packed.size(),
                            raw.size(), &out));
  EXPECT_EQ(std::string(out.begin(), out.end()), raw);
  // Wrong expected size, a reference before the start, a cut stream: refused.
  EXPECT_FALSE(lzfDecompress(reinterpret_cast<const unsigned char*>(packed.data()), packed.size(),
                             raw.size() + 1, &out));
  const unsigned char bad_ref[] = {0x00, 'a', 0x20, 0x05};  // distance 6 after one byte
  EXPECT_FALSE(lzfDecompress(bad_ref, sizeof(bad_ref), 4, &out));
  EXPECT_FALSE(lzfDecompress(reinterpret_cast<const unsigned char*>(packed.data()),
                             packed.size() - 1, raw.size(), &out));
}

TEST(PcdReader, MalformedAndTruncatedFilesAreRefusedWithTheReason) {
  const std::vector<Eigen::Vector3d> points = samplePoints();
  PcdOptions binary;
  binary.data = PcdData::kBinary;
  const std::string good_binary = makePcd(points, binary);
  expectError([&] { (void)parsePcd(good_binary.substr(0, good_binary.size() - 1), "cut.pcd"); },
              {"cut.pcd", "truncated"});
  expectError([&] { (void)parsePcd(good_binary + "xx", "long.pcd"); },
              {"long.pcd", "unexpected data"});
  const std::string good_ascii = makePcd(points, PcdOptions{});
  const std::string cut_ascii =
      good_ascii.substr(0, good_ascii.rfind('\n', good_ascii.size() - 2) + 1);
  expectError([&] { (void)parsePcd(cut_ascii, "cut_ascii.pcd"); },
              {"cut_ascii.pcd", "truncated", "59 of 60"});
  PcdOptions compressed;
  compressed.data = PcdData::kBinaryCompressed;
  const std::string good_compressed = makePcd(points, compressed);
  expectError(
      [&] { (void)parsePcd(good_compressed.substr(0, good_compressed.size() - 3), "c.pcd"); },
      {"c.pcd", "truncated"});
  std::string corrupt = good_compressed;
  const std::size_t data_start = corrupt.find("DATA binary_compressed\n") + 23 + 8;
  corrupt[data_start] = static_cast<char>(0xE0);  // a back reference before any output
  expectError([&] { (void)parsePcd(corrupt, "corrupt.pcd"); }, {"corrupt.pcd", "LZF"});

  auto header = [](const std::string& fields) {
    return "VERSION 0.7\n" + fields + "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
  };
  expectError([&] { (void)parsePcd(header("FIELDS x y\nSIZE 4 4\nTYPE F F\n"), "noz.pcd"); },
              {"noz.pcd", "no field 'z'"});
  expectError([&] { (void)parsePcd(header("FIELDS x y z\nSIZE 4 4 4\nTYPE F I F\n"), "int.pcd"); },
              {"int.pcd", "'y' must be TYPE F"});
  expectError(
      [&] {
        (void)parsePcd(header("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 2 1\n"), "cnt.pcd");
      },
      {"cnt.pcd", "COUNT 1"});
  expectError([&] { (void)parsePcd(header("FIELDS x y z\nSIZE 4 4\nTYPE F F F\n"), "size.pcd"); },
              {"size.pcd", "SIZE has 2"});
  expectError([&] { (void)parsePcd(header("FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\n"), "s3.pcd"); },
              {"s3.pcd", "SIZE '3'"});
  expectError(
      [&] { (void)parsePcd(header("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOLOR 1\n"), "kw.pcd"); },
      {"kw.pcd", "unknown keyword 'COLOR'"});
  expectError(
      [&] {
        (void)parsePcd(
            "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\nPOINTS 3\nDATA ascii\n",
            "n.pcd");
      },
      {"n.pcd", "POINTS 3 is not WIDTH x HEIGHT"});
  expectError(
      [&] {
        (void)parsePcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA lzma\n",
                       "d.pcd");
      },
      {"d.pcd", "'lzma'"});
  expectError([&] { (void)parsePcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\n", "h.pcd"); },
              {"h.pcd", "before its DATA line"});
  expectError(
      [&] {
        (void)parsePcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2\n", "v.pcd");
      },
      {"v.pcd", "expected 3 values, got 2"});
  expectError(
      [&] {
        (void)parsePcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 two 3\n",
                       "w.pcd");
      },
      {"w.pcd", "'two' is not a number"});
  expectError(
      [&] {
        (void)parsePcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n4 5 6\n",
                       "x.pcd");
      },
      {"x.pcd", "more data"});
  // A huge declared size is refused without allocating it.
  expectError(
      [&] {
        (void)parsePcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4000000000\nDATA binary\n",
                       "big.pcd");
      },
      {"big.pcd", "too large"});
  expectError(
      [&] {
        (void)parsePcd(
            "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4000000000\nDATA ascii\n1 2 3\n",
            "big2.pcd");
      },
      {"big2.pcd", "truncated", "1 of 4000000000"});
  expectError(
      [&] {
        (void)parsePly(
            "ply\nformat binary_little_endian 1.0\nelement vertex 999999999999\nproperty float "
            "x\nproperty float y\nproperty float z\nend_header\n",
            "big.ply");
      },
      {"big.ply", "truncated", "'vertex' declares 999999999999 items"});
  // WIDTH x HEIGHT would wrap around 64 bits to POINTS 0 (an "empty" cloud): refused.
  expectError(
      [&] {
        (void)parsePcd(
            "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4294967296\nHEIGHT 4294967296\nPOINTS "
            "0\nDATA ascii\n",
            "wrap.pcd");
      },
      {"wrap.pcd", "beyond 32 bits"});
  // LZF that claims to expand 4 bytes into 4 GB is refused before the 4 GB are allocated.
  std::string bomb =
      "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 357913941\nDATA binary_compressed\n";
  for (const std::uint32_t v : {std::uint32_t{4}, std::uint32_t{4294967292u}, std::uint32_t{0}}) {
    for (int b = 0; b < 4; ++b) bomb.push_back(static_cast<char>((v >> (8 * b)) & 0xFFu));
  }
  expectError([&] { (void)parsePcd(bomb, "bomb.pcd"); },
              {"bomb.pcd", "4 bytes of LZF data cannot decode to 4294967292"});
  expectError([&] { (void)parsePcd(good_compressed + "xy", "tail.pcd"); },
              {"tail.pcd", "2 bytes of unexpected data after the compressed block"});
  expectError(
      [&] {
        (void)parsePcd(
            "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nVIEWPOINT 0 0 0 2 0 0 0\nDATA ascii\n1 "
            "2 3\n",
            "vp.pcd");
      },
      {"vp.pcd", "VIEWPOINT"});
}

TEST(PlyReader, AllThreeEncodingsReadTheSame) {
  const std::vector<Eigen::Vector3d> points = samplePoints();
  for (const bool doubles : {false, true}) {
    for (const PlyFormat f :
         {PlyFormat::kAscii, PlyFormat::kBinaryLittleEndian, PlyFormat::kBinaryBigEndian}) {
      SCOPED_TRACE("doubles " + std::to_string(doubles) + " format " +
                   std::to_string(static_cast<int>(f)));
      const PointCloudFile cloud = parsePly(makePly(points, f, doubles), "mem.ply");
      expectCloud(cloud, points);
    }
  }
}

TEST(PlyReader, BigEndianIsNotReadAsLittleEndian) {
  // The same bytes declared little endian give other numbers: the byte order is honoured.
  const std::vector<Eigen::Vector3d> points = {{1.5, -2.0, 3.0}};
  std::string be = makePly(points, PlyFormat::kBinaryBigEndian, false);
  const PointCloudFile right = parsePly(be, "be.ply");
  ASSERT_EQ(right.points_C.size(), 1u);
  EXPECT_EQ(right.points_C[0], Eigen::Vector3f(1.5f, -2.0f, 3.0f));
  be.replace(be.find("binary_big_endian"), 17, "binary_little_endian");
  try {
    const PointCloudFile wrong = parsePly(be, "le.ply");
    ASSERT_EQ(wrong.points_C.size() + wrong.non_finite_dropped, 1u);
    if (!wrong.points_C.empty()) {
      EXPECT_NE(wrong.points_C[0], right.points_C[0]);
    }
  } catch (const std::runtime_error&) {
    // also fine: the list counts read wrongly can run past the end
  }
}

TEST(PlyReader, MalformedAndTruncatedFilesAreRefusedWithTheReason) {
  const std::vector<Eigen::Vector3d> points = samplePoints();
  const std::string le = makePly(points, PlyFormat::kBinaryLittleEndian, false);
  expectError([&] { (void)parsePly(le.substr(0, le.size() - 2), "cut.ply"); },
              {"cut.ply", "truncated", "face 1"});
  expectError([&] { (void)parsePly(le.substr(0, le.size() - 200), "cut2.ply"); },
              {"cut2.ply", "truncated", "vertex"});
  expectError([&] { (void)parsePly(le + "junk", "long.ply"); }, {"long.ply", "unexpected data"});
  const std::string ascii = makePly(points, PlyFormat::kAscii, false);
  expectError([&] { (void)parsePly(ascii.substr(0, ascii.size() - 20), "cut.ply"); },
              {"cut.ply", "truncated"});
  expectError([&] { (void)parsePly("PLY\n", "a.ply"); }, {"a.ply", "not a PLY file"});
  expectError(
      [&] { (void)parsePly("ply\nformat binary_middle_endian 1.0\nend_header\n", "b.ply"); },
      {"b.ply", "unknown format"});
  expectError(
      [&] { (void)parsePly("ply\nformat ascii 1.0\nelement face 0\nend_header\n", "c.ply"); },
      {"c.ply", "no 'vertex' element"});
  expectError(
      [&] {
        (void)parsePly(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float "
            "y\nend_header\n1 2\n",
            "d.ply");
      },
      {"d.ply", "no property 'z'"});
  expectError(
      [&] {
        (void)parsePly(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty float y\nproperty "
            "float z\nend_header\n1 2 3\n",
            "e.ply");
      },
      {"e.ply", "'x' must be a float or double"});
  expectError(
      [&] {
        (void)parsePly(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty "
            "float z\nend_header\n1 b 3\n",
            "f.ply");
      },
      {"f.ply", "'b' is not a number"});
  expectError(
      [&] {
        (void)parsePly("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "g.ply");
      },
      {"g.ply", "before 'end_header'"});
  expectError(
      [&] {
        (void)parsePly(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty list float float x\nend_header\n",
            "h.ply");
      },
      {"h.ply", "not an integer type"});
  // An element with items but nothing in them would be looped over without reading a byte.
  expectError(
      [&] {
        (void)parsePly(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty "
            "float z\nelement junk 999999999999\nend_header\n1 2 3\n",
            "i.ply");
      },
      {"i.ply", "'junk' has 999999999999 items but no properties"});
}

TEST(PointCloudFile, ReadsByExtensionAndNamesThePath) {
  const std::string dir = ::testing::TempDir() + "/mlmap_pcf";
  std::filesystem::create_directories(dir);
  const std::vector<Eigen::Vector3d> points = samplePoints();
  mlmap::testing::writeFile(dir + "/a.PCD", makePcd(points, PcdOptions{}));
  mlmap::testing::writeFile(dir + "/b.ply", makePly(points, PlyFormat::kAscii, false));
  expectCloud(readPointCloudFile(dir + "/a.PCD"), points);
  expectCloud(readPointCloudFile(dir + "/b.ply"), points);
  EXPECT_TRUE(isPointCloudFileName("x.Ply"));
  EXPECT_FALSE(isPointCloudFileName("x.bin"));
  expectError([&] { (void)readPointCloudFile(dir + "/missing.pcd"); },
              {dir + "/missing.pcd", "cannot open"});
  expectError([&] { (void)readPointCloudFile(dir + "/a.txt"); }, {"a.txt", "not a .pcd or .ply"});
}

}  // namespace
}  // namespace mlmap::datasets
