// mlmap_cyclone_peer: a ROS 2 peer built on Cyclone DDS (Jazzy's other tier-1 middleware) for the
// cross-vendor interoperability tests. It uses Cyclone's C API with types that idlc generated
// from mlmap's own idl/ files, and does not link the Fast DDS side of mlmap.
//
//   listen: subscribes to PointCloud2 topics (RELIABLE, VOLATILE) and OccupancyGrid topics
//           (RELIABLE, TRANSIENT_LOCAL, as Nav2 subscribes to maps) and writes a canonical record
//           of every sample (sample_record.h) into --out. A sample that did not arrive as XCDR1
//           little endian (what ROS 2 sends), or does not deserialise, is logged and not recorded.
//           Fields are recorded as they are and never interpreted, so nothing from the wire can
//           make it read out of bounds.
//   fly:    flies the simulator through the built-in scenario (as mlmap_sensor_publisher does)
//           and publishes the organised clouds (float32 x, y, z, intensity) and the poses
//           (geometry_msgs/PoseStamped, 50 Hz, ahead of the camera) BEST_EFFORT, as sensor
//           drivers and PX4 do.
//
// Cyclone's configuration comes from CYCLONEDDS_URI, which must be set (e.g. to
// config/dds/cyclone_loopback.xml): the peer refuses Cyclone's default multicast discovery.

#include "mlmap/core/config.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/sim/depth_camera.h"

#include "sample_record.h"

#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>

#include "geometry_msgs/msg/PoseStamped_.h"
#include "nav_msgs/msg/OccupancyGrid_.h"
#include "sensor_msgs/msg/PointCloud2_.h"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace mlmap;
using Clock = std::chrono::steady_clock;

std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) { g_stop = true; }

/// Encapsulation identifier of plain CDR (XCDR1), little endian: what ROS 2 puts on the wire.
constexpr std::uint8_t kCdrLe[2] = {0x00, 0x01};
/// Samples taken per dds_takecdr call.
constexpr std::uint32_t kTakeBatch = 8;

/// Throws with Cyclone's message when `rc` is an error; returns it otherwise (entities, counts).
dds_return_t check(dds_return_t rc, const std::string& what) {
  if (rc < 0) throw std::runtime_error(what + ": " + dds_strretcode(rc));
  return rc;
}

/// Deletes a Cyclone entity (and everything it contains) when it goes out of scope.
class EntityGuard {
 public:
  explicit EntityGuard(dds_entity_t entity) : entity_(entity) {}
  ~EntityGuard() { dds_delete(entity_); }
  EntityGuard(const EntityGuard&) = delete;
  EntityGuard& operator=(const EntityGuard&) = delete;
  [[nodiscard]] dds_entity_t get() const { return entity_; }

 private:
  dds_entity_t entity_;
};

/// A QoS object freed when it goes out of scope.
class Qos {
 public:
  Qos(dds_reliability_kind_t reliability, dds_durability_kind_t durability, std::int32_t depth)
      : qos_(dds_create_qos()) {
    dds_qset_reliability(qos_, reliability, DDS_SECS(1));
    dds_qset_durability(qos_, durability);
    dds_qset_history(qos_, DDS_HISTORY_KEEP_LAST, depth);
  }
  ~Qos() { dds_delete_qos(qos_); }
  Qos(const Qos&) = delete;
  Qos& operator=(const Qos&) = delete;
  [[nodiscard]] const dds_qos_t* get() const { return qos_; }

 private:
  dds_qos_t* qos_;
};

dds_entity_t createParticipant(int domain_id) {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  if (uri == nullptr || *uri == '\0') {
    throw std::runtime_error(
        "CYCLONEDDS_URI is not set; set it to a loopback configuration, e.g. "
        "file://<mlmap>/config/dds/cyclone_loopback.xml (the peer does not "
        "use Cyclone's default multicast discovery on the real network)");
  }
  return check(dds_create_participant(static_cast<dds_domainid_t>(domain_id), nullptr, nullptr),
               "cannot create a Cyclone DDS participant on domain " + std::to_string(domain_id));
}

dds_entity_t createTopic(dds_entity_t participant, const dds_topic_descriptor_t* type,
                         const std::string& name) {
  return check(dds_create_topic(participant, type, name.c_str(), nullptr, nullptr),
               "cannot create topic " + name);
}

std::string cString(const char* s) { return s == nullptr ? std::string() : std::string(s); }

template <typename Seq>
std::size_t seqLength(const Seq& seq) {
  return seq._buffer == nullptr ? 0 : seq._length;
}

// ---- listen ---------------------------------------------------------------------------------

interop::SampleRecord record(const sensor_msgs_msg_dds__PointCloud2_& msg) {
  interop::SampleRecord r("sensor_msgs::msg::dds_::PointCloud2_");
  const std::string frame_id = cString(msg.header_.frame_id_);
  r.add("header.stamp.sec", msg.header_.stamp_.sec_);
  r.addUnsigned("header.stamp.nanosec", msg.header_.stamp_.nanosec_);
  r.addString("header.frame_id", frame_id.data(), frame_id.size());
  r.addUnsigned("height", msg.height_);
  r.addUnsigned("width", msg.width_);
  r.addUnsigned("fields.length", seqLength(msg.fields_));
  for (std::size_t i = 0; i < seqLength(msg.fields_); ++i) {
    const sensor_msgs_msg_dds__PointField_& f = msg.fields_._buffer[i];
    const std::string name = cString(f.name_);
    r.addString("fields.name", name.data(), name.size());
    r.addUnsigned("fields.offset", f.offset_);
    r.addUnsigned("fields.datatype", f.datatype_);
    r.addUnsigned("fields.count", f.count_);
  }
  r.addBool("is_bigendian", msg.is_bigendian_);
  r.addUnsigned("point_step", msg.point_step_);
  r.addUnsigned("row_step", msg.row_step_);
  r.addBytes("data", msg.data_._buffer, seqLength(msg.data_));
  r.addBool("is_dense", msg.is_dense_);
  return r;
}

interop::SampleRecord record(const nav_msgs_msg_dds__OccupancyGrid_& msg) {
  interop::SampleRecord r("nav_msgs::msg::dds_::OccupancyGrid_");
  const std::string frame_id = cString(msg.header_.frame_id_);
  r.add("header.stamp.sec", msg.header_.stamp_.sec_);
  r.addUnsigned("header.stamp.nanosec", msg.header_.stamp_.nanosec_);
  r.addString("header.frame_id", frame_id.data(), frame_id.size());
  const nav_msgs_msg_dds__MapMetaData_& info = msg.info_;
  r.add("info.map_load_time.sec", info.map_load_time_.sec_);
  r.addUnsigned("info.map_load_time.nanosec", info.map_load_time_.nanosec_);
  r.addFloat("info.resolution", info.resolution_);
  r.addUnsigned("info.width", info.width_);
  r.addUnsigned("info.height", info.height_);
  r.addDouble("info.origin.position.x", info.origin_.position_.x_);
  r.addDouble("info.origin.position.y", info.origin_.position_.y_);
  r.addDouble("info.origin.position.z", info.origin_.position_.z_);
  r.addDouble("info.origin.orientation.x", info.origin_.orientation_.x_);
  r.addDouble("info.origin.orientation.y", info.origin_.orientation_.y_);
  r.addDouble("info.origin.orientation.z", info.origin_.orientation_.z_);
  r.addDouble("info.origin.orientation.w", info.origin_.orientation_.w_);
  r.addBytes("data", msg.data_._buffer, seqLength(msg.data_));
  return r;
}

/// One subscribed topic of the listener: takes the serialised samples, checks their encoding,
/// deserialises and records them.
template <typename Msg>
class RecordingReader {
 public:
  RecordingReader(dds_entity_t participant, const dds_topic_descriptor_t* type, std::string kind,
                  const std::string& topic, const Qos& qos, std::string out_dir)
      : type_(type), kind_(std::move(kind)), out_dir_(std::move(out_dir)) {
    reader_ = check(
        dds_create_reader(participant, createTopic(participant, type, topic), qos.get(), nullptr),
        "cannot create a reader on " + topic);
  }

  /// Writers the reader has matched now.
  [[nodiscard]] std::uint32_t matched() const {
    dds_subscription_matched_status_t status;
    return dds_get_subscription_matched_status(reader_, &status) == DDS_RETCODE_OK
               ? status.current_count
               : 0;
  }

  /// Takes and records every available sample.
  void poll() {
    ddsi_serdata* samples[kTakeBatch] = {};
    dds_sample_info_t infos[kTakeBatch];
    for (;;) {
      const dds_return_t n = check(dds_takecdr(reader_, samples, kTakeBatch, infos, DDS_ANY_STATE),
                                   "dds_takecdr on " + kind_);
      for (dds_return_t i = 0; i < n; ++i) {
        if (infos[i].valid_data) handle(samples[i]);
        ddsi_serdata_unref(samples[i]);
        samples[i] = nullptr;
      }
      if (n < static_cast<dds_return_t>(kTakeBatch)) return;
    }
  }

  [[nodiscard]] int recorded() const { return recorded_; }
  [[nodiscard]] int rejected() const { return rejected_; }

 private:
  void handle(const ddsi_serdata* serdata) {
    const std::uint32_t bytes = ddsi_serdata_size(serdata);
    std::uint8_t header[4] = {};
    if (bytes < sizeof(header)) {
      ++rejected_;
      spdlog::error("{}: a sample of {} bytes, shorter than its encapsulation header", kind_,
                    bytes);
      return;
    }
    ddsi_serdata_to_ser(serdata, 0, sizeof(header), header);
    if (header[0] != kCdrLe[0] || header[1] != kCdrLe[1]) {
      ++rejected_;
      spdlog::error("{}: encapsulation 0x{:02x}{:02x}, ROS 2 expects CDR_LE (0x0001, XCDR1)", kind_,
                    header[0], header[1]);
      return;
    }
    Msg msg{};
    if (!ddsi_serdata_to_sample(serdata, &msg, nullptr, nullptr)) {
      dds_sample_free(&msg, type_, DDS_FREE_CONTENTS);
      ++rejected_;
      spdlog::error("{}: a sample of {} bytes does not deserialise", kind_, bytes);
      return;
    }
    const interop::SampleRecord r = record(msg);
    std::string path =
        out_dir_ + "/" +
        interop::recordFileName(kind_, msg.header_.stamp_.sec_, msg.header_.stamp_.nanosec_);
    for (int copy = 1; std::filesystem::exists(path); ++copy) {
      path += ".dup" + std::to_string(copy);  // the same stamp twice: keep both, the check fails
    }
    dds_sample_free(&msg, type_, DDS_FREE_CONTENTS);
    if (!r.writeTo(path)) throw std::runtime_error("cannot write " + path);
    ++recorded_;
    spdlog::info("{}: recorded {} ({} bytes serialised)", kind_, path, bytes);
  }

  const dds_topic_descriptor_t* type_;
  std::string kind_;
  std::string out_dir_;
  dds_entity_t reader_ = 0;
  int recorded_ = 0;
  int rejected_ = 0;
};

struct ListenOptions {
  std::string out_dir;
  std::string ready_file;
  std::vector<std::string> cloud_topics{"rt/mlmap/local_map/occupied"};
  std::vector<std::string> grid_topics{"rt/mlmap/grid"};
  int cloud_writers = 1;
  int expect_clouds = 0;
  int expect_grids = 0;
  double timeout_s = 30.0;
  double linger_s = 1.0;
  double stay_s = 0.0;  ///< at least this long, even when everything expected came earlier
};

/// The record kind of a topic: `kind` alone when it is the only topic of its kind (the records of
/// the loopback tests), else `kind` and the topic, so that equal stamps on two topics never meet.
std::string recordKind(const std::string& kind, const std::string& topic, std::size_t topics) {
  if (topics == 1) return kind;
  std::string name = kind + "@" + topic;
  std::replace(name.begin(), name.end(), '/', '.');
  return name;
}

/// Readers of one message type on several topics, polled and counted together.
template <typename Msg>
class RecordingReaders {
 public:
  RecordingReaders(dds_entity_t participant, const dds_topic_descriptor_t* type,
                   const std::string& kind, const std::vector<std::string>& topics, const Qos& qos,
                   const std::string& out_dir) {
    for (const std::string& topic : topics) {
      readers_.push_back(std::make_unique<RecordingReader<Msg>>(
          participant, type, recordKind(kind, topic, topics.size()), topic, qos, out_dir));
    }
  }
  void poll() {
    for (auto& reader : readers_) reader->poll();
  }
  /// True when every topic's reader has matched at least `writers` writers.
  [[nodiscard]] bool matched(std::uint32_t writers) const {
    return std::all_of(readers_.begin(), readers_.end(),
                       [writers](const auto& reader) { return reader->matched() >= writers; });
  }
  /// The fewest samples recorded on any one topic.
  [[nodiscard]] int fewestRecorded() const {
    int fewest = std::numeric_limits<int>::max();
    for (const auto& reader : readers_) fewest = std::min(fewest, reader->recorded());
    return readers_.empty() ? 0 : fewest;
  }
  [[nodiscard]] int recorded() const { return sum(&RecordingReader<Msg>::recorded); }
  [[nodiscard]] int rejected() const { return sum(&RecordingReader<Msg>::rejected); }

 private:
  int sum(int (RecordingReader<Msg>::*count)() const) const {
    int total = 0;
    for (const auto& reader : readers_) total += ((*reader).*count)();
    return total;
  }
  std::vector<std::unique_ptr<RecordingReader<Msg>>> readers_;
};

std::string joined(const std::vector<std::string>& topics) {
  std::string text;
  for (const std::string& topic : topics) text += (text.empty() ? "" : ", ") + topic;
  return text;
}

int listen(int domain_id, const ListenOptions& o) {
  std::filesystem::create_directories(o.out_dir);
  const EntityGuard participant(createParticipant(domain_id));
  RecordingReaders<sensor_msgs_msg_dds__PointCloud2_> clouds(
      participant.get(), &sensor_msgs_msg_dds__PointCloud2__desc, "cloud", o.cloud_topics,
      Qos(DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE, 10), o.out_dir);
  // History 10, not Nav2's 1: a writer that wrongly sent more than its last grid to a late joiner
  // must show up as extra records, not be hidden by the reader's own history.
  RecordingReaders<nav_msgs_msg_dds__OccupancyGrid_> grids(
      participant.get(), &nav_msgs_msg_dds__OccupancyGrid__desc, "grid", o.grid_topics,
      Qos(DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL, 10), o.out_dir);
  spdlog::info("listening on {} and {} (domain {})", joined(o.cloud_topics), joined(o.grid_topics),
               domain_id);

  const auto start = Clock::now();
  auto elapsed_s = [&start] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  bool ready = false;
  double complete_at_s = -1.0;
  while (!g_stop) {
    clouds.poll();
    grids.poll();
    if (!ready && clouds.matched(static_cast<std::uint32_t>(o.cloud_writers)) && grids.matched(1)) {
      ready = true;
      std::ofstream(o.ready_file) << "1\n";
      spdlog::info("matched every writer after {:.2f} s", elapsed_s());
    }
    if (complete_at_s < 0 && clouds.fewestRecorded() >= o.expect_clouds &&
        grids.fewestRecorded() >= o.expect_grids) {
      complete_at_s = elapsed_s();  // stay a little: anything more would be an unexpected extra
    }
    if (complete_at_s >= 0 && elapsed_s() > std::max(complete_at_s + o.linger_s, o.stay_s)) break;
    if (elapsed_s() > o.timeout_s) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  spdlog::info("recorded {} clouds and {} grids (expected {} and {} per topic), refused {} samples",
               clouds.recorded(), grids.recorded(), o.expect_clouds, o.expect_grids,
               clouds.rejected() + grids.rejected());
  if (complete_at_s < 0) {
    spdlog::error("not everything arrived within {} s", o.timeout_s);
    return 1;
  }
  return 0;
}

// ---- fly --------------------------------------------------------------------------------------

builtin_interfaces_msg_dds__Time_ rosTime(double stamp_s) {
  builtin_interfaces_msg_dds__Time_ t{};
  const double sec = std::floor(stamp_s);
  auto nanosec = static_cast<std::int64_t>(std::llround((stamp_s - sec) * 1e9));
  auto whole = static_cast<std::int64_t>(sec);
  if (nanosec >= 1000000000) {
    nanosec -= 1000000000;
    ++whole;
  }
  t.sec_ = static_cast<std::int32_t>(whole);
  t.nanosec_ = static_cast<std::uint32_t>(nanosec);
  return t;
}

/// The organised cloud of a depth frame as mlmap_sensor_publisher sends it: width x height points
/// of float32 x, y, z, intensity (= z), NaN where the pixel has no return, is_dense false.
class OrganisedCloud {
 public:
  explicit OrganisedCloud(std::string frame_id) : frame_id_(std::move(frame_id)) {
    for (std::uint32_t i = 0; i < 4; ++i) {
      fields_[i].name_ = names_[i];
      fields_[i].offset_ = 4 * i;
      fields_[i].datatype_ = 7;  // FLOAT32
      fields_[i].count_ = 1;
    }
  }

  /// The message for `frame` at `stamp_s`; it points into this object (valid until the next call).
  const sensor_msgs_msg_dds__PointCloud2_& message(const DepthFrame& frame, double stamp_s) {
    const PinholeIntrinsics& k = frame.intrinsics;
    data_.resize(static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height) *
                 kPointBytes);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::size_t i = 0;
    for (int v = 0; v < k.height; ++v) {
      for (int u = 0; u < k.width; ++u, ++i) {
        const double z = frame.depth_m[i];
        float p[4] = {nan, nan, nan, nan};
        if (std::isfinite(z) && z > 0.0) {
          p[0] = static_cast<float>((u - k.cx) * z / k.fx);
          p[1] = static_cast<float>((v - k.cy) * z / k.fy);
          p[2] = static_cast<float>(z);
          p[3] = static_cast<float>(z);
        }
        std::memcpy(data_.data() + kPointBytes * i, p, sizeof(p));
      }
    }
    msg_ = {};
    msg_.header_.stamp_ = rosTime(stamp_s);
    msg_.header_.frame_id_ = frame_id_.data();
    msg_.height_ = static_cast<std::uint32_t>(k.height);
    msg_.width_ = static_cast<std::uint32_t>(k.width);
    msg_.fields_._maximum = msg_.fields_._length = 4;
    msg_.fields_._buffer = fields_;
    msg_.fields_._release = false;
    msg_.is_bigendian_ = false;
    msg_.point_step_ = kPointBytes;
    msg_.row_step_ = kPointBytes * msg_.width_;
    msg_.data_._maximum = msg_.data_._length = static_cast<std::uint32_t>(data_.size());
    msg_.data_._buffer = data_.data();
    msg_.data_._release = false;
    msg_.is_dense_ = false;
    return msg_;
  }

 private:
  static constexpr std::uint32_t kPointBytes = 16;
  std::string frame_id_;
  char names_[4][10] = {"x", "y", "z", "intensity"};
  sensor_msgs_msg_dds__PointField_ fields_[4] = {};
  std::vector<std::uint8_t> data_;
  sensor_msgs_msg_dds__PointCloud2_ msg_{};
};

struct FlyOptions {
  std::string cloud_topic = "rt/cloud";
  std::string pose_topic = "rt/pose";
  std::string world_frame = "map";
  std::string sensor_frame = "camera_depth_optical_frame";
  int max_frames = 0;
  double rate_hz = 0.0;
  double speed = 1.0;
  double pose_rate_hz = 50.0;
  double wait_s = 10.0;
  double settle_s = 1.0;
};

bool publicationMatched(dds_entity_t writer) {
  dds_publication_matched_status_t status;
  return dds_get_publication_matched_status(writer, &status) == DDS_RETCODE_OK &&
         status.current_count > 0;
}

int fly(int domain_id, const FlyOptions& o) {
  const datasets::Scenario scenario = datasets::defaultScenario();
  const double rate_hz = o.rate_hz > 0 ? o.rate_hz : scenario.frame_rate_hz;
  const Transform T_B_S = MapConfig{}.sensor.T_B_S();  // mlmap_node's default mounting

  const EntityGuard participant(createParticipant(domain_id));
  // Sensor data QoS (BEST_EFFORT, KEEP_LAST 5), as camera drivers and PX4 publish.
  const Qos sensor_qos(DDS_RELIABILITY_BEST_EFFORT, DDS_DURABILITY_VOLATILE, 5);
  auto createWriter = [&](const dds_topic_descriptor_t* type, const std::string& topic) {
    return check(dds_create_writer(participant.get(), createTopic(participant.get(), type, topic),
                                   sensor_qos.get(), nullptr),
                 "cannot create a writer on " + topic);
  };
  const dds_entity_t cloud_writer =
      createWriter(&sensor_msgs_msg_dds__PointCloud2__desc, o.cloud_topic);
  const dds_entity_t pose_writer =
      createWriter(&geometry_msgs_msg_dds__PoseStamped__desc, o.pose_topic);

  const auto wait_start = Clock::now();
  while (!(publicationMatched(cloud_writer) && publicationMatched(pose_writer))) {
    if (g_stop || std::chrono::duration<double>(Clock::now() - wait_start).count() > o.wait_s) {
      spdlog::error("no subscriber matched {} and {} within {} s", o.cloud_topic, o.pose_topic,
                    o.wait_s);
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // Our writers match before the remote readers have matched them, and a reader drops samples
  // of a writer it does not know yet: give the other side time to finish discovery.
  std::this_thread::sleep_for(std::chrono::duration<double>(o.settle_s));

  const int available =
      static_cast<int>(std::floor(scenario.trajectory.duration_s() * rate_hz)) + 1;
  const int frames = o.max_frames > 0 ? std::min(o.max_frames, available) : available;
  spdlog::info("publishing {} clouds on {} at {} Hz and poses on {} at {} Hz", frames,
               o.cloud_topic, rate_hz, o.pose_topic, o.pose_rate_hz);
  const sim::DepthCamera camera(scenario.camera);
  OrganisedCloud cloud(o.sensor_frame);
  std::string world_frame = o.world_frame;
  // Stamps look like a real system's: wall-clock time at the start plus the flight time.
  const double stamp0_s = std::floor(
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count());
  auto publishPose = [&](double t_s) {
    const Transform T_W_B = scenario.trajectory.poseAt(t_s);
    const Eigen::Quaterniond q(T_W_B.linear());
    geometry_msgs_msg_dds__PoseStamped_ pose{};
    pose.header_.stamp_ = rosTime(stamp0_s + t_s);
    pose.header_.frame_id_ = world_frame.data();
    pose.pose_.position_ = {T_W_B.translation().x(), T_W_B.translation().y(),
                            T_W_B.translation().z()};
    pose.pose_.orientation_ = {q.x(), q.y(), q.z(), q.w()};
    check(dds_write(pose_writer, &pose), "cannot write a pose");
  };

  const auto start = Clock::now();
  const double pose_period_s = 1.0 / o.pose_rate_hz;
  long pose_k = 0;
  int sent = 0;
  for (int i = 0; i < frames && !g_stop; ++i) {
    const double t_s = o.speed * i / rate_hz;
    DepthFrame frame;
    frame.T_W_B = scenario.trajectory.poseAt(t_s);
    camera.render(scenario.world, frame.T_W_B * T_B_S, t_s, &frame);
    std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(i / rate_hz)));
    // Odometry runs up to one pose period ahead of the camera, as mlmap_sensor_publisher's.
    for (; static_cast<double>(pose_k) * pose_period_s <= t_s + pose_period_s + 1e-9; ++pose_k) {
      publishPose(static_cast<double>(pose_k) * pose_period_s);
    }
    check(dds_write(cloud_writer, &cloud.message(frame, stamp0_s + t_s)), "cannot write a cloud");
    ++sent;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the last samples leave
  spdlog::info("done: {} clouds published", sent);
  return sent == frames ? 0 : 1;
}

/// ROS_DOMAIN_ID when set (0..232), else 0.
int defaultDomainId() {
  const char* text = std::getenv("ROS_DOMAIN_ID");
  if (text == nullptr || *text == '\0') return 0;
  char* end = nullptr;
  const long id = std::strtol(text, &end, 10);
  if (*end != '\0' || id < 0 || id > 232) {
    throw std::runtime_error(std::string("ROS_DOMAIN_ID '") + text + "' is not a domain id 0..232");
  }
  return static_cast<int>(id);
}

}  // namespace

/// `discover`: how long a newly created participant takes to learn of a writer on `topic` (as a
/// one-shot ROS 2 command such as `ros2 topic info` does: it only sees what discovery delivered).
struct DiscoverOptions {
  std::string topic = "rt/mlmap/status";
  double timeout_s = 5.0;
};

/// Creates a participant, reads the DCPSPublication built-in topic until a writer on the topic
/// appears, prints "discovered <topic> after <ms> ms" and returns 0; 3 when it timed out.
int discover(int domain_id, const DiscoverOptions& o) {
  const Clock::time_point start = Clock::now();
  const dds_entity_t participant = createParticipant(domain_id);
  const dds_entity_t reader =
      check(dds_create_reader(participant, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr),
            "cannot read the DCPSPublication built-in topic");
  const Clock::time_point deadline = start + std::chrono::duration_cast<Clock::duration>(
                                                 std::chrono::duration<double>(o.timeout_s));
  int rc = 3;
  while (rc == 3 && Clock::now() < deadline && !g_stop) {
    void* samples[kTakeBatch] = {};
    dds_sample_info_t infos[kTakeBatch];
    const int32_t n = dds_take(reader, samples, infos, kTakeBatch, kTakeBatch);
    for (int32_t i = 0; i < n; ++i) {
      const auto* endpoint = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
      if (infos[i].valid_data && endpoint->topic_name != nullptr &&
          o.topic == endpoint->topic_name) {
        rc = 0;
      }
    }
    if (n > 0) dds_return_loan(reader, samples, n);
    if (rc == 3) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  dds_delete(participant);
  if (rc == 0) {
    std::printf("discovered %s after %.1f ms\n", o.topic.c_str(), ms);
  } else {
    std::printf("did not discover %s within %.1f ms\n", o.topic.c_str(), ms);
  }
  return rc;
}

int main(int argc, char** argv) {
  CLI::App app{"mlmap_cyclone_peer: a Cyclone DDS peer of mlmap_node for interoperability tests"};
  app.require_subcommand(1);
  int domain_id = -1;
  app.add_option("--domain", domain_id, "DDS domain (default: ROS_DOMAIN_ID, else 0)")
      ->check(CLI::Range(0, 232));

  ListenOptions listen_options;
  CLI::App* listen_cmd =
      app.add_subcommand("listen", "record every PointCloud2 and OccupancyGrid received");
  listen_cmd->add_option("--out", listen_options.out_dir, "folder for the records")->required();
  listen_cmd
      ->add_option("--ready-file", listen_options.ready_file,
                   "created once both readers have matched a writer")
      ->required();
  listen_cmd
      ->add_option("--cloud-topic", listen_options.cloud_topics,
                   "DDS topic of the clouds (repeat for more)")
      ->capture_default_str();
  listen_cmd
      ->add_option("--grid-topic", listen_options.grid_topics,
                   "DDS topic of the grids (repeat for more)")
      ->capture_default_str();
  listen_cmd
      ->add_option("--cloud-writers", listen_options.cloud_writers,
                   "cloud writers to match before signalling ready")
      ->capture_default_str();
  listen_cmd->add_option("--expect-clouds", listen_options.expect_clouds,
                         "clouds to wait for, per topic");
  listen_cmd->add_option("--expect-grids", listen_options.expect_grids,
                         "grids to wait for, per topic");
  listen_cmd->add_option("--timeout", listen_options.timeout_s, "give up after this many seconds")
      ->capture_default_str();
  listen_cmd
      ->add_option("--stay", listen_options.stay_s,
                   "stay subscribed at least this many seconds (a subscriber that stays, as "
                   "a ROS 2 node does)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);

  FlyOptions fly_options;
  CLI::App* fly_cmd =
      app.add_subcommand("fly", "fly the built-in scenario, publish clouds and poses");
  fly_cmd->add_option("--cloud-topic", fly_options.cloud_topic, "DDS topic of the clouds")
      ->capture_default_str();
  fly_cmd->add_option("--pose-topic", fly_options.pose_topic, "DDS topic of the poses")
      ->capture_default_str();
  fly_cmd
      ->add_option("--max-frames", fly_options.max_frames, "stop after this many frames (0: all)")
      ->check(CLI::NonNegativeNumber);
  fly_cmd->add_option("--rate", fly_options.rate_hz, "frames per second (default: the scenario's)")
      ->check(CLI::NonNegativeNumber);
  fly_cmd->add_option("--speed", fly_options.speed, "flight seconds per wall-clock second")
      ->check(CLI::PositiveNumber);
  fly_cmd
      ->add_option("--wait-for-subscriber", fly_options.wait_s,
                   "seconds to wait for the node's readers")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  DiscoverOptions discover_options;
  CLI::App* discover_cmd =
      app.add_subcommand("discover", "time until a new participant learns of a writer on a topic");
  discover_cmd->add_option("--topic", discover_options.topic, "DDS topic of the writer")
      ->capture_default_str();
  discover_cmd
      ->add_option("--timeout", discover_options.timeout_s, "give up after this many seconds")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);

  try {
    if (domain_id < 0) domain_id = defaultDomainId();
    if (discover_cmd->parsed()) return discover(domain_id, discover_options);
    return listen_cmd->parsed() ? listen(domain_id, listen_options) : fly(domain_id, fly_options);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
