#pragma once
/// @file
/// mlmap_msgs/Submap on DDS: building a sample from a vehicle's changed submap, checking and
/// decoding a received one (every size checked before anything is allocated for it), each
/// vehicle's keyed topic rt/<vehicle>/mlmap/submaps and its QoS, and the writer mlmap_node shares
/// its map through.

#include "mlmap/fleet/submap_share.h"

#include "mlmap_msgs/msg/Submap_.h"

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace mlmap::dds {

/// The layout version of mlmap_msgs/Submap this code writes and reads (idl/README.md).
inline constexpr std::uint32_t kSubmapLayoutVersion = 2;
/// Largest submap a reader accepts [voxels] (a 256^3 submap), checked before decoding.
inline constexpr std::uint64_t kMaxSubmapVoxels = std::uint64_t{1} << 24;
/// Longest vehicle name [bytes].
inline constexpr std::size_t kMaxVehicleNameBytes = 256;
/// Submaps (instances) a writer keeps for late joiners, and that a reader tracks (all vehicles).
inline constexpr std::int32_t kMaxSubmapInstancesWriter = 1 << 17;
inline constexpr std::int32_t kMaxSubmapInstancesReader = 1 << 20;

/// The grid a vehicle's submaps lie on.
struct SubmapGeometry {
  double resolution_m = 0.0;                        ///< voxel edge
  Eigen::Vector3i cells = Eigen::Vector3i::Zero();  ///< voxels per submap and axis
};

/// The sample of `update`: its voxels encoded (fleet::encodeSubmapVoxels), keyed by `vehicle`
/// and the submap index, `sequence` and the map state's `stamp_s` in the header.
::mlmap_msgs::msg::dds_::Submap_ toSubmapMessage(const fleet::SubmapUpdate& update,
                                                 const SubmapGeometry& geometry,
                                                 const std::string& vehicle, std::uint64_t sequence,
                                                 double stamp_s, const std::string& frame_id);

/// Bytes of `msg` as a serialized sample: its CDR and the 4-byte encapsulation header (RTPS
/// headers not included).
std::size_t serializedSubmapBytes(const ::mlmap_msgs::msg::dds_::Submap_& msg);

/// A received sample, decoded.
struct DecodedSubmap {
  std::string vehicle;
  SubmapIndex index = SubmapIndex::Zero();
  std::uint64_t sequence = 0;
  double stamp_s = 0.0;
  SubmapGeometry geometry;
  std::vector<VoxelRecord> records;  ///< ascending offsets inside the submap
};

/// The checks of decodeSubmapMessage() that need no decoding (everything but the payload's
/// content): "" when they pass, else why not. Allocates nothing.
std::string submapHeaderProblem(const ::mlmap_msgs::msg::dds_::Submap_& msg);

/// Checks and decodes `msg` into `out`. Returns "" when it is accepted, else why not: a layout
/// version other than kSubmapLayoutVersion, an empty or overlong vehicle name, a resolution not
/// finite and > 0, a submap of no voxels or more than kMaxSubmapVoxels, an index beyond
/// GlobalMap::kSubmapIndexLimit, or a payload fleet::decodeSubmapVoxels() refuses.
std::string decodeSubmapMessage(const ::mlmap_msgs::msg::dds_::Submap_& msg, DecodedSubmap* out);

/// The DDS topic vehicle `vehicle` publishes its submaps on: "rt/<vehicle>/<topic>" (leading and
/// trailing '/' of both dropped), e.g. ("uav1", "mlmap/submaps") -> "rt/uav1/mlmap/submaps".
/// One topic per vehicle, so that a vehicle's DDS Security permissions can allow it to publish
/// its own submaps only, and a reader knows whose submaps a topic carries.
std::string vehicleSubmapTopic(const std::string& vehicle, const std::string& topic);
/// The vehicle whose submap topic `dds_topic` is (the inverse of vehicleSubmapTopic() for
/// `topic`), or "" when it is not one: no "rt/" prefix, not ending in "/<topic>", or a vehicle
/// name that is not a valid ROS name or is longer than kMaxVehicleNameBytes.
std::string vehicleOfSubmapTopic(const std::string& dds_topic, const std::string& topic);

/// The writer's QoS on a vehicle's submap topic: RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1 per
/// instance (the latest state of each submap for late joiners), up to kMaxSubmapInstancesWriter.
eprosima::fastdds::dds::DataWriterQos submapWriterQos();
/// The matching reader's: RELIABLE, TRANSIENT_LOCAL (late joiners get the writers' history),
/// KEEP_LAST 1 per instance, up to kMaxSubmapInstancesReader.
eprosima::fastdds::dds::DataReaderQos submapReaderQos();

/// A vehicle's writer of its changed submaps on its own topic, vehicleSubmapTopic(vehicle,
/// topic). Sequence numbers start at the wall clock's microseconds when it is made and grow by
/// one per sample, so a vehicle that restarts sends newer ones than before (while its clock does
/// not go back).
class SubmapWriter {
 public:
  /// Throws std::runtime_error when the writer cannot be created (also when DDS Security's
  /// permissions do not let this participant publish the vehicle's topic).
  SubmapWriter(eprosima::fastdds::dds::Publisher* publisher, const std::string& topic,
               std::string vehicle, const SubmapGeometry& geometry, std::string frame_id);
  /// Writes one sample per update; returns their serializedSubmapBytes(). A failed write is
  /// counted in failures().
  std::size_t write(const std::vector<fleet::SubmapUpdate>& updates, double stamp_s);
  [[nodiscard]] eprosima::fastdds::dds::DataWriter* get() const { return writer_; }
  [[nodiscard]] std::uint64_t samplesWritten() const { return samples_; }
  [[nodiscard]] std::uint64_t bytesWritten() const { return bytes_; }
  [[nodiscard]] std::uint64_t failures() const { return failures_; }
  [[nodiscard]] const std::string& vehicle() const { return vehicle_; }

 private:
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  std::string vehicle_;
  SubmapGeometry geometry_;
  std::string frame_id_;
  std::uint64_t sequence_ = 0;
  std::uint64_t samples_ = 0;
  std::uint64_t bytes_ = 0;
  std::uint64_t failures_ = 0;
};

}  // namespace mlmap::dds
