#include "mlmap/dds/transport/cloud_writer.h"

#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"

#include "mlmap/dds/wire/ros_conversions.h"

#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <stdexcept>
#include <vector>

namespace mlmap::dds {

namespace {
/// The generated PointCloud2 type with a size bound: Fast DDS 2.9 offers data-sharing only for a
/// type that says it has one, and gives its writer's history slots of that size.
class BoundedCloudPubSubType : public sensor_msgs::PointCloud2_PubSubType {
 public:
  explicit BoundedCloudPubSubType(std::uint32_t max_bytes) { m_typeSize = max_bytes; }
  bool is_bounded() const override { return true; }
};
}  // namespace

eprosima::fastdds::dds::DataWriter* createDataSharingCloudWriter(
    eprosima::fastdds::dds::Publisher* publisher, const std::string& dds_topic,
    eprosima::fastdds::dds::DataWriterQos qos, std::uint32_t max_bytes) {
  namespace fdds = eprosima::fastdds::dds;
  auto* participant = const_cast<fdds::DomainParticipant*>(publisher->get_participant());
  fdds::TypeSupport type(new BoundedCloudPubSubType(max_bytes));
  if (type.register_type(participant) != eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("cannot register DDS type " + type.get_type_name() +
                             " (is another PointCloud2 type registered in this participant?)");
  }
  fdds::Topic* topic =
      participant->create_topic(dds_topic, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (topic == nullptr) throw std::runtime_error("cannot create topic " + dds_topic);
  qos.data_sharing().automatic(
      std::vector<std::uint16_t>{dataSharingDomainId()});  // with mlmap's readers only
  // Data-sharing needs preallocated history slots (the shared pool).
  qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::PREALLOCATED_MEMORY_MODE;
  fdds::DataWriter* writer =
      publisher->create_datawriter(topic, withRosTypeHash(qos, type.get_type_name()));
  if (writer == nullptr)
    throw std::runtime_error("cannot create a data-sharing writer on " + dds_topic);
  return writer;
}

}  // namespace mlmap::dds
