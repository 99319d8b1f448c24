#include "mlmap/dds/fleet/submap_messages.h"

#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/fleet/submap_codec.h"

#include "mlmap_msgs/msg/Submap_PubSubTypes.h"

#include <chrono>
#include <cmath>

namespace mlmap::dds {
namespace fdds = eprosima::fastdds::dds;

::mlmap_msgs::msg::dds_::Submap_ toSubmapMessage(const fleet::SubmapUpdate& update,
                                                 const SubmapGeometry& geometry,
                                                 const std::string& vehicle, std::uint64_t sequence,
                                                 double stamp_s, const std::string& frame_id) {
  ::mlmap_msgs::msg::dds_::Submap_ msg;
  msg.header_().stamp_(toRosTime(stamp_s));
  msg.header_().frame_id_(frame_id);
  msg.version_(kSubmapLayoutVersion);
  msg.vehicle_(vehicle);
  msg.submap_x_(update.index.x());
  msg.submap_y_(update.index.y());
  msg.submap_z_(update.index.z());
  msg.sequence_(sequence);
  msg.resolution_(geometry.resolution_m);
  msg.size_x_(static_cast<std::uint32_t>(geometry.cells.x()));
  msg.size_y_(static_cast<std::uint32_t>(geometry.cells.y()));
  msg.size_z_(static_cast<std::uint32_t>(geometry.cells.z()));
  fleet::SubmapPayload payload = fleet::encodeSubmapVoxels(update.records);
  msg.voxel_count_(payload.voxel_count);
  msg.encoding_(static_cast<std::uint8_t>(payload.encoding));
  msg.raw_size_(payload.raw_size);
  msg.data_(std::move(payload.data));
  return msg;
}

std::string submapHeaderProblem(const ::mlmap_msgs::msg::dds_::Submap_& msg) {
  if (msg.version_() != kSubmapLayoutVersion) {
    return "layout version " + std::to_string(msg.version_()) + " (this reader knows " +
           std::to_string(kSubmapLayoutVersion) + ")";
  }
  if (msg.vehicle_().empty() || msg.vehicle_().size() > kMaxVehicleNameBytes) {
    return "vehicle name empty or longer than " + std::to_string(kMaxVehicleNameBytes) + " bytes";
  }
  if (!std::isfinite(msg.resolution_()) || !(msg.resolution_() > 0.0)) {
    return "resolution not finite and > 0";
  }
  const std::uint64_t voxels = std::uint64_t{msg.size_x_()} * msg.size_y_() * msg.size_z_();
  if (voxels == 0 || voxels > kMaxSubmapVoxels || msg.size_x_() > kMaxSubmapVoxels ||
      msg.size_y_() > kMaxSubmapVoxels || msg.size_z_() > kMaxSubmapVoxels) {
    return "submap of " + std::to_string(msg.size_x_()) + " x " + std::to_string(msg.size_y_()) +
           " x " + std::to_string(msg.size_z_()) + " voxels";
  }
  for (const std::int32_t c : {msg.submap_x_(), msg.submap_y_(), msg.submap_z_()}) {
    if (c < -GlobalMap::kSubmapIndexLimit || c >= GlobalMap::kSubmapIndexLimit) {
      return "submap index beyond the grid's limit";
    }
  }
  if (msg.voxel_count_() > voxels) {
    return std::string("payload refused: ") +
           fleet::toString(fleet::SubmapDecodeError::kTooManyVoxels);
  }
  return "";
}

std::string decodeSubmapMessage(const ::mlmap_msgs::msg::dds_::Submap_& msg, DecodedSubmap* out) {
  std::string problem = submapHeaderProblem(msg);
  if (!problem.empty()) return problem;
  const std::uint64_t voxels = std::uint64_t{msg.size_x_()} * msg.size_y_() * msg.size_z_();
  const fleet::SubmapDecodeError error =
      fleet::decodeSubmapVoxels(msg.voxel_count_(), msg.encoding_(), msg.raw_size_(),
                                msg.data_().data(), msg.data_().size(), voxels, &out->records);
  if (error != fleet::SubmapDecodeError::kNone) {
    return std::string("payload refused: ") + fleet::toString(error);
  }
  out->vehicle = msg.vehicle_();
  out->index = SubmapIndex(msg.submap_x_(), msg.submap_y_(), msg.submap_z_());
  out->sequence = msg.sequence_();
  out->stamp_s = toSeconds(msg.header_().stamp_());
  out->geometry.resolution_m = msg.resolution_();
  out->geometry.cells =
      Eigen::Vector3i(static_cast<int>(msg.size_x_()), static_cast<int>(msg.size_y_()),
                      static_cast<int>(msg.size_z_()));
  return "";
}

std::size_t serializedSubmapBytes(const ::mlmap_msgs::msg::dds_::Submap_& msg) {
  return ::mlmap_msgs::msg::dds_::Submap_::getCdrSerializedSize(msg) + 4;
}

namespace {
/// KEEP_LAST 1 per instance for up to `instances` submaps.
template <typename Qos>
void limitInstances(Qos* qos, std::int32_t instances) {
  qos->history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos->history().depth = 1;
  qos->resource_limits().max_instances = instances;
  qos->resource_limits().max_samples_per_instance = 1;
  qos->resource_limits().max_samples = instances;
  qos->resource_limits().allocated_samples = 64;
}
}  // namespace

fdds::DataWriterQos submapWriterQos() {
  fdds::DataWriterQos qos = latchedWriterQos();
  limitInstances(&qos, kMaxSubmapInstancesWriter);
  return qos;
}

fdds::DataReaderQos submapReaderQos() {
  fdds::DataReaderQos qos = reliableReaderQos(true, 1);
  qos.data_sharing().off();
  limitInstances(&qos, kMaxSubmapInstancesReader);
  return qos;
}

std::string vehicleSubmapTopic(const std::string& vehicle, const std::string& topic) {
  return ddsTopicName(vehicle, topic);
}

std::string vehicleOfSubmapTopic(const std::string& dds_topic, const std::string& topic) {
  const std::string prefix = "rt/";
  std::string tail = topic;
  while (!tail.empty() && tail.front() == '/') tail.erase(tail.begin());
  while (!tail.empty() && tail.back() == '/') tail.pop_back();
  tail.insert(tail.begin(), '/');
  if (tail.size() < 2 || dds_topic.size() <= prefix.size() + tail.size() ||
      dds_topic.compare(0, prefix.size(), prefix) != 0 ||
      dds_topic.compare(dds_topic.size() - tail.size(), tail.size(), tail) != 0) {
    return "";
  }
  std::string vehicle =
      dds_topic.substr(prefix.size(), dds_topic.size() - prefix.size() - tail.size());
  if (vehicle.size() > kMaxVehicleNameBytes || !rosNameProblem(vehicle).empty() ||
      vehicle.front() == '/') {
    return "";
  }
  return vehicle;
}

SubmapWriter::SubmapWriter(fdds::Publisher* publisher, const std::string& topic,
                           std::string vehicle, const SubmapGeometry& geometry,
                           std::string frame_id)
    : writer_(createWriter<::mlmap_msgs::msg::dds_::Submap_PubSubType>(
          publisher, vehicleSubmapTopic(vehicle, topic), submapWriterQos())),
      vehicle_(std::move(vehicle)),
      geometry_(geometry),
      frame_id_(std::move(frame_id)),
      sequence_(static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                               std::chrono::system_clock::now().time_since_epoch())
                                               .count())) {}

std::size_t SubmapWriter::write(const std::vector<fleet::SubmapUpdate>& updates, double stamp_s) {
  std::size_t bytes = 0;
  for (const fleet::SubmapUpdate& update : updates) {
    ::mlmap_msgs::msg::dds_::Submap_ msg =
        toSubmapMessage(update, geometry_, vehicle_, ++sequence_, stamp_s, frame_id_);
    if (writer_->write(&msg)) {
      ++samples_;
      bytes += serializedSubmapBytes(msg);
    } else {
      ++failures_;
    }
  }
  bytes_ += bytes;
  return bytes;
}

}  // namespace mlmap::dds
