#pragma once
/// @file
/// Readers for point-cloud files: PCD (PCL's format, v0.7 and v0.6 headers) and PLY.
///
/// - PCD: `DATA ascii`, `binary` and `binary_compressed` (LZF, as PCL writes it). Fields x, y, z
///   must be floating point (`TYPE F`, `SIZE` 4 or 8, `COUNT` 1); every other field, of any
///   SIZE / TYPE / COUNT, is skipped. Organised (HEIGHT > 1) or not. Binary data is little
///   endian (what PCL writes on every platform it runs on). `VIEWPOINT tx ty tz qw qx qy qz` is
///   returned as `T_C_V`, the sensor's pose in the cloud's frame.
/// - PLY: `ascii 1.0`, `binary_little_endian 1.0`, `binary_big_endian 1.0`. The `vertex` element
///   must have scalar x, y, z properties of type float / float32 or double / float64; its other
///   properties and every other element (faces with list properties included) are read past.
///
/// Points with a non-finite coordinate (NaN: no return, in organised clouds) are dropped and
/// counted. Coordinates stored as doubles are converted to float (the engine's point type).
/// Every problem (bad header, a field missing or of the wrong type, truncated data, trailing
/// data, a value that is not a number) throws std::runtime_error "<path>: <what is wrong>".

#include "mlmap/core/types.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mlmap::datasets {

/// What a point-cloud file held.
struct PointCloudFile {
  std::vector<Eigen::Vector3f> points_C;    ///< finite points in the cloud's frame C, file order
  std::size_t points_in_file = 0;           ///< points (vertices) the file declares
  std::size_t non_finite_dropped = 0;       ///< of those, dropped for a NaN / Inf coordinate
  std::uint32_t width = 0;                  ///< PCD WIDTH (PLY: the vertex count)
  std::uint32_t height = 1;                 ///< PCD HEIGHT: > 1 for an organised cloud (PLY: 1)
  Transform T_C_V = Transform::Identity();  ///< PCD VIEWPOINT: sensor pose in C (PLY: identity)
  std::string encoding;                     ///< e.g. "pcd ascii", "ply binary_big_endian"
};

/// Parses PCD content. `source_name` (the path) starts every error message.
/// @throws std::runtime_error on any problem (see the file comment).
[[nodiscard]] PointCloudFile parsePcd(const std::string& content, const std::string& source_name);

/// Parses PLY content. `source_name` (the path) starts every error message.
/// @throws std::runtime_error on any problem (see the file comment).
[[nodiscard]] PointCloudFile parsePly(const std::string& content, const std::string& source_name);

/// Reads a `.pcd` or `.ply` file (by extension, case-insensitive).
/// @throws std::runtime_error naming the path when it cannot be read, has another extension, or
///         its content is malformed.
[[nodiscard]] PointCloudFile readPointCloudFile(const std::string& path);

/// True when `file_name` ends in `.pcd` or `.ply` (case-insensitive).
[[nodiscard]] bool isPointCloudFileName(const std::string& file_name);

/// Decompresses an LZF block (the codec of PCD `binary_compressed`) into exactly
/// `expected_size` bytes. Returns false when the data is malformed or does not decode to that size.
[[nodiscard]] bool lzfDecompress(const unsigned char* in, std::size_t in_size,
                                 std::size_t expected_size, std::vector<unsigned char>* out);

/// Largest input file the dataset readers read whole [bytes] (1 GiB: some 80 million points of
/// a binary PCD).
inline constexpr std::uintmax_t kMaxInputFileBytes = std::uintmax_t{1} << 30;

/// Reads the whole regular file `path` into a string, checking its size against `max_bytes`
/// before anything is allocated. @throws std::runtime_error naming the path when it is missing,
/// not a regular file (a directory, device or pipe: /dev/zero never ends), larger than
/// `max_bytes`, or unreadable.
[[nodiscard]] std::string readFileBytes(const std::string& path,
                                        std::uintmax_t max_bytes = kMaxInputFileBytes);

}  // namespace mlmap::datasets
