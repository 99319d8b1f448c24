#include "mlmap/dds/wire/cloud_sample.h"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/NotEnoughMemoryException.h>

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

}  // namespace mlmap::dds
