#pragma once
/// @file
/// sensor_msgs/PointCloud2 as mlmap_node reads it: x, y, z decoded straight from the received
/// sample's bytes. The generated type would first copy the cloud's `data` (4.9 MB for a 640 x 480
/// cloud) into the message, and the node would then read that copy; here the one pass that
/// replaces the copy is the decode itself.

#include "mlmap/dds/ros_conversions.h"

#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace mlmap::dds {

/// A PointCloud2 sample. Written, it is the message it derives from (data_ included). Read
/// through CloudSamplePubSubType, data_ stays empty: the points are in `points_S` and the
/// decode's outcome in `status` (as decodePointCloud2() gives them).
struct CloudSample : sensor_msgs::PointCloud2_ {
  std::vector<Eigen::Vector3f> points_S;  ///< x, y, z of every point (NaN points kept)
  DecodeStatus status;                    ///< why the points are missing, when they are
};

/// The PointCloud2 type (same DDS type name and wire format as the generated one) for a
/// participant that reads clouds as CloudSample. serialize() takes any PointCloud2_ (a
/// CloudSample is one); deserialize() and createData() need / make a CloudSample. Register it
/// for every PointCloud2 topic of that participant (registerType() refuses a mix).
class CloudSamplePubSubType : public sensor_msgs::PointCloud2_PubSubType {
 public:
  /// Reads the message's fields as the generated type does, except data_: its bytes are
  /// decoded in place into points_S. false (with the sample unusable) on malformed CDR; may
  /// throw Fast CDR exceptions, as the generated code does (CheckedType catches them).
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override;
  void* createData() override;
  void deleteData(void* data) override;
};

}  // namespace mlmap::dds
