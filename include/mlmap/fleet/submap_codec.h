#pragma once
/// @file
/// The compact form of one submap's occupied voxels on the fleet's link (mlmap_msgs/Submap,
/// layout version 1, idl/README.md): the voxel offsets inside the submap (x-major, z fastest,
/// ascending) as the gaps between them in LEB128 varints (one byte for gaps below 128, most of
/// them along a surface), then the log-odds as little-endian int16 in units of 0.001 (LogOddsQ).
/// The whole is compressed with zstd when that makes it smaller. Decoding checks every size
/// before it allocates anything, so a sample that lies about its sizes or is a decompression
/// bomb is refused with a reason, never followed.

#include "mlmap/global/global_map.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace mlmap::fleet {

/// How `SubmapPayload::data` is stored.
enum class SubmapEncoding : std::uint8_t {
  kRaw = 0,   ///< the varint offsets and int16 log-odds as they are
  kZstd = 1,  ///< one zstd frame holding them (its content size in the frame header)
};

/// One submap's occupied voxels, encoded.
struct SubmapPayload {
  std::uint32_t voxel_count = 0;  ///< occupied voxels
  SubmapEncoding encoding = SubmapEncoding::kRaw;
  std::uint32_t raw_size = 0;      ///< bytes of the raw form (== data.size() when kRaw)
  std::vector<std::uint8_t> data;  ///< raw or zstd form
};

/// Why a payload was refused.
enum class SubmapDecodeError {
  kNone,
  kUnknownEncoding,  ///< encoding other than kRaw / kZstd
  kTooManyVoxels,    ///< voxel_count beyond the submap's voxels
  kSizeMismatch,     ///< raw_size impossible for voxel_count, or kRaw data of another size
  kBadCompression,   ///< not one zstd frame whose content size is raw_size
  kBadOffsets,       ///< a varint too long, an offset not ascending or beyond the submap
  kTrailingBytes,    ///< bytes left after the last value
};
const char* toString(SubmapDecodeError error);

/// The longest varint of an offset below 2^32.
inline constexpr std::size_t kMaxVarintBytes = 5;

/// Encodes `records` (ascending offsets, as GlobalMap holds them), compressed when smaller.
/// `compression_level`: zstd's level (1 fastest .. 19).
SubmapPayload encodeSubmapVoxels(const std::vector<VoxelRecord>& records,
                                 int compression_level = 3);

/// Decodes a payload of a submap of `voxels_per_submap` voxels into `records` (ascending
/// offsets). Allocates at most raw_size bytes, which is checked against voxel_count first
/// (3 .. 7 bytes per voxel), and voxel_count against the submap. On error `records` is empty.
SubmapDecodeError decodeSubmapVoxels(std::uint32_t voxel_count, std::uint8_t encoding,
                                     std::uint32_t raw_size, const std::uint8_t* data,
                                     std::size_t data_size, std::uint64_t voxels_per_submap,
                                     std::vector<VoxelRecord>* records);

}  // namespace mlmap::fleet
