#include "mlmap/dds/cloud_sample.h"

#include "mlmap/dds/participant.h"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/NotEnoughMemoryException.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <stdexcept>
#include <vector>

namespace mlmap::dds {

bool CloudSamplePubSubType::deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload,
                                        void* data) {
  namespace cdr = eprosima::fastcdr;
  auto* sample = static_cast<CloudSample*>(data);
  sample->points_S.clear();
  sample->status = {};
  sensor_msgs::PointCloud2_& msg = *sample;
  msg.data_().clear();
  cdr::FastBuffer buffer(reinterpret_cast<char*>(payload->data), payload->length);
  cdr::Cdr in(buffer, cdr::Cdr::DEFAULT_ENDIAN, cdr::Cdr::DDS_CDR);
  try {
    // The fields in the order of PointCloud2_::deserialize(), the generated code.
    in.read_encapsulation();
    payload->encapsulation = in.endianness() == cdr::Cdr::BIG_ENDIANNESS ? CDR_BE : CDR_LE;
    in >> msg.header_() >> msg.height_() >> msg.width_() >> msg.fields_() >> msg.is_bigendian_() >>
        msg.point_step_() >> msg.row_step_();
    // data: a sequence<octet>, its length then its bytes, decoded where they lie.
    std::uint32_t data_size = 0;
    in >> data_size;
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(in.getCurrentPosition());
    const std::size_t left = payload->length - static_cast<std::size_t>(bytes - payload->data);
    if (data_size > left) return false;  // the generated code's NotEnoughMemoryException
    sample->status = decodePointCloud2(msg, bytes, data_size, &sample->points_S);
    in.jump(data_size);
    in >> msg.is_dense_();
  } catch (const cdr::exception::NotEnoughMemoryException&) {
    return false;
  }
  return true;
}

void* CloudSamplePubSubType::createData() { return new CloudSample(); }

void CloudSamplePubSubType::deleteData(void* data) { delete static_cast<CloudSample*>(data); }

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
  fdds::Topic* topic = participant->create_topic(dds_topic, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (topic == nullptr) throw std::runtime_error("cannot create topic " + dds_topic);
  qos.data_sharing().automatic(std::vector<std::uint16_t>{dataSharingDomainId()});  // with mlmap's readers only
  // Data-sharing needs preallocated history slots (the shared pool).
  qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::PREALLOCATED_MEMORY_MODE;
  fdds::DataWriter* writer = publisher->create_datawriter(topic, qos);
  if (writer == nullptr) throw std::runtime_error("cannot create a data-sharing writer on " + dds_topic);
  return writer;
}

}  // namespace mlmap::dds
