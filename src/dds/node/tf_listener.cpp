#include "tf_listener.h"

#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <algorithm>

namespace mlmap::dds::node {

namespace {
/// tf2's buffer keeps 10 s; the node looks up poses at most a pose buffer behind.
constexpr double kMinTfHorizon_s = 10.0;
}  // namespace

bool TfListener::listensToTf(const DdsConfig& dds) {
  return resolveTfMode(dds) == TfMode::kMapOdom;
}

bool TfListener::listensToTfStatic(const DdsConfig& dds) {
  // map_odom: odom -> body may pass through static edges (base_footprint -> base_link).
  return listensToTf(dds) || resolveExtrinsicSource(dds) == ExtrinsicSource::kTfStatic;
}

TfListener::TfListener(eprosima::fastdds::dds::Subscriber* subscriber, const DdsConfig& dds,
                       std::set<std::pair<std::string, std::string>> own_edges,
                       CounterSink& counters, NodeLog& log)
    : own_edges_(std::move(own_edges)),
      counters_(counters),
      log_(log),
      buffer_(std::max(kMinTfHorizon_s, dds.pose_buffer_s), dds.pose_tolerance_s),
      readers_(subscriber, [this](const std::string& what) {
        counters_.add(&NodeCounters::inputs_malformed);
        log_.limited(LogLevel::kWarning, kReasonMalformed, what);
      }) {
  using TfType = ::tf2_msgs::msg::dds_::TFMessage_PubSubType;
  if (listensToTf(dds)) {
    readers_.add<TfType>(ddsTopicName("", "tf"), reliableReaderQos(false, 100),
                         [this](::tf2_msgs::msg::dds_::TFMessage_&& msg) { take(msg, false); });
  }
  if (listensToTfStatic(dds)) {
    readers_.add<TfType>(ddsTopicName("", "tf_static"), reliableReaderQos(true, 100),
                         [this](::tf2_msgs::msg::dds_::TFMessage_&& msg) { take(msg, true); });
  }
}

void TfListener::take(const ::tf2_msgs::msg::dds_::TFMessage_& msg, bool is_static) {
  for (const geometry_msgs::TransformStamped_& t : msg.transforms_()) {
    double stamp_s = 0.0;
    Transform T_parent_child;
    const DecodeStatus status = decodeTransform(t, &stamp_s, &T_parent_child);
    if (!status.ok()) {
      counters_.add(&NodeCounters::inputs_malformed);
      log_.limited(LogLevel::kWarning, kReasonMalformed,
                   std::string("rejected a malformed transform on ") +
                       (is_static ? "tf_static" : "tf") + ": " + toString(status.error) +
                       (status.detail.empty() ? "" : " (" + status.detail + ")"));
      continue;
    }
    const std::string& parent = t.header_().frame_id_();
    const std::string& child = t.child_frame_id_();
    if (own_edges_.count({parent, child}) != 0) continue;  // the node's own
    counters_.add(&NodeCounters::tf_transforms_received);
    std::lock_guard<std::mutex> lock(mutex_);
    if (is_static) {
      buffer_.setStatic(parent, child, T_parent_child);
    } else {
      buffer_.setDynamic(parent, child, stamp_s, T_parent_child);
    }
  }
}

TfBuffer::Lookup TfListener::lookup(const std::string& target, const std::string& source,
                                    double stamp_s, Transform* T_target_source) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return buffer_.lookup(target, source, stamp_s, T_target_source);
}

}  // namespace mlmap::dds::node
