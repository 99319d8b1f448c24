#include "mlmap/datasets/frame_directory.h"

#include "../support/expect_throw.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <stdexcept>
#include <string>
#include <unistd.h>

#ifndef MLMAP_SHARED_DATA_DIR
#error "MLMAP_SHARED_DATA_DIR must name the shared data folder (e.g. /work/shared/data)"
#endif

namespace mlmap::datasets {
namespace {

namespace fs = std::filesystem;

const std::string kTabletopDir = std::string(MLMAP_SHARED_DATA_DIR) + "/realsense_tabletop";

using mlmap::testing::expectThrowWith;

// ---- Real data ----------------------------------------------------------------------------------

TEST(FrameDirectoryRealData, ListsFiftyFramesInNumberOrder) {
  const FrameDirectory frames(kTabletopDir);
  ASSERT_EQ(frames.size(), 50u);
  EXPECT_EQ(frames.frameName(0), "frame-000015");
  EXPECT_EQ(frames.frameName(49), "frame-000113");
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames.frameNumber(i), 15 + 2 * static_cast<long>(i));
  }
  EXPECT_THROW((void)frames.frameName(50), std::out_of_range);
  EXPECT_THROW((void)frames.read(50), std::out_of_range);
}

TEST(FrameDirectoryRealData, ReadsIntrinsics) {
  const FrameDirectory frames(kTabletopDir);
  const PinholeIntrinsics& k = frames.intrinsics();
  EXPECT_NEAR(k.fx, 615.195, 1e-3);
  EXPECT_NEAR(k.fy, 615.195, 1e-3);
  EXPECT_NEAR(k.cx, 298.443, 1e-3);
  EXPECT_NEAR(k.cy, 247.519, 1e-3);
  EXPECT_EQ(k.width, 640);
  EXPECT_EQ(k.height, 480);
}

TEST(FrameDirectoryRealData, FirstFrameIsTheWorldOrigin) {
  const FrameDirectory frames(kTabletopDir);
  const DepthFrame frame = frames.read(0);
  EXPECT_TRUE(frame.T_W_B.isApprox(Transform::Identity(), 1e-12));
  EXPECT_TRUE(frame.T_B_S.isApprox(Transform::Identity(), 1e-12));
  EXPECT_DOUBLE_EQ(frame.stamp_s, 15.0 / 30.0);
  EXPECT_EQ(frame.encoding, DepthEncoding::kUint16Millimetres);
  EXPECT_TRUE(frame.depth_m.empty());
  EXPECT_EQ(frame.intrinsics.width, 640);
  EXPECT_EQ(frame.depth_mm.size(), 640u * 480u);
}

TEST(FrameDirectoryRealData, EveryFrameHasPlausibleDepthAndPose) {
  const FrameDirectory frames(kTabletopDir);
  std::uint16_t min_mm = 65535;
  std::uint16_t max_mm = 0;
  std::size_t valid_total = 0;
  std::size_t in_range_total = 0;  // within the 0.27-1.8 m stated in the data's README
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const DepthFrame frame = frames.read(i);
    ASSERT_EQ(frame.depth_mm.size(), 640u * 480u);
    std::size_t valid = 0;
    for (const std::uint16_t d : frame.depth_mm) {
      if (d == 0) continue;
      ++valid;
      in_range_total += (d >= 270 && d <= 1800) ? 1 : 0;
      min_mm = std::min(min_mm, d);
      max_mm = std::max(max_mm, d);
    }
    valid_total += valid;
    const double valid_fraction = double(valid) / double(frame.depth_mm.size());
    EXPECT_GT(valid_fraction, 0.30) << frames.frameName(i);
    EXPECT_LT(valid_fraction, 0.42) << frames.frameName(i);
    const Eigen::Matrix3d R = frame.T_W_B.linear();
    EXPECT_TRUE((R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
    EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
    EXPECT_LT(frame.T_W_B.translation().norm(), 1.0) << frames.frameName(i);
    EXPECT_DOUBLE_EQ(frame.stamp_s, static_cast<double>(frames.frameNumber(i)) / 30.0);
  }
  // About 36 % valid pixels per frame.
  EXPECT_NEAR(double(valid_total) / (50.0 * 640 * 480), 0.36, 0.02);
  // The stated 0.27-1.8 m holds for ~98 % of the pixels; the rest are near-range flying pixels
  // down to ~0.09 m and a handful up to ~1.9 m.
  EXPECT_GT(double(in_range_total) / double(valid_total), 0.97);
  EXPECT_GE(min_mm, 50);
  EXPECT_LE(max_mm, 2000);
}

TEST(FrameDirectoryRealData, LastPoseMatchesTheFile) {
  const FrameDirectory frames(kTabletopDir);
  const Transform T = frames.read(49).T_W_B;
  // First and last rows of frame-000113.pose.txt.
  EXPECT_NEAR(T(0, 0), 0.38588948281543473, 1e-4);
  EXPECT_NEAR(T(0, 2), -0.90671016734733823, 1e-4);
  EXPECT_NEAR(T(0, 3), 0.32478579197660018, 1e-12);
  EXPECT_NEAR(T(2, 3), 0.24718962005338835, 1e-12);
  EXPECT_NEAR(T(2, 0), 0.90351373320498107, 1e-4);
}

// ---- Synthetic directories ----------------------------------------------------------------------

/// A fresh temporary folder, removed at the end of the test.
class TempFrameDir : public ::testing::Test {
 protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("mlmap_frame_dir_" + std::to_string(::getpid()) + "_" +
                                        info->name() + "_" + std::to_string(counter++));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  [[nodiscard]] std::string path(const std::string& name) const { return (dir_ / name).string(); }

  void writeText(const std::string& name, const std::string& text) const {
    std::ofstream out(path(name));
    out << text;
  }
  void writeIntrinsics(const std::string& name = "intrinsics.K.txt",
                       const std::string& text = "500 0 80.5\n0 510 60.5\n0 0 1\n") const {
    writeText(name, text);
  }
  void writeDepth(const std::string& stem, const cv::Mat& image) const {
    ASSERT_TRUE(cv::imwrite(path(stem + ".depth.png"), image));
  }
  void writePose(const std::string& stem, const std::string& text = kIdentityPose) const {
    writeText(stem + ".pose.txt", text);
  }
  /// A 160x120 16-bit frame whose pixel (r, c) holds 1000 + r * 160 + c (mod 60000).
  [[nodiscard]] static cv::Mat rampImage() {
    cv::Mat image(120, 160, CV_16UC1);
    for (int r = 0; r < image.rows; ++r) {
      for (int c = 0; c < image.cols; ++c) {
        image.at<std::uint16_t>(r, c) = static_cast<std::uint16_t>(1000 + r * 160 + c);
      }
    }
    return image;
  }
  void writeFrame(const std::string& stem) const {
    writeDepth(stem, rampImage());
    writePose(stem);
  }

  static constexpr const char* kIdentityPose = "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  fs::path dir_;
};

TEST_F(TempFrameDir, CameraIntrinsicsVariantAndNumericOrder) {
  writeIntrinsics("camera-intrinsics.txt", "500 0 80.5 0 510 60.5 0 0 1");
  writeFrame("frame-10");
  writeFrame("frame-2");
  writeFrame("frame-000001");
  writeText("frame-5.color.png", "not read");  // other files are ignored
  const FrameDirectory frames(dir_.string());
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames.frameName(0), "frame-000001");
  EXPECT_EQ(frames.frameName(1), "frame-2");
  EXPECT_EQ(frames.frameName(2), "frame-10");
  EXPECT_EQ(frames.directory(), dir_.string());
  const PinholeIntrinsics& k = frames.intrinsics();
  EXPECT_DOUBLE_EQ(k.fx, 500.0);
  EXPECT_DOUBLE_EQ(k.fy, 510.0);
  EXPECT_DOUBLE_EQ(k.cx, 80.5);
  EXPECT_DOUBLE_EQ(k.cy, 60.5);
  EXPECT_EQ(k.width, 160);
  EXPECT_EQ(k.height, 120);
  const DepthFrame frame = frames.read(2);
  EXPECT_DOUBLE_EQ(frame.stamp_s, 10.0 / 30.0);
  ASSERT_EQ(frame.depth_mm.size(), 160u * 120u);
  EXPECT_EQ(frame.depth_mm[0], 1000);
  EXPECT_EQ(frame.depth_mm[7 * 160 + 3], 1000 + 7 * 160 + 3);  // row-major
}

TEST_F(TempFrameDir, Max16BitValueMeansNoData) {
  writeIntrinsics();
  cv::Mat image = rampImage();
  image.at<std::uint16_t>(5, 6) = 65535;
  image.at<std::uint16_t>(0, 1) = 0;
  image.at<std::uint16_t>(2, 3) = 65534;
  writeDepth("frame-000000", image);
  writePose("frame-000000");
  const DepthFrame frame = FrameDirectory(dir_.string()).read(0);
  EXPECT_EQ(frame.depth_mm[5 * 160 + 6], 0);
  EXPECT_EQ(frame.depth_mm[1], 0);
  EXPECT_EQ(frame.depth_mm[2 * 160 + 3], 65534);
  EXPECT_EQ(frame.depth_mm[4], 1004);
}

TEST_F(TempFrameDir, PoseIsCameraToWorldAndReorthonormalised) {
  writeIntrinsics();
  writeDepth("frame-000000", rampImage());
  // 90 degrees about z plus a 2e-4 perturbation (inside the 1e-3 tolerance), then a translation.
  writePose("frame-000000", "0.0002 -1 0 1.5\n1 0 0 -2\n0 0 1 0.25\n0 0 0 1\n");
  const Transform T = FrameDirectory(dir_.string()).read(0).T_W_B;
  const Eigen::Matrix3d R = T.linear();
  EXPECT_TRUE((R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(1.5, -2.0, 0.25)));
  // p_W = R p_C + t: the camera x axis points along world +y.
  EXPECT_TRUE((T * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d(1.5, -1.0, 0.25), 1e-3));
}

TEST_F(TempFrameDir, MissingPoseFileIsNamed) {
  writeIntrinsics();
  writeFrame("frame-000000");
  writeDepth("frame-000001", rampImage());
  expectThrowWith([&] { FrameDirectory frames(dir_.string()); },
                  {path("frame-000001.pose.txt"), "missing pose file"});
}

TEST_F(TempFrameDir, MissingIntrinsicsIsReported) {
  writeFrame("frame-000000");
  expectThrowWith([&] { FrameDirectory frames(dir_.string()); },
                  {"intrinsics.K.txt", "camera-intrinsics.txt", dir_.string()});
}

TEST_F(TempFrameDir, MalformedIntrinsicsAreRejected) {
  writeFrame("frame-000000");
  const std::string k_path = path("intrinsics.K.txt");
  const auto open = [&] { FrameDirectory frames(dir_.string()); };

  writeIntrinsics("intrinsics.K.txt", "500 0 80 0 510 60 0 0");
  expectThrowWith(open, {k_path, "9 numbers", "found 8"});
  writeIntrinsics("intrinsics.K.txt", "500 0 80 0 510 60 0 0 1 7");
  expectThrowWith(open, {k_path, "found 10"});
  writeIntrinsics("intrinsics.K.txt", "500 0 80 0 five 60 0 0 1");
  expectThrowWith(open, {k_path, "'five'", "not a number"});
  writeIntrinsics("intrinsics.K.txt", "500 0 80 0 nan 60 0 0 1");
  expectThrowWith(open, {k_path, "not finite"});
  writeIntrinsics("intrinsics.K.txt", "500 0 80 0 1e999 60 0 0 1");
  expectThrowWith(open, {k_path, "not finite"});
  writeIntrinsics("intrinsics.K.txt", "-500 0 80 0 510 60 0 0 1");
  expectThrowWith(open, {k_path, "positive"});
  writeIntrinsics("intrinsics.K.txt", "500 0 80 0 0 60 0 0 1");
  expectThrowWith(open, {k_path, "positive"});
  writeIntrinsics("intrinsics.K.txt", "500 0 80 0 510 60 0 0 2");
  expectThrowWith(open, {k_path, "pinhole"});
  writeIntrinsics("intrinsics.K.txt", "");
  expectThrowWith(open, {k_path, "found 0"});
}

TEST_F(TempFrameDir, BadPosesAreRejectedAtRead) {
  writeIntrinsics();
  writeFrame("frame-000000");
  const std::string pose = path("frame-000000.pose.txt");
  const auto read = [&] { (void)FrameDirectory(dir_.string()).read(0); };

  writePose("frame-000000", "1.1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");  // scaled
  expectThrowWith(read, {pose, "not a rotation"});
  writePose("frame-000000", "1 0.01 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");  // sheared
  expectThrowWith(read, {pose, "not a rotation"});
  writePose("frame-000000", "-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");  // reflection
  expectThrowWith(read, {pose, "det"});
  writePose("frame-000000", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n");
  expectThrowWith(read, {pose, "last row"});
  writePose("frame-000000", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0\n");
  expectThrowWith(read, {pose, "16 numbers", "found 15"});
  writePose("frame-000000", "1 0 0 0\n0 1 0 inf\n0 0 1 0\n0 0 0 1\n");
  expectThrowWith(read, {pose, "not finite"});
  writePose("frame-000000", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1,\n");
  expectThrowWith(read, {pose, "not a number"});
}

TEST_F(TempFrameDir, WrongImageTypeOrSizeIsRejected) {
  writeIntrinsics();
  writeFrame("frame-000000");
  writeDepth("frame-000001", cv::Mat(120, 160, CV_8UC1, cv::Scalar(7)));
  writePose("frame-000001");
  writeDepth("frame-000002", cv::Mat(120, 160, CV_16UC3, cv::Scalar(7, 7, 7)));
  writePose("frame-000002");
  writeDepth("frame-000003", cv::Mat(60, 80, CV_16UC1, cv::Scalar(7)));
  writePose("frame-000003");
  writeText("frame-000004.depth.png", "this is not a PNG");
  writePose("frame-000004");

  const FrameDirectory frames(dir_.string());
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_NO_THROW((void)frames.read(0));
  expectThrowWith([&] { (void)frames.read(1); },
                  {path("frame-000001.depth.png"), "8-bit samples of PNG colour type 0"});
  expectThrowWith([&] { (void)frames.read(2); },
                  {path("frame-000002.depth.png"), "16-bit samples of PNG colour type 2"});
  expectThrowWith([&] { (void)frames.read(3); }, {path("frame-000003.depth.png"), "80x60"});
  expectThrowWith([&] { (void)frames.read(4); },
                  {path("frame-000004.depth.png"), "not a PNG file"});
}

// A small PNG may declare a huge image (a decompression bomb: 1.7 MB declaring 30000 x 30000
// was decoded to 1.9 GB before the size check); the header is checked before decoding. A device
// named like a frame is never read.
TEST_F(TempFrameDir, HugeDeclaredImagesAndDevicesAreRefusedBeforeReading) {
  writeIntrinsics();
  writeFrame("frame-000000");
  writeFrame("frame-000001");
  std::string png;
  {
    std::ifstream in(path("frame-000001.depth.png"), std::ios::binary);
    png.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  ASSERT_GT(png.size(), 33u);
  const unsigned char side[4] = {0x00, 0x00, 0x75, 0x30};  // 30000, big-endian
  for (int i = 0; i < 4; ++i) png[16 + i] = png[20 + i] = static_cast<char>(side[i]);
  writeText("frame-000001.depth.png", png);
  writePose("frame-000002");
  fs::create_symlink("/dev/zero", path("frame-000002.depth.png"));

  const FrameDirectory frames(dir_.string());
  ASSERT_EQ(frames.size(), 3u);
  expectThrowWith([&] { (void)frames.read(1); },
                  {path("frame-000001.depth.png"), "declares 30000 x 30000 pixels"});
  expectThrowWith([&] { (void)frames.read(2); },
                  {path("frame-000002.depth.png"), "not a regular file"});
}

TEST_F(TempFrameDir, WrongFirstImageFailsAtOpen) {
  writeIntrinsics();
  writeDepth("frame-000000", cv::Mat(120, 160, CV_8UC1, cv::Scalar(7)));
  writePose("frame-000000");
  expectThrowWith([&] { FrameDirectory frames(dir_.string()); },
                  {path("frame-000000.depth.png"), "8-bit samples"});
}

TEST_F(TempFrameDir, EmptyOrMissingDirectoryIsReported) {
  writeIntrinsics();
  expectThrowWith([&] { FrameDirectory frames(dir_.string()); }, {dir_.string(), "no frame-"});
  expectThrowWith([&] { FrameDirectory frames(path("does-not-exist")); },
                  {path("does-not-exist"), "not a readable directory"});
}

TEST_F(TempFrameDir, UnparsableOrDuplicateFrameNumbersAreReported) {
  writeIntrinsics();
  writeFrame("frame-abc");
  expectThrowWith([&] { FrameDirectory frames(dir_.string()); },
                  {path("frame-abc.depth.png"), "frame number"});
  fs::remove(path("frame-abc.depth.png"));
  writeFrame("frame-7");
  writeFrame("frame-007");
  expectThrowWith([&] { FrameDirectory frames(dir_.string()); }, {"same frame number"});
}

}  // namespace
}  // namespace mlmap::datasets
