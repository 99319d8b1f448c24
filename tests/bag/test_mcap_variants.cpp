/// @file
/// The MCAP container as another writer (@mcap/core) writes it in every combination of its
/// options: chunked or not, with or without message and chunk indexes, statistics, summary
/// offsets, repeated schemas and channels, zstd and lz4 chunks; with an attachment, metadata, a
/// schemaless channel and messages out of log-time order. Every record must be found in file
/// order by the scan, and every message in log-time order by the reader.

#include "bag_fixtures.h"

#include "mlmap/bag/mcap.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <tuple>

namespace {

namespace mcap = mlmap::bag::mcap;
using mlmap::bag::testing::fixture;
using Key = std::tuple<std::uint64_t, std::uint16_t, std::uint32_t, std::vector<std::uint8_t>>;

const nlohmann::json& variants() {
  static const nlohmann::json json = [] {
    std::ifstream in(fixture("variants.json"));
    return nlohmann::json::parse(in);
  }();
  return json;
}

/// The messages as written (file order).
std::vector<Key> writtenMessages() {
  std::vector<Key> keys;
  for (const auto& m : variants()["messages"]) {
    keys.emplace_back(std::stoull(m["log_time"].get<std::string>()),
                      m["channel_id"].get<std::uint16_t>(), m["sequence"].get<std::uint32_t>(),
                      m["data"].get<std::vector<std::uint8_t>>());
  }
  return keys;
}

TEST(McapVariants, ScanFindsEveryRecordInFileOrder) {
  const int count = variants()["count"];
  ASSERT_EQ(count, 7);
  for (int k = 0; k < count; ++k) {
    SCOPED_TRACE(k);
    std::vector<Key> messages;
    std::set<std::pair<std::uint16_t, std::string>> schemas;
    std::set<std::tuple<std::uint16_t, std::uint16_t, std::string, std::string>> channels;
    std::vector<mcap::Attachment> attachments;
    std::vector<mcap::Metadata> metadata;
    const mcap::ScanResult result = mcap::scanRecords(
        fixture("variant_" + std::to_string(k) + ".mcap"), [&](const mcap::Record& record) {
          if (const auto* m = std::get_if<mcap::Message>(&record)) {
            EXPECT_EQ(m->publish_time_ns, m->log_time_ns + 100);
            messages.emplace_back(m->log_time_ns, m->channel_id, m->sequence, m->data);
          } else if (const auto* s = std::get_if<mcap::Schema>(&record)) {
            schemas.emplace(s->id,
                            s->name + "/" + s->encoding + "/" + std::to_string(s->data.size()));
          } else if (const auto* c = std::get_if<mcap::Channel>(&record)) {
            channels.emplace(c->id, c->schema_id, c->topic, c->message_encoding);
            if (c->topic == "/a") {
              EXPECT_EQ(c->metadata, (std::map<std::string, std::string>{{"k", "v"}}));
            }
          } else if (const auto* a = std::get_if<mcap::Attachment>(&record)) {
            attachments.push_back(*a);
          } else if (const auto* md = std::get_if<mcap::Metadata>(&record)) {
            metadata.push_back(*md);
          }
        });
    EXPECT_TRUE(result.complete) << result.warning;
    EXPECT_EQ(messages, writtenMessages());
    EXPECT_EQ(schemas, (std::set<std::pair<std::uint16_t, std::string>>{{1, "A/jsonschema/3"},
                                                                        {2, "B/ros2msg/0"}}));
    EXPECT_EQ(channels.size(), 3U);
    EXPECT_EQ(channels.count({2, 0, "/raw", "raw"}), 1U);  // schemaless
    ASSERT_EQ(attachments.size(), 1U);
    EXPECT_EQ(attachments[0].name, "calib.yaml");
    EXPECT_EQ(attachments[0].media_type, "text/yaml");
    EXPECT_EQ(attachments[0].log_time_ns, 4U);
    EXPECT_EQ(attachments[0].create_time_ns, 3U);
    EXPECT_EQ(attachments[0].data, (std::vector<std::uint8_t>{9, 8, 7}));
    ASSERT_EQ(metadata.size(), 1U);
    EXPECT_EQ(metadata[0].name, "recorder");
    EXPECT_EQ(metadata[0].metadata,
              (std::map<std::string, std::string>{{"robot", "uav1"}, {"site", "lab"}}));
  }
}

TEST(McapVariants, ReaderGivesEveryMessageInLogTimeOrder) {
  std::vector<Key> want = writtenMessages();
  std::stable_sort(want.begin(), want.end(),
                   [](const Key& a, const Key& b) { return std::get<0>(a) < std::get<0>(b); });
  // The summary is used when it has chunk indexes and the channels (not repeated in it: scanned).
  const std::vector<bool> indexed = {false, false, true, true, false, true, false};
  for (int k = 0; k < 7; ++k) {
    SCOPED_TRACE(k);
    const mcap::McapReader reader(fixture("variant_" + std::to_string(k) + ".mcap"));
    EXPECT_TRUE(reader.warnings().empty());
    EXPECT_EQ(reader.usedSummary(), indexed[static_cast<std::size_t>(k)]);
    std::vector<Key> got;
    for (std::size_t i = 0; i < reader.messages().size(); ++i) {
      const mcap::Message m = reader.read(i);
      got.emplace_back(m.log_time_ns, m.channel_id, m.sequence, m.data);
    }
    EXPECT_EQ(got, want);
  }
}

}  // namespace
