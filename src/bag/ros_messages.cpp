#include "mlmap/bag/ros_messages.h"

#include "mlmap/dds/wire/cdr_check.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstring>
#include <limits>
#include <stdexcept>

namespace mlmap::bag {
namespace {

/// The bytes as the SerializedPayload_t a DDS reader hands to the type, through `type`'s
/// deserialize(), which may throw Fast CDR exceptions on malformed data (as the node's
/// CheckedType catches them). The bytes are first checked against the type's CDR layout
/// (checkCdrPayload), as CheckedType checks a sample: Fast CDR would size a sequence from its
/// declared count before noticing the bytes are missing.
template <typename PubSubType, typename Msg>
void deserialize(const std::vector<std::uint8_t>& bytes, const std::string& what, Msg* msg) {
  if (bytes.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::runtime_error(what + ": " + std::to_string(bytes.size()) + " bytes, over 4 GiB");
  }
  static thread_local PubSubType type;
  static const dds::CdrStructLayout* const layout = dds::cdrLayoutOf(type.getName());
  if (layout == nullptr) {
    throw std::logic_error(std::string("no CDR layout for ") + type.getName());
  }
  const dds::CdrCheck check = dds::checkCdrPayload(*layout, bytes.data(), bytes.size());
  if (!check.ok) {
    throw std::runtime_error(what + ": malformed CDR (" + std::to_string(bytes.size()) +
                             " bytes): " + check.error);
  }
  eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<std::uint32_t>(bytes.size()));
  if (!bytes.empty()) std::memcpy(payload.data, bytes.data(), bytes.size());
  payload.length = static_cast<std::uint32_t>(bytes.size());
  bool ok = false;
  try {
    ok = type.deserialize(&payload, msg);
  } catch (const std::exception&) {
    ok = false;
  }
  if (!ok)
    throw std::runtime_error(what + ": malformed CDR (" + std::to_string(bytes.size()) + " bytes)");
}

}  // namespace

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::sensor_msgs::Image_* msg) {
  deserialize<sensor_msgs::msg::dds_::Image_PubSubType>(bytes, what, msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::sensor_msgs::CameraInfo_* msg) {
  deserialize<sensor_msgs::msg::dds_::CameraInfo_PubSubType>(bytes, what, msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::geometry_msgs::PoseStamped_* msg) {
  deserialize<geometry_msgs::msg::dds_::PoseStamped_PubSubType>(bytes, what, msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::nav_msgs::Odometry_* msg) {
  deserialize<nav_msgs::msg::dds_::Odometry_PubSubType>(bytes, what, msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               tf2_msgs::TFMessage_* msg) {
  deserialize<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(bytes, what, msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::CloudSample* sample) {
  deserialize<dds::CloudSamplePubSubType>(bytes, what, sample);
}

bool transformOf(const dds::geometry_msgs::TransformStamped_& msg, Transform* T_parent_child) {
  const auto& t = msg.transform_().translation_();
  const auto& q = msg.transform_().rotation_();
  return makePose(Eigen::Vector3d(t.x_(), t.y_(), t.z_()),
                  Eigen::Quaterniond(q.w_(), q.x_(), q.y_(), q.z_()), T_parent_child);
}

}  // namespace mlmap::bag
