#pragma once
/// @file
/// The byte-level parts of the MCAP reader: little-endian fields read with their bounds checked,
/// CRC-32 and chunk decompression. Internal to src/bag.

#include "mlmap/bag/mcap.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mlmap::bag::mcap::detail {

/// Opcodes of the MCAP records.
enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};
/// Name of a record's opcode ("Chunk", ...; "opcode 0x42" for unknown ones).
std::string opcodeName(std::uint8_t opcode);

/// The 8 bytes that open and close an MCAP file.
inline constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
/// Opcode and length before every record body.
inline constexpr std::uint64_t kRecordPrefixBytes = 9;

/// Reads the fields of one record body; every read checks the bytes left and throws
/// std::runtime_error ("field X needs N bytes, M left") when they are not there.
class Cursor {
 public:
  Cursor(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t u8();
  std::uint16_t u16();
  std::uint32_t u32();
  std::uint64_t u64();
  /// A uint32 length-prefixed string.
  std::string string();
  /// A uint32 length-prefixed byte array.
  std::vector<std::uint8_t> bytes32();
  /// A uint64 length-prefixed byte array.
  std::vector<std::uint8_t> bytes64();
  /// A uint32 length-prefixed map of strings.
  std::map<std::string, std::string> stringMap();
  /// A uint32 length-prefixed map of uint16 -> uint64.
  std::map<std::uint16_t, std::uint64_t> idMap();
  /// The bytes not read yet, all of them.
  std::vector<std::uint8_t> rest();
  /// Bytes not read yet.
  [[nodiscard]] std::size_t left() const { return size_ - pos_; }
  /// Position in the body.
  [[nodiscard]] std::size_t position() const { return pos_; }
  /// Moves past `n` bytes (checked).
  void skip(std::uint64_t n, const char* what);

 private:
  void need(std::uint64_t n, const char* what) const;
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

/// Parses the body of a record of `opcode` (not Chunk, MessageIndex: see below). Trailing
/// bytes after the known fields are ignored, as the format allows. Throws on a short body.
Record parseRecord(std::uint8_t opcode, const std::uint8_t* body, std::size_t size);
/// True for the opcodes parseRecord() reads.
bool isParsedOpcode(std::uint8_t opcode);

/// A Chunk record's fields; `records` points into the parsed body.
struct ChunkHeader {
  std::uint64_t message_start_time_ns = 0;
  std::uint64_t message_end_time_ns = 0;
  std::uint64_t uncompressed_size = 0;
  std::uint32_t uncompressed_crc = 0;
  std::string compression;
  const std::uint8_t* records = nullptr;
  std::size_t records_size = 0;
};
/// Parses a Chunk record's body. Throws when its records length exceeds the body.
ChunkHeader parseChunk(const std::uint8_t* body, std::size_t size);
/// The chunk's records decompressed: exactly uncompressed_size bytes (at most `max_bytes`, itself
/// at most kMaxMcapRecordBytes) matching uncompressed_crc when it is not 0. Throws
/// std::runtime_error saying what is wrong (unknown compression, declared size too large or not
/// the real one, bad CRC, corrupt data).
std::vector<std::uint8_t> decompressChunk(const ChunkHeader& chunk,
                                          std::uint64_t max_bytes = kMaxMcapRecordBytes);

/// CRC-32 (IEEE 802.3, as MCAP uses) of `size` bytes, continuing `crc` (0 to start).
std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace mlmap::bag::mcap::detail
