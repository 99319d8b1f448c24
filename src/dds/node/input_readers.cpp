#include "input_readers.h"

#include "mlmap/dds/transport/participant.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"

#include <cstdint>

namespace mlmap::dds::node {

InputReaders::InputReaders(eprosima::fastdds::dds::Subscriber* subscriber, const DdsConfig& dds,
                           InputQueue& queue, CounterSink& counters, NodeLog& log)
    : dds_(dds),
      queue_(queue),
      counters_(counters),
      log_(log),
      readers_(subscriber, [this](const std::string& what) {
        counters_.add(&NodeCounters::inputs_malformed);
        log_.limited(LogLevel::kWarning, kReasonMalformed, what);
      }) {
  const TopicNames& n = dds.topics;
  add<CloudSamplePubSubType>(n.cloud);  // one PointCloud2 type per participant
  add<geometry_msgs::PoseStamped_PubSubType>(n.pose);
  add<nav_msgs::Odometry_PubSubType>(n.odometry);
  add<sensor_msgs::Image_PubSubType>(n.depth_image);
  add<sensor_msgs::CameraInfo_PubSubType>(n.camera_info);
}

template <typename PubSubType>
void InputReaders::add(const std::string& name) {
  if (name.empty()) return;
  const std::string dds_topic = ddsTopicName(dds_.ns, name);
  eprosima::fastdds::dds::DataReaderQos qos = sensorReaderQos();
  if (!dds_.data_sharing) qos.data_sharing().off();
  readers_.add<PubSubType>(
      dds_topic, qos, [this](typename PubSubType::type&& msg) { handOver(Input(std::move(msg))); },
      // This reader's own count, so that the total follows current_count exactly.
      [this, dds_topic, mine = std::int64_t{0}](int now) mutable {
        const std::int64_t change = now - mine;
        mine = now;
        if (change == 0) return;
        counters_.addPublishersMatched(change);
        log_.always(LogLevel::kInfo, dds_topic + ": a publisher " +
                                         (change > 0 ? "matched" : "left") + " (" +
                                         std::to_string(now) + " now)");
      });
}

void InputReaders::handOver(Input&& input) {
  if (queue_.push(std::move(input)) == InputQueue::PushResult::kQueuedOldestFrameDropped) {
    counters_.add(&NodeCounters::frames_handover_dropped);
    log_.limited(LogLevel::kWarning, kReasonHandover,
                 "input thread behind: dropped the oldest waiting cloud / image");
  }
}

}  // namespace mlmap::dds::node
