// mlmap_node's ROS 2 services (issue 30): requests and replies framed and paired as
// rmw_fastrtps_cpp (Jazzy) does, called by a client written here that does what rmw_fastrtps_cpp's
// client does; the read-only parameters against the effective configuration, every key; save and
// clear; concurrent clients; malformed requests. Domains 214..219 (235..239 lie beyond 232, the
// largest ROS domain id), loopback only.

#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/fair_request_queue.h"
#include "mlmap/dds/node/mapping_node.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/graph/ros_graph.h"
#include "mlmap/dds/node/ros_services.h"
#include "mlmap/dds/wire/type_hash.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"
#include "mlmap/pipeline/map_engine.h"

#include "dds_test_support.h"
#include "raw_type.h"
#include "service_client.h"
#include "../support/temp_dir.h"

#include "rcl_interfaces/srv/DescribeParameters_PubSubTypes.h"
#include "rcl_interfaces/srv/GetParameterTypes_PubSubTypes.h"
#include "rcl_interfaces/srv/GetParameters_PubSubTypes.h"
#include "rcl_interfaces/srv/ListParameters_PubSubTypes.h"
#include "rcl_interfaces/srv/SetParametersAtomically_PubSubTypes.h"
#include "rcl_interfaces/srv/SetParameters_PubSubTypes.h"
#include "rmw_dds_common/msg/ParticipantEntitiesInfo_PubSubTypes.h"
#include "std_srvs/srv/Trigger_PubSubTypes.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
namespace rcl_srv = ::rcl_interfaces::srv::dds_;
namespace rcl_msg = ::rcl_interfaces::msg::dds_;
namespace std_srv = ::std_srvs::srv::dds_;
using test_support::localhostConfig;
using test_support::RmwFastrtpsStyleClient;
using test_support::waitFor;

constexpr const char* kNode = "mlmap_node";

// --- The wire, without DDS -----------------------------------------------------------------------

TEST(ServiceWire, TopicNamesAsRmwNamesANodesPrivateServices) {
  const ServiceTopics root = privateServiceTopics("/", kNode, "save_map");
  EXPECT_EQ(root.request, "rq/mlmap_node/save_mapRequest");
  EXPECT_EQ(root.reply, "rr/mlmap_node/save_mapReply");
  const ServiceTopics ns = privateServiceTopics(rosNodeNamespace("uav1/"), kNode, "get_parameters");
  EXPECT_EQ(ns.request, "rq/uav1/mlmap_node/get_parametersRequest");
  EXPECT_EQ(ns.reply, "rr/uav1/mlmap_node/get_parametersReply");
}

TEST(ServiceWire, QosIsRmwsServicesDefault) {
  const fdds::DataReaderQos r = serviceReaderQos();
  EXPECT_EQ(r.reliability().kind, fdds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(r.durability().kind, fdds::VOLATILE_DURABILITY_QOS);
  EXPECT_EQ(r.history().kind, fdds::KEEP_LAST_HISTORY_QOS);
  EXPECT_EQ(r.history().depth, 10);
  EXPECT_EQ(r.data_sharing().kind(), fdds::DataSharingKind::OFF);
  const fdds::DataWriterQos w = serviceWriterQos();
  EXPECT_EQ(w.reliability().kind, fdds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(w.durability().kind, fdds::VOLATILE_DURABILITY_QOS);
  EXPECT_EQ(w.history().kind, fdds::KEEP_LAST_HISTORY_QOS);
  EXPECT_EQ(w.history().depth, 10);
  EXPECT_EQ(w.data_sharing().kind(), fdds::DataSharingKind::OFF);
}

rtps::GUID_t guidWithEntityKind(std::uint8_t kind, std::uint8_t key) {
  rtps::GUID_t guid;
  for (int i = 0; i < 12; ++i) guid.guidPrefix.value[i] = static_cast<rtps::octet>(i + 1);
  guid.entityId.value[0] = 0;
  guid.entityId.value[1] = 0;
  guid.entityId.value[2] = key;
  guid.entityId.value[3] = kind;
  return guid;
}

TEST(ServiceWire, ReplyGoesToTheClientsReaderWhenTheRequestNamesIt) {
  const rtps::GUID_t writer = guidWithEntityKind(0x03, 1);  // user writer, no key
  const rtps::GUID_t reader = guidWithEntityKind(0x04, 2);  // user reader, no key
  EXPECT_TRUE(isReaderGuid(reader));
  EXPECT_FALSE(isReaderGuid(writer));

  fdds::SampleInfo info;
  info.sample_identity.writer_guid(writer);
  info.sample_identity.sequence_number(rtps::SequenceNumber_t(1, 7));
  info.related_sample_identity.writer_guid(reader);
  RequestId id = requestIdOf(info);
  EXPECT_EQ(id.reply_to, reader);
  EXPECT_EQ(id.request_writer, writer);
  EXPECT_EQ(id.sequence, rtps::SequenceNumber_t(1, 7));
  rtps::WriteParams params = replyWriteParams(id);
  EXPECT_EQ(params.related_sample_identity().writer_guid(), reader);
  EXPECT_EQ(params.related_sample_identity().sequence_number(), rtps::SequenceNumber_t(1, 7));

  // A client that names no reader (an older rmw_fastrtps) gets the reply on its writer's GUID.
  info.related_sample_identity = rtps::SampleIdentity::unknown();
  id = requestIdOf(info);
  EXPECT_EQ(id.reply_to, writer);
  EXPECT_EQ(replyWriteParams(id).related_sample_identity().writer_guid(), writer);
}

// --- Parameters against the effective configuration, every key -----------------------------------

/// Every scalar or sequence leaf of `node` as its dotted key.
void yamlLeaves(const YAML::Node& node, const std::string& path,
                std::map<std::string, YAML::Node>* out) {
  if (node.IsMap()) {
    for (const auto& kv : node) {
      const std::string key = kv.first.as<std::string>();
      yamlLeaves(kv.second, path.empty() ? key : path + "." + key, out);
    }
  } else {
    (*out)[path] = node;
  }
}

/// The parameter value `v` equals the YAML value `y` of the effective configuration, by type.
void expectSameValue(const std::string& name, const rcl_msg::ParameterValue_& v,
                     const YAML::Node& y) {
  SCOPED_TRACE(name);
  switch (static_cast<ParameterType>(v.type_())) {
    case ParameterType::kNotSet:
      EXPECT_TRUE(y.IsNull());
      break;
    case ParameterType::kBool:
      EXPECT_EQ(v.bool_value_(), y.as<bool>());
      break;
    case ParameterType::kInteger:
      EXPECT_EQ(v.integer_value_(), y.as<std::int64_t>());
      break;
    case ParameterType::kDouble:
      EXPECT_EQ(v.double_value_(), y.as<double>());
      break;
    case ParameterType::kString:
      EXPECT_EQ(v.string_value_(), y.as<std::string>());
      break;
    case ParameterType::kDoubleArray:
      ASSERT_TRUE(y.IsSequence());
      ASSERT_EQ(v.double_array_value_().size(), y.size());
      for (std::size_t i = 0; i < y.size(); ++i)
        EXPECT_EQ(v.double_array_value_()[i], y[i].as<double>());
      break;
    case ParameterType::kIntegerArray:
      ASSERT_TRUE(y.IsSequence());
      ASSERT_EQ(v.integer_array_value_().size(), y.size());
      for (std::size_t i = 0; i < y.size(); ++i) {
        EXPECT_EQ(v.integer_array_value_()[i], y[i].as<std::int64_t>());
      }
      break;
    default:
      ADD_FAILURE() << "unexpected parameter type " << int(v.type_());
  }
}

/// A configuration whose values differ from the defaults in every kind of key.
NodeConfig changedConfig(int domain_id) {
  NodeConfig config;
  config.dds = localhostConfig(domain_id);
  config.dds.ns = "uav7";
  config.map.local_map.resolution_m = 0.25;
  config.map.sensor.translation_B_m = Eigen::Vector3d(0.1, -0.2, 0.3);
  config.map_file.save_period_s = 0.0;
  return config;
}

/// The effective configuration's keys and values, read back from its YAML (the reference).
std::map<std::string, YAML::Node> referenceKeys(const NodeConfig& config) {
  std::map<std::string, YAML::Node> keys;
  yamlLeaves(YAML::Load(toYaml(effectiveNodeConfig(config))), "", &keys);
  return keys;
}

TEST(ParameterTable, EveryKeyOfTheEffectiveConfigWithItsValue) {
  const NodeConfig config = changedConfig(215);
  const std::map<std::string, YAML::Node> reference = referenceKeys(config);
  const ParameterTable table(effectiveNodeConfig(config));
  std::vector<std::string> expected;
  expected.reserve(reference.size());
  for (const auto& [key, value] : reference) expected.push_back(key);
  ASSERT_EQ(table.names(), expected);
  ASSERT_GT(expected.size(), 50u);

  rcl_srv::GetParameters_Request_ request;
  request.names_(expected);
  const rcl_srv::GetParameters_Response_ got = table.get(request);
  ASSERT_EQ(got.values_().size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    expectSameValue(expected[i], got.values_()[i], reference.at(expected[i]));
  }
  // Spot checks of the naming and the typing ROS users expect.
  const auto value = [&](const std::string& name) {
    rcl_srv::GetParameters_Request_ one;
    one.names_({name});
    const auto r = table.get(one);
    return r.values_().empty() ? rcl_msg::ParameterValue_() : r.values_()[0];
  };
  EXPECT_EQ(value("local_map.resolution_m").type_(), std::uint8_t(ParameterType::kDouble));
  EXPECT_EQ(value("local_map.resolution_m").double_value_(), 0.25);
  EXPECT_EQ(value("pipeline.threaded").bool_value_(), true) << "the node always runs threaded";
  EXPECT_EQ(value("dds.ns").string_value_(), "uav7");
  EXPECT_EQ(value("dds.domain_id").type_(), std::uint8_t(ParameterType::kInteger));
  EXPECT_EQ(value("dds.domain_id").integer_value_(), 215);
}

TEST(ParameterTable, DescribedReadOnlyTypedAndRefusedWithAReason) {
  const ParameterTable table(effectiveNodeConfig(changedConfig(215)));
  rcl_srv::DescribeParameters_Request_ describe;
  describe.names_(table.names());
  const auto descriptors = table.describe(describe).descriptors_();
  ASSERT_EQ(descriptors.size(), table.names().size());
  rcl_srv::GetParameterTypes_Request_ types_request;
  types_request.names_(table.names());
  const auto types = table.types(types_request).types_();
  ASSERT_EQ(types.size(), descriptors.size());
  for (std::size_t i = 0; i < descriptors.size(); ++i) {
    EXPECT_TRUE(descriptors[i].read_only_()) << descriptors[i].name_();
    EXPECT_EQ(descriptors[i].name_(), table.names()[i]);
    EXPECT_EQ(descriptors[i].type_(), types[i]);
    EXPECT_FALSE(descriptors[i].description_().empty()) << descriptors[i].name_();
  }

  rcl_srv::SetParameters_Request_ set;
  rcl_msg::Parameter_ p;
  p.name_("local_map.resolution_m");
  set.parameters_().push_back(p);
  p.name_("no.such.key");
  set.parameters_().push_back(p);
  const auto results = table.set(set).results_();
  ASSERT_EQ(results.size(), 2u);
  EXPECT_FALSE(results[0].successful_());
  EXPECT_NE(results[0].reason_().find("read-only"), std::string::npos) << results[0].reason_();
  EXPECT_FALSE(results[1].successful_());
  EXPECT_NE(results[1].reason_().find("not declared"), std::string::npos) << results[1].reason_();

  // Unknown names, as rclcpp answers them: no values, no descriptors, type NOT_SET.
  rcl_srv::GetParameters_Request_ get;
  get.names_({"local_map.resolution_m", "no.such.key"});
  EXPECT_TRUE(table.get(get).values_().empty());
  rcl_srv::GetParameterTypes_Request_ unknown_type;
  unknown_type.names_({"no.such.key"});
  EXPECT_EQ(table.types(unknown_type).types_(), std::vector<std::uint8_t>{0});
}

/// rclcpp's list_parameters, written the slow obvious way: the reference for ParameterTable::list.
std::vector<std::string> listedNames(const std::vector<std::string>& all,
                                     const std::vector<std::string>& prefixes,
                                     std::uint64_t depth) {
  std::vector<std::string> out;
  for (const std::string& name : all) {
    const auto dots = [](const std::string& s) {
      return std::uint64_t(std::count(s.begin(), s.end(), '.'));
    };
    bool ok = prefixes.empty() && (depth == 0 || dots(name) < depth);
    for (const std::string& p : prefixes) {
      if (name == p) ok = true;
      if (name.rfind(p + ".", 0) == 0 && (depth == 0 || dots(name.substr(p.size())) < depth))
        ok = true;
    }
    if (ok) out.push_back(name);
  }
  return out;
}

TEST(ParameterTable, ListFollowsRclcppsPrefixesAndDepth) {
  const ParameterTable table(effectiveNodeConfig(changedConfig(215)));
  const std::vector<std::string> all = table.names();
  for (const std::vector<std::string>& prefixes :
       {std::vector<std::string>{}, {"dds"}, {"dds.topics", "local_map"}, {"nothing"}}) {
    for (std::uint64_t depth : {0u, 1u, 2u, 3u}) {
      rcl_srv::ListParameters_Request_ request;
      request.prefixes_(prefixes);
      request.depth_(depth);
      const auto result = table.list(request).result_();
      EXPECT_EQ(result.names_(), listedNames(all, prefixes, depth))
          << "prefixes " << prefixes.size() << " depth " << depth;
      for (const std::string& prefix : result.prefixes_()) {
        EXPECT_TRUE(
            std::any_of(result.names_().begin(), result.names_().end(),
                        [&](const std::string& n) { return n.rfind(prefix + ".", 0) == 0; }))
            << prefix;
      }
    }
  }
  rcl_srv::ListParameters_Request_ top;
  top.depth_(1);
  EXPECT_TRUE(table.list(top).result_().names_().empty()) << "every key is in a section";
  rcl_srv::ListParameters_Request_ everything;
  const auto prefixes = table.list(everything).result_().prefixes_();
  EXPECT_NE(std::find(prefixes.begin(), prefixes.end(), "dds.topics"), prefixes.end());
}

// --- A client as rmw_fastrtps_cpp's, against a running node --------------------------------------

using TriggerClient = RmwFastrtpsStyleClient<std_srv::Trigger_Request_PubSubType,
                                             std_srv::Trigger_Response_PubSubType>;
using ListClient = RmwFastrtpsStyleClient<rcl_srv::ListParameters_Request_PubSubType,
                                          rcl_srv::ListParameters_Response_PubSubType>;
using GetClient = RmwFastrtpsStyleClient<rcl_srv::GetParameters_Request_PubSubType,
                                         rcl_srv::GetParameters_Response_PubSubType>;
using DescribeClient = RmwFastrtpsStyleClient<rcl_srv::DescribeParameters_Request_PubSubType,
                                              rcl_srv::DescribeParameters_Response_PubSubType>;
using TypesClient = RmwFastrtpsStyleClient<rcl_srv::GetParameterTypes_Request_PubSubType,
                                           rcl_srv::GetParameterTypes_Response_PubSubType>;
using SetClient = RmwFastrtpsStyleClient<rcl_srv::SetParameters_Request_PubSubType,
                                         rcl_srv::SetParameters_Response_PubSubType>;
using SetAtomicallyClient =
    RmwFastrtpsStyleClient<rcl_srv::SetParametersAtomically_Request_PubSubType,
                           rcl_srv::SetParametersAtomically_Response_PubSubType>;

using mlmap::test::TempDir;

/// A map file with occupied voxels in the local window and in the global map, made by an engine of
/// `map`'s configuration flying 20 m along x past a wall.
void writeMapFile(const MapConfig& map, const std::string& path) {
  MapEngine engine(map);
  for (int i = 0; i < 40; ++i) {
    PointCloudFrame f;
    f.stamp_s = 0.1 * i;
    f.T_W_B.translation() = Eigen::Vector3d(0.5 * i, 0.0, 1.0);
    for (int a = -10; a <= 10; ++a)
      for (int b = -5; b <= 5; ++b) f.points_S.emplace_back(4.0f, 0.2f * float(a), 0.2f * float(b));
    ASSERT_EQ(engine.submit(std::move(f)), FrameStatus::kAccepted);
  }
  engine.flush();
  io::saveMapFile(engine.exportState(), path);
}

TEST(NodeServices, SaveMapWritesALoadableFileAndClearMapEmptiesTheMap) {
  TempDir dir("mlmap_services_save");
  NodeConfig config;
  config.dds = localhostConfig(216);
  const std::string loaded = (dir.path / "start.mlmap").string();
  const std::string saved = (dir.path / "saved.mlmap").string();
  writeMapFile(config.map, loaded);
  config.map_file.load_path = loaded;
  config.map_file.save_path = saved;
  MappingNode node(config);
  const std::size_t voxels_loaded = io::occupiedVoxels(io::loadMapFile(loaded)).size();
  ASSERT_GT(voxels_loaded, 0u);

  const ParticipantPtr participant = createParticipant(localhostConfig(216), "service_client");
  const std::string ns = rosNodeNamespace(config.dds.ns);
  TriggerClient save(participant.get(), privateServiceTopics(ns, kNode, "save_map"));
  TriggerClient clear(participant.get(), privateServiceTopics(ns, kNode, "clear_map"));
  ASSERT_TRUE(waitFor([&] { return save.ready() && clear.ready(); }));

  const auto saved_reply = save.callUntilAnswered({});
  ASSERT_TRUE(saved_reply);
  EXPECT_TRUE(saved_reply->success_()) << saved_reply->message_();
  EXPECT_NE(saved_reply->message_().find(saved), std::string::npos) << saved_reply->message_();
  EXPECT_EQ(io::occupiedVoxels(io::loadMapFile(saved)).size(), voxels_loaded);

  const auto cleared = clear.callUntilAnswered({});
  ASSERT_TRUE(cleared);
  EXPECT_TRUE(cleared->success_()) << cleared->message_();
  EXPECT_EQ(node.engineStats().global_voxels, 0u);
  ASSERT_NE(node.snapshot(), nullptr);
  EXPECT_EQ(node.snapshot()->window().size.prod(), 0) << "the snapshot planners read is empty";

  const std::uint64_t saves_before = node.counters().map_saves;
  const auto saved_again = save.call({});
  ASSERT_TRUE(saved_again);
  EXPECT_TRUE(saved_again->success_()) << saved_again->message_();
  EXPECT_TRUE(io::occupiedVoxels(io::loadMapFile(saved)).empty());
  EXPECT_EQ(node.counters().map_saves, saves_before + 1);
  EXPECT_EQ(node.counters().map_saves_failed, 0u);
  // Counted once the reply is written, which may be just after the client took it.
  EXPECT_TRUE(waitFor([&] { return node.serviceCounters().requests >= 3u; }))
      << node.serviceCounters().requests << " requests counted";
}

/// A service endpoint of the node as discovery reports it to another participant.
struct DiscoveredEndpoint {
  std::string type;
  std::string user_data;
  fdds::ReliabilityQosPolicyKind reliability = fdds::BEST_EFFORT_RELIABILITY_QOS;
  fdds::DurabilityQosPolicyKind durability = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  Gid gid{};
};

/// The endpoints on rq/ and rr/ topics that this participant discovered, by topic.
class ServiceEndpointLog : public fdds::DomainParticipantListener {
 public:
  void on_publisher_discovery(fdds::DomainParticipant*, rtps::WriterDiscoveryInfo&& info) override {
    if (info.status != rtps::WriterDiscoveryInfo::DISCOVERED_WRITER) return;
    const rtps::WriterProxyData& w = info.info;
    add(w.topicName().to_string(), w.typeName().to_string(), w.m_qos.m_userData.data_vec(),
        w.m_qos.m_reliability.kind, w.m_qos.m_durability.kind, w.guid());
  }
  void on_subscriber_discovery(fdds::DomainParticipant*,
                               rtps::ReaderDiscoveryInfo&& info) override {
    if (info.status != rtps::ReaderDiscoveryInfo::DISCOVERED_READER) return;
    const rtps::ReaderProxyData& r = info.info;
    add(r.topicName().to_string(), r.typeName().to_string(), r.m_qos.m_userData.data_vec(),
        r.m_qos.m_reliability.kind, r.m_qos.m_durability.kind, r.guid());
  }
  std::map<std::string, DiscoveredEndpoint> endpoints() {
    std::lock_guard<std::mutex> lock(mutex_);
    return endpoints_;
  }

 private:
  void add(const std::string& topic, const std::string& type,
           const std::vector<rtps::octet>& user_data, fdds::ReliabilityQosPolicyKind reliability,
           fdds::DurabilityQosPolicyKind durability, const rtps::GUID_t& guid) {
    if (topic.rfind("rq/", 0) != 0 && topic.rfind("rr/", 0) != 0) return;
    std::lock_guard<std::mutex> lock(mutex_);
    endpoints_[topic] = {type, std::string(user_data.begin(), user_data.end()), reliability,
                         durability, toGid(guid)};
  }
  std::mutex mutex_;
  std::map<std::string, DiscoveredEndpoint> endpoints_;
};

// What a ROS 2 tool learns of the services: rq/ readers and rr/ writers with rmw's type names,
// RELIABLE and VOLATILE, the Jazzy type hash of the request / response type in USER_DATA (the
// vectors of ../shared/reference/ros2-type-hashes.md), and their GIDs in ros_discovery_info.
TEST(NodeServices, EndpointsAsRmwFastrtpsAnnouncesThemAndListedInTheGraph) {
  constexpr int kDomain = 215;
  // The listeners outlive the observer's readers: declared first, destroyed last.
  ServiceEndpointLog log;
  std::mutex infos_mutex;
  std::vector<::rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_> infos;
  TakeListener<::rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_> info_listener(
      [&](::rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_&& info) {
        std::lock_guard<std::mutex> lock(infos_mutex);
        infos.push_back(std::move(info));
      },
      [](const std::string&) {});
  const ParticipantSetup setup = participantSetup(localhostConfig(kDomain), "observer");
  const ParticipantPtr observer(fdds::DomainParticipantFactory::get_instance()->create_participant(
      kDomain, setup.qos, &log, fdds::StatusMask::none()));
  ASSERT_TRUE(observer);
  createReader<::rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_PubSubType>(
      observer->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT), "ros_discovery_info",
      reliableReaderQos(true, 1), &info_listener);
  MappingNode node([] {
    NodeConfig config;
    config.dds = localhostConfig(kDomain);
    return config;
  }());

  struct Expected {
    const char* service;
    const char* request_type;
    const char* request_hash;
    const char* response_type;
    const char* response_hash;
  };
  const std::vector<Expected> expected = {
      {"save_map", "std_srvs::srv::dds_::Trigger_Request_",
       "RIHS01_"
       "d010825374ce8918e72bfd826c82603e60f45419e932ea976f807b74a863a199",
       "std_srvs::srv::dds_::Trigger_Response_",
       "RIHS01_"
       "2d946c21e2fc3f1e9ca6986a8191d85fcc70097a8bb7771a053564bc47009cdf"},
      {"clear_map", "std_srvs::srv::dds_::Trigger_Request_",
       "RIHS01_"
       "d010825374ce8918e72bfd826c82603e60f45419e932ea976f807b74a863a199",
       "std_srvs::srv::dds_::Trigger_Response_",
       "RIHS01_"
       "2d946c21e2fc3f1e9ca6986a8191d85fcc70097a8bb7771a053564bc47009cdf"},
      {"get_parameters", "rcl_interfaces::srv::dds_::GetParameters_Request_",
       "RIHS01_"
       "135a9e1c3d7cebef792f6687d7ddf99949b21a0bd9a320d863a9110a3f5cf4d6",
       "rcl_interfaces::srv::dds_::GetParameters_Response_",
       "RIHS01_"
       "9fa773b46e39cc5d02db6224d8fd520bb9caeeffc2b27c96c1e59431baba9f2a"},
      {"list_parameters", "rcl_interfaces::srv::dds_::ListParameters_Request_",
       "RIHS01_"
       "a1b0b5d6b967a5b8ac5bc8563c3ea678f349e312a6a4967227c5a96bc5ce38df",
       "rcl_interfaces::srv::dds_::ListParameters_Response_",
       "RIHS01_"
       "31b937b82de3612426be79f231e386259f97e8dc843e3f2845288b4bfa296bdd"},
      {"describe_parameters", "rcl_interfaces::srv::dds_::DescribeParameters_Request_",
       "RIHS01_"
       "05dd1c2bc87dec2627105c8070d6f9725c781a4f2ab852975bf105462b82b644",
       "rcl_interfaces::srv::dds_::DescribeParameters_Response_",
       "RIHS01_"
       "ad6747319613c6131589e062e095b469a46cc764f7d0f12a001a49e6cd893995"},
      // These three as rosidl_generator_type_description wrote them in a ROS 2 Jazzy build of
      // rcl_interfaces (share/rcl_interfaces/srv/*.json).
      {"get_parameter_types", "rcl_interfaces::srv::dds_::GetParameterTypes_Request_",
       "RIHS01_"
       "87d7ec5ef545d4daa289d500025d31fb2437bc8b8365ca367161c4dac4be33fd",
       "rcl_interfaces::srv::dds_::GetParameterTypes_Response_",
       "RIHS01_"
       "ac1335dce67c478e669434f6ac2fbff34fcd529580f272d3006785ba8b54e47f"},
      {"set_parameters", "rcl_interfaces::srv::dds_::SetParameters_Request_",
       "RIHS01_"
       "130d46386b7e84ea9ecf60608a4d83cbe5e5cb7c6cc5b712b7a4e3a6c254e932",
       "rcl_interfaces::srv::dds_::SetParameters_Response_",
       "RIHS01_"
       "7a0e8140a0b8d98308fa81a5403a766e610af29a239caf54b7553227906fc266"},
      {"set_parameters_atomically", "rcl_interfaces::srv::dds_::SetParametersAtomically_Request_",
       "RIHS01_"
       "db0bd950ed5ed867a0e90b225e44dea382d762c0762ff3e0ee842190042a59e5",
       "rcl_interfaces::srv::dds_::SetParametersAtomically_Response_",
       "RIHS01_"
       "31b1a38c5b0b9d893ee24da45f69638f4561c78461d82d52750f429b534502b8"},
  };
  ASSERT_TRUE(waitFor([&] { return log.endpoints().size() == 2 * expected.size(); }))
      << log.endpoints().size() << " service endpoints discovered";
  const std::map<std::string, DiscoveredEndpoint> found = log.endpoints();
  std::set<Gid> service_gids;
  for (const Expected& e : expected) {
    const ServiceTopics topics = privateServiceTopics("/", kNode, e.service);
    for (const bool request : {true, false}) {
      const std::string& topic = request ? topics.request : topics.reply;
      SCOPED_TRACE(topic);
      ASSERT_EQ(found.count(topic), 1u);
      const DiscoveredEndpoint& d = found.at(topic);
      const std::string type = request ? e.request_type : e.response_type;
      const char* hash = request ? e.request_hash : e.response_hash;
      EXPECT_EQ(d.type, type);
      EXPECT_EQ(d.user_data,
                "typehash=" + (hash != nullptr ? std::string(hash) : rosTypeHash(type)) + ";");
      EXPECT_EQ(d.reliability, fdds::RELIABLE_RELIABILITY_QOS);
      EXPECT_EQ(d.durability, fdds::VOLATILE_DURABILITY_QOS);
      service_gids.insert(d.gid);
    }
  }
  // ros_discovery_info lists every service endpoint with the node's other endpoints.
  ASSERT_TRUE(waitFor([&] {
    std::lock_guard<std::mutex> lock(infos_mutex);
    if (infos.empty() || infos.back().node_entities_info_seq_().size() != 1) return false;
    const auto& listed = infos.back().node_entities_info_seq_()[0];
    std::set<Gid> gids;
    for (const auto& g : listed.reader_gid_seq_()) gids.insert(g.data_());
    for (const auto& g : listed.writer_gid_seq_()) gids.insert(g.data_());
    return std::includes(gids.begin(), gids.end(), service_gids.begin(), service_gids.end());
  })) << "the service endpoints are missing from ros_discovery_info";
}

TEST(NodeServices, SaveMapWithoutASavePathRepliesWhy) {
  NodeConfig config;
  config.dds = localhostConfig(217);
  MappingNode node(config);
  const ParticipantPtr participant = createParticipant(localhostConfig(217), "service_client");
  TriggerClient save(participant.get(), privateServiceTopics("/", kNode, "save_map"));
  ASSERT_TRUE(waitFor([&] { return save.ready(); }));
  const auto reply = save.callUntilAnswered({});
  ASSERT_TRUE(reply);
  EXPECT_FALSE(reply->success_());
  EXPECT_NE(reply->message_().find("map_file.save_path"), std::string::npos) << reply->message_();
  EXPECT_EQ(node.counters().map_saves_failed, 0u) << "no save was tried";
}

TEST(NodeServices, ParametersOverTheWireEqualTheEffectiveConfigEveryKey) {
  const NodeConfig config = changedConfig(218);
  const std::map<std::string, YAML::Node> reference = referenceKeys(config);
  MappingNode node(config);
  const ParticipantPtr participant = createParticipant(localhostConfig(218), "param_client");
  const std::string ns = rosNodeNamespace(config.dds.ns);
  ListClient list(participant.get(), privateServiceTopics(ns, kNode, "list_parameters"));
  GetClient get(participant.get(), privateServiceTopics(ns, kNode, "get_parameters"));
  DescribeClient describe(participant.get(),
                          privateServiceTopics(ns, kNode, "describe_parameters"));
  TypesClient types(participant.get(), privateServiceTopics(ns, kNode, "get_parameter_types"));
  SetClient set(participant.get(), privateServiceTopics(ns, kNode, "set_parameters"));
  SetAtomicallyClient set_atomically(participant.get(),
                                     privateServiceTopics(ns, kNode, "set_parameters_atomically"));
  ASSERT_TRUE(waitFor([&] {
    return list.ready() && get.ready() && describe.ready() && types.ready() && set.ready() &&
           set_atomically.ready();
  }));

  const auto listed = list.callUntilAnswered({});  // `ros2 param list`: no prefixes, recursive
  ASSERT_TRUE(listed);
  std::vector<std::string> expected;
  expected.reserve(reference.size());
  for (const auto& [key, value] : reference) expected.push_back(key);
  ASSERT_EQ(listed->result_().names_(), expected);

  rcl_srv::GetParameters_Request_ get_all;
  get_all.names_(expected);
  const auto values = get.callUntilAnswered(get_all);
  ASSERT_TRUE(values);
  ASSERT_EQ(values->values_().size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    expectSameValue(expected[i], values->values_()[i], reference.at(expected[i]));
  }

  rcl_srv::DescribeParameters_Request_ describe_all;
  describe_all.names_(expected);
  const auto descriptors = describe.callUntilAnswered(describe_all);
  ASSERT_TRUE(descriptors);
  ASSERT_EQ(descriptors->descriptors_().size(), expected.size());
  rcl_srv::GetParameterTypes_Request_ types_all;
  types_all.names_(expected);
  const auto typed = types.callUntilAnswered(types_all);
  ASSERT_TRUE(typed);
  ASSERT_EQ(typed->types_().size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_TRUE(descriptors->descriptors_()[i].read_only_()) << expected[i];
    EXPECT_EQ(descriptors->descriptors_()[i].type_(), values->values_()[i].type_()) << expected[i];
    EXPECT_EQ(typed->types_()[i], values->values_()[i].type_()) << expected[i];
  }

  rcl_srv::SetParameters_Request_ set_one;
  rcl_msg::Parameter_ p;
  p.name_("local_map.resolution_m");
  p.value_().type_(std::uint8_t(ParameterType::kDouble));
  p.value_().double_value_(0.1);
  set_one.parameters_({p});
  const auto refused = set.callUntilAnswered(set_one);
  ASSERT_TRUE(refused);
  ASSERT_EQ(refused->results_().size(), 1u);
  EXPECT_FALSE(refused->results_()[0].successful_());
  EXPECT_NE(refused->results_()[0].reason_().find("read-only"), std::string::npos);

  // `ros2 param set` goes through set_parameters; rclpy's client waits for this one as well.
  rcl_srv::SetParametersAtomically_Request_ set_two;
  rcl_msg::Parameter_ unknown;
  unknown.name_("no.such.key");
  set_two.parameters_({p, unknown});
  const auto refused_whole = set_atomically.callUntilAnswered(set_two);
  ASSERT_TRUE(refused_whole);
  EXPECT_FALSE(refused_whole->result_().successful_());
  EXPECT_NE(refused_whole->result_().reason_().find("read-only"), std::string::npos)
      << refused_whole->result_().reason_();
  set_two.parameters_({unknown});
  const auto undeclared = set_atomically.callUntilAnswered(set_two);
  ASSERT_TRUE(undeclared);
  EXPECT_FALSE(undeclared->result_().successful_());
  EXPECT_NE(undeclared->result_().reason_().find("not declared"), std::string::npos);
  const auto nothing = set_atomically.callUntilAnswered({});
  ASSERT_TRUE(nothing);
  EXPECT_TRUE(nothing->result_().successful_()) << "an empty request sets nothing, as in rclcpp";
}

TEST(NodeServices, ConcurrentClientsEachGetTheirOwnReplyAndMalformedRequestsAreCounted) {
  NodeConfig config;
  config.dds = localhostConfig(219);
  MappingNode node(config);
  const ServiceTopics topics = privateServiceTopics("/", kNode, "get_parameters");

  // Two clients, each in a participant of its own, calling at the same time with different names:
  // each must get the values of its own names, every time.
  const ParticipantPtr a_participant = createParticipant(localhostConfig(219), "client_a");
  const ParticipantPtr b_participant = createParticipant(localhostConfig(219), "client_b");
  // Replies to both go to both readers: a client that takes late on a loaded machine while the
  // other calls fast would lose its own reply from rmw's 10-deep history (service_client.h).
  constexpr int kReplyDepth = 100;
  GetClient a(a_participant.get(), topics, kReplyDepth);
  GetClient b(b_participant.get(), topics, kReplyDepth);
  ASSERT_TRUE(waitFor([&] { return a.ready() && b.ready(); })) << "the clients did not match";
  rcl_srv::GetParameters_Request_ nothing;
  ASSERT_TRUE(a.callUntilAnswered(nothing)) << "no answer to client a";
  ASSERT_TRUE(b.callUntilAnswered(nothing)) << "no answer to client b";
  constexpr int kCalls = 20;
  std::atomic<int> a_right{0}, b_right{0};
  auto run = [&](GetClient& client, const std::string& name, ParameterType type,
                 std::atomic<int>& right) {
    rcl_srv::GetParameters_Request_ request;
    request.names_({name});
    for (int i = 0; i < kCalls; ++i) {
      const auto reply = client.call(request);
      if (reply && reply->values_().size() == 1 &&
          reply->values_()[0].type_() == std::uint8_t(type))
        ++right;
    }
  };
  std::thread ta([&] { run(a, "local_map.resolution_m", ParameterType::kDouble, a_right); });
  std::thread tb([&] { run(b, "dds.ns", ParameterType::kString, b_right); });
  ta.join();
  tb.join();
  const ServiceCounters counted = node.serviceCounters();
  EXPECT_EQ(a_right.load(), kCalls)
      << counted.requests << " answered, " << counted.replies_unmatched << " unmatched";
  EXPECT_EQ(b_right.load(), kCalls)
      << counted.requests << " answered, " << counted.replies_unmatched << " unmatched";
  EXPECT_GT(a.foreignReplies() + b.foreignReplies(), 0) << "the clients share the reply topic";

  // A request that cannot be decoded (a sequence claiming 2^31 names) is counted and dropped, and
  // the service goes on answering.
  const ParticipantPtr raw = createParticipant(localhostConfig(219), "raw_client");
  fdds::TypeSupport raw_type(
      new test_support::RawType("rcl_interfaces::srv::dds_::GetParameters_Request_", 1024));
  raw_type.register_type(raw.get());
  fdds::Topic* topic =
      raw->create_topic(topics.request, raw_type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  fdds::Publisher* publisher = raw->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  fdds::DataWriter* raw_writer = publisher->create_datawriter(topic, serviceWriterQos());
  ASSERT_NE(raw_writer, nullptr);
  ASSERT_TRUE(waitFor([&] { return test_support::writerMatched(raw_writer); }))
      << "the raw writer did not match";
  test_support::RawBytes bad = test_support::CdrBytes().u32(0x7fffffffu).bytes();
  // Written until counted: the node's reader may match this writer after the writer matched it
  // (see callUntilAnswered()), and drops what came before.
  // cppcheck-suppress knownConditionTrueFalse ; the node's service thread counts it
  EXPECT_TRUE(waitFor([&] {
    if (node.serviceCounters().requests_malformed >= 1) return true;
    raw_writer->write(&bad);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    return node.serviceCounters().requests_malformed >= 1;
  })) << "the malformed request was not counted";
  rcl_srv::GetParameters_Request_ request;
  request.names_({"dds.ns"});
  const auto after = a.call(request);
  ASSERT_TRUE(after) << "no answer after the malformed request";
  EXPECT_EQ(after->values_().size(), 1u);
}

// --- Bounds: a client that floods the services ---------------------------------------------------

TEST(FairRequestQueue, ServesClientsInTurnWithinItsBounds) {
  using Queue = FairRequestQueue<int, int>;
  using Pushed = Queue::Pushed;
  Queue queue(5, 3);
  EXPECT_FALSE(queue.pop());
  EXPECT_EQ(queue.push(1, 10), Pushed::kQueued);
  EXPECT_EQ(queue.push(1, 11), Pushed::kQueued);
  EXPECT_EQ(queue.push(1, 12), Pushed::kQueued);
  EXPECT_EQ(queue.push(1, 13), Pushed::kRefused) << "client 1 holds its share of 3";
  EXPECT_EQ(queue.push(2, 20), Pushed::kQueued);
  EXPECT_EQ(queue.push(2, 21), Pushed::kQueued);
  EXPECT_EQ(queue.size(), 5u);
  // Full: a client with nothing waiting takes the busiest client's newest place (1 holds 3).
  EXPECT_EQ(queue.push(3, 30), Pushed::kQueuedInPlace);
  EXPECT_EQ(queue.size(), 5u);
  EXPECT_EQ(queue.size(1), 2u);
  // A client as busy as the busiest does not take its place; newcomers do, until every client
  // holds at most one more than a newcomer would.
  EXPECT_EQ(queue.push(2, 22), Pushed::kRefused);
  EXPECT_EQ(queue.push(4, 40), Pushed::kQueuedInPlace);  // 1's 11 dropped
  EXPECT_EQ(queue.push(5, 50), Pushed::kQueuedInPlace);  // 2's 21 dropped
  EXPECT_EQ(queue.push(6, 60), Pushed::kRefused);
  EXPECT_EQ(queue.size(), 5u);
  // Each client in turn, each one's requests in order.
  std::vector<int> served;
  while (auto job = queue.pop()) served.push_back(*job);
  EXPECT_EQ(served, (std::vector<int>{10, 20, 30, 40, 50}));
  // A client that arrives while another is served waits for at most one request of it.
  for (int k = 0; k < 3; ++k) ASSERT_EQ(queue.push(1, 100 + k), Pushed::kQueued);
  EXPECT_EQ(*queue.pop(), 100);
  ASSERT_EQ(queue.push(2, 200), Pushed::kQueued);
  EXPECT_EQ(*queue.pop(), 200);
  EXPECT_EQ(*queue.pop(), 101);
  queue.clear();
  EXPECT_TRUE(queue.empty());
}

// A flood of save_map requests that name a reply reader that never matches (4,151 in 10 s in the
// attack) used to hold the one service thread for 100 ms each: honest calls waited minutes.
// Requests now wait in bounded per-client queues served in turn, and unmatched replies wait
// beside them.
TEST(NodeServices, AFloodOfRequestsToAReaderThatNeverComesDelaysNoOne) {
  TempDir dir("mlmap_services_flood");
  NodeConfig config;
  config.dds = localhostConfig(214);
  config.map_file.save_path = (dir.path / "saved.mlmap").string();
  MappingNode node(config);
  const std::string ns = rosNodeNamespace(config.dds.ns);

  const ParticipantPtr flooder = createParticipant(localhostConfig(214), "flooder");
  TriggerClient flood_endpoints(flooder.get(), privateServiceTopics(ns, kNode, "save_map"));
  const ParticipantPtr honest = createParticipant(localhostConfig(214), "honest");
  GetClient get(honest.get(), privateServiceTopics(ns, kNode, "get_parameters"));
  ASSERT_TRUE(waitFor([&] { return flood_endpoints.ready() && get.ready(); }));
  rcl_srv::GetParameters_Request_ request;
  request.names_({"dds.ns"});
  ASSERT_TRUE(get.callUntilAnswered(request));

  // The flooder's own request writer, naming a reader GUID that no participant has.
  rtps::GUID_t nowhere;
  for (int k = 0; k < 12; ++k) nowhere.guidPrefix.value[k] = static_cast<rtps::octet>(0xA0 + k);
  nowhere.entityId = rtps::EntityId_t(0x00000104);  // a user reader's kind
  ASSERT_TRUE(isReaderGuid(nowhere));
  std::atomic<bool> flooding{true};
  std::atomic<int> written{0};
  std::thread flood([&] {
    std_srv::Trigger_Request_ trigger;
    while (flooding) {
      rtps::WriteParams params;
      params.related_sample_identity().writer_guid() = nowhere;
      if (flood_endpoints.writer()->write(&trigger, params)) ++written;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
  });
  // Honest calls during the flood are answered as usual (each within 100 ms when the machine is
  // quiet; 5 s allows for a loaded one, where 3,000 flooded requests at 100 ms each took 300 s).
  int answered = 0;
  for (int i = 0; i < 10; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    const auto reply = get.call(request, std::chrono::milliseconds(5000));
    if (reply && reply->values_().size() == 1) ++answered;
  }
  flooding = false;
  flood.join();
  EXPECT_EQ(answered, 10) << written.load() << " flooded requests written";
  // Every flooded request either was refused (the queue held the flooder's share: how many
  // depends on how fast the map saves) or had its reply dropped, its reader never matching.
  const ServiceCounters counted = node.serviceCounters();
  EXPECT_GT(counted.replies_unmatched, 0u) << written.load() << " written";
  // The flooder's requests that were handled saved the map; none of them held the thread.
  EXPECT_GT(node.counters().map_saves, 0u);
}

}  // namespace
}  // namespace mlmap::dds
