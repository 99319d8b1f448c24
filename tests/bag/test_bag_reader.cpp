/// @file
/// BagReader on bags written by other writers: MCAP with zstd / lz4 / no chunks, with and
/// without indexes, sqlite3 (.db3), bag folders; every message comes back as written, in
/// log-time order.

#include "bag_fixtures.h"

#include "mlmap/bag/bag_reader.h"
#include "mlmap/bag/mcap.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>

namespace {

using mlmap::bag::BagMessage;
using mlmap::bag::BagReader;
using mlmap::bag::openBag;
using mlmap::bag::testing::fixture;

/// topic -> message count of a bag.
std::map<std::string, std::uint64_t> counts(const BagReader& bag) {
  std::map<std::string, std::uint64_t> result;
  for (const auto& topic : bag.topics()) result[topic.name] += topic.message_count;
  return result;
}

/// Every message's (log time, topic name, bytes), checked to come in log-time order, then sorted
/// by topic within equal log times (the order of equal stamps is the storage's).
std::vector<std::tuple<std::uint64_t, std::string, std::vector<std::uint8_t>>> allMessages(
    const BagReader& bag) {
  std::vector<std::tuple<std::uint64_t, std::string, std::vector<std::uint8_t>>> all;
  for (std::size_t i = 0; i < bag.entries().size(); ++i) {
    BagMessage m = bag.read(i);
    EXPECT_EQ(m.log_time_ns, bag.entries()[i].log_time_ns);
    EXPECT_EQ(m.topic, bag.entries()[i].topic);
    if (i > 0) {
      EXPECT_LE(bag.entries()[i - 1].log_time_ns, m.log_time_ns);
    }
    all.emplace_back(m.log_time_ns, bag.topics()[m.topic].name, std::move(m.data));
  }
  std::sort(all.begin(), all.end());
  return all;
}

TEST(BagReader, ListsTopicsWithTypesAndCounts) {
  const auto bag = openBag(fixture("clouds_zstd.mcap"));
  EXPECT_TRUE(bag->warnings().empty());
  const std::map<std::string, std::uint64_t> want = {
      {"/points", 4}, {"/pose", 9}, {"/tf_static", 1}};
  EXPECT_EQ(counts(*bag), want);
  const BagReader& reader = *bag;
  EXPECT_EQ(reader.topics()[reader.findTopic("/points")].type, "sensor_msgs/msg/PointCloud2");
  EXPECT_EQ(reader.topics()[reader.findTopic("/pose")].type, "geometry_msgs/msg/PoseStamped");
  EXPECT_EQ(reader.topics()[reader.findTopic("/pose")].serialization_format, "cdr");
  EXPECT_EQ(reader.findTopic("/nothing"), reader.topics().size());
  EXPECT_NE(reader.describeTopics().find("/points (sensor_msgs/msg/PointCloud2, 4 messages)"),
            std::string::npos);
}

TEST(BagReader, EveryStorageGivesTheSameMessages) {
  const auto reference = allMessages(*openBag(fixture("clouds_zstd.mcap")));
  ASSERT_EQ(reference.size(), 14U);
  for (const char* name :
       {"clouds_noindex.mcap", "clouds_folder", "clouds.db3", "clouds_db3_folder"}) {
    SCOPED_TRACE(name);
    const auto bag = openBag(fixture(name));
    EXPECT_TRUE(bag->warnings().empty());
    EXPECT_EQ(allMessages(*bag), reference);
  }
}

TEST(BagReader, Lz4AndUnchunkedMcapMatchTheSqliteCopy) {
  EXPECT_EQ(allMessages(*openBag(fixture("depth_lz4.mcap"))),
            allMessages(*openBag(fixture("depth.db3"))));
  const auto unchunked = openBag(fixture("depth32_unchunked.mcap"));
  EXPECT_EQ(counts(*unchunked).at("/camera/depth/image_rect_raw"), 3U);
}

TEST(BagReader, SummaryIsUsedWhenPresentAndScanOtherwise) {
  EXPECT_TRUE(mlmap::bag::mcap::McapReader(fixture("clouds_zstd.mcap")).usedSummary());
  EXPECT_FALSE(mlmap::bag::mcap::McapReader(fixture("clouds_noindex.mcap")).usedSummary());
}

}  // namespace
