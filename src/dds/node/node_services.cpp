#include "node_services.h"

#include "rcl_interfaces/srv/DescribeParameters_PubSubTypes.h"
#include "rcl_interfaces/srv/GetParameterTypes_PubSubTypes.h"
#include "rcl_interfaces/srv/GetParameters_PubSubTypes.h"
#include "rcl_interfaces/srv/ListParameters_PubSubTypes.h"
#include "rcl_interfaces/srv/SetParametersAtomically_PubSubTypes.h"
#include "rcl_interfaces/srv/SetParameters_PubSubTypes.h"
#include "std_srvs/srv/Trigger_PubSubTypes.h"

#include <sstream>
#include <utility>

namespace mlmap::dds::node {

namespace rcl = ::rcl_interfaces::srv::dds_;
namespace srv = ::std_srvs::srv::dds_;

NodeServices::NodeServices(eprosima::fastdds::dds::Publisher* publisher,
                           eprosima::fastdds::dds::Subscriber* subscriber,
                           const std::string& node_namespace, const std::string& node_name,
                           const NodeConfig& config, MapEngine& engine, MapPersistence& persistence,
                           NodeLog& log, std::function<void()> before_clear)
    : config_(config),
      engine_(engine),
      persistence_(persistence),
      log_(log),
      before_clear_(std::move(before_clear)),
      parameters_(config),
      host_(publisher, subscriber, [this](const std::string& problem) {
        log_.limited(LogLevel::kWarning, kReasonMalformed, "service: " + problem);
      }) {
  const auto topics = [&](const char* service) {
    return privateServiceTopics(node_namespace, node_name, service);
  };
  host_.add<srv::Trigger_Request_PubSubType, srv::Trigger_Response_PubSubType>(
      topics("save_map"), [this](const srv::Trigger_Request_&) { return saveMap(); });
  host_.add<srv::Trigger_Request_PubSubType, srv::Trigger_Response_PubSubType>(
      topics("clear_map"), [this](const srv::Trigger_Request_&) { return clearMap(); });
  host_.add<rcl::ListParameters_Request_PubSubType, rcl::ListParameters_Response_PubSubType>(
      topics("list_parameters"),
      [this](const rcl::ListParameters_Request_& r) { return parameters_.list(r); });
  host_.add<rcl::GetParameters_Request_PubSubType, rcl::GetParameters_Response_PubSubType>(
      topics("get_parameters"),
      [this](const rcl::GetParameters_Request_& r) { return parameters_.get(r); });
  host_
      .add<rcl::DescribeParameters_Request_PubSubType, rcl::DescribeParameters_Response_PubSubType>(
          topics("describe_parameters"),
          [this](const rcl::DescribeParameters_Request_& r) { return parameters_.describe(r); });
  host_.add<rcl::GetParameterTypes_Request_PubSubType, rcl::GetParameterTypes_Response_PubSubType>(
      topics("get_parameter_types"),
      [this](const rcl::GetParameterTypes_Request_& r) { return parameters_.types(r); });
  host_.add<rcl::SetParameters_Request_PubSubType, rcl::SetParameters_Response_PubSubType>(
      topics("set_parameters"),
      [this](const rcl::SetParameters_Request_& r) { return parameters_.set(r); });
  // rclpy's parameter client (`ros2 param`) waits for this one too before any call.
  host_.add<rcl::SetParametersAtomically_Request_PubSubType,
            rcl::SetParametersAtomically_Response_PubSubType>(
      topics("set_parameters_atomically"), [this](const rcl::SetParametersAtomically_Request_& r) {
        return parameters_.setAtomically(r);
      });
}

srv::Trigger_Response_ NodeServices::saveMap() {
  srv::Trigger_Response_ reply;
  if (config_.map_file.save_path.empty()) {
    reply.success_(false);
    reply.message_(
        "no map file is configured: set map_file.save_path in the "
        "node's configuration");
    log_.always(LogLevel::kWarning, "save_map service: " + reply.message_());
    return reply;
  }
  const MapPersistence::SaveOutcome outcome = persistence_.save("save_map service");
  reply.success_(outcome.ok);
  reply.message_(outcome.message);
  return reply;
}

srv::Trigger_Response_ NodeServices::clearMap() {
  const EngineStats before = engine_.stats();
  if (before_clear_) before_clear_();
  engine_.clear();
  std::ostringstream m;
  m << "cleared the map (" << before.global_voxels
    << " global voxels and the local window); the next frames map again";
  srv::Trigger_Response_ reply;
  reply.success_(true);
  reply.message_(m.str());
  log_.always(LogLevel::kInfo, "clear_map service: " + reply.message_());
  return reply;
}

}  // namespace mlmap::dds::node
