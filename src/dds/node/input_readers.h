#pragma once
/// @file
/// The node's inputs: one BEST_EFFORT reader per configured input topic, whose listener only
/// takes samples and hands them to the InputQueue.

#include "counter_sink.h"
#include "input_queue.h"
#include "node_log.h"

#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/dds/transport/entities.h"

#include <fastdds/dds/subscriber/Subscriber.hpp>

#include <string>

namespace mlmap::dds::node {

/// Creates the readers of `dds.topics` (cloud, pose, odometry, depth image, camera info; empty
/// names are left out) in `subscriber`. Samples that fail to decode are counted
/// (inputs_malformed) and logged; each publisher matched or lost is counted
/// (publishers_matched) and logged. The listeners live as long as this object: destroy the
/// readers (the participant) first.
class InputReaders {
 public:
  InputReaders(eprosima::fastdds::dds::Subscriber* subscriber, const DdsConfig& dds,
               InputQueue& queue, CounterSink& counters, NodeLog& log);

 private:
  template <typename PubSubType>
  void add(const std::string& name);
  void handOver(Input&& input);

  const DdsConfig& dds_;
  InputQueue& queue_;
  CounterSink& counters_;
  NodeLog& log_;
  TakeReaders readers_;  ///< the readers' listeners
};

}  // namespace mlmap::dds::node
