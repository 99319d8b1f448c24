#pragma once
/// @file
/// The node's TF input: readers on rt/tf and rt/tf_static, as a tf2 listener has them, filling a
/// TfBuffer that the input thread (sensor extrinsics) and the publishing thread (odom -> body)
/// look up.

#include "counter_sink.h"
#include "node_log.h"

#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/tf_buffer.h"

#include "tf2_msgs/msg/TFMessage_.h"

#include <fastdds/dds/subscriber/Subscriber.hpp>

#include <mutex>
#include <set>
#include <string>
#include <utility>

namespace mlmap::dds::node {

/// Listens to rt/tf (tf_mode map_odom: the robot's odom -> body) and rt/tf_static (also with
/// sensor_extrinsic tf_static; a TRANSIENT_LOCAL reader, so the latched transforms published
/// before the node started arrive too). Both topics are absolute (no namespace), as tf2's. The
/// edges the node publishes itself are ignored (it would read them back). Each transform taken
/// is counted (tf_transforms_received); a malformed one is counted (inputs_malformed), logged
/// and ignored. Lookups are thread-safe. The listeners live as long as this object: destroy the
/// readers (the participant) first.
class TfListener {
 public:
  /// Creates the readers the configuration needs in `subscriber` (none when it needs none).
  /// `own_edges`: the (parent, child) pairs the node publishes.
  TfListener(eprosima::fastdds::dds::Subscriber* subscriber, const DdsConfig& dds,
             std::set<std::pair<std::string, std::string>> own_edges, CounterSink& counters,
             NodeLog& log);

  /// The configuration makes the node listen to rt/tf (dynamic) or rt/tf_static.
  [[nodiscard]] static bool listensToTf(const DdsConfig& dds);
  [[nodiscard]] static bool listensToTfStatic(const DdsConfig& dds);

  /// TfBuffer::lookup() on what was received so far.
  TfBuffer::Lookup lookup(const std::string& target, const std::string& source, double stamp_s,
                          Transform* T_target_source) const;

 private:
  void take(const ::tf2_msgs::msg::dds_::TFMessage_& msg, bool is_static);

  std::set<std::pair<std::string, std::string>> own_edges_;
  CounterSink& counters_;
  NodeLog& log_;
  mutable std::mutex mutex_;
  TfBuffer buffer_;      ///< guarded by mutex_
  TakeReaders readers_;  ///< the readers' listeners
};

}  // namespace mlmap::dds::node
