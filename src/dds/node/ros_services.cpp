#include "mlmap/dds/node/ros_services.h"

#include "mlmap/core/key_list.h"
#include "mlmap/dds/transport/participant.h"

#include <Eigen/Core>

#include <algorithm>
#include <optional>
#include <utility>

namespace mlmap::dds {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
namespace rcl_msg = ::rcl_interfaces::msg::dds_;
namespace rcl_srv = ::rcl_interfaces::srv::dds_;

namespace {

/// rmw_qos_profile_services_default's depth.
constexpr int kServiceDepth = 10;
/// The RTPS entity kind bit that readers have and writers do not (RTPS 9.3.1.2).
constexpr std::uint8_t kEntityIdIsReaderBit = 0x04;

}  // namespace

ServiceTopics privateServiceTopics(const std::string& node_namespace, const std::string& node_name,
                                   const std::string& service) {
  std::string base = node_namespace;
  if (base.empty() || base.back() != '/') base += '/';
  base += node_name + "/" + service;  // "/ns/node/service"
  return {"rq" + base + "Request", "rr" + base + "Reply"};
}

fdds::DataReaderQos serviceReaderQos() {
  fdds::DataReaderQos qos = reliableReaderQos(false, kServiceDepth);
  qos.data_sharing().off();
  return qos;
}

fdds::DataWriterQos serviceWriterQos() { return reliableWriterQos(kServiceDepth); }

RequestId requestIdOf(const fdds::SampleInfo& info) {
  RequestId id;
  id.request_writer = info.sample_identity.writer_guid();
  id.sequence = info.sample_identity.sequence_number();
  const rtps::GUID_t& reader = info.related_sample_identity.writer_guid();
  id.reply_to = reader != rtps::GUID_t::unknown() ? reader : id.request_writer;
  return id;
}

bool isReaderGuid(const rtps::GUID_t& guid) {
  return (guid.entityId.value[3] & kEntityIdIsReaderBit) != 0;
}

rtps::WriteParams replyWriteParams(const RequestId& id) {
  rtps::WriteParams params;
  params.related_sample_identity().writer_guid() = id.reply_to;
  params.related_sample_identity().sequence_number() = id.sequence;
  return params;
}

// --- ServiceHost ---------------------------------------------------------------------------------

void ServiceHost::ReplyWriter::on_publication_matched(
    fdds::DataWriter*, const fdds::PublicationMatchedStatus& status) {
  const rtps::GUID_t reader = rtps::iHandle2GUID(status.last_subscription_handle);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (status.current_count_change > 0) {
      readers_.insert(reader);
    } else if (status.current_count_change < 0) {
      readers_.erase(reader);
    }
  }
  if (status.current_count_change > 0 && on_matched_) on_matched_();
}

bool ServiceHost::ReplyWriter::isMatched(const rtps::GUID_t& reader) {
  std::lock_guard<std::mutex> lock(mutex_);
  return readers_.count(reader) > 0;
}

ServiceHost::ServiceHost(fdds::Publisher* publisher, fdds::Subscriber* subscriber,
                         std::function<void(const std::string&)> on_problem,
                         const ServiceLimits& limits)
    : publisher_(publisher),
      subscriber_(subscriber),
      on_problem_(std::move(on_problem)),
      limits_(limits),
      jobs_(std::max<std::size_t>(1, limits.queued_requests),
            std::max<std::size_t>(1, limits.queued_requests_per_client)) {}

ServiceHost::~ServiceHost() { stop(); }

void ServiceHost::start() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (thread_.joinable() || stopping_) return;
  thread_ = std::thread([this] { run(); });
}

void ServiceHost::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    jobs_.clear();
    waiting_replies_.clear();
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

ServiceCounters ServiceHost::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

void ServiceHost::post(const RequestId& id, std::function<void()> job) {
  std::size_t queued = 0, of_client = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
    using Pushed = decltype(jobs_)::Pushed;
    const Pushed pushed = jobs_.push(id.request_writer.guidPrefix, std::move(job));
    if (pushed != Pushed::kRefused) {
      // In place of the busiest client's newest request: that one is the refused one.
      if (pushed == Pushed::kQueuedInPlace) ++counters_.requests_refused;
      cv_.notify_all();
      return;
    }
    ++counters_.requests_refused;
    queued = jobs_.size();
    of_client = jobs_.size(id.request_writer.guidPrefix);
  }
  if (on_problem_) {
    on_problem_("request refused: " + std::to_string(queued) + " requests wait (" +
                std::to_string(of_client) + " of this client), at most " +
                std::to_string(limits_.queued_requests) + " (" +
                std::to_string(limits_.queued_requests_per_client) + " a client)");
  }
}

void ServiceHost::run() {
  for (;;) {
    std::optional<std::function<void()>> job;
    std::vector<WaitingReply> ready, expired;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      const auto wake = [this] {
        return stopping_ || !jobs_.empty() || reader_matched_ ||
               (!waiting_replies_.empty() &&
                std::chrono::steady_clock::now() >= waiting_replies_.front().deadline);
      };
      if (waiting_replies_.empty()) {
        cv_.wait(lock, wake);
      } else {
        cv_.wait_until(lock, waiting_replies_.front().deadline, wake);
      }
      if (stopping_) return;
      reader_matched_ = false;
      settleWaitingReplies(&ready, &expired);
      job = jobs_.pop();
    }
    for (const WaitingReply& r : ready) writeReply(r.write, r.id);
    if (!expired.empty() && on_problem_) {
      on_problem_("no reply sent on " + expired.front().out->writer->get_topic()->get_name() +
                  (expired.size() > 1 ? " (and " + std::to_string(expired.size() - 1) + " more)"
                                      : std::string()) +
                  ": the client's reply reader did not match in time");
    }
    if (job) (*job)();
  }
}

void ServiceHost::settleWaitingReplies(std::vector<WaitingReply>* ready,
                                       std::vector<WaitingReply>* expired) {
  if (waiting_replies_.empty()) return;  // the common case: no reply waits
  const auto now = std::chrono::steady_clock::now();
  std::deque<WaitingReply> still;
  for (WaitingReply& r : waiting_replies_) {
    if (r.out->isMatched(r.id.reply_to)) {
      ready->push_back(std::move(r));
    } else if (now >= r.deadline) {
      ++counters_.replies_unmatched;
      expired->push_back(std::move(r));
    } else {
      still.push_back(std::move(r));
    }
  }
  // Deadlines are in the order the replies were made, so the front is always the earliest.
  waiting_replies_ = std::move(still);
}

void ServiceHost::countMalformed(const std::string& topic, const std::string& reason) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.requests_malformed;
  }
  if (on_problem_) {
    on_problem_("cannot decode a request on " + topic + " (malformed CDR: " + reason +
                "): dropped");
  }
}

void ServiceHost::sendReply(ReplyWriter& out, WriteReply write, const RequestId& id) {
  // As rmw_fastrtps_cpp: a reply addressed to the client's reader is sent once that reader is
  // matched (up to the writer's max_blocking_time), or it could be sent before the client can
  // receive it. Unlike rmw it waits beside the queue, not on the thread: a client that names a
  // reader that never comes delays no one.
  if (!isReaderGuid(id.reply_to) || out.isMatched(id.reply_to)) {
    writeReply(write, id);
    return;
  }
  const auto& blocking = out.writer->get_qos().reliability().max_blocking_time;
  const auto timeout = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::seconds(blocking.seconds) + std::chrono::nanoseconds(blocking.nanosec));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto client = id.request_writer.guidPrefix;
    const auto of_client = static_cast<std::size_t>(std::count_if(
        waiting_replies_.begin(), waiting_replies_.end(),
        [&](const WaitingReply& r) { return r.id.request_writer.guidPrefix == client; }));
    if (waiting_replies_.size() < limits_.waiting_replies &&
        of_client < limits_.waiting_replies_per_client) {
      waiting_replies_.push_back(
          {&out, id, std::move(write), std::chrono::steady_clock::now() + timeout});
      return;
    }
    ++counters_.replies_unmatched;
  }
  if (on_problem_) {
    on_problem_("no reply sent on " + out.writer->get_topic()->get_name() +
                ": too many replies wait for their client's reader to match");
  }
}

void ServiceHost::writeReply(const WriteReply& write, const RequestId& id) {
  rtps::WriteParams params = replyWriteParams(id);
  const bool written = write(params);
  std::lock_guard<std::mutex> lock(mutex_);
  if (written) {
    ++counters_.requests;
  } else {
    ++counters_.replies_unmatched;
  }
}

// --- Parameters ----------------------------------------------------------------------------------

NodeConfig effectiveNodeConfig(const NodeConfig& config) {
  NodeConfig effective = config;
  effective.map.pipeline.threaded = true;
  return effective;
}

namespace {

rcl_msg::ParameterValue_ typed(ParameterType type) {
  rcl_msg::ParameterValue_ value;
  value.type_(static_cast<std::uint8_t>(type));
  return value;
}

rcl_msg::ParameterValue_ parameterValue(double v) {
  rcl_msg::ParameterValue_ value = typed(ParameterType::kDouble);
  value.double_value_(v);
  return value;
}
rcl_msg::ParameterValue_ parameterValue(int v) {
  rcl_msg::ParameterValue_ value = typed(ParameterType::kInteger);
  value.integer_value_(v);
  return value;
}
rcl_msg::ParameterValue_ parameterValue(std::uint32_t v) {
  rcl_msg::ParameterValue_ value = typed(ParameterType::kInteger);
  value.integer_value_(static_cast<std::int64_t>(v));
  return value;
}
rcl_msg::ParameterValue_ parameterValue(bool v) {
  rcl_msg::ParameterValue_ value = typed(ParameterType::kBool);
  value.bool_value_(v);
  return value;
}
rcl_msg::ParameterValue_ parameterValue(const std::string& v) {
  rcl_msg::ParameterValue_ value = typed(ParameterType::kString);
  value.string_value_(v);
  return value;
}
rcl_msg::ParameterValue_ parameterValue(UnknownAs v) {
  return parameterValue(std::string(toString(v)));
}
rcl_msg::ParameterValue_ parameterValue(const std::optional<bool>& v) {
  return v ? parameterValue(*v) : typed(ParameterType::kNotSet);
}
template <class Scalar, int kRows>
rcl_msg::ParameterValue_ parameterValue(const Eigen::Matrix<Scalar, kRows, 1>& v) {
  if constexpr (std::is_integral_v<Scalar>) {
    rcl_msg::ParameterValue_ value = typed(ParameterType::kIntegerArray);
    for (int i = 0; i < kRows; ++i) value.integer_array_value_().push_back(v[i]);
    return value;
  } else {
    rcl_msg::ParameterValue_ value = typed(ParameterType::kDoubleArray);
    for (int i = 0; i < kRows; ++i) value.double_array_value_().push_back(v[i]);
    return value;
  }
}

/// Collects every key of a config struct as (dotted name, value, description).
template <class Entry>
class ParameterCollector {
 public:
  ParameterCollector(std::map<std::string, Entry>* out, std::string path)
      : out_(out), path_(std::move(path)) {}

  template <class T>
  void key(const char* name, const T& field, const char* unit, const char* doc) {
    Entry& e = (*out_)[path_.empty() ? std::string(name) : path_ + "." + name];
    e.value = parameterValue(field);
    e.description = doc;
    std::replace(e.description.begin(), e.description.end(), '\n', ' ');
    if (*unit != '\0') e.description += std::string(" [") + unit + "]";
  }
  template <class S>
  void section(const char* name, const S& sub, const char* /*doc*/) {
    ParameterCollector nested(out_, path_.empty() ? std::string(name) : path_ + "." + name);
    visitConfig(sub, nested);
  }

 private:
  std::map<std::string, Entry>* out_;
  std::string path_;
};

/// The part of `name` after `prefix` + ".", or nothing when `name` is not under `prefix`.
bool isUnder(const std::string& name, const std::string& prefix) {
  return name.size() > prefix.size() + 1 && name.compare(0, prefix.size(), prefix) == 0 &&
         name[prefix.size()] == '.';
}

std::uint64_t dotsIn(const std::string& text, std::size_t from = 0) {
  return static_cast<std::uint64_t>(
      std::count(text.begin() + static_cast<std::ptrdiff_t>(from), text.end(), '.'));
}

}  // namespace

ParameterTable::ParameterTable(const NodeConfig& config) {
  ParameterCollector<Entry> collector(&entries_, "");
  visitConfig(config, collector);
}

std::vector<std::string> ParameterTable::names() const {
  std::vector<std::string> out;
  out.reserve(entries_.size());
  for (const auto& [name, entry] : entries_) out.push_back(name);
  return out;
}

rcl_srv::ListParameters_Response_ ParameterTable::list(
    const rcl_srv::ListParameters_Request_& request) const {
  // rclcpp's NodeParameters::list_parameters (Jazzy): depth counts the separators below a prefix.
  const std::uint64_t depth = request.depth_();
  const bool recursive = depth == 0;  // ListParameters DEPTH_RECURSIVE
  rcl_srv::ListParameters_Response_ response;
  std::vector<std::string>& names = response.result_().names_();
  std::vector<std::string>& prefixes = response.result_().prefixes_();
  for (const auto& entry : entries_) {
    const std::string& name = entry.first;
    const bool get_all = request.prefixes_().empty() && (recursive || dotsIn(name) < depth);
    const bool prefix_matches = std::any_of(
        request.prefixes_().begin(), request.prefixes_().end(), [&](const std::string& p) {
          if (name == p) return true;
          return isUnder(name, p) && (recursive || dotsIn(name, p.size()) < depth);
        });
    if (!get_all && !prefix_matches) continue;
    names.push_back(name);
    const std::size_t last = name.find_last_of('.');
    if (last == std::string::npos) continue;
    const std::string prefix = name.substr(0, last);
    if (std::find(prefixes.begin(), prefixes.end(), prefix) == prefixes.end())
      prefixes.push_back(prefix);
  }
  return response;
}

rcl_srv::GetParameters_Response_ ParameterTable::get(
    const rcl_srv::GetParameters_Request_& request) const {
  rcl_srv::GetParameters_Response_ response;
  for (const std::string& name : request.names_()) {
    const auto it = entries_.find(name);
    if (it == entries_.end()) return {};
    response.values_().push_back(it->second.value);
  }
  return response;
}

rcl_srv::DescribeParameters_Response_ ParameterTable::describe(
    const rcl_srv::DescribeParameters_Request_& request) const {
  rcl_srv::DescribeParameters_Response_ response;
  for (const std::string& name : request.names_()) {
    const auto it = entries_.find(name);
    if (it == entries_.end()) return {};
    rcl_msg::ParameterDescriptor_ d;
    d.name_(name);
    d.type_(it->second.value.type_());
    d.description_(it->second.description);
    d.additional_constraints_(
        "read-only: mlmap_node's configuration file; "
        "change it there and restart the node");
    d.read_only_(true);
    response.descriptors_().push_back(std::move(d));
  }
  return response;
}

rcl_srv::GetParameterTypes_Response_ ParameterTable::types(
    const rcl_srv::GetParameterTypes_Request_& request) const {
  rcl_srv::GetParameterTypes_Response_ response;
  for (const std::string& name : request.names_()) {
    const auto it = entries_.find(name);
    response.types_().push_back(it == entries_.end()
                                    ? static_cast<std::uint8_t>(ParameterType::kNotSet)
                                    : it->second.value.type_());
  }
  return response;
}

std::string ParameterTable::refusal(const std::string& name) const {
  if (entries_.count(name) == 0) {
    return "parameter '" + name + "' cannot be set because it was not declared";
  }
  return "parameter '" + name +
         "' is read-only: mlmap_node's parameters show its configuration file; change the file "
         "and restart the node";
}

rcl_srv::SetParameters_Response_ ParameterTable::set(
    const rcl_srv::SetParameters_Request_& request) const {
  rcl_srv::SetParameters_Response_ response;
  for (const rcl_msg::Parameter_& p : request.parameters_()) {
    rcl_msg::SetParametersResult_ result;
    result.successful_(false);
    result.reason_(refusal(p.name_()));
    response.results_().push_back(std::move(result));
  }
  return response;
}

rcl_srv::SetParametersAtomically_Response_ ParameterTable::setAtomically(
    const rcl_srv::SetParametersAtomically_Request_& request) const {
  rcl_srv::SetParametersAtomically_Response_ response;
  const bool any = !request.parameters_().empty();
  response.result_().successful_(!any);
  if (any) response.result_().reason_(refusal(request.parameters_().front().name_()));
  return response;
}

}  // namespace mlmap::dds
