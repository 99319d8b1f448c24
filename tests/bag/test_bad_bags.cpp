/// @file
/// Bad bags get a clear message naming the file and the byte offset or record, never a crash:
/// a recording cut off (read up to the cut, with a warning), a wrong magic, a chunk whose
/// lengths lie, an unknown compression, a malformed message, a type the reader does not know,
/// a sqlite3 file that is not a rosbag2 bag, a metadata.yaml of another storage.

#include "bag_fixtures.h"

#include "mlmap/bag/bag_frame_source.h"
#include "mlmap/bag/bag_reader.h"
#include "mlmap/bag/mcap.h"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <zstd.h>

#include <cstring>
#include <filesystem>

namespace {

namespace fs = std::filesystem;
using mlmap::bag::openBag;
using mlmap::bag::testing::fixture;
using mlmap::bag::testing::readAll;
using mlmap::bag::testing::writeAll;

/// A scratch file path for this test.
std::string scratch(const std::string& name) {
  const fs::path dir = fs::path(MLMAP_BAG_FIXTURES_DIR).parent_path() / "bad_bags";
  fs::create_directories(dir);
  return (dir / name).string();
}

std::uint64_t u64At(const std::vector<std::uint8_t>& bytes, std::size_t at) {
  std::uint64_t v = 0;
  std::memcpy(&v, bytes.data() + at, 8);  // x86-64 / ARM64: little endian, as MCAP
  return v;
}

void setU64(std::vector<std::uint8_t>* bytes, std::size_t at, std::uint64_t v) {
  std::memcpy(bytes->data() + at, &v, 8);
}

/// Byte offset of the first record with `opcode` in the data section of an MCAP file.
std::size_t firstRecord(const std::vector<std::uint8_t>& bytes, std::uint8_t opcode) {
  std::size_t at = 8;
  while (at + 9 <= bytes.size() && bytes[at] != opcode)
    at += 9 + static_cast<std::size_t>(u64At(bytes, at + 1));
  if (at + 9 > bytes.size()) throw std::runtime_error("no record of that opcode");
  return at;
}

/// The message of the std::runtime_error `make` throws ("" when it throws none).
template <typename Make>
std::string errorOf(Make&& make) {
  try {
    make();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

/// Opens `path` as a bag and reads every message.
void readEverything(const std::string& path) {
  const auto bag = openBag(path);
  for (std::size_t i = 0; i < bag->entries().size(); ++i) (void)bag->read(i);
}

/// Appends little-endian integers and MCAP strings, to write hostile MCAP files by hand.
struct LittleEndian {
  std::vector<std::uint8_t> bytes;
  template <typename T>
  void put(T value) {
    const auto* raw = reinterpret_cast<const std::uint8_t*>(&value);
    bytes.insert(bytes.end(), raw, raw + sizeof(T));
  }
  void string(const std::string& s) {
    put(static_cast<std::uint32_t>(s.size()));
    bytes.insert(bytes.end(), s.begin(), s.end());
  }
  void record(std::uint8_t opcode, const std::vector<std::uint8_t>& body) {
    put(opcode);
    put(static_cast<std::uint64_t>(body.size()));
    bytes.insert(bytes.end(), body.begin(), body.end());
  }
};

/// A closed MCAP file without a summary whose `chunks` zstd chunks each hold `records` (as a
/// writer that compresses very well would make them).
std::vector<std::uint8_t> mcapWithZstdChunks(const std::vector<std::uint8_t>& records,
                                             int chunks = 1) {
  std::vector<std::uint8_t> compressed(ZSTD_compressBound(records.size()));
  const std::size_t n =
      ZSTD_compress(compressed.data(), compressed.size(), records.data(), records.size(), 3);
  if (ZSTD_isError(n) != 0) throw std::runtime_error(ZSTD_getErrorName(n));
  compressed.resize(n);
  LittleEndian chunk;
  chunk.put(std::uint64_t{0});  // message_start_time
  chunk.put(std::uint64_t{0});  // message_end_time
  chunk.put(static_cast<std::uint64_t>(records.size()));
  chunk.put(std::uint32_t{0});  // no CRC
  chunk.string("zstd");
  chunk.put(static_cast<std::uint64_t>(compressed.size()));
  chunk.bytes.insert(chunk.bytes.end(), compressed.begin(), compressed.end());
  LittleEndian file;
  const std::uint8_t magic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
  file.bytes.assign(magic, magic + 8);
  LittleEndian header;
  header.string("ros2");
  header.string("mlmap test");
  file.record(0x01, header.bytes);
  for (int c = 0; c < chunks; ++c) file.record(0x06, chunk.bytes);
  file.record(0x0F, std::vector<std::uint8_t>(4, 0));   // DataEnd
  file.record(0x02, std::vector<std::uint8_t>(20, 0));  // Footer: no summary
  file.bytes.insert(file.bytes.end(), magic, magic + 8);
  return file.bytes;
}

/// `count` copies of one empty Message record (31 bytes, the smallest there is) on channel 1.
std::vector<std::uint8_t> emptyMessages(std::size_t count) {
  LittleEndian message;
  message.put(std::uint16_t{1});
  message.put(std::uint32_t{0});  // sequence
  message.put(std::uint64_t{0});  // log_time
  message.put(std::uint64_t{0});  // publish_time
  LittleEndian out;
  for (std::size_t i = 0; i < count; ++i) out.record(0x05, message.bytes);
  return out.bytes;
}

TEST(BadBags, TruncatedMcapIsReadUpToTheCutWithAWarning) {
  const std::vector<std::uint8_t> whole = readAll(fixture("clouds_noindex.mcap"));
  const double data_end = static_cast<double>(firstRecord(whole, 0x0F));  // cuts inside the data
  std::size_t previous = 0;
  for (const double fraction : {0.35, 0.7, 0.95}) {
    SCOPED_TRACE(fraction);
    const std::string path = scratch("truncated.mcap");
    writeAll(path,
             {whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(data_end * fraction)});
    const auto bag = openBag(path);
    ASSERT_FALSE(bag->warnings().empty());
    EXPECT_NE(bag->warnings()[0].find(path + ": no footer (the recording was cut off)"),
              std::string::npos)
        << bag->warnings()[0];
    EXPECT_LT(bag->entries().size(), 14U);
    EXPECT_GE(bag->entries().size(), previous);  // more of the file, at least as many messages
    previous = bag->entries().size();
    for (std::size_t i = 0; i < bag->entries().size(); ++i) (void)bag->read(i);
  }
  EXPECT_GT(previous, 0U);
  // Cut off, the compressed bag too: whole chunks before the cut are read.
  const std::vector<std::uint8_t> zstd = readAll(fixture("clouds_zstd.mcap"));
  const double zstd_data_end = static_cast<double>(firstRecord(zstd, 0x0F));
  const std::string path = scratch("truncated_zstd.mcap");
  writeAll(path, {zstd.begin(), zstd.begin() + static_cast<std::ptrdiff_t>(zstd_data_end * 0.8)});
  const mlmap::bag::mcap::McapReader reader(path);
  EXPECT_FALSE(reader.usedSummary());
  EXPECT_GT(reader.messages().size(), 0U);
  EXPECT_LT(reader.messages().size(), 14U);
}

TEST(BadBags, WrongMagic) {
  std::vector<std::uint8_t> bytes = readAll(fixture("clouds_zstd.mcap"));
  bytes[1] = 'X';
  const std::string path = scratch("wrong_magic.mcap");
  writeAll(path, bytes);
  EXPECT_EQ(errorOf([&] { mlmap::bag::mcap::McapReader reader(path); }),
            path + ": not an MCAP file (wrong magic at byte 0)");
  EXPECT_EQ(errorOf([&] { readEverything(path); }),
            path + ": neither MCAP nor sqlite3 (unknown first bytes)");
}

TEST(BadBags, ChunkWhoseRecordsLengthLies) {
  std::vector<std::uint8_t> bytes = readAll(fixture("clouds_noindex.mcap"));
  const std::size_t chunk = firstRecord(bytes, 0x06);
  // Body: start, end, uncompressed_size (u64 x3), crc (u32), compression "" (u32 0), records
  // length.
  const std::size_t records_length_at = chunk + 9 + 24 + 4 + 4;
  setU64(&bytes, records_length_at, u64At(bytes, records_length_at) + 1000);
  const std::string path = scratch("lying_records_length.mcap");
  writeAll(path, bytes);
  const std::string error = errorOf([&] { readEverything(path); });
  EXPECT_NE(
      error.find(path + ": Chunk record at byte " + std::to_string(chunk) + ": its records length"),
      std::string::npos)
      << error;
}

TEST(BadBags, ChunkWhoseRecordLengthRunsPastTheEnd) {
  std::vector<std::uint8_t> bytes = readAll(fixture("clouds_noindex.mcap"));
  const std::size_t chunk = firstRecord(bytes, 0x06);
  setU64(&bytes, chunk + 1, std::uint64_t{1} << 40);  // 1 TiB: must not be allocated
  const std::string path = scratch("lying_chunk_length.mcap");
  writeAll(path, bytes);
  const std::string error = errorOf([&] { readEverything(path); });
  EXPECT_NE(error.find(path + ": Chunk record at byte " + std::to_string(chunk) +
                       ": declares 1099511627776 bytes"),
            std::string::npos)
      << error;
}

TEST(BadBags, ChunkWhoseUncompressedSizeLies) {
  std::vector<std::uint8_t> bytes = readAll(fixture("clouds_zstd.mcap"));
  const std::size_t chunk = firstRecord(bytes, 0x06);
  const std::size_t size_at = chunk + 9 + 16;
  for (const std::uint64_t lie :
       {u64At(bytes, size_at) + 1, u64At(bytes, size_at) - 1, std::uint64_t{1} << 33}) {
    SCOPED_TRACE(lie);
    std::vector<std::uint8_t> lying = bytes;
    setU64(&lying, size_at, lie);
    const std::string path = scratch("lying_uncompressed_size.mcap");
    writeAll(path, lying);
    const std::string error = errorOf([&] { readEverything(path); });
    EXPECT_NE(error.find(path + ": Chunk record at byte " + std::to_string(chunk) + ": "),
              std::string::npos)
        << error;
    EXPECT_NE(error.find(std::to_string(lie)), std::string::npos) << error;
  }
}

TEST(BadBags, UnknownCompression) {
  std::vector<std::uint8_t> bytes = readAll(fixture("clouds_zstd.mcap"));
  const std::size_t chunk = firstRecord(bytes, 0x06);
  const std::size_t name_at = chunk + 9 + 24 + 4 + 4;
  ASSERT_EQ(std::string(bytes.begin() + name_at, bytes.begin() + name_at + 4), "zstd");
  bytes[name_at + 3] = 'x';
  const std::string path = scratch("unknown_compression.mcap");
  writeAll(path, bytes);
  const std::string error = errorOf([&] { readEverything(path); });
  EXPECT_NE(error.find(path + ": Chunk record at byte " + std::to_string(chunk) +
                       ": unknown compression 'zstx' (known: none, zstd, lz4)"),
            std::string::npos)
      << error;
}

TEST(BadBags, CorruptCompressedData) {
  for (const char* name : {"clouds_zstd.mcap", "depth_lz4.mcap"}) {
    SCOPED_TRACE(name);
    std::vector<std::uint8_t> bytes = readAll(fixture(name));
    const std::size_t chunk = firstRecord(bytes, 0x06);
    const std::size_t data_at = chunk + 9 + 24 + 4 + 4 + 4 + 8;
    for (std::size_t k = 8; k < 40; ++k) bytes[data_at + k] ^= 0x5A;
    const std::string path = scratch(std::string("corrupt_") + name);
    writeAll(path, bytes);
    const std::string error = errorOf([&] { readEverything(path); });
    EXPECT_NE(error.find(path + ": Chunk record at byte " + std::to_string(chunk)),
              std::string::npos)
        << error;
  }
}

/// Runs `sql` on a copy of clouds.db3 and returns the copy's path.
std::string editedDb3(const std::string& name, const std::string& sql) {
  std::string path = scratch(name);
  fs::copy_file(fixture("clouds.db3"), path, fs::copy_options::overwrite_existing);
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_close(db);
  return path;
}

TEST(BadBags, MalformedMessageNamesTopicAndTime) {
  const std::string path = editedDb3(
      "malformed_cloud.db3",
      "UPDATE messages SET data = x'0001000001' WHERE topic_id = "
      "(SELECT id FROM topics WHERE name = '/points') AND timestamp = 1700000001100000000");
  const std::string error = errorOf([&] {
    mlmap::bag::BagFrameSource source(openBag(path), mlmap::bag::BagFrameSourceOptions{});
  });
  EXPECT_EQ(
      error,
      path +
          ": /points message at log time 1700000001100000000 ns: malformed CDR header (5 bytes)");
}

TEST(BadBags, TfMessageDeclaringMoreTransformsThanItsBytesIsRefusedBeforeAllocation) {
  // Issue 43 item 10 in a bag: the /tf_static message declares 1,048,576 transforms in 1 MB
  // (Fast CDR alone sized the vector first: 134 MB; the 16 MB message, 2 GB). Refused
  // with the member and the count before Fast CDR reads it (allocations: BagCdrBounds.*).
  const std::string path = editedDb3(
      "tf_static_huge_count.db3",
      "UPDATE messages SET data = x'0001000000001000' || zeroblob(1048576) WHERE topic_id = "
      "(SELECT id FROM topics WHERE name = '/tf_static')");
  const std::string error = errorOf([&] {
    mlmap::bag::BagFrameSource source(openBag(path), mlmap::bag::BagFrameSourceOptions{});
  });
  EXPECT_EQ(error, path +
                       ": /tf_static message at log time 1700000000900000000 ns: malformed CDR "
                       "(1048584 bytes): tf2_msgs::msg::dds_::TFMessage_ `transforms`: sequence "
                       "declares 1048576 elements of >= 72 bytes, 1048576 bytes remain");
}

TEST(BadBags, UnknownTypeIsNotTakenForAnInput) {
  const std::string path = editedDb3(
      "unknown_type.db3", "UPDATE topics SET type = 'acme_msgs/msg/Cloud' WHERE name = '/points'");
  const std::string error = errorOf([&] {
    mlmap::bag::BagFrameSource source(openBag(path), mlmap::bag::BagFrameSourceOptions{});
  });
  EXPECT_NE(error.find("0 PointCloud2 topics and 0 depth Image topics"), std::string::npos)
      << error;
  EXPECT_NE(error.find("/points (acme_msgs/msg/Cloud, 4 messages)"), std::string::npos) << error;
  mlmap::bag::BagFrameSourceOptions named;
  named.inputs.cloud_topics = {"/points"};
  const std::string named_error =
      errorOf([&] { mlmap::bag::BagFrameSource source(openBag(path), named); });
  EXPECT_NE(
      named_error.find("'/points' is a acme_msgs/msg/Cloud, not a sensor_msgs/msg/PointCloud2"),
      std::string::npos)
      << named_error;
}

TEST(BadBags, SqliteFileThatIsNotABag) {
  const std::string path = scratch("not_a_bag.db3");
  fs::remove(path);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE other(x INTEGER)", nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  EXPECT_EQ(errorOf([&] { readEverything(path); }),
            path + ": not a rosbag2 sqlite3 bag: 'topics' is missing, not a table");
  std::vector<std::uint8_t> bytes = readAll(path);
  std::fill(bytes.begin() + 100, bytes.end(), 0xEE);  // the header stays, the pages are garbage
  writeAll(path, bytes);
  EXPECT_NE(errorOf([&] { readEverything(path); }).find(path + ": "), std::string::npos);
}

// `messages` or `topics` as a view: a recursive view never ends and a join makes rows without
// bound from a small file; only tables are read, whose rows the file's size bounds.
TEST(BadBags, ViewsInsteadOfTablesAreRefused) {
  const std::string recursive =
      editedDb3("recursive_view.db3",
                "ALTER TABLE messages RENAME TO m0; CREATE VIEW messages AS WITH RECURSIVE "
                "r(id, topic_id, timestamp, data) AS (SELECT id, topic_id, timestamp, data FROM m0 "
                "UNION ALL SELECT id, topic_id, timestamp + 1, data FROM r) SELECT * FROM r");
  EXPECT_EQ(errorOf([&] { readEverything(recursive); }),
            recursive + ": not a rosbag2 sqlite3 bag: 'messages' is a view, not a table");
  const std::string topics = editedDb3(
      "topics_view.db3",
      "ALTER TABLE topics RENAME TO t0; CREATE VIEW topics AS SELECT a.* FROM t0 a, t0 b, t0 c");
  EXPECT_EQ(errorOf([&] { readEverything(topics); }),
            topics + ": not a rosbag2 sqlite3 bag: 'topics' is a view, not a table");
}

// A FIFO (or a device) named as the bag is refused at once: opening a FIFO blocks until
// something writes to it.
TEST(BadBags, AFifoIsRefusedWithoutWaiting) {
  for (const char* name : {"fifo.mcap", "fifo.db3"}) {
    const std::string path = scratch(name);
    fs::remove(path);
    ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0) << path;
    EXPECT_EQ(errorOf([&] { readEverything(path); }),
              path + ": not a regular file (a device, pipe or socket), not a bag");
  }
  EXPECT_EQ(errorOf([&] { readEverything("/dev/zero"); }),
            "/dev/zero: not a regular file (a device, pipe or socket), not a bag");
}

TEST(BadBags, MetadataOfAnotherStorage) {
  const fs::path dir = scratch("other_storage");
  fs::create_directories(dir);
  std::ofstream(dir / "metadata.yaml")
      << "rosbag2_bagfile_information:\n  version: 9\n"
         "  storage_identifier: rosbag_v2\n  relative_file_paths: [a.bag]\n";
  EXPECT_EQ(
      errorOf([&] { readEverything(dir.string()); }),
      (dir / "metadata.yaml").string() + ": storage_identifier 'rosbag_v2' (known: mcap, sqlite3)");
  std::ofstream(dir / "metadata.yaml")
      << "rosbag2_bagfile_information:\n  storage_identifier: mcap\n"
         "  relative_file_paths: [../../etc/passwd]\n";
  EXPECT_NE(
      errorOf([&] { readEverything(dir.string()); }).find("is not a file name inside the folder"),
      std::string::npos);
}

// A chunk of tiny messages that compresses a thousandfold used to be indexed in full (24 bytes a
// message, 2 GB for a 1 GiB chunk of a 300 KB file): the index is now bounded by the file's size.
TEST(BadBags, ChunksOfTinyMessagesCannotOutgrowTheFile) {
  // Three chunks of 1.5 M messages (46.5 MB decompressed each): 4.5 M in all.
  const std::size_t count = std::size_t{3} << 19;
  const std::vector<std::uint8_t> bytes = mcapWithZstdChunks(emptyMessages(count), 3);
  ASSERT_LT(bytes.size(), std::size_t{64} << 10);  // a 48 kB file
  const std::string path = scratch("tiny_messages.mcap");
  writeAll(path, bytes);
  const std::string error = errorOf([&] { readEverything(path); });
  EXPECT_NE(error.find(path + ": Chunk record at byte "), std::string::npos) << error;
  EXPECT_NE(error.find(": more than 4194304 messages in a file of " + std::to_string(bytes.size()) +
                       " bytes"),
            std::string::npos)
      << error;
  // Fewer of the same messages are read.
  writeAll(path, mcapWithZstdChunks(emptyMessages(1000)));
  const mlmap::bag::mcap::McapReader reader(path);
  EXPECT_EQ(reader.messages().size(), 1000u);
}

// A small file's chunk may not decompress to tens of megabytes, even when zstd really delivers
// them (zeros): the bound comes from the file's size, checked before allocating.
TEST(BadBags, ASmallFilesChunkCannotDecompressToHundredsOfMegabytes) {
  LittleEndian message;
  message.put(std::uint16_t{1});
  message.put(std::uint32_t{0});
  message.put(std::uint64_t{0});
  message.put(std::uint64_t{0});
  message.bytes.resize(message.bytes.size() + (std::size_t{80} << 20), 0);  // 80 MiB of zeros
  LittleEndian records;
  records.record(0x05, message.bytes);
  const std::vector<std::uint8_t> bytes = mcapWithZstdChunks(records.bytes);
  ASSERT_LT(bytes.size(), std::size_t{64} << 10);
  const std::string path = scratch("zeros.mcap");
  writeAll(path, bytes);
  const std::uint64_t limit = mlmap::bag::mcap::maxDecompressedChunkBytes(bytes.size());
  EXPECT_EQ(limit, std::uint64_t{64} << 20);
  const std::string error = errorOf([&] { readEverything(path); });
  EXPECT_NE(error.find(std::to_string(records.bytes.size()) + " exceeds the limit of " +
                       std::to_string(limit) + " bytes for this file"),
            std::string::npos)
      << error;
  EXPECT_EQ(mlmap::bag::mcap::maxDecompressedChunkBytes(std::uint64_t{1} << 30),
            mlmap::bag::kMaxMcapRecordBytes);
  EXPECT_EQ(mlmap::bag::mcap::maxDecompressedChunkBytes(std::uint64_t{1} << 20),
            std::uint64_t{256} << 20);
}

}  // namespace
