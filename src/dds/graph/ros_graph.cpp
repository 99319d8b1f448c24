#include "mlmap/dds/graph/ros_graph.h"

#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include "rcl_interfaces/msg/Log_PubSubTypes.h"
#include "rmw_dds_common/msg/ParticipantEntitiesInfo_PubSubTypes.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace mlmap::dds {

namespace fdds = eprosima::fastdds::dds;
namespace rmw = ::rmw_dds_common::msg::dds_;

namespace {

/// The topic rmw publishes the graph on (no `rt/` prefix: it is not a ROS topic).
constexpr const char* kDiscoveryInfoTopic = "ros_discovery_info";
/// rcl's /rosout depth and lifespan.
constexpr int kRosoutDepth = 1000;
constexpr int kRosoutLifespan_s = 10;

rmw::Gid_ toGidMessage(const eprosima::fastrtps::rtps::GUID_t& guid) {
  rmw::Gid_ gid;
  gid.data_() = toGid(guid);
  return gid;
}

}  // namespace

Gid toGid(const eprosima::fastrtps::rtps::GUID_t& guid) {
  Gid gid{};
  static_assert(sizeof(guid.guidPrefix.value) + sizeof(guid.entityId.value) == sizeof(Gid));
  std::memcpy(gid.data(), guid.guidPrefix.value, sizeof(guid.guidPrefix.value));
  std::memcpy(gid.data() + sizeof(guid.guidPrefix.value), guid.entityId.value,
              sizeof(guid.entityId.value));
  return gid;
}

std::string rosNodeNamespace(const std::string& ns) {
  const std::string topic = ddsTopicName(ns, "");  // "rt" + "/token" per namespace token
  return topic.size() > 2 ? topic.substr(2) : "/";
}

std::string rosLoggerName(const std::string& node_namespace, const std::string& node_name) {
  std::string name;
  for (const char c : node_namespace) {
    if (c != '/') {
      name += c;
    } else if (!name.empty() && name.back() != '.') {
      name += '.';
    }
  }
  if (!name.empty() && name.back() != '.') name += '.';
  return name + node_name;
}

fdds::DataWriterQos discoveryInfoWriterQos() {
  return latchedWriterQos();  // RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1
}

DiscoveryInfoPublisher::DiscoveryInfoPublisher(fdds::DomainParticipant* participant,
                                               const std::string& node_name,
                                               const std::string& node_namespace) {
  fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  if (publisher == nullptr)
    throw std::runtime_error("cannot create the ros_discovery_info publisher");
  writer_ = createWriter<rmw::ParticipantEntitiesInfo_PubSubType>(publisher, kDiscoveryInfoTopic,
                                                                  discoveryInfoWriterQos());
  info_.gid_(toGidMessage(participant->guid()));
  rmw::NodeEntitiesInfo_ node;
  node.node_name_(node_name);
  node.node_namespace_(node_namespace);
  info_.node_entities_info_seq_().push_back(std::move(node));
}

void DiscoveryInfoPublisher::announce(const std::vector<const fdds::Publisher*>& publishers,
                                      const std::vector<const fdds::Subscriber*>& subscribers) {
  std::vector<rmw::Gid_> writers;
  for (const fdds::Publisher* publisher : publishers) {
    std::vector<fdds::DataWriter*> found;
    publisher->get_datawriters(found);
    for (const fdds::DataWriter* w : found) writers.push_back(toGidMessage(w->guid()));
  }
  std::vector<rmw::Gid_> readers;
  for (const fdds::Subscriber* subscriber : subscribers) {
    std::vector<fdds::DataReader*> found;
    subscriber->get_datareaders(found);
    for (const fdds::DataReader* r : found) readers.push_back(toGidMessage(r->guid()));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  rmw::NodeEntitiesInfo_& node = info_.node_entities_info_seq_().front();
  node.writer_gid_seq_(std::move(writers));
  node.reader_gid_seq_(std::move(readers));
  if (!writer_->write(&info_)) {
    throw std::runtime_error("cannot publish ros_discovery_info");
  }
}

rmw::ParticipantEntitiesInfo_ DiscoveryInfoPublisher::published() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return info_;
}

fdds::DataWriterQos rosoutWriterQos() {
  fdds::DataWriterQos qos = reliableWriterQos(kRosoutDepth);
  qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  qos.lifespan().duration = eprosima::fastrtps::Duration_t(kRosoutLifespan_s, 0);
  return qos;
}

std::uint8_t rosLogLevel(LogLevel level) {
  switch (level) {
    case LogLevel::kInfo:
      return 20;
    case LogLevel::kWarning:
      return 30;
    case LogLevel::kError:
      return 40;
  }
  return 40;  // not reached: every level is listed
}

RosoutWriter::RosoutWriter(fdds::Publisher* publisher, std::string logger_name)
    : writer_(createWriter<::rcl_interfaces::msg::dds_::Log_PubSubType>(
          publisher, ddsTopicName("", "rosout"), rosoutWriterQos())),
      logger_name_(std::move(logger_name)) {}

void RosoutWriter::write(LogLevel level, const std::string& message) const {
  ::rcl_interfaces::msg::dds_::Log_ line;
  line.stamp_(toRosTime(wallClockNow_s()));
  line.level_(rosLogLevel(level));
  line.name_(logger_name_);
  line.msg_(message);
  writer_->write(&line);  // a log line that cannot go out is not worth another log line
}

}  // namespace mlmap::dds
