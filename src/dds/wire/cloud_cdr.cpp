#include "mlmap/dds/wire/cloud_cdr.h"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/NotEnoughMemoryException.h>

namespace mlmap::dds {

bool decodeCloudSampleCdr(const std::uint8_t* bytes, std::size_t size, CloudSample* sample) {
  namespace cdr = eprosima::fastcdr;
  sample->points_S.clear();
  sample->status = {};
  sensor_msgs::PointCloud2_& msg = *sample;
  msg.data_().clear();
  // Fast CDR's reading buffer is not const; deserialization only reads it.
  cdr::FastBuffer buffer(reinterpret_cast<char*>(const_cast<std::uint8_t*>(bytes)), size);
  cdr::Cdr in(buffer, cdr::Cdr::DEFAULT_ENDIAN, cdr::Cdr::DDS_CDR);
  try {
    // The fields in the order of PointCloud2_::deserialize(), the generated code.
    in.read_encapsulation();
    in >> msg.header_() >> msg.height_() >> msg.width_() >> msg.fields_() >> msg.is_bigendian_() >>
        msg.point_step_() >> msg.row_step_();
    // data: a sequence<octet>, its length then its bytes, decoded where they lie.
    std::uint32_t data_size = 0;
    in >> data_size;
    const auto* data = reinterpret_cast<const std::uint8_t*>(in.getCurrentPosition());
    const std::size_t left = size - static_cast<std::size_t>(data - bytes);
    if (data_size > left) return false;  // the generated code's NotEnoughMemoryException
    sample->status = decodePointCloud2(msg, data, data_size, &sample->points_S);
    in.jump(data_size);
    in >> msg.is_dense_();
  } catch (const cdr::exception::NotEnoughMemoryException&) {
    return false;
  }
  return true;
}

}  // namespace mlmap::dds
