#pragma once
/// @file
/// The onboard mapping node: one DomainParticipant, ROS 2 topics in, map layers out.
///
/// Threads (paper Figure 5):
/// - Fast DDS's listener threads only take samples and hand them over (a bounded queue);
/// - the input thread decodes and validates messages, pairs clouds and depth images with poses
///   (PoseBuffer) and submits frames to the engine;
/// - the engine's awareness and local-global threads map;
/// - the publishing thread turns snapshots and layer copies into messages at the configured
///   rates, so a slow or vanished subscriber never blocks mapping.
///
/// Every rejected input is counted (NodeCounters, also in the status message) and logged at most
/// once per second per reason.

#include "mlmap/dds/node/node_config.h"
#include "mlmap/dds/node/node_counters.h"
#include "mlmap/dds/node/ros_services.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/pipeline/map_engine.h"

#include <atomic>
#include <cstdint>
#include <memory>

namespace mlmap::dds {

/// Runs the mapping node until destroyed (or stop()).
class MappingNode {
 public:
  /// Creates the participant, the engine, the readers and writers, publishes rt/tf_static (with
  /// dds.publish_sensor_tf) and starts the threads. Throws std::invalid_argument (bad config) or
  /// std::runtime_error (DDS).
  explicit MappingNode(const NodeConfig& config, const LogSink& log = {});
  ~MappingNode();
  MappingNode(const MappingNode&) = delete;
  MappingNode& operator=(const MappingNode&) = delete;

  /// Stops taking input, drains the engine, publishes the last state and joins every thread.
  /// Idempotent.
  void stop();

  [[nodiscard]] NodeCounters counters() const;
  [[nodiscard]] EngineStats engineStats() const;
  /// The engine's latest snapshot (what the layers are published from); any thread, any time.
  [[nodiscard]] std::shared_ptr<const MapSnapshot> snapshot() const;
  /// The domain the participant joined.
  [[nodiscard]] int domainId() const;
  /// What the node's ROS 2 services (~/save_map, ~/clear_map, the parameter services) counted.
  [[nodiscard]] ServiceCounters serviceCounters() const;
  /// Logs a line as the node logs its own: to the LogSink and, until stop() deletes the
  /// participant, to /rosout (a program's progress lines, so that ROS 2 tools see them too).
  void log(LogLevel level, const std::string& message) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlmap::dds
