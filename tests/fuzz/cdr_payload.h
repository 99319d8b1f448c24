#pragma once
/// @file
/// Raw CDR bytes -> a generated ROS 2 type, the way mlmap_node receives a sample: the bytes become
/// the SerializedPayload_t that Fast DDS hands to the reader's type, and the type is the
/// CheckedType<PubSubType> that registerType() registers (mlmap/dds/transport/entities.h), whose
/// deserialize() reports malformed CDR instead of throwing. The payload starts with the 4-byte
/// encapsulation header (00 01 00 00: CDR little endian).

#include "mlmap/dds/transport/entities.h"

#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace mlmap::fuzz {

/// Deserialises `size` bytes at `data` into `msg` through CheckedType<PubSubType>. Returns false
/// when the node would drop the sample as malformed (TakeListener's on_error).
template <typename PubSubType, typename Msg>
bool deserializeAsNodeDoes(const std::uint8_t* data, std::size_t size, Msg* msg) {
  static dds::CheckedType<PubSubType> type;  // one per message type, as registered once
  eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<std::uint32_t>(size));
  if (size > 0) std::memcpy(payload.data, data, size);
  payload.length = static_cast<std::uint32_t>(size);
  // Its return value is what the node's flag (detail::deserializeFailed) records: false exactly
  // when the flag is set; the node reads the flag only because Fast DDS drops the return value.
  return type.deserialize(&payload, msg);
}

}  // namespace mlmap::fuzz
