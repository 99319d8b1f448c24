// mlmap_interop_talker: the Fast DDS side of the mlmap -> Cyclone DDS interoperability test.
//
// Publishes deterministic messages built by mlmap's own encoders (encodePointCloud2,
// toOccupancyGrid) on the node's topics with the node's QoS presets, and writes a canonical record
// (sample_record.h) of every message it sent into --out, to be compared byte for byte with what
// the Cyclone reader (mlmap_cyclone_peer listen) recorded. The sequence:
//   1. two grids on the latched grid topic while no reader exists: a late joiner must receive
//      only the second (RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1, as a ROS 2 map server);
//      then the file <out>/latched.done tells the test script to start the reader;
//   2. once --ready-file exists (the reader has matched every writer) and the writers have matched
//      it too: malformed payloads under the PointCloud2 type name, from a second participant
//      (a broken or hostile sender: the reader must survive them and record none);
//   3. the clouds, each acknowledged before the next (one of them 4.8 MB);
//   4. a third grid, live (the reader is still alive and listening).

#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/rtps/common/SerializedPayload.h>

#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include "sample_record.h"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <thread>
#include <vector>

namespace {

using namespace mlmap;
namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

interop::SampleRecord record(const mlmap::dds::sensor_msgs::PointCloud2_& msg) {
  interop::SampleRecord r("sensor_msgs::msg::dds_::PointCloud2_");
  r.add("header.stamp.sec", msg.header_().stamp_().sec_());
  r.addUnsigned("header.stamp.nanosec", msg.header_().stamp_().nanosec_());
  r.addString("header.frame_id", msg.header_().frame_id_().data(),
              msg.header_().frame_id_().size());
  r.addUnsigned("height", msg.height_());
  r.addUnsigned("width", msg.width_());
  r.addUnsigned("fields.length", msg.fields_().size());
  for (const mlmap::dds::sensor_msgs::PointField_& f : msg.fields_()) {
    r.addString("fields.name", f.name_().data(), f.name_().size());
    r.addUnsigned("fields.offset", f.offset_());
    r.addUnsigned("fields.datatype", f.datatype_());
    r.addUnsigned("fields.count", f.count_());
  }
  r.addBool("is_bigendian", msg.is_bigendian_());
  r.addUnsigned("point_step", msg.point_step_());
  r.addUnsigned("row_step", msg.row_step_());
  r.addBytes("data", msg.data_().data(), msg.data_().size());
  r.addBool("is_dense", msg.is_dense_());
  return r;
}

interop::SampleRecord record(const mlmap::dds::nav_msgs::OccupancyGrid_& msg) {
  interop::SampleRecord r("nav_msgs::msg::dds_::OccupancyGrid_");
  r.add("header.stamp.sec", msg.header_().stamp_().sec_());
  r.addUnsigned("header.stamp.nanosec", msg.header_().stamp_().nanosec_());
  r.addString("header.frame_id", msg.header_().frame_id_().data(),
              msg.header_().frame_id_().size());
  const mlmap::dds::nav_msgs::MapMetaData_& info = msg.info_();
  r.add("info.map_load_time.sec", info.map_load_time_().sec_());
  r.addUnsigned("info.map_load_time.nanosec", info.map_load_time_().nanosec_());
  r.addFloat("info.resolution", info.resolution_());
  r.addUnsigned("info.width", info.width_());
  r.addUnsigned("info.height", info.height_());
  r.addDouble("info.origin.position.x", info.origin_().position_().x_());
  r.addDouble("info.origin.position.y", info.origin_().position_().y_());
  r.addDouble("info.origin.position.z", info.origin_().position_().z_());
  r.addDouble("info.origin.orientation.x", info.origin_().orientation_().x_());
  r.addDouble("info.origin.orientation.y", info.origin_().orientation_().y_());
  r.addDouble("info.origin.orientation.z", info.origin_().orientation_().z_());
  r.addDouble("info.origin.orientation.w", info.origin_().orientation_().w_());
  r.addBytes("data", msg.data_().data(), msg.data_().size());
  return r;
}

/// A small deterministic generator (the records carry the values, so only run-to-run stability
/// matters, not portability).
class Lcg {
 public:
  explicit Lcg(std::uint64_t seed) : state_(seed) {}
  /// Uniform in [lo, hi).
  float uniform(float lo, float hi) {
    state_ = state_ * 6364136223846793005ull + 1442695040888963407ull;
    return lo + (hi - lo) * static_cast<float>(state_ >> 40) / static_cast<float>(1u << 24);
  }

 private:
  std::uint64_t state_;
};

std::vector<Eigen::Vector3f> randomPoints(std::size_t n, std::uint64_t seed) {
  Lcg lcg(seed);
  std::vector<Eigen::Vector3f> points(n);
  for (Eigen::Vector3f& p : points)
    p = {lcg.uniform(-20, 20), lcg.uniform(-20, 20), lcg.uniform(-1, 6)};
  return points;
}

std::vector<float> randomIntensity(std::size_t n, std::uint64_t seed) {
  Lcg lcg(seed);
  std::vector<float> values(n);
  for (float& v : values) v = lcg.uniform(-2, 2);
  return values;
}

/// The clouds to send: what mlmap's encoder makes of empty, small, non-finite and large inputs,
/// plus one whose sizes disagree with each other (as a broken sender would publish it): the
/// reader must record it as it is, not interpret it.
std::vector<mlmap::dds::sensor_msgs::PointCloud2_> testClouds(std::size_t large_points) {
  std::vector<mlmap::dds::sensor_msgs::PointCloud2_> clouds;
  clouds.push_back(mlmap::dds::encodePointCloud2({}, nullptr, 1700000000.0, "map"));

  std::vector<Eigen::Vector3f> points = randomPoints(1000, 1);
  points[10] = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  points[11].y() = std::numeric_limits<float>::infinity();
  clouds.push_back(
      mlmap::dds::encodePointCloud2(points, nullptr, -1.5, "base_link"));  // negative stamp

  points = randomPoints(5000, 2);
  std::vector<float> intensity = randomIntensity(points.size(), 3);
  clouds.push_back(mlmap::dds::encodePointCloud2(points, &intensity, 1700000001.123456789,
                                                 "camera_depth_optical_frame/\xc3\xbc"));  // UTF-8

  points = randomPoints(large_points, 4);
  intensity = randomIntensity(points.size(), 5);
  clouds.push_back(mlmap::dds::encodePointCloud2(points, &intensity, 1700000002.5, "map"));

  mlmap::dds::sensor_msgs::PointCloud2_ odd;
  odd.header_().stamp_(mlmap::dds::toRosTime(1700000003.0));
  odd.header_().frame_id_("");
  odd.height_(2);
  odd.width_(3);
  mlmap::dds::sensor_msgs::PointField_ field;
  field.name_("x");
  field.offset_(4000000000u);
  field.datatype_(200);
  field.count_(0);
  odd.fields_().push_back(field);
  odd.is_bigendian_(true);
  odd.point_step_(0);
  odd.row_step_(5);
  odd.data_({0, 1, 2, 0xfe, 0xff, 0x80, 0x7f});
  odd.is_dense_(true);
  clouds.push_back(odd);
  return clouds;
}

/// A grid of `width` x `height` cells cycling through every OccupancyGrid value (-1, 0..100).
mlmap::dds::nav_msgs::OccupancyGrid_ testGrid(int width, int height, double stamp_s) {
  ProjectedGrid grid;
  grid.origin_W = {-3.2, 1.7};
  grid.resolution_m = 0.2;
  grid.width = width;
  grid.height = height;
  grid.cells.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (std::size_t i = 0; i < grid.cells.size(); ++i) {
    grid.cells[i] = static_cast<std::int8_t>(static_cast<int>(i % 102) - 1);
  }
  return mlmap::dds::toOccupancyGrid(grid, 1.25, stamp_s, "map");
}

/// Raw bytes (encapsulation header included) put on the wire as they are, under the PointCloud2
/// type name: what a broken or hostile sender could publish. Needs a participant of its own (one
/// participant cannot hold two types of one name).
class RawPayloadType : public fdds::TopicDataType {
 public:
  using Bytes = std::vector<std::uint8_t>;
  RawPayloadType() {
    setName("sensor_msgs::msg::dds_::PointCloud2_");
    m_typeSize = 4096;  // the payloads are small; larger ones are reallocated
    m_isGetKeyDefined = false;
  }
  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override {
    const Bytes& bytes = *static_cast<const Bytes*>(data);
    payload->reserve(static_cast<std::uint32_t>(bytes.size()));
    std::memcpy(payload->data, bytes.data(), bytes.size());
    payload->length = static_cast<std::uint32_t>(bytes.size());
    return true;
  }
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t*, void*) override { return false; }
  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override {
    return [data] { return static_cast<std::uint32_t>(static_cast<const Bytes*>(data)->size()); };
  }
  void* createData() override { return new Bytes(); }
  void deleteData(void* data) override { delete static_cast<Bytes*>(data); }
  bool getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) override { return false; }
};

/// Builds XCDR1 little-endian payloads by hand (alignment counted after the 4-byte header).
class CdrBytes {
 public:
  CdrBytes() : bytes_{0x00, 0x01, 0x00, 0x00} {}
  CdrBytes& u32(std::uint32_t value) {
    while ((bytes_.size() - 4) % 4 != 0) bytes_.push_back(0);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&value);  // little-endian host
    bytes_.insert(bytes_.end(), p, p + 4);
    return *this;
  }
  CdrBytes& octet(std::uint8_t value) {
    bytes_.push_back(value);
    return *this;
  }
  CdrBytes& str(const std::string& text) {
    u32(static_cast<std::uint32_t>(text.size() + 1));
    bytes_.insert(bytes_.end(), text.begin(), text.end());
    return octet(0);
  }
  [[nodiscard]] const RawPayloadType::Bytes& bytes() const { return bytes_; }

 private:
  RawPayloadType::Bytes bytes_;
};

/// Payloads a reader must refuse without crashing: too short, lengths beyond the payload, and a
/// valid cloud announced with other encapsulations (XCDR2 little endian, which for PointCloud2
/// has the very same bytes, so only the encapsulation check can tell; and big endian).
std::vector<RawPayloadType::Bytes> malformedClouds() {
  std::vector<RawPayloadType::Bytes> payloads;
  payloads.push_back({0x00, 0x01});
  payloads.push_back(CdrBytes().u32(1700000005).u32(0).u32(0xfffffff0u).octet('m').bytes());
  payloads.push_back(
      CdrBytes().u32(1700000006).u32(0).str("map").u32(1).u32(3).u32(0x40000000u).bytes());
  payloads.push_back(CdrBytes()
                         .u32(1700000007)
                         .u32(0)
                         .str("map")
                         .u32(1)
                         .u32(3)
                         .u32(0)
                         .octet(0)
                         .u32(16)
                         .u32(48)
                         .u32(1000000)
                         .u32(0)
                         .u32(0)
                         .bytes());
  mlmap::dds::sensor_msgs::PointCloud2_ cloud =
      mlmap::dds::encodePointCloud2(randomPoints(100, 6), nullptr, 1700000008.0, "map");
  mlmap::dds::sensor_msgs::PointCloud2_PubSubType typed;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(typed.getSerializedSizeProvider(&cloud)());
  typed.serialize(&cloud, &payload);
  RawPayloadType::Bytes valid(payload.data, payload.data + payload.length);
  for (const std::uint8_t encapsulation :
       {std::uint8_t{0x07}, std::uint8_t{0x00}}) {  // CDR2_LE, CDR_BE
    payloads.push_back(valid);
    payloads.back()[1] = encapsulation;
  }
  return payloads;
}

void save(const interop::SampleRecord& r, const std::string& dir, const std::string& kind,
          const mlmap::dds::ros_time::Time_& stamp) {
  const std::string path =
      dir + "/" + interop::recordFileName(kind, stamp.sec_(), stamp.nanosec_());
  if (!r.writeTo(path)) throw std::runtime_error("cannot write " + path);
}

void waitAcknowledged(fdds::DataWriter* writer, const char* what) {
  if (writer->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(20, 0)) !=
      eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error(std::string("the reader did not acknowledge the ") + what +
                             " within 20 s");
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap_interop_talker: Fast DDS side of the mlmap -> Cyclone DDS interop test"};
  std::string out_dir, ready_file;
  double wait_s = 20.0;
  std::size_t large_points = 300000;
  app.add_option("--out", out_dir, "folder for the records of the messages sent")->required();
  app.add_option("--ready-file", ready_file, "the reader creates this file once it has matched")
      ->required();
  app.add_option("--wait", wait_s, "seconds to wait for the reader")->check(CLI::PositiveNumber);
  app.add_option("--large-points", large_points, "points of the large cloud (16 bytes each)");
  CLI11_PARSE(app, argc, argv);

  try {
    std::filesystem::create_directories(out_dir);
    const mlmap::dds::DdsConfig
        config;  // ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE, node defaults
    mlmap::dds::ParticipantPtr participant =
        mlmap::dds::createParticipant(config, "mlmap_interop_talker");
    fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    const std::string grid_topic = mlmap::dds::ddsTopicName(config.ns, config.topics.grid);
    const std::string cloud_topic = mlmap::dds::ddsTopicName(config.ns, config.topics.local_map);
    // The node's presets: its grid writer is latched, its map clouds reliable and volatile.
    fdds::DataWriter* grid_writer =
        mlmap::dds::createWriter<mlmap::dds::nav_msgs::OccupancyGrid_PubSubType>(
            publisher, grid_topic, mlmap::dds::latchedWriterQos());
    fdds::DataWriter* cloud_writer =
        mlmap::dds::createWriter<mlmap::dds::sensor_msgs::PointCloud2_PubSubType>(
            publisher, cloud_topic, mlmap::dds::reliableWriterQos(2));
    mlmap::dds::ParticipantPtr bad_participant =
        mlmap::dds::createParticipant(config, "mlmap_interop_bad_sender");
    fdds::DataWriter* bad_writer = mlmap::dds::createWriter<RawPayloadType>(
        bad_participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT), cloud_topic,
        mlmap::dds::reliableWriterQos(10));

    // 1. Latched grids before any reader: only the last one may reach the late joiner.
    mlmap::dds::nav_msgs::OccupancyGrid_ superseded = testGrid(37, 23, 1699999990.0);
    mlmap::dds::nav_msgs::OccupancyGrid_ latched = testGrid(250, 180, 1699999991.25);
    if (!grid_writer->write(&superseded) || !grid_writer->write(&latched)) {
      throw std::runtime_error("cannot write a grid");
    }
    fdds::PublicationMatchedStatus matched;
    grid_writer->get_publication_matched_status(matched);
    if (matched.total_count != 0) {
      throw std::runtime_error(
          "a grid reader existed before the latched grid was written: "
          "the late-joiner check would prove nothing");
    }
    save(record(latched), out_dir, "grid", latched.header_().stamp_());
    std::ofstream(out_dir + "/latched.done") << "1\n";
    spdlog::info("wrote 2 grids on {} with no reader; waiting for {}", grid_topic, ready_file);

    // 2. Malformed payloads, once both sides have matched.
    const auto wait_start = Clock::now();
    for (;;) {
      fdds::PublicationMatchedStatus bad_matched;
      bad_writer->get_publication_matched_status(bad_matched);
      cloud_writer->get_publication_matched_status(matched);
      if (matched.current_count > 0 && bad_matched.current_count > 0 &&
          std::filesystem::exists(ready_file)) {
        break;
      }
      if (std::chrono::duration<double>(Clock::now() - wait_start).count() > wait_s) {
        throw std::runtime_error(fmt::format("no ready reader within {} s ({} matched on {})",
                                             wait_s, matched.current_count, cloud_topic));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::vector<RawPayloadType::Bytes> malformed = malformedClouds();
    for (RawPayloadType::Bytes& payload : malformed) {
      if (!bad_writer->write(&payload)) throw std::runtime_error("cannot write a raw payload");
    }
    waitAcknowledged(bad_writer, "malformed clouds");
    spdlog::info("{} malformed clouds written and acknowledged", malformed.size());

    // 3. Clouds.
    std::vector<mlmap::dds::sensor_msgs::PointCloud2_> clouds = testClouds(large_points);
    for (mlmap::dds::sensor_msgs::PointCloud2_& cloud : clouds) {
      const auto t0 = Clock::now();
      if (!cloud_writer->write(&cloud)) throw std::runtime_error("cannot write a cloud");
      waitAcknowledged(cloud_writer, "cloud");
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      save(record(cloud), out_dir, "cloud", cloud.header_().stamp_());
      spdlog::info("cloud of {} bytes on {}: written and acknowledged in {:.1f} ms",
                   cloud.data_().size(), cloud_topic, ms);
    }

    // 4. A live grid update.
    mlmap::dds::nav_msgs::OccupancyGrid_ live = testGrid(251, 181, 1700000010.0);
    if (!grid_writer->write(&live)) throw std::runtime_error("cannot write a grid");
    waitAcknowledged(grid_writer, "live grid");
    save(record(live), out_dir, "grid", live.header_().stamp_());
    spdlog::info("done: 2 grids and {} clouds acknowledged by the reader", clouds.size());
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
