#include "mlmap/datasets/frame_directory.h"

#include "mlmap/datasets/point_cloud_file.h"
#include "mlmap/pictures/png_codec.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace mlmap::datasets {
namespace {

namespace fs = std::filesystem;

constexpr const char* kFramePrefix = "frame-";
constexpr const char* kDepthSuffix = ".depth.png";
constexpr const char* kPoseSuffix = ".pose.txt";
constexpr const char* kIntrinsicsFileNames[] = {"intrinsics.K.txt", "camera-intrinsics.txt"};
/// Allowed deviation of the fixed entries of K (zeros, the final 1) and of the pose's last row.
constexpr double kFixedEntryTolerance = 1e-6;

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// Reads every whitespace-separated token of a text file's content as a finite double.
/// `what` describes the content for error messages ("intrinsics", "pose"), `path` names the file.
std::vector<double> parseNumbers(const std::string& text, const std::string& path,
                                 const char* what) {
  std::istringstream in(text);
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    errno = 0;
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') {
      throw std::runtime_error("FrameDirectory: " + std::string(what) + " file '" + path +
                               "': token " + std::to_string(values.size() + 1) + " ('" + token +
                               "') is not a number");
    }
    if (!std::isfinite(value) || errno == ERANGE) {
      throw std::runtime_error("FrameDirectory: " + std::string(what) + " file '" + path +
                               "': value " + std::to_string(values.size() + 1) + " ('" + token +
                               "') is not finite");
    }
    values.push_back(value);
  }
  return values;
}

}  // namespace

PinholeIntrinsics parseIntrinsicsK(const std::string& text, const std::string& path) {
  const std::vector<double> k = parseNumbers(text, path, "intrinsics");
  if (k.size() != 9) {
    throw std::runtime_error("FrameDirectory: intrinsics file '" + path +
                             "' must hold a 3x3 K matrix (9 numbers), found " +
                             std::to_string(k.size()) + " numbers");
  }
  PinholeIntrinsics intrinsics;
  intrinsics.fx = k[0];
  intrinsics.fy = k[4];
  intrinsics.cx = k[2];
  intrinsics.cy = k[5];
  if (!(intrinsics.fx > 0.0) || !(intrinsics.fy > 0.0)) {
    throw std::runtime_error("FrameDirectory: intrinsics file '" + path +
                             "': focal lengths must be positive (fx = " + std::to_string(k[0]) +
                             ", fy = " + std::to_string(k[4]) + ")");
  }
  const bool pinhole_shape =
      std::abs(k[1]) <= kFixedEntryTolerance && std::abs(k[3]) <= kFixedEntryTolerance &&
      std::abs(k[6]) <= kFixedEntryTolerance && std::abs(k[7]) <= kFixedEntryTolerance &&
      std::abs(k[8] - 1.0) <= kFixedEntryTolerance;
  if (!pinhole_shape) {
    throw std::runtime_error("FrameDirectory: intrinsics file '" + path +
                             "' is not a skew-free pinhole K [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  return intrinsics;
}

Transform parsePoseMatrix(const std::string& text, const std::string& path) {
  const std::vector<double> m = parseNumbers(text, path, "pose");
  if (m.size() != 16) {
    throw std::runtime_error("FrameDirectory: pose file '" + path +
                             "' must hold a 4x4 matrix (16 numbers), found " +
                             std::to_string(m.size()) + " numbers");
  }
  const Eigen::Matrix4d matrix =
      Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(m.data());
  const Eigen::RowVector4d last_row = matrix.row(3);
  if ((last_row - Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0)).cwiseAbs().maxCoeff() >
      kFixedEntryTolerance) {
    throw std::runtime_error("FrameDirectory: pose file '" + path + "': last row must be 0 0 0 1");
  }
  const Eigen::Matrix3d rotation = matrix.topLeftCorner<3, 3>();
  const double orthonormality_error =
      (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthonormality_error > kPoseOrthonormalTolerance || rotation.determinant() <= 0.0) {
    std::ostringstream message;
    message << "FrameDirectory: pose file '" << path
            << "': rotation part is not a rotation (max |R^T R - I| = " << orthonormality_error
            << ", det = " << rotation.determinant() << ", tolerance " << kPoseOrthonormalTolerance
            << ")";
    throw std::runtime_error(message.str());
  }
  Transform pose = Transform::Identity();
  pose.linear() = Eigen::Quaterniond(rotation).normalized().toRotationMatrix();
  pose.translation() = matrix.topRightCorner<3, 1>();
  return pose;
}

namespace {

/// Largest depth image read [pixels] (4096 x 4096; depth sensors give at most about 2 MP) and
/// its largest side: checked in the PNG header, before anything is decoded.
constexpr std::uint64_t kMaxDepthPixels = std::uint64_t{1} << 24;
constexpr std::uint32_t kMaxDepthSide = 16384;
/// Largest depth PNG file [bytes]: a 16 MP 16-bit image stored uncompressed, with room to spare.
constexpr std::uintmax_t kMaxDepthFileBytes = std::uintmax_t{64} << 20;

std::uint32_t bigEndian32(const std::string& bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(bytes[at + i]);
  return v;
}

/// Checks the PNG signature and header (IHDR) of `bytes` before decoding: a 16-bit grayscale
/// image within kMaxDepthSide and kMaxDepthPixels (a small file may declare a huge image).
void checkDepthPngHeader(const std::string& bytes, const std::string& path) {
  static const char kSignature[] = "\x89PNG\r\n\x1a\n";
  constexpr std::size_t kHeaderEnd = 33;  // signature 8, chunk length 4, "IHDR" 4, data 13, CRC 4
  if (bytes.size() < kHeaderEnd || bytes.compare(0, 8, kSignature, 8) != 0 ||
      bytes.compare(12, 4, "IHDR") != 0) {
    throw std::runtime_error("FrameDirectory: depth image '" + path +
                             "' is not a PNG file (depth images are 16-bit PNG)");
  }
  const std::uint32_t width = bigEndian32(bytes, 16);
  const std::uint32_t height = bigEndian32(bytes, 20);
  const int bit_depth = static_cast<unsigned char>(bytes[24]);
  const int color_type = static_cast<unsigned char>(bytes[25]);
  if (width == 0 || height == 0 || width > kMaxDepthSide || height > kMaxDepthSide ||
      std::uint64_t{width} * height > kMaxDepthPixels) {
    throw std::runtime_error("FrameDirectory: depth image '" + path + "' declares " +
                             std::to_string(width) + " x " + std::to_string(height) +
                             " pixels; at most " + std::to_string(kMaxDepthPixels) +
                             " pixels and " + std::to_string(kMaxDepthSide) + " per side are read");
  }
  if (bit_depth != 16 || color_type != 0) {
    throw std::runtime_error("FrameDirectory: depth image '" + path + "' has " +
                             std::to_string(bit_depth) + "-bit samples of PNG colour type " +
                             std::to_string(color_type) +
                             ", expected 16-bit grayscale (type 0, millimetres)");
  }
}

/// Loads a depth PNG and checks it is 16-bit single channel; its header is checked before it
/// is decoded.
cv::Mat loadDepthImage(const std::string& path) {
  const std::string bytes = readFileBytes(path, kMaxDepthFileBytes);
  checkDepthPngHeader(bytes, path);
  cv::Mat image;
  try {
    image = pictures::decodePng(bytes.data(), bytes.size());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("FrameDirectory: cannot decode depth image '" + path +
                             "' (a corrupted PNG: " + e.what() + ")");
  }
  if (image.type() != CV_16UC1) {
    throw std::runtime_error("FrameDirectory: depth image '" + path + "' is " +
                             cv::typeToString(image.type()) +
                             ", expected 16-bit single channel (CV_16UC1, millimetres)");
  }
  return image;
}

}  // namespace

FrameDirectory::FrameDirectory(const std::string& dir) : dir_(dir) {
  std::error_code error;
  if (!fs::is_directory(dir, error)) {
    throw std::runtime_error("FrameDirectory: '" + dir + "' is not a readable directory");
  }

  const std::string prefix = kFramePrefix;
  const std::string depth_suffix = kDepthSuffix;
  fs::directory_iterator it(dir, error);
  if (error) {
    throw std::runtime_error("FrameDirectory: cannot list '" + dir + "': " + error.message());
  }
  for (const fs::directory_entry& file : it) {
    const std::string file_name = file.path().filename().string();
    if (file_name.rfind(prefix, 0) != 0 || !endsWith(file_name, depth_suffix)) {
      continue;
    }
    Entry entry;
    entry.name = file_name.substr(0, file_name.size() - depth_suffix.size());
    const std::string digits = entry.name.substr(prefix.size());
    const bool all_digits =
        !digits.empty() && digits.size() <= 12 &&
        std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; });
    if (!all_digits) {
      throw std::runtime_error("FrameDirectory: cannot parse a frame number from '" +
                               file.path().string() + "' (expected frame-<digits>.depth.png)");
    }
    entry.number = std::stol(digits);
    entry.depth_path = file.path().string();
    entry.pose_path = (fs::path(dir) / (entry.name + kPoseSuffix)).string();
    entries_.push_back(std::move(entry));
  }
  if (entries_.empty()) {
    throw std::runtime_error("FrameDirectory: no frame-*.depth.png files in '" + dir + "'");
  }
  std::sort(entries_.begin(), entries_.end(),
            [](const Entry& a, const Entry& b) { return a.number < b.number; });
  for (std::size_t i = 1; i < entries_.size(); ++i) {
    if (entries_[i].number == entries_[i - 1].number) {
      throw std::runtime_error("FrameDirectory: '" + entries_[i - 1].depth_path + "' and '" +
                               entries_[i].depth_path + "' have the same frame number");
    }
  }
  for (const Entry& entry : entries_) {
    if (!fs::is_regular_file(entry.pose_path, error)) {
      throw std::runtime_error("FrameDirectory: missing pose file '" + entry.pose_path +
                               "' for depth image '" + entry.depth_path + "'");
    }
  }

  std::string intrinsics_path;
  for (const char* name : kIntrinsicsFileNames) {
    const fs::path candidate = fs::path(dir) / name;
    if (fs::is_regular_file(candidate, error)) {
      intrinsics_path = candidate.string();
      break;
    }
  }
  if (intrinsics_path.empty()) {
    throw std::runtime_error("FrameDirectory: no intrinsics file in '" + dir +
                             "' (expected intrinsics.K.txt or camera-intrinsics.txt)");
  }
  intrinsics_ = parseIntrinsicsK(readFileBytes(intrinsics_path), intrinsics_path);

  const cv::Mat first = loadDepthImage(entries_.front().depth_path);
  intrinsics_.width = first.cols;
  intrinsics_.height = first.rows;
}

std::size_t FrameDirectory::size() const { return entries_.size(); }

const PinholeIntrinsics& FrameDirectory::intrinsics() const { return intrinsics_; }

const std::string& FrameDirectory::directory() const { return dir_; }

std::string FrameDirectory::frameName(std::size_t i) const { return entry(i).name; }

long FrameDirectory::frameNumber(std::size_t i) const { return entry(i).number; }

const FrameDirectory::Entry& FrameDirectory::entry(std::size_t i) const {
  if (i >= entries_.size()) {
    throw std::out_of_range("FrameDirectory: frame index " + std::to_string(i) + " out of range (" +
                            std::to_string(entries_.size()) + " frames in '" + dir_ + "')");
  }
  return entries_[i];
}

DepthFrame FrameDirectory::read(std::size_t i) const {
  const Entry& e = entry(i);
  const cv::Mat image = loadDepthImage(e.depth_path);
  if (image.cols != intrinsics_.width || image.rows != intrinsics_.height) {
    throw std::runtime_error("FrameDirectory: depth image '" + e.depth_path + "' is " +
                             std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                             ", expected " + std::to_string(intrinsics_.width) + "x" +
                             std::to_string(intrinsics_.height) + " like the first frame");
  }

  DepthFrame frame;
  frame.T_W_B = parsePoseMatrix(readFileBytes(e.pose_path), e.pose_path);
  frame.T_B_S = Transform::Identity();
  frame.stamp_s = static_cast<double>(e.number) / kFrameDirectoryRate_hz;
  frame.encoding = DepthEncoding::kUint16Millimetres;
  frame.intrinsics = intrinsics_;
  frame.depth_mm.resize(static_cast<std::size_t>(image.rows) *
                        static_cast<std::size_t>(image.cols));
  for (int row = 0; row < image.rows; ++row) {
    const std::uint16_t* src = image.ptr<std::uint16_t>(row);
    std::uint16_t* dst = frame.depth_mm.data() + static_cast<std::size_t>(row) * image.cols;
    for (int col = 0; col < image.cols; ++col) {
      dst[col] = src[col] == kNoDepthMarker_mm ? std::uint16_t{0} : src[col];
    }
  }
  return frame;
}

}  // namespace mlmap::datasets
