// dds::LayerReceiver against samples a writer of another participant sends on loopback, as
// mlmap_node does: every layer kept (the latest of each), counted and aged; malformed samples
// dropped and counted; the subscriptions the configuration and as_bridge give. Domains 227, 228.

#include "mlmap/dds/ground/layer_receiver.h"
#include "mlmap/dds/transport/entities.h"

#include "dds_test_support.h"

#include "mlmap_msgs/msg/Status_PubSubTypes.h"
#include "mlmap_msgs/msg/VoxelBlock_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <set>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
using test_support::localhostConfig;
using test_support::waitFor;
using TfType = ::tf2_msgs::msg::dds_::TFMessage_PubSubType;

/// A participant that writes the node's layers (the node's QoS: latched for the global map and
/// the grid, reliable for the rest).
class LayerWriter {
 public:
  explicit LayerWriter(const DdsConfig& dds)
      : participant_(createParticipant(dds, "layer_writer")),
        publisher_(participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT)),
        ns_(dds.ns) {}

  /// A writer of `PubSubType` on the node's topic `name` (in the namespace unless "tf").
  template <typename PubSubType>
  fdds::DataWriter* writer(const std::string& name, bool latched = false) {
    return createWriter<PubSubType>(publisher_, ddsTopicName(name == "tf" ? "" : ns_, name),
                                    latched ? latchedWriterQos() : reliableWriterQos(10));
  }

 private:
  ParticipantPtr participant_;
  fdds::Publisher* publisher_;
  std::string ns_;
};

/// Waits until `writer` matched a reader, then writes `msg`.
template <typename Msg>
void writeWhenMatched(fdds::DataWriter* writer, Msg msg) {
  ASSERT_TRUE(waitFor([&] { return test_support::writerMatched(writer); }));
  ASSERT_TRUE(writer->write(&msg));
}

std::vector<Eigen::Vector3f> somePoints(float offset, int count) {
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < count; ++i) {
    const auto f = static_cast<float>(i);
    points.emplace_back(offset + 0.1f * f, 0.2f * f, -0.3f * f);
  }
  return points;
}

nav_msgs::OccupancyGrid_ someGrid(std::uint32_t width, std::uint32_t height, std::size_t cells,
                                  double stamp_s) {
  nav_msgs::OccupancyGrid_ grid;
  grid.header_().stamp_(toRosTime(stamp_s));
  grid.info_().width_(width);
  grid.info_().height_(height);
  std::vector<std::int8_t> data(cells);
  for (std::size_t i = 0; i < cells; ++i) data[i] = static_cast<std::int8_t>(i % 102) - 1;
  grid.data_(data);
  return grid;
}

TEST(LayerReceiver, KeepsTheLatestOfEveryLayerWithItsCountsAndAges) {
  test_support::NoIntraprocessDelivery loopback;  // through the transport, as between processes
  DdsConfig dds = localhostConfig(228);
  dds.ns = "uav1";
  dds.tf_mode = "world_body";
  std::vector<std::pair<std::string, int>> matched;
  std::mutex matched_mutex;
  LayerReceiverEvents events;
  events.on_matched = [&](const std::string& topic, int publishers) {
    std::lock_guard<std::mutex> lock(matched_mutex);
    matched.emplace_back(topic, publishers);
  };
  LayerReceiver rx(dds, {}, events);
  const TopicNames& n = dds.topics;
  EXPECT_EQ(rx.subscribed(),
            (std::vector<std::string>{n.awareness, n.local_map, n.global_map, n.esdf_slice, n.grid,
                                      n.esdf_block, n.status, "tf"}));
  EXPECT_FALSE(rx.nodeFound());
  EXPECT_FALSE(rx.lastArrival());

  LayerWriter node(dds);
  const double now_s = wallClockNow_s();
  using Cloud = sensor_msgs::PointCloud2_PubSubType;
  // Two local maps: the second is kept. Stamped a second ago: aged about 1000 ms.
  fdds::DataWriter* local = node.writer<Cloud>(n.local_map);
  writeWhenMatched(local, encodePointCloud2(somePoints(0, 5), nullptr, now_s - 1.0, "world"));
  const std::vector<Eigen::Vector3f> local_W = somePoints(1, 7);
  writeWhenMatched(local, encodePointCloud2(local_W, nullptr, now_s - 1.0, "world"));
  // The global map is latched: written before anything matched, it still arrives.
  const std::vector<Eigen::Vector3f> global_W = somePoints(2, 3);
  sensor_msgs::PointCloud2_ global = encodePointCloud2(global_W, nullptr, now_s - 1.0, "world");
  ASSERT_TRUE(node.writer<Cloud>(n.global_map, true)->write(&global));
  const std::vector<Eigen::Vector3f> slice_W = somePoints(3, 4);
  const std::vector<float> distance_m{-0.5f, 0.f, 1.25f, 3.f};
  writeWhenMatched(node.writer<Cloud>(n.esdf_slice),
                   encodePointCloud2(slice_W, &distance_m, now_s - 1.0, "world"));
  const std::vector<Eigen::Vector3f> awareness_W = somePoints(4, 2);
  writeWhenMatched(node.writer<Cloud>(n.awareness),
                   encodePointCloud2(awareness_W, nullptr, now_s - 1.0, "world"));
  const nav_msgs::OccupancyGrid_ grid = someGrid(3, 2, 6, now_s - 1.0);
  writeWhenMatched(node.writer<nav_msgs::OccupancyGrid_PubSubType>(n.grid, true), grid);
  mlmap_msgs::VoxelBlock_ block;
  block.values_(std::vector<float>(9, 0.5f));
  writeWhenMatched(node.writer<mlmap_msgs::VoxelBlock_PubSubType>(n.esdf_block), block);
  mlmap_msgs::Status_ status;  // unstamped: no age
  status.frames_mapped_(17);
  status.global_voxels_(3);
  writeWhenMatched(node.writer<mlmap_msgs::Status_PubSubType>(n.status), status);
  fdds::DataWriter* tf = node.writer<TfType>("tf");
  for (int i = 0; i < 3; ++i) {
    ::tf2_msgs::msg::dds_::TFMessage_ msg;
    msg.transforms_().resize(1);
    msg.transforms_()[0].header_().stamp_(toRosTime(now_s - 1.0));
    msg.transforms_()[0].transform_().translation_().x_(1.0 * i);
    msg.transforms_()[0].transform_().translation_().y_(2.0);
    writeWhenMatched(tf, msg);
  }

  ASSERT_TRUE(waitFor([&] {
    const auto counts = rx.messageCounts();
    return counts.size() == 8 && counts.at(n.local_map) == 2 && counts.at("tf") == 3;
  })) << "received "
      << rx.messageCounts().size() << " topics";
  EXPECT_TRUE(rx.nodeFound());
  EXPECT_TRUE(rx.lastArrival());
  EXPECT_TRUE(rx.missingOf(rx.subscribed()).empty());
  EXPECT_EQ(rx.missingOf({"mlmap/nothing", n.grid}), std::vector<std::string>{"mlmap/nothing"});

  const ReceivedLayers got = rx.finish();
  EXPECT_EQ(got.local_W, local_W);
  EXPECT_EQ(got.global_W, global_W);
  EXPECT_EQ(got.awareness_W, awareness_W);
  EXPECT_EQ(got.esdf_slice_W, slice_W);
  EXPECT_EQ(got.esdf_slice_distance_m, distance_m);
  EXPECT_EQ(got.grid.data_(), grid.data_());
  EXPECT_EQ(got.grid.info_().width_(), 3u);
  EXPECT_EQ(got.status.frames_mapped_(), 17u);
  EXPECT_EQ(got.status.global_voxels_(), 3u);
  EXPECT_EQ(got.trajectory_W,
            (std::vector<Eigen::Vector3d>{{0.0, 2.0, 0.0}, {1.0, 2.0, 0.0}, {2.0, 2.0, 0.0}}));
  EXPECT_EQ(got.malformed, 0u);

  const TopicLog& l = got.topics.at(n.local_map);
  EXPECT_EQ(l.messages, 2u);
  EXPECT_EQ(l.bytes, (5u + 7u) * 12u);  // float32 x, y, z
  EXPECT_EQ(l.last_points, 7u);
  EXPECT_LE(l.first_at, l.last_at);
  ASSERT_EQ(l.age_ms.size(), 2u);
  for (const double age_ms : l.age_ms) {
    EXPECT_GE(age_ms, 999.0);
    EXPECT_LT(age_ms, 1000.0 + 60e3);  // the writing may wait for discovery
  }
  EXPECT_EQ(got.topics.at(n.esdf_slice).bytes, 4u * 16u);  // with the distance
  EXPECT_EQ(got.topics.at(n.grid).bytes, 6u);
  EXPECT_EQ(got.topics.at(n.grid).last_points, 6u);
  EXPECT_EQ(got.topics.at(n.esdf_block).bytes, 9u * 4u);
  EXPECT_EQ(got.topics.at(n.esdf_block).last_points, 9u);
  EXPECT_EQ(got.topics.at(n.status).bytes, sizeof(mlmap_msgs::Status_));
  EXPECT_TRUE(got.topics.at(n.status).age_ms.empty());  // a zero stamp has no age
  EXPECT_EQ(got.topics.at("tf").messages, 3u);
  EXPECT_EQ(got.topics.at("tf").bytes, 0u);

  // Handed over: the receiver keeps nothing, and no callback comes after finish().
  EXPECT_TRUE(rx.snapshot().topics.empty());
  std::lock_guard<std::mutex> lock(matched_mutex);
  const std::set<std::string> topics_matched = [&] {
    std::set<std::string> names;
    for (const auto& [topic, publishers] : matched) {
      if (publishers > 0) names.insert(topic);
    }
    return names;
  }();
  EXPECT_EQ(topics_matched.size(), 8u);
}

TEST(LayerReceiver, DropsAndCountsMalformedSamplesAndSubscribesAsTheBridge) {
  test_support::NoIntraprocessDelivery loopback;
  DdsConfig dds = localhostConfig(227);
  dds.tf_mode = "none";
  dds.rates.awareness_hz = 0;  // disabled: not subscribed
  dds.topics.status = "";      // disabled: not subscribed
  std::atomic<int> reported{0};
  LayerReceiverEvents events;
  events.on_malformed = [&](const std::string&) { ++reported; };
  std::atomic<int> local_map_publishers{0};
  events.on_matched = [&](const std::string& topic, int publishers) {
    if (topic == dds.topics.local_map) local_map_publishers = publishers;
  };
  LayerReceiverOptions options;
  options.as_bridge = true;  // no ESDF block
  LayerReceiver rx(dds, options, events);
  const TopicNames& n = dds.topics;
  EXPECT_EQ(rx.subscribed(),
            (std::vector<std::string>{n.local_map, n.global_map, n.esdf_slice, n.grid}));

  LayerWriter node(dds);
  // A grid whose data is shorter than width x height: dropped, never drawn.
  fdds::DataWriter* grid = node.writer<nav_msgs::OccupancyGrid_PubSubType>(n.grid, true);
  writeWhenMatched(grid, someGrid(4, 4, 15, 1.0));
  // A cloud whose data disagrees with its sizes: dropped.
  sensor_msgs::PointCloud2_ cloud = encodePointCloud2(somePoints(0, 3), nullptr, 1.0, "world");
  cloud.data_().pop_back();
  fdds::DataWriter* local = node.writer<sensor_msgs::PointCloud2_PubSubType>(n.local_map);
  // BEST_EFFORT as the bridge: a sample the reader has not matched yet is lost.
  ASSERT_TRUE(waitFor([&] { return local_map_publishers.load() > 0; }));
  writeWhenMatched(local, cloud);
  ASSERT_TRUE(waitFor([&] { return reported.load() == 2; })) << reported.load();
  EXPECT_EQ(rx.snapshot().malformed, 2u);
  EXPECT_TRUE(rx.messageCounts().empty());
  // A good grid after them is kept.
  writeWhenMatched(grid, someGrid(4, 4, 16, 1.0));
  ASSERT_TRUE(waitFor([&] { return rx.messageCounts().count(n.grid) == 1; }));
  const ReceivedLayers got = rx.finish();
  EXPECT_EQ(got.grid.data_().size(), 16u);
  EXPECT_TRUE(got.local_W.empty());
  EXPECT_EQ(got.malformed, 2u);
  EXPECT_EQ(missingOf(got, rx.subscribed()),
            (std::vector<std::string>{n.local_map, n.global_map, n.esdf_slice}));
}

}  // namespace
}  // namespace mlmap::dds
