#include "mlmap/fleet/submap_codec.h"

#include <zstd.h>

namespace mlmap::fleet {

const char* toString(SubmapDecodeError error) {
  switch (error) {
    case SubmapDecodeError::kNone:
      return "ok";
    case SubmapDecodeError::kUnknownEncoding:
      return "unknown encoding";
    case SubmapDecodeError::kTooManyVoxels:
      return "more voxels than the submap holds";
    case SubmapDecodeError::kSizeMismatch:
      return "sizes that disagree";
    case SubmapDecodeError::kBadCompression:
      return "not one zstd frame of the stated size";
    case SubmapDecodeError::kBadOffsets:
      return "voxel offsets not ascending within the submap";
    case SubmapDecodeError::kTrailingBytes:
      return "bytes after the last value";
  }
  return "?";
}

namespace {

/// Bytes of the raw form of `count` voxels: at least one varint byte and two value bytes each.
constexpr std::uint64_t kMinBytesPerVoxel = 1 + sizeof(LogOddsQ);
constexpr std::uint64_t kMaxBytesPerVoxel = kMaxVarintBytes + sizeof(LogOddsQ);

void appendVarint(std::uint32_t v, std::vector<std::uint8_t>* out) {
  while (v >= 0x80) {
    out->push_back(static_cast<std::uint8_t>(v | 0x80));
    v >>= 7;
  }
  out->push_back(static_cast<std::uint8_t>(v));
}

/// Reads a varint at `*pos` of [begin, end); false when it runs past `end` or beyond 32 bits.
bool readVarint(const std::uint8_t* data, std::size_t size, std::size_t* pos, std::uint32_t* v) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < kMaxVarintBytes; ++i) {
    if (*pos >= size) return false;
    const std::uint8_t byte = data[(*pos)++];
    value |= static_cast<std::uint64_t>(byte & 0x7f) << (7 * i);
    if ((byte & 0x80) == 0) {
      if (value > 0xffffffffu) return false;
      *v = static_cast<std::uint32_t>(value);
      return true;
    }
  }
  return false;
}

/// Parses the raw form.
SubmapDecodeError parseRaw(const std::uint8_t* data, std::size_t size, std::uint32_t count,
                           std::uint64_t voxels_per_submap, std::vector<VoxelRecord>* records) {
  records->resize(count);
  std::size_t pos = 0;
  std::uint64_t next = 0;  // the smallest offset the next voxel may have
  for (std::uint32_t i = 0; i < count; ++i) {
    std::uint32_t gap = 0;
    if (!readVarint(data, size, &pos, &gap)) return SubmapDecodeError::kBadOffsets;
    const std::uint64_t offset = next + gap;
    if (offset >= voxels_per_submap) return SubmapDecodeError::kBadOffsets;
    (*records)[i].offset = static_cast<std::uint32_t>(offset);
    next = offset + 1;
  }
  if (size - pos != std::size_t{count} * sizeof(LogOddsQ)) {
    return size - pos < std::size_t{count} * sizeof(LogOddsQ) ? SubmapDecodeError::kSizeMismatch
                                                              : SubmapDecodeError::kTrailingBytes;
  }
  for (std::uint32_t i = 0; i < count; ++i, pos += 2) {
    const auto u = static_cast<std::uint16_t>(data[pos] | (data[pos + 1] << 8));
    (*records)[i].log_odds = static_cast<LogOddsQ>(u);
  }
  return SubmapDecodeError::kNone;
}

}  // namespace

SubmapPayload encodeSubmapVoxels(const std::vector<VoxelRecord>& records, int compression_level) {
  SubmapPayload out;
  out.voxel_count = static_cast<std::uint32_t>(records.size());
  std::vector<std::uint8_t> raw;
  raw.reserve(records.size() * 3);
  std::uint32_t next = 0;
  for (const VoxelRecord& r : records) {
    appendVarint(r.offset - next, &raw);
    next = r.offset + 1;
  }
  for (const VoxelRecord& r : records) {
    const auto u = static_cast<std::uint16_t>(r.log_odds);
    raw.push_back(static_cast<std::uint8_t>(u & 0xff));
    raw.push_back(static_cast<std::uint8_t>(u >> 8));
  }
  out.raw_size = static_cast<std::uint32_t>(raw.size());
  if (!raw.empty()) {
    std::vector<std::uint8_t> packed(ZSTD_compressBound(raw.size()));
    const std::size_t n =
        ZSTD_compress(packed.data(), packed.size(), raw.data(), raw.size(), compression_level);
    if (ZSTD_isError(n) == 0 && n < raw.size()) {
      packed.resize(n);
      out.encoding = SubmapEncoding::kZstd;
      out.data = std::move(packed);
      return out;
    }
  }
  out.data = std::move(raw);
  return out;
}

SubmapDecodeError decodeSubmapVoxels(std::uint32_t voxel_count, std::uint8_t encoding,
                                     std::uint32_t raw_size, const std::uint8_t* data,
                                     std::size_t data_size, std::uint64_t voxels_per_submap,
                                     std::vector<VoxelRecord>* records) {
  records->clear();
  if (encoding != static_cast<std::uint8_t>(SubmapEncoding::kRaw) &&
      encoding != static_cast<std::uint8_t>(SubmapEncoding::kZstd)) {
    return SubmapDecodeError::kUnknownEncoding;
  }
  if (voxel_count > voxels_per_submap) return SubmapDecodeError::kTooManyVoxels;
  if (raw_size < voxel_count * kMinBytesPerVoxel || raw_size > voxel_count * kMaxBytesPerVoxel) {
    return SubmapDecodeError::kSizeMismatch;
  }
  SubmapDecodeError error = SubmapDecodeError::kNone;
  if (encoding == static_cast<std::uint8_t>(SubmapEncoding::kRaw)) {
    if (data_size != raw_size) return SubmapDecodeError::kSizeMismatch;
    error = parseRaw(data, data_size, voxel_count, voxels_per_submap, records);
  } else {
    // The frame must say its content size, and it must be raw_size: only then is the buffer
    // (bounded by the voxel count above) allocated and filled, never beyond it.
    const unsigned long long content = ZSTD_getFrameContentSize(data, data_size);
    if (content == ZSTD_CONTENTSIZE_UNKNOWN || content == ZSTD_CONTENTSIZE_ERROR ||
        content != raw_size || ZSTD_findFrameCompressedSize(data, data_size) != data_size) {
      return SubmapDecodeError::kBadCompression;
    }
    std::vector<std::uint8_t> raw(raw_size);
    const std::size_t n = ZSTD_decompress(raw.data(), raw.size(), data, data_size);
    if (ZSTD_isError(n) != 0 || n != raw_size) return SubmapDecodeError::kBadCompression;
    error = parseRaw(raw.data(), raw.size(), voxel_count, voxels_per_submap, records);
  }
  if (error != SubmapDecodeError::kNone) records->clear();
  return error;
}

}  // namespace mlmap::fleet
