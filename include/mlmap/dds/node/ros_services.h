#pragma once
/// @file
/// ROS 2 services over plain Fast DDS, framed as rmw_fastrtps_cpp (Jazzy's default rmw) frames
/// them, and the read-only ROS 2 parameters of mlmap_node.
///
/// The wire (rmw_fastrtps_shared_cpp, Jazzy: rmw_request.cpp, rmw_response.cpp,
/// custom_service_info.hpp):
/// - a service `name` of node `node` in namespace `/ns` is a request topic `rq/ns/node/nameRequest`
///   (type `<pkg>::srv::dds_::<Srv>_Request_`) read by the server and a reply topic
///   `rr/ns/node/nameReply` (`<Srv>_Response_`) written by it, both with
///   rmw_qos_profile_services_default (RELIABLE, VOLATILE, KEEP_LAST 10) and the type hash of the
///   request / response type in USER_DATA; payloads are the plain CDR of the request / response;
/// - the client writes a request with WriteParams whose related_sample_identity's writer GUID is
///   the GUID of its reply reader; the request's own sample identity (request writer GUID, sequence
///   number) names the request;
/// - the server replies with related_sample_identity = (that reply reader's GUID, the request's
///   sequence number), or (the request writer's GUID, ...) when the request carried no reader GUID;
///   when it names a reader, the server sends it once its reply writer has matched that reader
///   (waiting up to the writer's max_blocking_time), and drops the reply when the client's
///   endpoints have left;
/// - a client takes every reply on its topic and keeps those whose related_sample_identity's writer
///   GUID is its reply reader's or its request writer's, pairing them by sequence number.

#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/fair_request_queue.h"
#include "mlmap/dds/node/node_config.h"

#include "rcl_interfaces/srv/DescribeParameters_.h"
#include "rcl_interfaces/srv/GetParameterTypes_.h"
#include "rcl_interfaces/srv/GetParameters_.h"
#include "rcl_interfaces/srv/ListParameters_.h"
#include "rcl_interfaces/srv/SetParametersAtomically_.h"
#include "rcl_interfaces/srv/SetParameters_.h"

#include <fastrtps/rtps/common/SampleIdentity.h>
#include <fastrtps/rtps/common/WriteParams.h>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace mlmap::dds {

/// The DDS topics of one ROS 2 service.
struct ServiceTopics {
  std::string request;  ///< e.g. "rq/uav1/mlmap_node/save_mapRequest"
  std::string reply;    ///< e.g. "rr/uav1/mlmap_node/save_mapReply"
};

/// The topics of the node-private service `~/<service>` of node `node_name` in the ROS namespace
/// `node_namespace` ("/" or "/a/b", rosNodeNamespace()).
ServiceTopics privateServiceTopics(const std::string& node_namespace, const std::string& node_name,
                                   const std::string& service);

/// rmw_qos_profile_services_default as rmw_fastrtps_cpp applies it to a service's request reader:
/// RELIABLE, VOLATILE, KEEP_LAST 10, no data-sharing.
eprosima::fastdds::dds::DataReaderQos serviceReaderQos();
/// The same for a service's reply writer (and a client's request writer): RELIABLE, VOLATILE,
/// KEEP_LAST 10, synchronous publishing, no data-sharing.
eprosima::fastdds::dds::DataWriterQos serviceWriterQos();

/// How a server addresses its reply to one request (rmw_fastrtps_cpp's pairing).
struct RequestId {
  /// The client's reply reader when the request named it (its related_sample_identity), else the
  /// request writer: the reply's related_sample_identity writer GUID.
  eprosima::fastrtps::rtps::GUID_t reply_to;
  /// The request writer (its sample identity).
  eprosima::fastrtps::rtps::GUID_t request_writer;
  /// The request's sequence number (its sample identity).
  eprosima::fastrtps::rtps::SequenceNumber_t sequence;
};

/// The RequestId of a request taken with `info` (its sample identity and related sample identity).
RequestId requestIdOf(const eprosima::fastdds::dds::SampleInfo& info);

/// True when `guid` names a reader (RTPS entity kinds: the reader bit 0x04 of the last entity id
/// octet), as rmw_fastrtps_cpp tells a client's reply reader from its request writer.
bool isReaderGuid(const eprosima::fastrtps::rtps::GUID_t& guid);

/// The WriteParams of the reply to `id`: related_sample_identity = (reply_to, sequence).
eprosima::fastrtps::rtps::WriteParams replyWriteParams(const RequestId& id);

/// What the services of a node count. Thread-safe through ServiceHost.
struct ServiceCounters {
  std::uint64_t requests = 0;            ///< requests taken and answered
  std::uint64_t requests_malformed = 0;  ///< requests that failed to decode (dropped)
  /// Requests dropped unhandled: the queue was full, or held the client's share already.
  std::uint64_t requests_refused = 0;
  /// Replies not sent: the client's reader never matched, or too many replies were waiting for
  /// readers to match.
  std::uint64_t replies_unmatched = 0;
};

/// The bounds of a ServiceHost: what a client that floods the services can hold.
struct ServiceLimits {
  std::size_t queued_requests = 64;            ///< requests waiting for the thread, in all
  std::size_t queued_requests_per_client = 8;  ///< ... of one client (participant)
  std::size_t waiting_replies = 64;            ///< replies waiting for their reader to match
  std::size_t waiting_replies_per_client = 8;  ///< ... of one client
};

/// Serves ROS 2 services of one node on a participant: per service a request reader and a reply
/// writer (ServiceHost::add()), the handlers run one at a time on a thread of the host's own (never
/// on Fast DDS's listener threads, so a slow handler such as a map save delays only other
/// requests). Requests wait in a FairRequestQueue (clients, i.e. participants, served in turn;
/// bounded by ServiceLimits, the rest refused and counted); a reply whose client reader has not
/// matched yet waits beside the queue, never on the thread. Create the services, then start();
/// stop() before the participant's entities go.
class ServiceHost {
 public:
  /// Services whose endpoints live on `publisher` and `subscriber` (so that ros_discovery_info
  /// lists them with the node's other endpoints). `on_problem` hears one line per malformed request
  /// or unsent reply (any thread; keep it short).
  ServiceHost(eprosima::fastdds::dds::Publisher* publisher,
              eprosima::fastdds::dds::Subscriber* subscriber,
              std::function<void(const std::string&)> on_problem, const ServiceLimits& limits = {});
  ~ServiceHost();
  ServiceHost(const ServiceHost&) = delete;
  ServiceHost& operator=(const ServiceHost&) = delete;

  /// Serves the service on `topics` whose requests are `ReqPubSub::type` and replies
  /// `RespPubSub::type`: `handler` turns each request into its reply. Throws std::runtime_error
  /// when DDS refuses an endpoint. Call before start().
  template <class ReqPubSub, class RespPubSub>
  void add(const ServiceTopics& topics,
           std::function<typename RespPubSub::type(const typename ReqPubSub::type&)> handler);

  /// Starts answering requests.
  void start();
  /// Stops answering (requests not yet handled are dropped) and joins the thread. Idempotent.
  void stop();

  /// What was counted so far.
  [[nodiscard]] ServiceCounters counters() const;

 private:
  /// One service's reply writer and the client readers it matched (rmw's ServicePubListener).
  class ReplyWriter : public eprosima::fastdds::dds::DataWriterListener {
   public:
    /// `on_matched` runs (on Fast DDS's listener thread) each time a reader matches.
    explicit ReplyWriter(std::function<void()> on_matched) : on_matched_(std::move(on_matched)) {}
    void on_publication_matched(
        eprosima::fastdds::dds::DataWriter* writer,
        const eprosima::fastdds::dds::PublicationMatchedStatus& status) override;
    /// True when `reader` is matched now.
    bool isMatched(const eprosima::fastrtps::rtps::GUID_t& reader);
    eprosima::fastdds::dds::DataWriter* writer = nullptr;

   private:
    std::function<void()> on_matched_;
    std::mutex mutex_;
    std::set<eprosima::fastrtps::rtps::GUID_t> readers_;
  };

  /// Writes a reply with the given parameters; true when written.
  using WriteReply = std::function<bool(eprosima::fastrtps::rtps::WriteParams&)>;

  /// A reply waiting for its client's reader to match its writer.
  struct WaitingReply {
    ReplyWriter* out = nullptr;
    RequestId id;
    WriteReply write;
    std::chrono::steady_clock::time_point deadline;
  };

  /// Takes requests on the listener thread and queues their handling.
  class RequestListener : public eprosima::fastdds::dds::DataReaderListener {
   public:
    explicit RequestListener(std::function<void(eprosima::fastdds::dds::DataReader*)> take)
        : take_(std::move(take)) {}
    void on_data_available(eprosima::fastdds::dds::DataReader* reader) override { take_(reader); }

   private:
    std::function<void(eprosima::fastdds::dds::DataReader*)> take_;
  };

  /// Queues `job`, the handling of request `id`, for the handler thread: dropped once stopped,
  /// refused and counted beyond the ServiceLimits.
  void post(const RequestId& id, std::function<void()> job);
  /// Sends the reply to request `id` on `out` as rmw_fastrtps_cpp does: at once when `id` names
  /// no reader or a matched one, else once it matches (within the writer's max_blocking_time);
  /// counts what is not sent. Never waits.
  void sendReply(ReplyWriter& out, WriteReply write, const RequestId& id);
  /// Writes the reply to `id` with `write` and counts the outcome.
  void writeReply(const WriteReply& write, const RequestId& id);
  /// Under `mutex_`: moves the waiting replies whose reader matched to `ready`, drops (and
  /// counts) the expired ones into `expired`.
  void settleWaitingReplies(std::vector<WaitingReply>* ready, std::vector<WaitingReply>* expired);
  /// Counts a request that failed to deserialise on `topic`, and reports `reason`.
  void countMalformed(const std::string& topic, const std::string& reason);
  void run();

  eprosima::fastdds::dds::Publisher* publisher_;
  eprosima::fastdds::dds::Subscriber* subscriber_;
  std::function<void(const std::string&)> on_problem_;
  ServiceLimits limits_;
  std::vector<std::unique_ptr<ReplyWriter>> writers_;
  std::vector<std::unique_ptr<RequestListener>> listeners_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  FairRequestQueue<eprosima::fastrtps::rtps::GuidPrefix_t, std::function<void()>> jobs_;
  std::deque<WaitingReply> waiting_replies_;
  bool reader_matched_ = false;  // a reply writer matched a reader since the last look
  bool stopping_ = false;
  ServiceCounters counters_;
  std::thread thread_;
};

template <class ReqPubSub, class RespPubSub>
void ServiceHost::add(
    const ServiceTopics& topics,
    std::function<typename RespPubSub::type(const typename ReqPubSub::type&)> handler) {
  using Request = typename ReqPubSub::type;
  using Reply = typename RespPubSub::type;
  auto out = std::make_unique<ReplyWriter>([this] {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      reader_matched_ = true;
    }
    cv_.notify_all();
  });
  out->writer = createWriter<RespPubSub>(publisher_, topics.reply, serviceWriterQos(), out.get());
  ReplyWriter* reply_writer = out.get();
  writers_.push_back(std::move(out));
  auto shared_handler = std::make_shared<std::function<Reply(const Request&)>>(std::move(handler));
  auto take = [this, reply_writer, shared_handler](eprosima::fastdds::dds::DataReader* reader) {
    for (;;) {
      auto request = std::make_shared<Request>();
      eprosima::fastdds::dds::SampleInfo info;
      detail::deserializeFailed() = false;
      const bool taken = reader->take_next_sample(request.get(), &info) ==
                         eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
      // cppcheck-suppress knownConditionTrueFalse ; set by
      // CheckedType::deserialize inside take
      if (detail::deserializeFailed()) {
        countMalformed(reader->get_topicdescription()->get_name(), detail::deserializeError());
        continue;
      }
      if (!taken) return;
      if (!info.valid_data) continue;
      const RequestId id = requestIdOf(info);
      post(id, [this, reply_writer, shared_handler, request, id] {
        auto reply = std::make_shared<Reply>((*shared_handler)(*request));
        eprosima::fastdds::dds::DataWriter* writer = reply_writer->writer;
        sendReply(
            *reply_writer,
            [reply, writer](eprosima::fastrtps::rtps::WriteParams& params) {
              return writer->write(reply.get(), params);
            },
            id);
      });
    }
  };
  auto listener = std::make_unique<RequestListener>(std::move(take));
  createReader<ReqPubSub>(subscriber_, topics.request, serviceReaderQos(), listener.get());
  listeners_.push_back(std::move(listener));
}

/// rcl_interfaces/msg/ParameterType constants.
enum class ParameterType : std::uint8_t {
  kNotSet = 0,
  kBool = 1,
  kInteger = 2,
  kDouble = 3,
  kString = 4,
  kByteArray = 5,
  kBoolArray = 6,
  kIntegerArray = 7,
  kDoubleArray = 8,
  kStringArray = 9,
};

/// What mlmap_node runs with for the configuration `config` read from its file: the same, with
/// pipeline.threaded true (the node always runs both stages on threads of their own).
NodeConfig effectiveNodeConfig(const NodeConfig& config);

/// The node's configuration as read-only ROS 2 parameters, one per key, named by its dotted path in
/// the YAML file (`local_map.resolution_m`, `dds.topics.cloud`), typed as rclcpp types them: double
/// -> DOUBLE, int and uint32 -> INTEGER, bool -> BOOL, text and names of choices -> STRING, vectors
/// -> DOUBLE_ARRAY / INTEGER_ARRAY, an unset optional -> NOT_SET. The answers to rcl_interfaces'
/// parameter services follow rclcpp's ParameterService (Jazzy).
class ParameterTable {
 public:
  /// The parameters of `config` (pass effectiveNodeConfig()).
  explicit ParameterTable(const NodeConfig& config);

  /// Every parameter name, sorted.
  [[nodiscard]] std::vector<std::string> names() const;

  /// ~/list_parameters: the names under the request's prefixes (all when none) down to its depth
  /// (0: recursive), with the prefixes of the names listed.
  [[nodiscard]] rcl_interfaces::srv::dds_::ListParameters_Response_ list(
      const rcl_interfaces::srv::dds_::ListParameters_Request_& request) const;
  /// ~/get_parameters: the values in the order asked; no values when one name is unknown (as rclcpp
  /// answers an undeclared parameter).
  [[nodiscard]] rcl_interfaces::srv::dds_::GetParameters_Response_ get(
      const rcl_interfaces::srv::dds_::GetParameters_Request_& request) const;
  /// ~/describe_parameters: descriptors (read_only, the key's meaning and unit); none when one name
  /// is unknown.
  [[nodiscard]] rcl_interfaces::srv::dds_::DescribeParameters_Response_ describe(
      const rcl_interfaces::srv::dds_::DescribeParameters_Request_& request) const;
  /// ~/get_parameter_types: one type per name, NOT_SET for an unknown one.
  [[nodiscard]] rcl_interfaces::srv::dds_::GetParameterTypes_Response_ types(
      const rcl_interfaces::srv::dds_::GetParameterTypes_Request_& request) const;
  /// ~/set_parameters: every parameter refused, with the reason (read-only, or not declared).
  [[nodiscard]] rcl_interfaces::srv::dds_::SetParameters_Response_ set(
      const rcl_interfaces::srv::dds_::SetParameters_Request_& request) const;
  /// ~/set_parameters_atomically: refused as a whole when it names a parameter (all are
  /// read-only), with the first parameter's reason; an empty request succeeds, as in rclcpp.
  [[nodiscard]] rcl_interfaces::srv::dds_::SetParametersAtomically_Response_ setAtomically(
      const rcl_interfaces::srv::dds_::SetParametersAtomically_Request_& request) const;

 private:
  /// Why `name` cannot be set: read-only, or not declared.
  [[nodiscard]] std::string refusal(const std::string& name) const;

  struct Entry {
    rcl_interfaces::msg::dds_::ParameterValue_ value;
    std::string description;
  };
  std::map<std::string, Entry> entries_;
};

}  // namespace mlmap::dds
