#pragma once
// What a ROS 2 tool sees of a process in the graph, for the DDS tests: the endpoints of a named
// participant as Fast DDS discovery reports them (with their GIDs, topics, types, USER_DATA and
// QoS), an observer participant of the test's own, and every sample a reader took.

#include "mlmap/dds/graph/ros_graph.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"

#include "dds_test_support.h"

#include "rmw_dds_common/msg/ParticipantEntitiesInfo_.h"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>

#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace mlmap::dds::test_support {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
namespace rmw = ::rmw_dds_common::msg::dds_;

/// An endpoint as a remote participant learns of it through discovery.
struct Endpoint {
  Gid gid{};
  std::string topic;
  std::string type;
  std::string user_data;
  fdds::ReliabilityQosPolicyKind reliability = fdds::BEST_EFFORT_RELIABILITY_QOS;
  fdds::DurabilityQosPolicyKind durability = fdds::VOLATILE_DURABILITY_QOS;
  eprosima::fastrtps::Duration_t lifespan;
};

/// The endpoints of the participant named `name` that this participant discovered.
class EndpointLog : public fdds::DomainParticipantListener {
 public:
  explicit EndpointLog(std::string name) : name_(std::move(name)) {}

  void on_participant_discovery(fdds::DomainParticipant*,
                                rtps::ParticipantDiscoveryInfo&& info) override {
    if (info.status != rtps::ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT) return;
    if (info.info.m_participantName.to_string() != name_) return;
    std::lock_guard<std::mutex> lock(mutex_);
    participant_ = info.info.m_guid;
  }
  void on_publisher_discovery(fdds::DomainParticipant*, rtps::WriterDiscoveryInfo&& info) override {
    if (info.status != rtps::WriterDiscoveryInfo::DISCOVERED_WRITER) return;
    const rtps::WriterProxyData& w = info.info;
    add(&writers_, w.guid(),
        endpoint(w.guid(), w.topicName().to_string(), w.typeName().to_string(),
                 w.m_qos.m_userData.data_vec(), w.m_qos.m_reliability.kind,
                 w.m_qos.m_durability.kind, w.m_qos.m_lifespan.duration));
  }
  void on_subscriber_discovery(fdds::DomainParticipant*,
                               rtps::ReaderDiscoveryInfo&& info) override {
    if (info.status != rtps::ReaderDiscoveryInfo::DISCOVERED_READER) return;
    const rtps::ReaderProxyData& r = info.info;
    add(&readers_, r.guid(),
        endpoint(r.guid(), r.topicName().to_string(), r.typeName().to_string(),
                 r.m_qos.m_userData.data_vec(), r.m_qos.m_reliability.kind,
                 r.m_qos.m_durability.kind, r.m_qos.m_lifespan.duration));
  }

  /// The named participant's GUID, once discovered.
  std::optional<rtps::GUID_t> participant() {
    std::lock_guard<std::mutex> lock(mutex_);
    return participant_;
  }
  /// Its writers (`writers` true) or readers discovered so far.
  std::vector<Endpoint> endpoints(bool writers) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<Endpoint> out;
    for (const auto& [guid, e] : writers ? writers_ : readers_) {
      if (participant_ && guid.guidPrefix == participant_->guidPrefix) out.push_back(e);
    }
    return out;
  }
  /// Its endpoint on `topic` (writers or readers), if discovered.
  std::optional<Endpoint> on(const std::string& topic, bool writer) {
    for (const Endpoint& e : endpoints(writer)) {
      if (e.topic == topic) return e;
    }
    return std::nullopt;
  }

 private:
  static Endpoint endpoint(const rtps::GUID_t& guid, std::string topic, std::string type,
                           const std::vector<rtps::octet>& user_data,
                           fdds::ReliabilityQosPolicyKind reliability,
                           fdds::DurabilityQosPolicyKind durability,
                           eprosima::fastrtps::Duration_t lifespan) {
    return Endpoint{toGid(guid),     std::move(topic),
                    std::move(type), std::string(user_data.begin(), user_data.end()),
                    reliability,     durability,
                    lifespan};
  }
  void add(std::map<rtps::GUID_t, Endpoint>* to, const rtps::GUID_t& guid, Endpoint e) {
    std::lock_guard<std::mutex> lock(mutex_);
    (*to)[guid] = std::move(e);
  }

  std::string name_;
  std::mutex mutex_;
  std::optional<rtps::GUID_t> participant_;
  std::map<rtps::GUID_t, Endpoint> writers_;
  std::map<rtps::GUID_t, Endpoint> readers_;
};

/// A participant of the test's own ("a ROS 2 tool") that logs what it discovers of the
/// participant named `observed` (mlmap_node's by default).
struct Observer {
  explicit Observer(int domain_id, const std::string& observed = "mlmap_node") : log(observed) {
    const ParticipantSetup setup = participantSetup(localhostConfig(domain_id), "observer");
    participant.reset(fdds::DomainParticipantFactory::get_instance()->create_participant(
        domain_id, setup.qos, &log, fdds::StatusMask::none()));
    if (participant) subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  }
  EndpointLog log;
  ParticipantPtr participant;
  fdds::Subscriber* subscriber = nullptr;
};

/// Every sample a reader took, kept in order.
template <typename Msg>
class Received {
 public:
  TakeListener<Msg> listener{[this](Msg&& m) {
                               std::lock_guard<std::mutex> lock(mutex_);
                               all_.push_back(std::move(m));
                             },
                             [](const std::string&) {}};
  std::vector<Msg> all() {
    std::lock_guard<std::mutex> lock(mutex_);
    return all_;
  }

 private:
  std::mutex mutex_;
  std::vector<Msg> all_;
};

inline std::set<Gid> gidsOf(const std::vector<Endpoint>& endpoints,
                            const std::string& except_topic) {
  std::set<Gid> out;
  for (const Endpoint& e : endpoints) {
    if (e.topic != except_topic) out.insert(e.gid);
  }
  return out;
}

inline std::set<Gid> gidsOf(const std::vector<rmw::Gid_>& gids) {
  std::set<Gid> out;
  for (const rmw::Gid_& g : gids) out.insert(g.data_());
  return out;
}

/// The latest ros_discovery_info sample of `infos`, once it lists one node whose writers (but the
/// ros_discovery_info writer) and readers are exactly the endpoints `log` discovered, else the
/// latest at waitFor()'s deadline (nullopt: none arrived). `*agreed` says which: discovery and
/// the announcements arrive in any order.
inline std::optional<rmw::ParticipantEntitiesInfo_> agreeingDiscoveryInfo(
    Received<rmw::ParticipantEntitiesInfo_>& infos, EndpointLog& log, bool* agreed) {
  auto latest = [&]() -> std::optional<rmw::ParticipantEntitiesInfo_> {
    const std::vector<rmw::ParticipantEntitiesInfo_> all = infos.all();
    if (all.empty()) return std::nullopt;
    return all.back();
  };
  *agreed = waitFor([&] {
    const std::optional<rmw::ParticipantEntitiesInfo_> info = latest();
    if (!info || info->node_entities_info_seq_().size() != 1) return false;
    const rmw::NodeEntitiesInfo_& n = info->node_entities_info_seq_()[0];
    return !n.reader_gid_seq_().empty() &&
           gidsOf(n.writer_gid_seq_()) == gidsOf(log.endpoints(true), "ros_discovery_info") &&
           gidsOf(n.reader_gid_seq_()) == gidsOf(log.endpoints(false), "");
  });
  return latest();
}

}  // namespace mlmap::dds::test_support
