#pragma once
/// @file
/// How a process without ROS shows up in a ROS 2 graph as a node, as rmw_fastrtps_cpp (Jazzy)
/// does it: `ros_discovery_info` (rmw_dds_common/msg/ParticipantEntitiesInfo: the participant's
/// GID and, per node, its name, namespace and the GIDs of its readers and writers; `ros2 node
/// list`, `ros2 node info`, `ros2 topic info -v` and rqt_graph are built from it), and the node's
/// log lines on `/rosout` (rcl_interfaces/msg/Log, with rcl's QoS).
/// Library mlmap_dds_graph (transport and message types only): mlmap_node and mlmap_planner_peer
/// use it.

#include "mlmap/pipeline/rate_limited_log.h"

#include "rcl_interfaces/msg/Log_.h"
#include "rmw_dds_common/msg/ParticipantEntitiesInfo_.h"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastrtps/rtps/common/Guid.h>

#include <array>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

namespace mlmap::dds {

/// A ROS 2 GID as rmw_fastrtps_cpp makes it from a Fast DDS GUID (Jazzy: 16 bytes): the GUID
/// prefix (12 bytes), then the entity id (4 bytes).
using Gid = std::array<std::uint8_t, 16>;

/// The GID of an entity with GUID `guid` (rmw_fastrtps_shared_cpp's
/// copy_from_fastrtps_guid_to_byte_array).
Gid toGid(const eprosima::fastrtps::rtps::GUID_t& guid);

/// The ROS 2 namespace of a node whose topics live under mlmap's `dds.ns`: "" -> "/",
/// "uav1" -> "/uav1", "/a/b/" -> "/a/b".
std::string rosNodeNamespace(const std::string& ns);

/// The logger name rcl gives a node (Log.name on /rosout): the namespace's tokens and the node
/// name joined by '.': ("/", "mlmap_node") -> "mlmap_node", ("/uav1", ...) -> "uav1.mlmap_node".
std::string rosLoggerName(const std::string& node_namespace, const std::string& node_name);

/// The QoS of rmw's `ros_discovery_info` writer: RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1.
eprosima::fastdds::dds::DataWriterQos discoveryInfoWriterQos();

/// Publishes the participant's `ros_discovery_info` with one node. The writer has a publisher of
/// its own, so it is never one of the node's endpoints (rmw lists it under no node either).
/// Its entities belong to the participant: delete the participant before this object.
class DiscoveryInfoPublisher {
 public:
  /// The writer on `participant`, for the node `node_name` in `node_namespace` (a ROS namespace,
  /// rosNodeNamespace()). Nothing is published before announce(). Throws std::runtime_error
  /// when DDS refuses an entity.
  DiscoveryInfoPublisher(eprosima::fastdds::dds::DomainParticipant* participant,
                         const std::string& node_name, const std::string& node_namespace);

  /// Publishes the node with every writer of `publishers` and every reader of `subscribers`, as
  /// they are now: call it again whenever the node creates or deletes an endpoint (the sample
  /// replaces the last one: KEEP_LAST 1, TRANSIENT_LOCAL). Thread-safe.
  void announce(const std::vector<const eprosima::fastdds::dds::Publisher*>& publishers,
                const std::vector<const eprosima::fastdds::dds::Subscriber*>& subscribers);

  /// The sample announce() published last (empty node list before the first call).
  [[nodiscard]] rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_ published() const;

  /// The writer on `ros_discovery_info`.
  [[nodiscard]] eprosima::fastdds::dds::DataWriter* writer() const { return writer_; }

 private:
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  mutable std::mutex mutex_;
  rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_ info_;
};

/// The QoS of rcl's `/rosout` writer (rcl_qos_profile_rosout_default): RELIABLE,
/// TRANSIENT_LOCAL, KEEP_LAST 1000, lifespan 10 s.
eprosima::fastdds::dds::DataWriterQos rosoutWriterQos();

/// The rcl_interfaces/msg/Log level of a log line: INFO 20, WARN 30, ERROR 40.
std::uint8_t rosLogLevel(LogLevel level);

/// Writes a node's log lines to `rt/rosout` as rcl does (rqt_console, `ros2 topic echo
/// /rosout`). Its writer belongs to the publisher given: delete the participant before this
/// object.
class RosoutWriter {
 public:
  /// A writer on `publisher` whose lines carry `logger_name` (rosLoggerName()). Throws
  /// std::runtime_error when DDS refuses it.
  RosoutWriter(eprosima::fastdds::dds::Publisher* publisher, std::string logger_name);

  /// Publishes one line, stamped with the wall clock. Thread-safe; never throws.
  void write(LogLevel level, const std::string& message) const;

  /// The writer on `rt/rosout`.
  [[nodiscard]] eprosima::fastdds::dds::DataWriter* writer() const { return writer_; }

 private:
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  std::string logger_name_;
};

}  // namespace mlmap::dds
