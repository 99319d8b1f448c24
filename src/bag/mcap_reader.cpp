#include "mlmap/bag/mcap.h"

#include "mcap_codec.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>
#include <tuple>

namespace mlmap::bag::mcap {
namespace {

using detail::kRecordPrefixBytes;

/// An open file descriptor, closed on destruction.
class File {
 public:
  explicit File(const std::string& path) : path_(path) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0)
      throw std::runtime_error(path + ": cannot open: " + std::generic_category().message(errno));
    struct stat st {};
    if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
      ::close(fd_);
      throw std::runtime_error(path + ": not a regular file");
    }
    size_ = static_cast<std::uint64_t>(st.st_size);
  }
  ~File() {
    if (fd_ >= 0) ::close(fd_);
  }
  File(const File&) = delete;
  File& operator=(const File&) = delete;
  /// Releases the descriptor to the caller.
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }
  [[nodiscard]] int fd() const { return fd_; }
  [[nodiscard]] std::uint64_t size() const { return size_; }

 private:
  std::string path_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

/// Reads `size` bytes at `offset` of `fd` into `out` (the caller checked they are in the file).
void readAt(int fd, const std::string& path, std::uint64_t offset, std::size_t size,
            std::uint8_t* out) {
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::pread(fd, out + done, size - done, static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      throw std::runtime_error(
          path + ": read error at byte " + std::to_string(offset + done) +
          (n < 0 ? ": " + std::generic_category().message(errno) : ": end of file"));
    }
    done += static_cast<std::size_t>(n);
  }
}

std::vector<std::uint8_t> readBytes(int fd, const std::string& path, std::uint64_t offset,
                                    std::uint64_t size) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  readAt(fd, path, offset, bytes.size(), bytes.data());
  return bytes;
}

bool isMagic(const std::uint8_t* bytes) { return std::memcmp(bytes, detail::kMagic, 8) == 0; }

std::string where(const std::string& path, std::uint8_t opcode, std::uint64_t offset) {
  return path + ": " + detail::opcodeName(opcode) + " record at byte " + std::to_string(offset);
}

/// A record's opcode and body length, read at `offset`.
struct RecordPrefix {
  std::uint8_t opcode = 0;
  std::uint64_t length = 0;
};

RecordPrefix readPrefix(int fd, const std::string& path, std::uint64_t offset) {
  std::uint8_t raw[kRecordPrefixBytes];
  readAt(fd, path, offset, sizeof(raw), raw);
  detail::Cursor in(raw, sizeof(raw));
  RecordPrefix prefix;
  prefix.opcode = in.u8();
  prefix.length = in.u64();
  return prefix;
}

/// Checks the opening magic; returns whether the file ends with the closing one.
bool checkMagic(const File& file, const std::string& path) {
  std::uint8_t magic[8];
  if (file.size() < 8) {
    throw std::runtime_error(path + ": not an MCAP file (" + std::to_string(file.size()) +
                             " bytes, shorter than the magic)");
  }
  readAt(file.fd(), path, 0, 8, magic);
  if (!isMagic(magic))
    throw std::runtime_error(path + ": not an MCAP file (wrong magic at byte 0)");
  if (file.size() < 16) return false;
  readAt(file.fd(), path, file.size() - 8, 8, magic);
  return isMagic(magic);
}

/// Runs `step` with the file's context added to any error it throws.
template <typename Step>
auto withContext(const std::string& context, Step&& step) -> decltype(step()) {
  try {
    return step();
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(context + ": " + e.what());
  }
}

/// Visits the records of a decompressed chunk (Schema, Channel, Message; others skipped).
void visitChunkRecords(const std::vector<std::uint8_t>& records, const std::string& context,
                       const std::function<void(std::uint8_t, std::uint64_t, const std::uint8_t*,
                                                std::size_t)>& visit) {
  std::uint64_t pos = 0;
  while (pos < records.size()) {
    detail::Cursor in(records.data() + pos, records.size() - pos);
    const std::uint8_t opcode = withContext(context, [&] { return in.u8(); });
    const std::uint64_t length = withContext(
        context + ": record at chunk byte " + std::to_string(pos), [&] { return in.u64(); });
    if (length > in.left()) {
      throw std::runtime_error(context + ": " + detail::opcodeName(opcode) +
                               " record at chunk byte " + std::to_string(pos) + " declares " +
                               std::to_string(length) + " bytes, " + std::to_string(in.left()) +
                               " left in the chunk");
    }
    visit(opcode, pos, records.data() + pos + kRecordPrefixBytes, static_cast<std::size_t>(length));
    pos += kRecordPrefixBytes + length;
  }
}

}  // namespace

std::uint64_t maxDecompressedChunkBytes(std::uint64_t file_size) {
  constexpr std::uint64_t kFloor = std::uint64_t{64} << 20;
  constexpr std::uint64_t kPerFileByte = 256;
  const std::uint64_t scaled = file_size > kMaxMcapRecordBytes / kPerFileByte
                                   ? kMaxMcapRecordBytes
                                   : file_size * kPerFileByte;
  return std::min(kMaxMcapRecordBytes, std::max(kFloor, scaled));
}

std::uint64_t maxIndexedMessages(std::uint64_t file_size) {
  return std::max<std::uint64_t>(std::uint64_t{1} << 22, file_size / 2);
}

ScanResult scanRecords(const std::string& path, const std::function<void(const Record&)>& visit) {
  File file(path);
  const bool closed = checkMagic(file, path);
  ScanResult result;
  std::uint64_t offset = 8;
  const std::uint64_t end = closed ? file.size() - 8 : file.size();
  while (offset < end) {
    if (end - offset < kRecordPrefixBytes) {
      result.warning = path + ": cut off inside a record header at byte " + std::to_string(offset);
      return result;
    }
    const RecordPrefix prefix = readPrefix(file.fd(), path, offset);
    const std::string context = where(path, prefix.opcode, offset);
    const std::uint64_t left = end - offset - kRecordPrefixBytes;
    if (prefix.length > left) {
      if (closed) {
        throw std::runtime_error(context + ": declares " + std::to_string(prefix.length) +
                                 " bytes, only " + std::to_string(left) + " remain before the end");
      }
      result.warning = context + ": declares " + std::to_string(prefix.length) + " bytes, only " +
                       std::to_string(left) + " remain: the file was cut off";
      return result;
    }
    const std::uint64_t body_offset = offset + kRecordPrefixBytes;
    if (prefix.opcode == detail::kChunk || detail::isParsedOpcode(prefix.opcode)) {
      if (prefix.length > kMaxMcapRecordBytes) {
        throw std::runtime_error(context + ": " + std::to_string(prefix.length) +
                                 " bytes exceed the limit of " +
                                 std::to_string(kMaxMcapRecordBytes));
      }
      const std::vector<std::uint8_t> body = readBytes(file.fd(), path, body_offset, prefix.length);
      if (prefix.opcode == detail::kChunk) {
        const std::vector<std::uint8_t> records = withContext(context, [&] {
          return detail::decompressChunk(detail::parseChunk(body.data(), body.size()),
                                         maxDecompressedChunkBytes(file.size()));
        });
        visitChunkRecords(
            records, context,
            [&](std::uint8_t opcode, std::uint64_t pos, const std::uint8_t* data,
                std::size_t size) {
              if (!detail::isParsedOpcode(opcode)) return;
              const std::string inner = context + ": " + detail::opcodeName(opcode) +
                                        " record at chunk byte " + std::to_string(pos);
              visit(withContext(inner, [&] { return detail::parseRecord(opcode, data, size); }));
            });
      } else {
        visit(withContext(
            context, [&] { return detail::parseRecord(prefix.opcode, body.data(), body.size()); }));
      }
    }
    offset = body_offset + prefix.length;
  }
  if (!closed) {
    result.warning =
        path + ": no closing magic after byte " + std::to_string(offset) + ": the file was cut off";
    return result;
  }
  result.complete = true;
  return result;
}

McapReader::McapReader(const std::string& path) : path_(path) {
  File file(path);
  file_size_ = file.size();
  const bool closed = checkMagic(file, path);
  fd_ = file.release();
  try {
    if (!closed || !openIndexed()) openByScan(closed);
    if (!closed) {
      warnings_.insert(warnings_.begin(), path + ": no footer (the recording was cut off): read " +
                                              std::to_string(messages_.size()) +
                                              " messages by a linear scan up to the cut");
    }
  } catch (...) {
    ::close(fd_);
    fd_ = -1;
    throw;
  }
  const auto key = [this](const MessageLocation& m) {
    const std::uint64_t position = m.chunk == 0 ? m.offset : chunks_[m.chunk - 1].offset;
    return std::make_tuple(m.log_time_ns, position, m.chunk == 0 ? 0 : m.offset);
  };
  std::sort(messages_.begin(), messages_.end(),
            [&](const MessageLocation& a, const MessageLocation& b) { return key(a) < key(b); });
}

McapReader::~McapReader() {
  if (fd_ >= 0) ::close(fd_);
}

bool McapReader::openIndexed() {
  // The footer: the record just before the closing magic.
  const std::uint64_t footer_offset = file_size_ - 8 - kRecordPrefixBytes - 20;
  if (file_size_ < 8 + kRecordPrefixBytes + 20 + 8) return false;
  const RecordPrefix prefix = readPrefix(fd_, path_, footer_offset);
  if (prefix.opcode != detail::kFooter || prefix.length != 20) {
    throw std::runtime_error(where(path_, prefix.opcode, footer_offset) +
                             ": expected the Footer record (20 bytes) before the closing magic");
  }
  const std::vector<std::uint8_t> body =
      readBytes(fd_, path_, footer_offset + kRecordPrefixBytes, 20);
  const auto footer =
      std::get<Footer>(detail::parseRecord(detail::kFooter, body.data(), body.size()));
  if (footer.summary_start == 0) return false;
  if (footer.summary_start < 8 || footer.summary_start > footer_offset) {
    throw std::runtime_error(where(path_, detail::kFooter, footer_offset) + ": summary_start " +
                             std::to_string(footer.summary_start) + " is outside the file");
  }
  const std::uint64_t summary_end =
      footer.summary_offset_start != 0 ? footer.summary_offset_start : footer_offset;
  if (summary_end < footer.summary_start || summary_end > footer_offset) {
    throw std::runtime_error(where(path_, detail::kFooter, footer_offset) +
                             ": summary_offset_start " + std::to_string(summary_end) +
                             " is outside the summary");
  }
  if (summary_end - footer.summary_start > kMaxMcapRecordBytes) {
    throw std::runtime_error(path_ + ": summary section of " +
                             std::to_string(summary_end - footer.summary_start) +
                             " bytes is too large");
  }
  const std::vector<std::uint8_t> summary =
      readBytes(fd_, path_, footer.summary_start, summary_end - footer.summary_start);
  std::vector<ChunkIndex> chunk_indexes;
  bool has_statistics = false;
  Statistics statistics;
  visitChunkRecords(
      summary, path_ + ": summary section at byte " + std::to_string(footer.summary_start),
      [&](std::uint8_t opcode, std::uint64_t pos, const std::uint8_t* data, std::size_t size) {
        if (!detail::isParsedOpcode(opcode)) return;
        const std::string context = where(path_, opcode, footer.summary_start + pos);
        Record record =
            withContext(context, [&] { return detail::parseRecord(opcode, data, size); });
        if (auto* s = std::get_if<Schema>(&record)) {
          schemas_[s->id] = std::move(*s);
        } else if (auto* c = std::get_if<Channel>(&record)) {
          channels_[c->id] = std::move(*c);
        } else if (auto* ci = std::get_if<ChunkIndex>(&record)) {
          chunk_indexes.push_back(std::move(*ci));
        } else if (auto* st = std::get_if<Statistics>(&record)) {
          has_statistics = true;
          statistics = *st;
        }
      });
  const bool no_messages = has_statistics && statistics.message_count == 0;
  if (channels_.empty() && !no_messages) return false;
  if (chunk_indexes.empty() && !no_messages) return false;  // messages outside chunks: scan
  std::sort(chunk_indexes.begin(), chunk_indexes.end(),
            [](const ChunkIndex& a, const ChunkIndex& b) {
              return a.chunk_start_offset < b.chunk_start_offset;
            });
  for (const ChunkIndex& index : chunk_indexes) {
    const std::string context =
        path_ + ": ChunkIndex of the chunk at byte " + std::to_string(index.chunk_start_offset);
    if (index.chunk_start_offset < 8 || index.chunk_length < kRecordPrefixBytes ||
        index.chunk_start_offset > footer.summary_start ||
        index.chunk_length > footer.summary_start - index.chunk_start_offset) {
      throw std::runtime_error(context + ": the chunk (" + std::to_string(index.chunk_length) +
                               " bytes) is not inside the data section");
    }
    chunks_.push_back({index.chunk_start_offset, index.chunk_length});
    const auto chunk = static_cast<std::uint32_t>(chunks_.size());
    if (index.message_index_offsets.empty()) {
      indexChunk(chunk, chunkRecords(chunk), index.chunk_start_offset);
      continue;
    }
    for (const auto& [channel_id, offset] : index.message_index_offsets) {
      if (offset < 8 || offset >= footer.summary_start ||
          footer.summary_start - offset < kRecordPrefixBytes) {
        throw std::runtime_error(context + ": message index of channel " +
                                 std::to_string(channel_id) + " at byte " + std::to_string(offset) +
                                 " is outside the data section");
      }
      const RecordPrefix mi = readPrefix(fd_, path_, offset);
      const std::string mi_context = where(path_, mi.opcode, offset);
      if (mi.opcode != detail::kMessageIndex || mi.length > kMaxMcapRecordBytes ||
          mi.length > footer.summary_start - offset - kRecordPrefixBytes) {
        throw std::runtime_error(mi_context +
                                 ": not a MessageIndex record inside the data section");
      }
      const std::vector<std::uint8_t> entries =
          readBytes(fd_, path_, offset + kRecordPrefixBytes, mi.length);
      withContext(mi_context, [&] {
        detail::Cursor in(entries.data(), entries.size());
        const std::uint16_t id = in.u16();
        const std::uint32_t bytes = in.u32();
        if (bytes > in.left()) throw std::runtime_error("its records run past the record");
        if (bytes % 16 != 0) throw std::runtime_error("its records length is not a multiple of 16");
        // Each entry is 16 bytes of the file and each message at least 31 of its chunk: indexes
        // that list more (the same records pointed at again and again) are refused, so that
        // the index in memory stays proportional to the file.
        if (messages_.size() + bytes / 16 > file_size_ / 16 ||
            bytes / 16 > index.uncompressed_size / 31) {
          throw std::runtime_error("it lists more messages than the file or its chunk can hold");
        }
        for (std::uint32_t k = 0; k < bytes / 16; ++k) {
          MessageLocation location;
          location.log_time_ns = in.u64();
          location.offset = in.u64();
          location.channel_id = id;
          location.chunk = chunk;
          if (location.offset >= index.uncompressed_size) {
            throw std::runtime_error("message offset " + std::to_string(location.offset) +
                                     " is outside its chunk of " +
                                     std::to_string(index.uncompressed_size) + " bytes");
          }
          messages_.push_back(location);
        }
        return 0;
      });
    }
  }
  if (has_statistics && statistics.message_count != messages_.size()) {
    // Messages outside the indexed chunks (the format allows them): only a scan finds them all.
    chunks_.clear();
    messages_.clear();
    return false;
  }
  used_summary_ = true;
  return true;
}

void McapReader::openByScan(bool closed) {
  schemas_.clear();
  channels_.clear();
  chunks_.clear();
  messages_.clear();
  cached_chunk_ = 0;  // chunk numbers of an abandoned indexed opening mean other chunks here
  cached_records_.clear();
  const std::uint64_t end = closed ? file_size_ - 8 : file_size_;
  const bool cut_allowed = !closed;
  std::uint64_t offset = 8;
  while (offset < end) {
    if (end - offset < kRecordPrefixBytes) {
      warnings_.push_back(path_ + ": cut off inside a record header at byte " +
                          std::to_string(offset));
      return;
    }
    const RecordPrefix prefix = readPrefix(fd_, path_, offset);
    const std::string context = where(path_, prefix.opcode, offset);
    const std::uint64_t left = end - offset - kRecordPrefixBytes;
    if (prefix.length > left) {
      if (!cut_allowed) {
        throw std::runtime_error(context + ": declares " + std::to_string(prefix.length) +
                                 " bytes, only " + std::to_string(left) + " remain before the end");
      }
      warnings_.push_back(context + ": declares " + std::to_string(prefix.length) +
                          " bytes, only " + std::to_string(left) +
                          " remain: the file was cut off there");
      return;
    }
    const std::uint64_t body_offset = offset + kRecordPrefixBytes;
    if (prefix.length > kMaxMcapRecordBytes &&
        (prefix.opcode == detail::kChunk || prefix.opcode == detail::kSchema ||
         prefix.opcode == detail::kChannel)) {
      throw std::runtime_error(context + ": " + std::to_string(prefix.length) +
                               " bytes exceed the limit of " + std::to_string(kMaxMcapRecordBytes));
    }
    if (prefix.opcode == detail::kMessage) {
      constexpr std::uint64_t kMessageHead = 2 + 4 + 8 + 8;
      if (prefix.length < kMessageHead) {
        throw std::runtime_error(context + ": " + std::to_string(prefix.length) +
                                 " bytes, shorter than a Message's fields");
      }
      const std::vector<std::uint8_t> head = readBytes(fd_, path_, body_offset, kMessageHead);
      detail::Cursor in(head.data(), head.size());
      MessageLocation location;
      location.channel_id = in.u16();
      in.u32();
      location.log_time_ns = in.u64();
      location.offset = offset;
      messages_.push_back(location);
    } else if (prefix.opcode == detail::kSchema || prefix.opcode == detail::kChannel) {
      const std::vector<std::uint8_t> body = readBytes(fd_, path_, body_offset, prefix.length);
      Record record = withContext(
          context, [&] { return detail::parseRecord(prefix.opcode, body.data(), body.size()); });
      if (auto* s = std::get_if<Schema>(&record)) schemas_[s->id] = std::move(*s);
      if (auto* c = std::get_if<Channel>(&record)) channels_[c->id] = std::move(*c);
    } else if (prefix.opcode == detail::kChunk) {
      chunks_.push_back({offset, kRecordPrefixBytes + prefix.length});
      const auto chunk = static_cast<std::uint32_t>(chunks_.size());
      const std::vector<std::uint8_t> records = chunkRecords(chunk);
      indexChunk(chunk, records, offset);
    } else if (prefix.opcode == detail::kDataEnd) {
      return;  // the summary follows: the scan has what it needs
    }
    offset = body_offset + prefix.length;
  }
  if (!closed)
    warnings_.push_back(path_ + ": no closing magic after byte " + std::to_string(offset));
}

void McapReader::indexChunk(std::uint32_t chunk, const std::vector<std::uint8_t>& records,
                            std::uint64_t chunk_offset) {
  const std::string context = where(path_, detail::kChunk, chunk_offset);
  const std::uint64_t max_messages = maxIndexedMessages(file_size_);
  // A record's name for errors, made only when one is thrown (a chunk may hold millions).
  const auto inner = [&](std::uint8_t opcode, std::uint64_t pos) {
    return context + ": " + detail::opcodeName(opcode) + " record at chunk byte " +
           std::to_string(pos);
  };
  visitChunkRecords(
      records, context,
      [&](std::uint8_t opcode, std::uint64_t pos, const std::uint8_t* data, std::size_t size) {
        if (opcode == detail::kMessage) {
          if (messages_.size() >= max_messages) {
            throw std::runtime_error(
                inner(opcode, pos) + ": more than " + std::to_string(max_messages) +
                " messages in a file of " + std::to_string(file_size_) +
                " bytes (at most one per 2 bytes of the file, or 2^22): its chunks compress "
                "beyond any recording's, refused before the index outgrows the file");
          }
          MessageLocation location;
          try {
            detail::Cursor in(data, size);
            location.channel_id = in.u16();
            in.u32();
            location.log_time_ns = in.u64();
            in.u64();
          } catch (const std::runtime_error& e) {
            throw std::runtime_error(inner(opcode, pos) + ": " + e.what());
          }
          location.chunk = chunk;
          location.offset = pos;
          messages_.push_back(location);
          return;
        }
        if (opcode != detail::kSchema && opcode != detail::kChannel) return;
        Record record = withContext(inner(opcode, pos),
                                    [&] { return detail::parseRecord(opcode, data, size); });
        if (auto* s = std::get_if<Schema>(&record)) schemas_[s->id] = std::move(*s);
        if (auto* c = std::get_if<Channel>(&record)) channels_[c->id] = std::move(*c);
      });
}

const std::vector<std::uint8_t>& McapReader::chunkRecords(std::uint32_t chunk) const {
  if (cached_chunk_ == chunk) return cached_records_;
  const ChunkSpan& span = chunks_.at(chunk - 1);
  const RecordPrefix prefix = readPrefix(fd_, path_, span.offset);
  const std::string context = where(path_, prefix.opcode, span.offset);
  if (prefix.opcode != detail::kChunk)
    throw std::runtime_error(context + ": expected a Chunk record");
  if (prefix.length != span.length - kRecordPrefixBytes) {
    throw std::runtime_error(context + ": declares " + std::to_string(prefix.length) +
                             " bytes, its chunk index " +
                             std::to_string(span.length - kRecordPrefixBytes));
  }
  if (prefix.length > kMaxMcapRecordBytes) {
    throw std::runtime_error(context + ": " + std::to_string(prefix.length) +
                             " bytes exceed the limit of " + std::to_string(kMaxMcapRecordBytes));
  }
  const std::vector<std::uint8_t> body =
      readBytes(fd_, path_, span.offset + kRecordPrefixBytes, prefix.length);
  cached_chunk_ = 0;
  cached_records_ = withContext(context, [&] {
    return detail::decompressChunk(detail::parseChunk(body.data(), body.size()),
                                   maxDecompressedChunkBytes(file_size_));
  });
  cached_chunk_ = chunk;
  return cached_records_;
}

namespace {

/// The message, after checking that it is the one its index entry says (a message index may lie).
Message checkedAgainstIndex(Message message, const MessageLocation& location) {
  if (message.log_time_ns != location.log_time_ns || message.channel_id != location.channel_id) {
    throw std::runtime_error("the message (channel " + std::to_string(message.channel_id) +
                             ", log time " + std::to_string(message.log_time_ns) +
                             ") is not the one its message index says (channel " +
                             std::to_string(location.channel_id) + ", log time " +
                             std::to_string(location.log_time_ns) + ")");
  }
  return message;
}

}  // namespace

Message McapReader::read(std::size_t i) const {
  if (i >= messages_.size()) {
    throw std::out_of_range(path_ + ": message " + std::to_string(i) + " of " +
                            std::to_string(messages_.size()));
  }
  const MessageLocation& location = messages_[i];
  std::lock_guard<std::mutex> lock(cache_mutex_);
  if (location.chunk == 0) {
    const RecordPrefix prefix = readPrefix(fd_, path_, location.offset);
    const std::string context = where(path_, prefix.opcode, location.offset);
    if (prefix.opcode != detail::kMessage || prefix.length > kMaxMcapRecordBytes ||
        prefix.length > file_size_ - location.offset - kRecordPrefixBytes) {
      throw std::runtime_error(context + ": not a Message record of at most the bytes left");
    }
    const std::vector<std::uint8_t> body =
        readBytes(fd_, path_, location.offset + kRecordPrefixBytes, prefix.length);
    return withContext(context, [&] {
      return checkedAgainstIndex(
          std::get<Message>(detail::parseRecord(detail::kMessage, body.data(), body.size())),
          location);
    });
  }
  const std::vector<std::uint8_t>& records = chunkRecords(location.chunk);
  const std::string context = where(path_, detail::kChunk, chunks_[location.chunk - 1].offset) +
                              ": message at chunk byte " + std::to_string(location.offset);
  return withContext(context, [&] {
    if (location.offset >= records.size()) throw std::runtime_error("outside the chunk");
    detail::Cursor in(records.data() + location.offset, records.size() - location.offset);
    const std::uint8_t opcode = in.u8();
    const std::uint64_t length = in.u64();
    if (opcode != detail::kMessage) throw std::runtime_error("not a Message record");
    if (length > in.left()) throw std::runtime_error("the record runs past the chunk");
    return checkedAgainstIndex(
        std::get<Message>(detail::parseRecord(detail::kMessage,
                                              records.data() + location.offset + kRecordPrefixBytes,
                                              static_cast<std::size_t>(length))),
        location);
  });
}

}  // namespace mlmap::bag::mcap
