#include "mlmap/dds/wire/cloud_sample.h"

namespace mlmap::dds {

bool CloudSamplePubSubType::deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload,
                                        void* data) {
  if (!decodeCloudSampleCdr(payload->data, payload->length, static_cast<CloudSample*>(data))) {
    return false;
  }
  // The encapsulation's second byte: 0 big-endian, 1 little-endian (as read_encapsulation()).
  payload->encapsulation = (payload->data[1] & 1) != 0 ? CDR_LE : CDR_BE;
  return true;
}

void* CloudSamplePubSubType::createData() { return new CloudSample(); }

void CloudSamplePubSubType::deleteData(void* data) { delete static_cast<CloudSample*>(data); }

}  // namespace mlmap::dds
