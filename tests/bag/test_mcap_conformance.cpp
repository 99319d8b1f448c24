/// @file
/// The MCAP format's own conformance files (shared/data/mcap-conformance, from foxglove/mcap):
/// every record a reader must find, in order, and every message through the indexed reader.
/// The copy in shared/ holds Git LFS pointers instead of the .mcap bytes (the .json files are
/// real): the tests skip, saying so, until the real files are there. MLMAP_MCAP_CONFORMANCE_DIR
/// names another copy (each .mcap with its .json), e.g. the files foxglove/mcap's own generator
/// writes (docs/replay.md says how, and how to check them against the LFS pointers).

#include "mlmap/bag/mcap.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <tuple>
#include <vector>

namespace {

namespace fs = std::filesystem;
namespace mcap = mlmap::bag::mcap;
using Json = nlohmann::json;
using Fields = std::map<std::string, Json>;

/// MLMAP_MCAP_CONFORMANCE_DIR when set, else shared/data/mcap-conformance.
fs::path dataDir() {
  const char* dir = std::getenv("MLMAP_MCAP_CONFORMANCE_DIR");  // NOLINT(concurrency-mt-unsafe)
  return dir != nullptr && *dir != '\0' ? fs::path(dir)
                                        : fs::path(MLMAP_SHARED_DATA_DIR) / "mcap-conformance";
}

const fs::path kDataDir = dataDir();

/// Why the conformance files cannot be read ("" when they can): absent, or LFS pointers.
std::string unavailable(const std::vector<fs::path>& files) {
  if (files.empty()) return kDataDir.string() + " holds no .mcap file";
  std::ifstream in(files.front(), std::ios::binary);
  std::string head(7, '\0');
  in.read(head.data(), 7);
  if (head == "version") return files.front().string() + " is a Git LFS pointer, not the MCAP file";
  return "";
}

Json bytes(const std::vector<std::uint8_t>& data) {
  Json list = Json::array();
  for (const std::uint8_t b : data) list.push_back(std::to_string(b));
  return list;
}

template <typename Key, typename Value>
Json mapOf(const std::map<Key, Value>& map) {
  Json object = Json::object();
  for (const auto& [key, value] : map) {
    if constexpr (std::is_same_v<Key, std::string>) {
      object[key] = value;
    } else {
      object[std::to_string(key)] = std::to_string(value);
    }
  }
  return object;
}

template <typename T>
std::string num(T value) {
  return std::to_string(value);
}

/// A record as the conformance .json writes it: type and fields sorted by name.
Json toJson(const mcap::Record& record) {
  std::string type;
  Fields f;
  std::visit(
      [&](const auto& r) {
        using R = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<R, mcap::Header>) {
          type = "Header", f = {{"profile", r.profile}, {"library", r.library}};
        } else if constexpr (std::is_same_v<R, mcap::Footer>) {
          type = "Footer", f = {{"summary_start", num(r.summary_start)},
                                {"summary_offset_start", num(r.summary_offset_start)},
                                {"summary_crc", num(r.summary_crc)}};
        } else if constexpr (std::is_same_v<R, mcap::Schema>) {
          type = "Schema", f = {{"id", num(r.id)},
                                {"name", r.name},
                                {"encoding", r.encoding},
                                {"data", bytes(r.data)}};
        } else if constexpr (std::is_same_v<R, mcap::Channel>) {
          type = "Channel", f = {{"id", num(r.id)},
                                 {"schema_id", num(r.schema_id)},
                                 {"topic", r.topic},
                                 {"message_encoding", r.message_encoding},
                                 {"metadata", mapOf(r.metadata)}};
        } else if constexpr (std::is_same_v<R, mcap::Message>) {
          type = "Message", f = {{"channel_id", num(r.channel_id)},
                                 {"sequence", num(r.sequence)},
                                 {"log_time", num(r.log_time_ns)},
                                 {"publish_time", num(r.publish_time_ns)},
                                 {"data", bytes(r.data)}};
        } else if constexpr (std::is_same_v<R, mcap::ChunkIndex>) {
          type = "ChunkIndex", f = {{"message_start_time", num(r.message_start_time_ns)},
                                    {"message_end_time", num(r.message_end_time_ns)},
                                    {"chunk_start_offset", num(r.chunk_start_offset)},
                                    {"chunk_length", num(r.chunk_length)},
                                    {"message_index_offsets", mapOf(r.message_index_offsets)},
                                    {"message_index_length", num(r.message_index_length)},
                                    {"compression", r.compression},
                                    {"compressed_size", num(r.compressed_size)},
                                    {"uncompressed_size", num(r.uncompressed_size)}};
        } else if constexpr (std::is_same_v<R, mcap::Attachment>) {
          type = "Attachment", f = {{"log_time", num(r.log_time_ns)},
                                    {"create_time", num(r.create_time_ns)},
                                    {"name", r.name},
                                    {"media_type", r.media_type},
                                    {"data", bytes(r.data)}};
        } else if constexpr (std::is_same_v<R, mcap::AttachmentIndex>) {
          type = "AttachmentIndex",
          f = {{"offset", num(r.offset)},        {"length", num(r.length)},
               {"log_time", num(r.log_time_ns)}, {"create_time", num(r.create_time_ns)},
               {"data_size", num(r.data_size)},  {"name", r.name},
               {"media_type", r.media_type}};
        } else if constexpr (std::is_same_v<R, mcap::Statistics>) {
          type = "Statistics", f = {{"message_count", num(r.message_count)},
                                    {"schema_count", num(r.schema_count)},
                                    {"channel_count", num(r.channel_count)},
                                    {"attachment_count", num(r.attachment_count)},
                                    {"metadata_count", num(r.metadata_count)},
                                    {"chunk_count", num(r.chunk_count)},
                                    {"message_start_time", num(r.message_start_time_ns)},
                                    {"message_end_time", num(r.message_end_time_ns)},
                                    {"channel_message_counts", mapOf(r.channel_message_counts)}};
        } else if constexpr (std::is_same_v<R, mcap::Metadata>) {
          type = "Metadata", f = {{"name", r.name}, {"metadata", mapOf(r.metadata)}};
        } else if constexpr (std::is_same_v<R, mcap::MetadataIndex>) {
          type = "MetadataIndex",
          f = {{"offset", num(r.offset)}, {"length", num(r.length)}, {"name", r.name}};
        } else if constexpr (std::is_same_v<R, mcap::SummaryOffset>) {
          type = "SummaryOffset", f = {{"group_opcode", num(r.group_opcode)},
                                       {"group_start", num(r.group_start)},
                                       {"group_length", num(r.group_length)}};
        } else {
          type = "DataEnd", f = {{"data_section_crc", num(r.data_section_crc)}};
        }
      },
      record);
  Json fields = Json::array();
  for (const auto& [name, value] : f) fields.push_back(Json::array({name, value}));
  return Json{{"type", type}, {"fields", fields}};
}

std::vector<fs::path> conformanceFiles() {
  std::vector<fs::path> files;
  if (!fs::is_directory(kDataDir)) return files;
  for (const auto& entry : fs::recursive_directory_iterator(kDataDir)) {
    if (entry.path().extension() == ".mcap") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

Json expected(const fs::path& mcap_path) {
  fs::path json_path = mcap_path;
  json_path.replace_extension(".json");
  std::ifstream in(json_path);
  return Json::parse(in);
}

TEST(McapConformance, ScanFindsEveryRecordInOrder) {
  const std::vector<fs::path> files = conformanceFiles();
  if (const std::string why = unavailable(files); !why.empty()) GTEST_SKIP() << why;
  EXPECT_EQ(files.size(), 416U);  // 416 variants of 7 cases: a copy that lost some tests less
  for (const fs::path& file : conformanceFiles()) {
    SCOPED_TRACE(file.filename().string());
    Json records = Json::array();
    const mcap::ScanResult result = mcap::scanRecords(
        file.string(), [&](const mcap::Record& r) { records.push_back(toJson(r)); });
    EXPECT_TRUE(result.complete) << result.warning;
    const Json want = expected(file)["records"];
    ASSERT_EQ(records.size(), want.size());
    for (std::size_t i = 0; i < want.size(); ++i) EXPECT_EQ(records[i], want[i]) << "record " << i;
  }
}

TEST(McapConformance, ReaderFindsEveryMessageInLogTimeOrder) {
  const std::vector<fs::path> files = conformanceFiles();
  if (const std::string why = unavailable(files); !why.empty()) GTEST_SKIP() << why;
  std::size_t indexed = 0;
  for (const fs::path& file : conformanceFiles()) {
    SCOPED_TRACE(file.filename().string());
    using Key = std::tuple<std::uint64_t, std::uint16_t, std::uint32_t, std::vector<std::uint8_t>>;
    std::vector<Key> want;
    const Json doc = expected(file);  // kept: a range over a temporary's member would dangle
    for (const Json& record : doc["records"]) {
      if (record["type"] != "Message") continue;
      std::map<std::string, Json> f;
      for (const Json& field : record["fields"]) f[field[0]] = field[1];
      std::vector<std::uint8_t> data;
      for (const Json& b : f["data"])
        data.push_back(static_cast<std::uint8_t>(std::stoi(b.get<std::string>())));
      want.emplace_back(std::stoull(f["log_time"].get<std::string>()),
                        static_cast<std::uint16_t>(std::stoul(f["channel_id"].get<std::string>())),
                        static_cast<std::uint32_t>(std::stoul(f["sequence"].get<std::string>())),
                        data);
    }
    mcap::McapReader reader(file.string());
    EXPECT_TRUE(reader.warnings().empty());
    indexed += reader.usedSummary() ? 1 : 0;
    std::vector<Key> got;
    for (std::size_t i = 0; i < reader.messages().size(); ++i) {
      const mcap::Message m = reader.read(i);
      EXPECT_EQ(m.log_time_ns, reader.messages()[i].log_time_ns);
      if (i > 0) {
        EXPECT_LE(reader.messages()[i - 1].log_time_ns, m.log_time_ns);
      }
      EXPECT_EQ(reader.channels().count(m.channel_id), 1U);
      got.emplace_back(m.log_time_ns, m.channel_id, m.sequence, m.data);
    }
    std::stable_sort(want.begin(), want.end(),
                     [](const Key& a, const Key& b) { return std::get<0>(a) < std::get<0>(b); });
    EXPECT_EQ(got, want);
  }
  EXPECT_GT(indexed, 50U);  // the chunk-indexed variants went through the summary
}

}  // namespace
