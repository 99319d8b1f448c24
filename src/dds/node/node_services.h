#pragma once
/// @file
/// mlmap_node's ROS 2 services (rmw_fastrtps_cpp's framing, mlmap/dds/node/ros_services.h):
/// `~/save_map` and `~/clear_map` (std_srvs/srv/Trigger) and the read-only parameter services of
/// rcl_interfaces
/// (`~/list_parameters`, `~/get_parameters`, `~/describe_parameters`, `~/get_parameter_types`,
/// `~/set_parameters`, `~/set_parameters_atomically`) over the node's effective configuration.

#include "map_persistence.h"
#include "node_log.h"

#include "mlmap/dds/node/node_config.h"
#include "mlmap/dds/node/ros_services.h"
#include "mlmap/pipeline/map_engine.h"

#include "std_srvs/srv/Trigger_.h"

#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>

#include <functional>
#include <string>

namespace mlmap::dds::node {

/// The node's services, on its publisher and subscriber (ros_discovery_info lists them with its
/// other endpoints). Delete the participant's entities (the participant) before this object.
class NodeServices {
 public:
  /// The services of node `node_name` in `node_namespace` (a ROS namespace), answering from
  /// `config` (the effective configuration), saving through `persistence`, clearing `engine`.
  /// `before_clear` runs just before each clear (e.g. to publish the emptied global map at once).
  /// Nothing is answered before start(). Throws std::runtime_error when DDS refuses an endpoint.
  NodeServices(eprosima::fastdds::dds::Publisher* publisher,
               eprosima::fastdds::dds::Subscriber* subscriber, const std::string& node_namespace,
               const std::string& node_name, const NodeConfig& config, MapEngine& engine,
               MapPersistence& persistence, NodeLog& log, std::function<void()> before_clear);

  /// Starts answering requests.
  void start() { host_.start(); }
  /// Stops answering (waits for a request being handled). Idempotent.
  void stop() { host_.stop(); }
  /// Requests answered, malformed, and replies not sent.
  [[nodiscard]] ServiceCounters counters() const { return host_.counters(); }

 private:
  std_srvs::srv::dds_::Trigger_Response_ saveMap();
  std_srvs::srv::dds_::Trigger_Response_ clearMap();

  const NodeConfig& config_;
  MapEngine& engine_;
  MapPersistence& persistence_;
  NodeLog& log_;
  std::function<void()> before_clear_;
  ParameterTable parameters_;
  ServiceHost host_;
};

}  // namespace mlmap::dds::node
