#include "mlmap/bag/ros_messages.h"

#include "mlmap/dds/wire/cdr_check.h"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

#include <limits>
#include <stdexcept>

namespace mlmap::bag {
namespace {

/// The bytes checked against the CDR layout of `dds_type` (checkCdrPayload, as the node's
/// CheckedType checks a sample: Fast CDR would size a sequence from its declared count before
/// noticing the bytes are missing). @throws std::runtime_error "`what`: malformed CDR ..." when
/// they do not pass, std::logic_error when the type has no layout.
void checkLayout(const std::vector<std::uint8_t>& bytes, const std::string& what,
                 const char* dds_type) {
  if (bytes.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::runtime_error(what + ": " + std::to_string(bytes.size()) + " bytes, over 4 GiB");
  }
  const dds::CdrStructLayout* const layout = dds::cdrLayoutOf(dds_type);
  if (layout == nullptr) throw std::logic_error(std::string("no CDR layout for ") + dds_type);
  const dds::CdrCheck check = dds::checkCdrPayload(*layout, bytes.data(), bytes.size());
  if (!check.ok) {
    throw std::runtime_error(what + ": malformed CDR (" + std::to_string(bytes.size()) +
                             " bytes): " + check.error);
  }
}

[[noreturn]] void malformed(const std::vector<std::uint8_t>& bytes, const std::string& what) {
  throw std::runtime_error(what + ": malformed CDR (" + std::to_string(bytes.size()) + " bytes)");
}

/// The checked bytes deserialised into `msg` with Fast CDR as the generated PubSubType's
/// deserialize() does (encapsulation, then the struct), without Fast DDS: the bag reader links
/// Fast CDR only. Fast CDR's exceptions on malformed data become "`what`: malformed CDR".
template <typename Msg>
void deserialize(const std::vector<std::uint8_t>& bytes, const std::string& what,
                 const char* dds_type, Msg* msg) {
  namespace cdr = eprosima::fastcdr;
  checkLayout(bytes, what, dds_type);
  // Fast CDR's reading buffer is not const; deserialization only reads it.
  cdr::FastBuffer buffer(reinterpret_cast<char*>(const_cast<std::uint8_t*>(bytes.data())),
                         bytes.size());
  cdr::Cdr in(buffer, cdr::Cdr::DEFAULT_ENDIAN, cdr::Cdr::DDS_CDR);
  try {
    in.read_encapsulation();
    msg->deserialize(in);
  } catch (const std::exception&) {  // Fast CDR's exceptions derive from it
    malformed(bytes, what);
  }
}

}  // namespace

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::sensor_msgs::Image_* msg) {
  deserialize(bytes, what, "sensor_msgs::msg::dds_::Image_", msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::sensor_msgs::CameraInfo_* msg) {
  deserialize(bytes, what, "sensor_msgs::msg::dds_::CameraInfo_", msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::geometry_msgs::PoseStamped_* msg) {
  deserialize(bytes, what, "geometry_msgs::msg::dds_::PoseStamped_", msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::nav_msgs::Odometry_* msg) {
  deserialize(bytes, what, "nav_msgs::msg::dds_::Odometry_", msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               tf2_msgs::TFMessage_* msg) {
  deserialize(bytes, what, "tf2_msgs::msg::dds_::TFMessage_", msg);
}

void decodeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what,
               dds::CloudSample* sample) {
  checkLayout(bytes, what, "sensor_msgs::msg::dds_::PointCloud2_");
  bool ok = false;
  try {
    ok = dds::decodeCloudSampleCdr(bytes.data(), bytes.size(), sample);
  } catch (const std::exception&) {
    ok = false;
  }
  if (!ok) malformed(bytes, what);
}

bool transformOf(const dds::geometry_msgs::TransformStamped_& msg, Transform* T_parent_child) {
  const auto& t = msg.transform_().translation_();
  const auto& q = msg.transform_().rotation_();
  return makePose(Eigen::Vector3d(t.x_(), t.y_(), t.z_()),
                  Eigen::Quaterniond(q.w_(), q.x_(), q.y_(), q.z_()), T_parent_child);
}

}  // namespace mlmap::bag
