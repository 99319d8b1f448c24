#pragma once
/// @file
/// sensor_msgs/PointCloud2 as mlmap_node reads it over DDS: CloudSamplePubSubType hands each
/// received sample's bytes to decodeCloudSampleCdr() (cloud_cdr.h, Fast CDR only), which decodes
/// x, y, z straight from them.

#include "mlmap/dds/wire/cloud_cdr.h"

#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

namespace mlmap::dds {

/// The PointCloud2 type (same DDS type name and wire format as the generated one) for a
/// participant that reads clouds as CloudSample. serialize() takes any PointCloud2_ (a
/// CloudSample is one); deserialize() and createData() need / make a CloudSample. Register it
/// for every PointCloud2 topic of that participant (registerType() refuses a mix).
///
/// It says it is bounded, which it is not: Fast DDS 2.9 lets a reader use data-sharing (read a
/// same-host writer's samples in the writer's shared memory, with no transport copies) only for
/// a type that says so, and checks nothing else of it. The claim would cost where Fast DDS
/// preallocates payloads (PREALLOCATED or PREALLOCATED_WITH_REALLOC history memory: payloads of
/// the type's size bound, far below a sensor's cloud, and larger samples dropped), so the QoS
/// helpers of participant.h use DYNAMIC_REUSABLE and no data-sharing writer.
class CloudSamplePubSubType : public sensor_msgs::PointCloud2_PubSubType {
 public:
  using type = CloudSample;  ///< what createData() makes and deserialize() fills
  /// Reads the message's fields as the generated type does, except data_: its bytes are
  /// decoded in place into points_S (decodeCloudSampleCdr()). false (with the sample unusable)
  /// on malformed CDR; may throw Fast CDR exceptions, as the generated code does (CheckedType
  /// catches them).
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override;
  void* createData() override;
  void deleteData(void* data) override;
  bool is_bounded() const override { return true; }
};

}  // namespace mlmap::dds
