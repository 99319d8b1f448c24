#pragma once
/// @file
/// MCAP files (the default storage of ROS 2 bags since Iron), read without the MCAP library:
/// the records of the format (https://mcap.dev/spec), chunks uncompressed, zstd or lz4 (frame
/// format), with or without a summary section.
///
/// Nothing read from a file is trusted: every length is checked against the bytes that remain
/// in its record and in the file before anything is allocated, a record or a decompressed chunk
/// held in memory is at most kMaxMcapRecordBytes (and a chunk at most
/// maxDecompressedChunkBytes() of the file), the index of messages at most maxIndexedMessages()
/// of the file, and a chunk must decompress to exactly the size it declares (and to its CRC
/// when it gives one). A malformed file gives a std::runtime_error
/// naming the file, the record and its byte offset.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <variant>
#include <vector>

namespace mlmap::bag {

/// The largest record, and the largest decompressed chunk, read into memory (1 GiB).
inline constexpr std::uint64_t kMaxMcapRecordBytes = std::uint64_t{1} << 30;

namespace mcap {

/// The largest chunk a file of `file_size` bytes may decompress to: 256 bytes per byte of the
/// file, at least 64 MiB (writers' chunks are about 1 MiB), at most kMaxMcapRecordBytes. A
/// small file cannot make the reader allocate a gigabyte.
std::uint64_t maxDecompressedChunkBytes(std::uint64_t file_size);

/// The most messages a file of `file_size` bytes may index: one per 2 bytes of the file (a
/// message record is at least 31 bytes before compression, so this allows 15:1 on the smallest
/// messages, a /clock stream's, and more on larger ones), at least 2^22. The index costs 24
/// bytes a message, so its memory stays within 12x the file (96 MiB for small files), however
/// well the chunks compress.
std::uint64_t maxIndexedMessages(std::uint64_t file_size);

/// Header record (opcode 0x01).
struct Header {
  std::string profile;  ///< "ros2" for ROS 2 bags
  std::string library;  ///< the writer
};
/// Footer record (0x02): where the summary section is (0: none).
struct Footer {
  std::uint64_t summary_start = 0;
  std::uint64_t summary_offset_start = 0;
  std::uint32_t summary_crc = 0;
};
/// Schema record (0x03): a message type ("sensor_msgs/msg/PointCloud2", encoding "ros2msg").
struct Schema {
  std::uint16_t id = 0;
  std::string name;
  std::string encoding;
  std::vector<std::uint8_t> data;  ///< the type's definition text
};
/// Channel record (0x04): a topic, its message encoding ("cdr") and schema (0: schemaless).
struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;
  std::map<std::string, std::string> metadata;
};
/// Message record (0x05).
struct Message {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time_ns = 0;      ///< when it was recorded [ns since the epoch]
  std::uint64_t publish_time_ns = 0;  ///< when it was published [ns]
  std::vector<std::uint8_t> data;     ///< the serialised message
};
/// Chunk index record (0x08): where a chunk is and what it holds.
struct ChunkIndex {
  std::uint64_t message_start_time_ns = 0;
  std::uint64_t message_end_time_ns = 0;
  std::uint64_t chunk_start_offset = 0;  ///< file offset of the Chunk record
  std::uint64_t chunk_length = 0;        ///< bytes of the Chunk record (opcode and length included)
  std::map<std::uint16_t, std::uint64_t> message_index_offsets;  ///< channel -> MessageIndex offset
  std::uint64_t message_index_length = 0;
  std::string compression;  ///< "", "zstd" or "lz4"
  std::uint64_t compressed_size = 0;
  std::uint64_t uncompressed_size = 0;
};
/// Attachment record (0x09).
struct Attachment {
  std::uint64_t log_time_ns = 0;
  std::uint64_t create_time_ns = 0;
  std::string name;
  std::string media_type;
  std::vector<std::uint8_t> data;
  std::uint32_t crc = 0;
};
/// Attachment index record (0x0A).
struct AttachmentIndex {
  std::uint64_t offset = 0;
  std::uint64_t length = 0;
  std::uint64_t log_time_ns = 0;
  std::uint64_t create_time_ns = 0;
  std::uint64_t data_size = 0;
  std::string name;
  std::string media_type;
};
/// Statistics record (0x0B).
struct Statistics {
  std::uint64_t message_count = 0;
  std::uint16_t schema_count = 0;
  std::uint32_t channel_count = 0;
  std::uint32_t attachment_count = 0;
  std::uint32_t metadata_count = 0;
  std::uint32_t chunk_count = 0;
  std::uint64_t message_start_time_ns = 0;
  std::uint64_t message_end_time_ns = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};
/// Metadata record (0x0C).
struct Metadata {
  std::string name;
  std::map<std::string, std::string> metadata;
};
/// Metadata index record (0x0D).
struct MetadataIndex {
  std::uint64_t offset = 0;
  std::uint64_t length = 0;
  std::string name;
};
/// Summary offset record (0x0E): where the records of one opcode are in the summary.
struct SummaryOffset {
  std::uint8_t group_opcode = 0;
  std::uint64_t group_start = 0;
  std::uint64_t group_length = 0;
};
/// Data end record (0x0F).
struct DataEnd {
  std::uint32_t data_section_crc = 0;
};

/// A record as scanRecords() yields it (Chunk records are yielded as their content, Message
/// index records are skipped).
using Record =
    std::variant<Header, Footer, Schema, Channel, Message, ChunkIndex, Attachment, AttachmentIndex,
                 Statistics, Metadata, MetadataIndex, SummaryOffset, DataEnd>;

/// How far a linear scan got.
struct ScanResult {
  bool complete = false;  ///< the closing magic was reached
  std::string warning;    ///< why not, when not: where the file was cut off
};

/// Reads every record of the MCAP file `path` in file order and hands each to `visit`: the
/// records inside each chunk in their place (decompressed), message indexes left out, unknown
/// opcodes skipped. A file that ends early (inside a record, or without the closing magic) is
/// not an error: the records before the cut are visited and the result says where it was cut.
/// @throws std::runtime_error naming the file and the byte offset on a wrong magic, a record
///         that contradicts itself, or a chunk that does not decompress to what it declares.
ScanResult scanRecords(const std::string& path, const std::function<void(const Record&)>& visit);

/// Where one message is: in the data section or inside a chunk.
struct MessageLocation {
  std::uint64_t log_time_ns = 0;
  std::uint16_t channel_id = 0;
  std::uint32_t chunk = 0;   ///< index into the reader's chunks + 1; 0: not in a chunk
  std::uint64_t offset = 0;  ///< of the Message record: in the file, or in the decompressed chunk
};

/// An MCAP file opened for reading messages by index in log-time order. Opening reads the
/// summary section (schemas, channels, chunk indexes) and the message indexes when the file has
/// them; otherwise (no summary or chunk index, or a file cut off before its footer) it scans
/// the file once, decompressing each chunk to find its messages, and records a warning when the
/// file was cut off. Only the locations of the messages are kept (24 bytes each), never their
/// data; read() decompresses the chunk of the message it reads (the last one stays cached).
/// read() may be called from several threads.
class McapReader {
 public:
  /// Opens `path`. @throws std::runtime_error naming the file and offset when it is not MCAP or
  /// is malformed.
  explicit McapReader(const std::string& path);
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  [[nodiscard]] const std::string& path() const { return path_; }
  /// Schemas by id.
  [[nodiscard]] const std::map<std::uint16_t, Schema>& schemas() const { return schemas_; }
  /// Channels by id.
  [[nodiscard]] const std::map<std::uint16_t, Channel>& channels() const { return channels_; }
  /// Every message's location, sorted by log time (ties in file order).
  [[nodiscard]] const std::vector<MessageLocation>& messages() const { return messages_; }
  /// True when the summary section and the chunk indexes were used (no full scan).
  [[nodiscard]] bool usedSummary() const { return used_summary_; }
  /// What was wrong but did not stop the reading (e.g. the file was cut off).
  [[nodiscard]] const std::vector<std::string>& warnings() const { return warnings_; }
  /// Message `i` of messages(). @throws std::out_of_range for a bad index and
  /// std::runtime_error (file and offset) when its record or chunk is malformed.
  [[nodiscard]] Message read(std::size_t i) const;

 private:
  struct ChunkSpan {
    std::uint64_t offset = 0;  ///< of the Chunk record in the file
    std::uint64_t length = 0;  ///< bytes of the record, opcode and length included
  };
  bool openIndexed();
  void openByScan(bool closed);
  void indexChunk(std::uint32_t chunk, const std::vector<std::uint8_t>& records,
                  std::uint64_t chunk_offset);
  const std::vector<std::uint8_t>& chunkRecords(std::uint32_t chunk) const;

  std::string path_;
  int fd_ = -1;
  std::uint64_t file_size_ = 0;
  std::map<std::uint16_t, Schema> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  std::vector<ChunkSpan> chunks_;
  std::vector<MessageLocation> messages_;
  bool used_summary_ = false;
  std::vector<std::string> warnings_;
  mutable std::mutex cache_mutex_;
  mutable std::uint32_t cached_chunk_ = 0;  ///< 0: none
  mutable std::vector<std::uint8_t> cached_records_;
};

}  // namespace mcap
}  // namespace mlmap::bag
