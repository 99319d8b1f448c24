#include "mlmap/pictures/png_codec.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

// mlmap's libpng codec against OpenCV's imgcodecs: a PNG reader and writer that is not mlmap's.

namespace mlmap::pictures {
namespace {

/// A `type` image of random samples (noise, so the compressed data take every path of zlib), with
/// a flat band (long runs).
cv::Mat randomImage(int rows, int cols, int type, unsigned seed) {
  cv::Mat image(rows, cols, type);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  image.rowRange(rows / 3, rows / 2).setTo(cv::Scalar::all(255));
  return image;
}

std::vector<std::uint8_t> opencvEncode(const cv::Mat& image) {
  std::vector<std::uint8_t> bytes;
  EXPECT_TRUE(cv::imencode(".png", image, bytes));
  return bytes;
}

bool sameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

TEST(PngCodec, EncodesWhatOpencvDecodesForEachType) {
  for (const int type : {CV_8UC1, CV_8UC3, CV_16UC1}) {
    const cv::Mat image = randomImage(37, 53, type, 7u + static_cast<unsigned>(type));
    const std::string bytes = encodePng(image);
    const cv::Mat encoded(1, static_cast<int>(bytes.size()), CV_8UC1,
                          const_cast<char*>(bytes.data()));
    const cv::Mat back = cv::imdecode(encoded, cv::IMREAD_UNCHANGED);
    EXPECT_TRUE(sameImage(back, image)) << cv::typeToString(type);
  }
}

TEST(PngCodec, DepthImagesGetTheSameBytesAsOpencvsDefaultSettings) {
  // The same libpng and the same settings (zlib level 1, run-length strategy, "sub" filter).
  const cv::Mat image = randomImage(64, 80, CV_16UC1, 11u);
  const std::vector<std::uint8_t> reference = opencvEncode(image);
  EXPECT_EQ(std::string(reference.begin(), reference.end()), encodePng(image));
}

TEST(PngCodec, PicturesAreCompressed) {
  // A picture-like image: flat background, a few flat boxes.
  cv::Mat image(600, 800, CV_8UC3, cv::Scalar(255, 255, 255));
  image(cv::Rect(100, 100, 300, 200)).setTo(cv::Scalar(30, 120, 200));
  image(cv::Rect(500, 50, 40, 400)).setTo(cv::Scalar(200, 10, 90));
  const std::string bytes = encodePng(image);
  EXPECT_LT(bytes.size(), image.total() * image.elemSize() / 50);
}

TEST(PngCodec, DecodesWhatOpencvEncodes) {
  for (const int type : {CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3}) {
    const cv::Mat image = randomImage(41, 29, type, 3u + static_cast<unsigned>(type));
    for (const int level : {1, 9}) {  // OpenCV's own settings, and the default strategy
      std::vector<std::uint8_t> bytes;
      ASSERT_TRUE(cv::imencode(".png", image, bytes, {cv::IMWRITE_PNG_COMPRESSION, level}));
      EXPECT_TRUE(sameImage(decodePng(bytes.data(), bytes.size()), image))
          << cv::typeToString(type) << ", level " << level;
    }
  }
}

TEST(PngCodec, RoundTripsItsOwnEncoding) {
  const cv::Mat image = randomImage(480, 640, CV_16UC1, 5u);
  const std::string bytes = encodePng(image);
  EXPECT_TRUE(sameImage(decodePng(bytes.data(), bytes.size()), image));
}

TEST(PngCodec, BadDataGetAClearErrorNotACrash) {
  const cv::Mat image = randomImage(30, 40, CV_16UC1, 9u);
  const std::string good = encodePng(image);
  const auto expectError = [](const std::string& bytes, const std::string& what,
                              const char* label) {
    try {
      (void)decodePng(bytes.data(), bytes.size());
      ADD_FAILURE() << label << ": no error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << label << ": " << e.what();
    }
  };
  expectError("", "not a PNG", "empty");
  expectError("GIF89a not a png at all", "not a PNG", "wrong magic");
  expectError(good.substr(0, 20), "decodePng", "cut in the header");
  expectError(good.substr(0, good.size() / 2), "decodePng", "cut in the image data");
  std::string corrupted = good;
  corrupted[good.size() / 2] = static_cast<char>(corrupted[good.size() / 2] ^ 0x5A);  // CRC fails
  expectError(corrupted, "decodePng", "a flipped byte");
  // A colour type it does not read: RGBA (OpenCV writes 4 channels so).
  const std::vector<std::uint8_t> rgba =
      opencvEncode(cv::Mat(4, 4, CV_8UC4, cv::Scalar(1, 2, 3, 4)));
  expectError(std::string(rgba.begin(), rgba.end()), "colour type 6", "RGBA");
  EXPECT_THROW((void)encodePng(cv::Mat()), std::runtime_error);
  EXPECT_THROW((void)encodePng(cv::Mat(3, 3, CV_32FC1, cv::Scalar(1.0))), std::runtime_error);
}

}  // namespace
}  // namespace mlmap::pictures
