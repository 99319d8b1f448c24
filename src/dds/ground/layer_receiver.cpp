#include "mlmap/dds/ground/layer_receiver.h"

#include "mlmap/dds/transport/entities.h"

#include "mlmap_msgs/msg/Status_PubSubTypes.h"
#include "mlmap_msgs/msg/VoxelBlock_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <cstring>
#include <utility>

namespace mlmap::dds {

namespace fdds = eprosima::fastdds::dds;

namespace {

/// The float32 `intensity` at offset 12 of each of the `count` points of a decoded cloud (the
/// ESDF slice's distances); empty when its point step cannot hold it.
std::vector<float> intensitiesAtOffset12(const sensor_msgs::PointCloud2_& msg, std::size_t count) {
  std::vector<float> values;
  if (msg.point_step_() < 16) return values;
  values.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    std::memcpy(&values[i], msg.data_().data() + i * msg.point_step_() + 12, 4);
  }
  return values;
}

}  // namespace

LayerReceiver::LayerReceiver(const DdsConfig& dds, LayerReceiverOptions options,
                             LayerReceiverEvents events)
    : options_(std::move(options)), events_(std::move(events)), ns_(dds.ns) {
  participant_ = createParticipant(dds, options_.participant_name);
  fdds::Subscriber* subscriber = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (subscriber == nullptr) throw std::runtime_error("cannot create a DDS subscriber");
  readers_ = std::make_unique<TakeReaders>(
      subscriber, [this](const std::string& what) { dropMalformed(what); });
  subscribeClouds(dds);
  subscribeGridAndEsdf(dds);
  subscribeStatusAndTf(dds);
}

LayerReceiver::~LayerReceiver() { close(); }

void LayerReceiver::close() {
  participant_.reset();
  readers_.reset();
}

ReceivedLayers LayerReceiver::finish() {
  close();
  std::lock_guard<std::mutex> lock(mutex_);
  return std::exchange(received_, ReceivedLayers{});
}

ReceivedLayers LayerReceiver::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return received_;
}

std::vector<std::string> missingOf(const ReceivedLayers& layers,
                                   const std::vector<std::string>& names) {
  std::vector<std::string> missing;
  for (const std::string& name : names) {
    if (layers.topics.count(name) == 0) missing.push_back(name);
  }
  return missing;
}

std::vector<std::string> LayerReceiver::missingOf(const std::vector<std::string>& names) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dds::missingOf(received_, names);
}

std::optional<SteadyClock::time_point> LayerReceiver::lastArrival() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<SteadyClock::time_point> newest;
  for (const auto& [name, t] : received_.topics) {
    if (!newest || t.last_at > *newest) newest = t.last_at;
  }
  return newest;
}

std::map<std::string, std::uint64_t> LayerReceiver::messageCounts() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::map<std::string, std::uint64_t> counts;
  for (const auto& [name, t] : received_.topics) counts[name] = t.messages;
  return counts;
}

void LayerReceiver::note(const std::string& name, std::size_t bytes, std::size_t points,
                         const ros_time::Time_& stamp) {
  TopicLog& t = received_.topics[name];
  const SteadyClock::time_point now = SteadyClock::now();
  if (t.messages == 0) t.first_at = now;
  t.last_at = now;
  ++t.messages;
  t.bytes += bytes;
  t.last_points = points;
  // A zero stamp is ROS's "no time" (the node's status before its first mapped frame): no age.
  if (stamp.sec_() == 0 && stamp.nanosec_() == 0) return;
  t.age_ms.push_back(1e3 * (wallClockNow_s() - toSeconds(stamp)));
}

void LayerReceiver::dropMalformed(const std::string& what) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++received_.malformed;
  }
  if (events_.on_malformed) events_.on_malformed(what);
}

template <typename PubSubType>
void LayerReceiver::add(const std::string& name, const fdds::DataReaderQos& qos,
                        std::function<void(typename PubSubType::type&&)> sink, bool absolute) {
  subscribed_.push_back(name);
  readers_->add<PubSubType>(ddsTopicName(absolute ? "" : ns_, name), qos, std::move(sink),
                            [this, name](int publishers) {
                              if (publishers > 0) node_found_.store(true);
                              if (events_.on_matched) events_.on_matched(name, publishers);
                            });
}

void LayerReceiver::subscribeClouds(const DdsConfig& dds) {
  const TopicNames& n = dds.topics;
  const PublishRates& r = dds.rates;
  // As over a lossy link with as_bridge: a lost sample is never repaired, the next replaces it.
  const fdds::DataReaderQos heavy =
      options_.as_bridge ? sensorReaderQos(1) : reliableReaderQos(false, 2);
  const fdds::DataReaderQos latched = reliableReaderQos(true, 2);
  auto cloudTopic = [&](const std::string& name, double rate_hz, const fdds::DataReaderQos& qos,
                        std::vector<Eigen::Vector3f> ReceivedLayers::*store, bool with_distances) {
    if (name.empty() || rate_hz <= 0) return;
    add<sensor_msgs::PointCloud2_PubSubType>(
        name, qos, [this, name, store, with_distances](sensor_msgs::PointCloud2_&& msg) {
          std::vector<Eigen::Vector3f> points;
          const DecodeStatus status = decodePointCloud2(msg, &points);
          if (!status.ok()) {
            return dropMalformed("cannot decode a PointCloud2 on " + name + ": " + status.detail);
          }
          std::vector<float> distances;
          if (with_distances) distances = intensitiesAtOffset12(msg, points.size());
          std::lock_guard<std::mutex> lock(mutex_);
          note(name, msg.data_().size(), points.size(), msg.header_().stamp_());
          if (with_distances) received_.esdf_slice_distance_m = std::move(distances);
          received_.*store = std::move(points);
        });
  };
  cloudTopic(n.awareness, r.awareness_hz, heavy, &ReceivedLayers::awareness_W, false);
  cloudTopic(n.local_map, r.local_map_hz, heavy, &ReceivedLayers::local_W, false);
  cloudTopic(n.global_map, r.global_map_hz, latched, &ReceivedLayers::global_W, false);
  cloudTopic(n.esdf_slice, r.esdf_hz, heavy, &ReceivedLayers::esdf_slice_W, true);
}

void LayerReceiver::subscribeGridAndEsdf(const DdsConfig& dds) {
  const TopicNames& n = dds.topics;
  if (!n.grid.empty() && dds.rates.grid_hz > 0) {
    add<nav_msgs::OccupancyGrid_PubSubType>(
        n.grid, reliableReaderQos(true, 1), [this, name = n.grid](nav_msgs::OccupancyGrid_&& msg) {
          const std::uint64_t cells =
              std::uint64_t{msg.info_().width_()} * std::uint64_t{msg.info_().height_()};
          if (msg.data_().size() != cells) {
            return dropMalformed("an OccupancyGrid on " + name + " holds " +
                                 std::to_string(msg.data_().size()) + " cells, not width x " +
                                 "height = " + std::to_string(cells));
          }
          std::lock_guard<std::mutex> lock(mutex_);
          note(name, msg.data_().size(), msg.data_().size(), msg.header_().stamp_());
          received_.grid = std::move(msg);
        });
  }
  if (!n.esdf_block.empty() && dds.rates.esdf_hz > 0 && !options_.as_bridge) {
    add<mlmap_msgs::VoxelBlock_PubSubType>(
        n.esdf_block, reliableReaderQos(false, 2),
        [this, name = n.esdf_block](mlmap_msgs::VoxelBlock_&& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          note(name, msg.values_().size() * 4, msg.values_().size(), msg.header_().stamp_());
        });
  }
}

void LayerReceiver::subscribeStatusAndTf(const DdsConfig& dds) {
  const std::string& status = dds.topics.status;
  if (!status.empty() && dds.rates.status_hz > 0) {
    add<mlmap_msgs::Status_PubSubType>(status, reliableReaderQos(false, 10),
                                       [this, status](mlmap_msgs::Status_&& msg) {
                                         std::lock_guard<std::mutex> lock(mutex_);
                                         note(status, sizeof(msg), 1, msg.header_().stamp_());
                                         received_.status = std::move(msg);
                                       });
  }
  // The trajectory is world -> body, which the node sends in tf_mode world_body only.
  if (resolveTfMode(dds) != TfMode::kWorldBody) return;
  add<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(
      "tf", reliableReaderQos(false, 100),
      [this](::tf2_msgs::msg::dds_::TFMessage_&& msg) {
        if (msg.transforms_().empty()) return;
        std::lock_guard<std::mutex> lock(mutex_);
        note("tf", 0, msg.transforms_().size(), msg.transforms_().front().header_().stamp_());
        for (const auto& t : msg.transforms_()) {
          const auto& p = t.transform_().translation_();
          received_.trajectory_W.emplace_back(p.x_(), p.y_(), p.z_());
        }
      },
      /*absolute=*/true);
}

}  // namespace mlmap::dds
