#pragma once
/// @file
/// Reader for the RGB-D "frame directory" layout used by 7-Scenes, 3DMatch and tsdf-fusion:
///
///   frame-000015.depth.png   16-bit PNG, z-depth in millimetres, 0 (and 65535) = no data
///   frame-000015.pose.txt    4x4 row-major camera-to-world matrix in metres
///   intrinsics.K.txt         3x3 K matrix (or `camera-intrinsics.txt`, same content)
///
/// The camera is the body here: frames come out with `T_W_B` = the pose file and `T_B_S` =
/// identity, so `T_W_B * T_B_S` maps optical-frame points (x right, y down, z forward) to the
/// world.

#include "mlmap/core/types.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mlmap::datasets {

/// Nominal frame rate of the layout; a frame's stamp is its frame number divided by this.
inline constexpr double kFrameDirectoryRate_hz = 30.0;

/// Depth value that some recordings (7-Scenes, 3DMatch) use, besides 0, for "no measurement".
inline constexpr std::uint16_t kNoDepthMarker_mm = 65535;

/// Tolerance on `R^T R - I` (max abs entry) when validating the rotation of a pose file.
inline constexpr double kPoseOrthonormalTolerance = 1e-3;

/// Parses the content of an intrinsics file (`intrinsics.K.txt`): 9 finite numbers, a skew-free
/// pinhole K `[fx 0 cx; 0 fy cy; 0 0 1]` with fx, fy > 0 (width and height are left 0).
/// @throws std::runtime_error naming `path` and what is wrong.
[[nodiscard]] PinholeIntrinsics parseIntrinsicsK(const std::string& text, const std::string& path);

/// Parses the content of a pose file (`frame-N.pose.txt`): a 4x4 row-major camera-to-world
/// matrix of finite numbers, last row `0 0 0 1`, a rotation within kPoseOrthonormalTolerance
/// (re-orthonormalised).
/// @throws std::runtime_error naming `path` and what is wrong.
[[nodiscard]] Transform parsePoseMatrix(const std::string& text, const std::string& path);

/// A directory of `frame-N.depth.png` / `frame-N.pose.txt` pairs with shared pinhole intrinsics.
///
/// The constructor checks the layout (every depth image has a pose file, the intrinsics file is
/// well formed, the first image is readable) and throws std::runtime_error naming the offending
/// path otherwise. Per-frame content (image type and size, pose validity) is checked by read().
class FrameDirectory {
 public:
  /// Opens `dir`: lists `frame-*.depth.png` sorted by frame number, requires a matching
  /// `.pose.txt` for each, reads the intrinsics from `intrinsics.K.txt` (preferred) or
  /// `camera-intrinsics.txt` and the image size from the first depth image.
  /// @throws std::runtime_error when the directory, a pose file, the intrinsics or the first
  ///         image is missing or malformed, or when there are no frames.
  explicit FrameDirectory(const std::string& dir);

  /// Number of frames.
  [[nodiscard]] std::size_t size() const;

  /// Camera intrinsics (K from the intrinsics file, width/height from the first image).
  [[nodiscard]] const PinholeIntrinsics& intrinsics() const;

  /// Directory this reader was opened on, as given to the constructor.
  [[nodiscard]] const std::string& directory() const;

  /// Name of frame `i` without extension, e.g. "frame-000015".
  /// @throws std::out_of_range when `i >= size()`.
  [[nodiscard]] std::string frameName(std::size_t i) const;

  /// Frame number of frame `i` as written in its file name, e.g. 15 for "frame-000015".
  /// @throws std::out_of_range when `i >= size()`.
  [[nodiscard]] long frameNumber(std::size_t i) const;

  /// Loads frame `i`: `kUint16Millimetres` depth (row-major, 65535 rewritten to 0), `stamp_s` =
  /// frame number / 30, `T_W_B` = the pose file (re-orthonormalised), `T_B_S` = identity.
  /// @throws std::out_of_range when `i >= size()`.
  /// @throws std::runtime_error when the image is unreadable, not 16-bit single channel, not of
  ///         the intrinsics size, or the pose file is not a valid rigid transform.
  [[nodiscard]] DepthFrame read(std::size_t i) const;

 private:
  /// One `frame-N` entry of the directory.
  struct Entry {
    long number = 0;         ///< N as parsed from the file name
    std::string name;        ///< "frame-N" with the original zero padding
    std::string depth_path;  ///< full path of the depth PNG
    std::string pose_path;   ///< full path of the pose text file
  };

  const Entry& entry(std::size_t i) const;

  std::string dir_;
  std::vector<Entry> entries_;
  PinholeIntrinsics intrinsics_;
};

}  // namespace mlmap::datasets
