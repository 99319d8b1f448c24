#pragma once
/// @file
/// sensor_msgs/PointCloud2 decoded straight from its CDR bytes with Fast CDR alone (no Fast DDS):
/// x, y, z read where they lie. The generated type would first copy the cloud's `data` (4.9 MB
/// for a 640 x 480 cloud) into the message, and the reader would then read that copy; here the
/// one pass that replaces the copy is the decode itself. mlmap_node's DDS reader
/// (CloudSamplePubSubType, cloud_sample.h) and the bag reader both decode through it.

#include "mlmap/dds/wire/ros_conversions.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace mlmap::dds {

/// A PointCloud2 sample. Written, it is the message it derives from (data_ included). Read
/// through decodeCloudSampleCdr() (or CloudSamplePubSubType), data_ stays empty: the points are
/// in `points_S` and the decode's outcome in `status` (as decodePointCloud2() gives them).
struct CloudSample : sensor_msgs::PointCloud2_ {
  std::vector<Eigen::Vector3f> points_S;  ///< x, y, z of every point (NaN points kept)
  DecodeStatus status;                    ///< why the points are missing, when they are
};

/// Decodes the `size` CDR bytes at `bytes` (encapsulation header first) into `sample`: the
/// message's fields as the generated PointCloud2_::deserialize() reads them, except data_, whose
/// bytes are decoded in place into sample->points_S. The bytes are only read. false (the sample
/// unusable) when they end before the message does; may throw Fast CDR exceptions on other
/// malformed data, as the generated code does.
bool decodeCloudSampleCdr(const std::uint8_t* bytes, std::size_t size, CloudSample* sample);

}  // namespace mlmap::dds
