#pragma once
/// @file
/// The node's outputs: a list of output operations (each a topic's writer, its rate and its
/// encoding) run by the publishing thread from the engine's snapshots and the layer copies of
/// the LayerMailbox, so that a slow or vanished subscriber never blocks mapping.

#include "counter_sink.h"
#include "layer_mailbox.h"
#include "node_log.h"
#include "tf_listener.h"

#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/pipeline/map_engine.h"

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>

#include <chrono>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace mlmap::dds::node {

/// A writer that counts what it publishes (messages_published) and logs a failed write.
class CountedWriter {
 public:
  CountedWriter(eprosima::fastdds::dds::DataWriter* writer, CounterSink& counters, NodeLog& log)
      : writer_(writer), counters_(&counters), log_(&log) {}
  /// Writes `msg` (a message of the writer's type); nothing when there is no writer.
  void write(void* msg) const;
  [[nodiscard]] explicit operator bool() const { return writer_ != nullptr; }
  [[nodiscard]] eprosima::fastdds::dds::DataWriter* get() const { return writer_; }

 private:
  eprosima::fastdds::dds::DataWriter* writer_;
  CounterSink* counters_;
  NodeLog* log_;
};

/// What one round of the publishing thread sees.
struct PublishRound {
  std::shared_ptr<const MapSnapshot> snap;  ///< the engine's latest (null before the first frame)
  LayerMailbox::News news;                  ///< the layer copies taken this round
  bool last = false;                        ///< the final round: publish whatever the rates say
};

/// One output of the node.
class OutputOperation {
 public:
  virtual ~OutputOperation() = default;
  /// Publishes what is new in `round`, if its rate allows (always in the last round).
  virtual void publish(const PublishRound& round) = 0;
};

/// Reports a subscriber that a writer cannot serve because it requests more than the writer
/// offers (e.g. TRANSIENT_LOCAL of a VOLATILE layer): DDS then matches nothing and says nothing.
class IncompatibleQosListener : public eprosima::fastdds::dds::DataWriterListener {
 public:
  explicit IncompatibleQosListener(std::function<void(const std::string&)> report)
      : report_(std::move(report)) {}
  void on_offered_incompatible_qos(
      eprosima::fastdds::dds::DataWriter* writer,
      const eprosima::fastdds::dds::OfferedIncompatibleQosStatus& status) override;

 private:
  std::function<void(const std::string&)> report_;
};

/// The writers of the configured outputs (an output whose name is empty or whose rate is 0 has
/// none), rt/tf (unless tf_mode is none) and the latched rt/tf_static (with publish_sensor_tf),
/// and the publishing thread. tf and tf_static are absolute topics, whatever the namespace.
class Outputs {
 public:
  /// Creates every writer in `publisher` and, with publish_sensor_tf, publishes rt/tf_static
  /// (the sensor's mounting T_B_S, latched for late joiners). `tf`: where tf_mode map_odom
  /// looks up odom -> body (may be null otherwise). `started`: the node's start (the status's
  /// uptime).
  Outputs(eprosima::fastdds::dds::Publisher* publisher, const DdsConfig& dds,
          const Transform& T_B_S, const TfListener* tf, MapEngine& engine, LayerMailbox& mailbox,
          CounterSink& counters, NodeLog& log, std::chrono::steady_clock::time_point started);

  /// The (parent, child) edges the node publishes on rt/tf and rt/tf_static with `dds`.
  static std::set<std::pair<std::string, std::string>> ownEdges(const DdsConfig& dds);
  ~Outputs();
  Outputs(const Outputs&) = delete;
  Outputs& operator=(const Outputs&) = delete;

  /// Starts the publishing thread.
  void start();
  /// Publishes the final state once, ends the thread, and gives the readers up to
  /// kShutdownAckWait in all to acknowledge what was written (a final state lost on the way is
  /// sent again only while the participant lives). Idempotent.
  void finish();
  /// A global map is published (the node hands over its last state at shutdown).
  [[nodiscard]] bool publishesGlobalMap() const { return has_global_; }
  /// The map is shared with the fleet (dds.fleet.publish).
  [[nodiscard]] bool sharesWithFleet() const { return has_fleet_; }

  /// How long the publishing thread waits for news before it checks the rate gates again.
  static constexpr std::chrono::milliseconds kPoll{20};
  /// At shutdown, how long the writers may wait for acknowledgements, all together.
  static constexpr std::chrono::milliseconds kShutdownAckWait{2000};

 private:
  void publishLoop();
  void waitForAcknowledgments();

  LayerMailbox& mailbox_;
  MapEngine& engine_;
  NodeLog& log_;
  IncompatibleQosListener qos_listener_;  ///< outlives the writers (the participant goes first)
  std::vector<std::unique_ptr<OutputOperation>> operations_;  ///< in publishing order
  std::vector<eprosima::fastdds::dds::DataWriter*> writers_;  ///< every writer, for finish()
  bool has_global_ = false;
  bool has_fleet_ = false;
  std::thread thread_;
  bool finished_ = false;
};

}  // namespace mlmap::dds::node
