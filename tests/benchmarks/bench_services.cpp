// mlmap_bench_services: round-trip time of mlmap_node's ROS 2 services, called on loopback by a
// client that does what rmw_fastrtps_cpp's does (tests/dds/service_client.h): one parameter
// (`ros2 param get`), every parameter (`ros2 param dump`: list, then get of all names) and the
// list alone. By default the node runs in this process (MappingNode, default configuration, no
// inputs) on a participant of its own: Fast DDS then delivers between the two participants
// without sockets (intra-process). With --external the node is a running mlmap_node process on
// the same domain (started with `dds: {domain_id: N, discovery_range: LOCALHOST}`), reached over
// loopback UDP / shared memory as a ROS 2 tool reaches it. The last case (not with --external:
// it would make a running node save its map 2,000 times a second) times the one-name get while
// another participant floods save_map with requests whose reply reader never matches (about
// 2,000 a second, from 2 s before). Figures (median, p99), not pass/fail.

#include "mlmap/dds/node/mapping_node.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/graph/ros_graph.h"
#include "mlmap/dds/node/ros_services.h"
#include "mlmap/pipeline/map_engine.h"

#include "../dds/service_client.h"

#include "rcl_interfaces/srv/GetParameters_PubSubTypes.h"
#include "rcl_interfaces/srv/ListParameters_PubSubTypes.h"
#include "std_srvs/srv/Trigger_PubSubTypes.h"

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace mlmap;
using namespace mlmap::dds;
namespace rcl = ::rcl_interfaces::srv::dds_;
using GetClient = test_support::RmwFastrtpsStyleClient<rcl::GetParameters_Request_PubSubType,
                                                       rcl::GetParameters_Response_PubSubType>;
using ListClient = test_support::RmwFastrtpsStyleClient<rcl::ListParameters_Request_PubSubType,
                                                        rcl::ListParameters_Response_PubSubType>;
using TriggerClient =
    test_support::RmwFastrtpsStyleClient<::std_srvs::srv::dds_::Trigger_Request_PubSubType,
                                         ::std_srvs::srv::dds_::Trigger_Response_PubSubType>;

/// Writes save_map requests (about 2,000 a second) that name a reply reader no participant has,
/// on a participant of its own, while it lives.
class Flood {
 public:
  Flood(const DdsConfig& dds, const std::string& ns)
      : participant_(createParticipant(dds, "bench_flooder")),
        client_(participant_.get(), privateServiceTopics(ns, "mlmap_node", "save_map")) {
    eprosima::fastrtps::rtps::GUID_t nowhere;
    for (int k = 0; k < 12; ++k) nowhere.guidPrefix.value[k] = static_cast<std::uint8_t>(0xA0 + k);
    nowhere.entityId = eprosima::fastrtps::rtps::EntityId_t(0x00000104);  // a reader's kind
    ready_ = test_support::waitFor([&] { return client_.ready(); });
    thread_ = std::thread([this, nowhere] {
      ::std_srvs::srv::dds_::Trigger_Request_ request;
      while (!stop_) {
        eprosima::fastrtps::rtps::WriteParams params;
        params.related_sample_identity().writer_guid() = nowhere;
        if (client_.writer()->write(&request, params)) ++written_;
        std::this_thread::sleep_for(std::chrono::microseconds(500));
      }
    });
  }
  ~Flood() {
    stop_ = true;
    thread_.join();
  }
  Flood(const Flood&) = delete;
  Flood& operator=(const Flood&) = delete;
  [[nodiscard]] bool ready() const { return ready_; }
  [[nodiscard]] long written() const { return written_; }

 private:
  ParticipantPtr participant_;
  TriggerClient client_;
  bool ready_ = false;
  std::atomic<bool> stop_{false};
  std::atomic<long> written_{0};
  std::thread thread_;
};

/// Times `calls` runs of `call` (false: no reply) and prints median and p99 in ms.
void timeCalls(const char* what, int calls, const std::function<bool()>& call) {
  std::vector<double> ms;
  ms.reserve(static_cast<std::size_t>(calls));
  int lost = 0;
  for (int i = 0; i < calls; ++i) {
    const auto start = std::chrono::steady_clock::now();
    if (!call()) {
      ++lost;
      continue;
    }
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                     .count());
  }
  const TimingSummary s = summarizeTimings(ms);
  std::printf("%-36s %6zu calls  median %7.3f ms  p99 %7.3f ms  max %7.3f ms  unanswered %d\n",
              what, s.samples, s.median_ms, s.p99_ms, s.max_ms, lost);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap_node's ROS 2 services: round-trip time on loopback"};
  int calls = 500;
  int domain_id = 219;
  bool external = false;
  app.add_option("--calls", calls, "timed calls per case")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  app.add_option("--domain", domain_id, "DDS domain of the node and the client (loopback only)")
      ->check(CLI::Range(0, 232))
      ->capture_default_str();
  app.add_flag("--external", external, "call a running mlmap_node instead of one in this process");
  CLI11_PARSE(app, argc, argv);

  NodeConfig config;
  config.dds.domain_id = domain_id;
  config.dds.discovery_range = "LOCALHOST";
  config.dds.security.enable = false;
  std::unique_ptr<MappingNode> node;
  if (!external) node = std::make_unique<MappingNode>(config);
  const ParticipantPtr participant = createParticipant(config.dds, "bench_client");
  const std::string ns = rosNodeNamespace(config.dds.ns);
  GetClient get(participant.get(), privateServiceTopics(ns, "mlmap_node", "get_parameters"));
  ListClient list(participant.get(), privateServiceTopics(ns, "mlmap_node", "list_parameters"));
  if (!test_support::waitFor([&] { return get.ready() && list.ready(); })) {
    std::fprintf(stderr, "the node's services were not discovered\n");
    return 1;
  }
  const auto names = list.callUntilAnswered({});
  if (!names || !get.callUntilAnswered({})) {
    std::fprintf(stderr, "the node does not answer\n");
    return 1;
  }
  const std::vector<std::string>& all = names->result_().names_();
  std::printf("mlmap_node: %zu parameters\n", all.size());

  rcl::GetParameters_Request_ one;
  one.names_({"local_map.resolution_m"});
  timeCalls("get_parameters, 1 name", calls, [&] { return get.call(one).has_value(); });
  timeCalls("list_parameters, all", calls, [&] { return list.call({}).has_value(); });
  rcl::GetParameters_Request_ every;
  every.names_(all);
  timeCalls("list + get_parameters, all names", calls,
            [&] { return list.call({}).has_value() && get.call(every).has_value(); });
  if (!external) {
    const Flood flood(config.dds, ns);
    if (!flood.ready()) {
      std::fprintf(stderr, "the flooder's request writer did not match the node\n");
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::seconds(2));  // the flood's backlog, if any, builds
    timeCalls("get_parameters, 1 name, in a flood", calls,
              [&] { return get.call(one).has_value(); });
    std::printf("flood: %ld save_map requests written\n", flood.written());
  }
  if (!node) return 0;
  const ServiceCounters c = node->serviceCounters();
  std::printf(
      "node: %llu requests answered, %llu malformed, %llu refused, %llu replies unmatched\n",
      static_cast<unsigned long long>(c.requests),
      static_cast<unsigned long long>(c.requests_malformed),
      static_cast<unsigned long long>(c.requests_refused),
      static_cast<unsigned long long>(c.replies_unmatched));
  return 0;
}
