#include "mcap_codec.h"

#include <lz4frame.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>

namespace mlmap::bag::mcap::detail {

std::string opcodeName(std::uint8_t opcode) {
  static const char* const kNames[] = {
      "",         "Header",        "Footer",        "Schema",     "Channel",         "Message",
      "Chunk",    "MessageIndex",  "ChunkIndex",    "Attachment", "AttachmentIndex", "Statistics",
      "Metadata", "MetadataIndex", "SummaryOffset", "DataEnd"};
  if (opcode >= 1 && opcode <= 0x0F) return kNames[opcode];
  char text[16];
  std::snprintf(text, sizeof(text), "opcode 0x%02x", opcode);
  return text;
}

void Cursor::need(std::uint64_t n, const char* what) const {
  if (n > size_ - pos_) {
    throw std::runtime_error(std::string(what) + " needs " + std::to_string(n) + " bytes, " +
                             std::to_string(size_ - pos_) + " left in the record");
  }
}

void Cursor::skip(std::uint64_t n, const char* what) {
  need(n, what);
  pos_ += static_cast<std::size_t>(n);
}

std::uint8_t Cursor::u8() {
  need(1, "a uint8 field");
  return data_[pos_++];
}

std::uint16_t Cursor::u16() {
  need(2, "a uint16 field");
  const std::uint16_t v = static_cast<std::uint16_t>(data_[pos_] | (data_[pos_ + 1] << 8));
  pos_ += 2;
  return v;
}

std::uint32_t Cursor::u32() {
  need(4, "a uint32 field");
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | data_[pos_ + static_cast<std::size_t>(i)];
  pos_ += 4;
  return v;
}

std::uint64_t Cursor::u64() {
  need(8, "a uint64 field");
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | data_[pos_ + static_cast<std::size_t>(i)];
  pos_ += 8;
  return v;
}

std::string Cursor::string() {
  const std::uint32_t n = u32();
  need(n, "a string");
  std::string s(reinterpret_cast<const char*>(data_ + pos_), n);
  pos_ += n;
  return s;
}

std::vector<std::uint8_t> Cursor::bytes32() {
  const std::uint32_t n = u32();
  need(n, "a byte array");
  std::vector<std::uint8_t> v(data_ + pos_, data_ + pos_ + n);
  pos_ += n;
  return v;
}

std::vector<std::uint8_t> Cursor::bytes64() {
  const std::uint64_t n = u64();
  need(n, "a byte array");
  std::vector<std::uint8_t> v(data_ + pos_, data_ + pos_ + n);
  pos_ += static_cast<std::size_t>(n);
  return v;
}

std::map<std::string, std::string> Cursor::stringMap() {
  const std::uint32_t n = u32();
  need(n, "a map");
  Cursor entries(data_ + pos_, n);
  pos_ += n;
  std::map<std::string, std::string> map;
  while (entries.left() > 0) {
    std::string key = entries.string();
    map[key] = entries.string();
  }
  return map;
}

std::map<std::uint16_t, std::uint64_t> Cursor::idMap() {
  const std::uint32_t n = u32();
  need(n, "a map");
  Cursor entries(data_ + pos_, n);
  pos_ += n;
  std::map<std::uint16_t, std::uint64_t> map;
  while (entries.left() > 0) {
    const std::uint16_t key = entries.u16();
    map[key] = entries.u64();
  }
  return map;
}

std::vector<std::uint8_t> Cursor::rest() {
  std::vector<std::uint8_t> v(data_ + pos_, data_ + size_);
  pos_ = size_;
  return v;
}

bool isParsedOpcode(std::uint8_t opcode) {
  return opcode >= kHeader && opcode <= kDataEnd && opcode != kChunk && opcode != kMessageIndex;
}

Record parseRecord(std::uint8_t opcode, const std::uint8_t* body, std::size_t size) {
  Cursor in(body, size);
  switch (opcode) {
    case kHeader: {
      Header r;
      r.profile = in.string();
      r.library = in.string();
      return r;
    }
    case kFooter: {
      Footer r;
      r.summary_start = in.u64();
      r.summary_offset_start = in.u64();
      r.summary_crc = in.u32();
      return r;
    }
    case kSchema: {
      Schema r;
      r.id = in.u16();
      r.name = in.string();
      r.encoding = in.string();
      r.data = in.bytes32();
      return r;
    }
    case kChannel: {
      Channel r;
      r.id = in.u16();
      r.schema_id = in.u16();
      r.topic = in.string();
      r.message_encoding = in.string();
      r.metadata = in.stringMap();
      return r;
    }
    case kMessage: {
      Message r;
      r.channel_id = in.u16();
      r.sequence = in.u32();
      r.log_time_ns = in.u64();
      r.publish_time_ns = in.u64();
      r.data = in.rest();
      return r;
    }
    case kChunkIndex: {
      ChunkIndex r;
      r.message_start_time_ns = in.u64();
      r.message_end_time_ns = in.u64();
      r.chunk_start_offset = in.u64();
      r.chunk_length = in.u64();
      r.message_index_offsets = in.idMap();
      r.message_index_length = in.u64();
      r.compression = in.string();
      r.compressed_size = in.u64();
      r.uncompressed_size = in.u64();
      return r;
    }
    case kAttachment: {
      Attachment r;
      r.log_time_ns = in.u64();
      r.create_time_ns = in.u64();
      r.name = in.string();
      r.media_type = in.string();
      r.data = in.bytes64();
      r.crc = in.u32();
      return r;
    }
    case kAttachmentIndex: {
      AttachmentIndex r;
      r.offset = in.u64();
      r.length = in.u64();
      r.log_time_ns = in.u64();
      r.create_time_ns = in.u64();
      r.data_size = in.u64();
      r.name = in.string();
      r.media_type = in.string();
      return r;
    }
    case kStatistics: {
      Statistics r;
      r.message_count = in.u64();
      r.schema_count = in.u16();
      r.channel_count = in.u32();
      r.attachment_count = in.u32();
      r.metadata_count = in.u32();
      r.chunk_count = in.u32();
      r.message_start_time_ns = in.u64();
      r.message_end_time_ns = in.u64();
      r.channel_message_counts = in.idMap();
      return r;
    }
    case kMetadata: {
      Metadata r;
      r.name = in.string();
      r.metadata = in.stringMap();
      return r;
    }
    case kMetadataIndex: {
      MetadataIndex r;
      r.offset = in.u64();
      r.length = in.u64();
      r.name = in.string();
      return r;
    }
    case kSummaryOffset: {
      SummaryOffset r;
      r.group_opcode = in.u8();
      r.group_start = in.u64();
      r.group_length = in.u64();
      return r;
    }
    case kDataEnd: {
      DataEnd r;
      r.data_section_crc = in.u32();
      return r;
    }
    default:
      throw std::logic_error("parseRecord: " + opcodeName(opcode) + " is not parsed here");
  }
}

ChunkHeader parseChunk(const std::uint8_t* body, std::size_t size) {
  Cursor in(body, size);
  ChunkHeader chunk;
  chunk.message_start_time_ns = in.u64();
  chunk.message_end_time_ns = in.u64();
  chunk.uncompressed_size = in.u64();
  chunk.uncompressed_crc = in.u32();
  chunk.compression = in.string();
  const std::uint64_t records_size = in.u64();
  if (records_size > in.left()) {
    throw std::runtime_error("its records length " + std::to_string(records_size) +
                             " exceeds the " + std::to_string(in.left()) +
                             " bytes left in the record");
  }
  chunk.records = body + in.position();
  chunk.records_size = static_cast<std::size_t>(records_size);
  return chunk;
}

namespace {

void decompressZstd(const ChunkHeader& chunk, std::vector<std::uint8_t>* out) {
  const unsigned long long declared = ZSTD_getFrameContentSize(chunk.records, chunk.records_size);
  if (declared == ZSTD_CONTENTSIZE_ERROR) throw std::runtime_error("zstd data are corrupt");
  if (declared != ZSTD_CONTENTSIZE_UNKNOWN && declared != chunk.uncompressed_size) {
    throw std::runtime_error("zstd frame holds " + std::to_string(declared) +
                             " bytes, the chunk declares " +
                             std::to_string(chunk.uncompressed_size));
  }
  const std::size_t n =
      ZSTD_decompress(out->data(), out->size(), chunk.records, chunk.records_size);
  if (ZSTD_isError(n) != 0) {
    throw std::runtime_error(std::string("zstd: ") + ZSTD_getErrorName(n) +
                             " (the chunk declares " + std::to_string(chunk.uncompressed_size) +
                             " bytes)");
  }
  if (n != out->size()) {
    throw std::runtime_error("zstd data decompress to " + std::to_string(n) +
                             " bytes, the chunk declares " + std::to_string(out->size()));
  }
}

void decompressLz4(const ChunkHeader& chunk, std::vector<std::uint8_t>* out) {
  LZ4F_dctx* context = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&context, LZ4F_VERSION)) != 0) {
    throw std::runtime_error("lz4: cannot create a decompression context");
  }
  std::size_t in_pos = 0;
  std::size_t out_pos = 0;
  std::size_t hint = 1;
  std::string error;
  while (hint != 0 && error.empty()) {
    std::size_t in_size = chunk.records_size - in_pos;
    std::size_t out_size = out->size() - out_pos;
    hint = LZ4F_decompress(context, out->data() + out_pos, &out_size, chunk.records + in_pos,
                           &in_size, nullptr);
    if (LZ4F_isError(hint) != 0) {
      error = std::string("lz4: ") + LZ4F_getErrorName(hint);
      break;
    }
    in_pos += in_size;
    out_pos += out_size;
    if (hint != 0 && in_size == 0 && out_size == 0) {
      error = in_pos == chunk.records_size
                  ? "lz4 frame ends early"
                  : "lz4 data decompress to more than the " + std::to_string(out->size()) +
                        " bytes the chunk declares";
    }
  }
  LZ4F_freeDecompressionContext(context);
  if (!error.empty()) throw std::runtime_error(error);
  if (out_pos != out->size()) {
    throw std::runtime_error("lz4 data decompress to " + std::to_string(out_pos) +
                             " bytes, the chunk declares " + std::to_string(out->size()));
  }
  if (in_pos != chunk.records_size) {
    throw std::runtime_error("lz4: " + std::to_string(chunk.records_size - in_pos) +
                             " bytes after the end of the frame");
  }
}

}  // namespace

std::vector<std::uint8_t> decompressChunk(const ChunkHeader& chunk, std::uint64_t max_bytes) {
  if (!chunk.compression.empty() && chunk.compression != "zstd" && chunk.compression != "lz4") {
    throw std::runtime_error("unknown compression '" + chunk.compression +
                             "' (known: none, zstd, lz4)");
  }
  const std::uint64_t limit = std::min(max_bytes, kMaxMcapRecordBytes);
  if (chunk.uncompressed_size > limit) {
    throw std::runtime_error("declared uncompressed size " +
                             std::to_string(chunk.uncompressed_size) + " exceeds the limit of " +
                             std::to_string(limit) + " bytes for this file");
  }
  if (chunk.compression.empty() && chunk.uncompressed_size != chunk.records_size) {
    throw std::runtime_error("uncompressed chunk holds " + std::to_string(chunk.records_size) +
                             " bytes but declares " + std::to_string(chunk.uncompressed_size));
  }
  // n compressed bytes cannot expand beyond what the codec allows (lz4: 255:1; zstd: 128 KiB per
  // block of at least 4 bytes): a larger declared size is a lie, refused before allocating it.
  const std::uint64_t max_ratio = chunk.compression == "lz4" ? 256 : 32768;
  if (!chunk.compression.empty() && chunk.uncompressed_size / max_ratio > chunk.records_size + 64) {
    throw std::runtime_error("declared uncompressed size " +
                             std::to_string(chunk.uncompressed_size) + " is impossible for " +
                             std::to_string(chunk.records_size) + " bytes of " + chunk.compression +
                             " data");
  }
  std::vector<std::uint8_t> out(static_cast<std::size_t>(chunk.uncompressed_size));
  if (chunk.compression.empty()) {
    if (!out.empty()) std::memcpy(out.data(), chunk.records, out.size());
  } else if (chunk.compression == "zstd") {
    decompressZstd(chunk, &out);
  } else {
    decompressLz4(chunk, &out);
  }
  if (chunk.uncompressed_crc != 0) {
    const std::uint32_t crc = crc32(out.data(), out.size());
    if (crc != chunk.uncompressed_crc) {
      throw std::runtime_error("CRC " + std::to_string(crc) + " of the decompressed records, " +
                               "the chunk declares " + std::to_string(chunk.uncompressed_crc));
    }
  }
  return out;
}

std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc) {
  static const std::array<std::uint32_t, 256> kTable = [] {
    std::array<std::uint32_t, 256> table{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1U) != 0 ? 0xEDB88320U ^ (c >> 1) : c >> 1;
      table[i] = c;
    }
    return table;
  }();
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = kTable[(crc ^ data[i]) & 0xFFU] ^ (crc >> 8);
  return ~crc;
}

}  // namespace mlmap::bag::mcap::detail
