#include "mlmap/dds/fleet/fleet_merger.h"

#include "mlmap/core/stopwatch.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/dds/fleet/submap_messages.h"
#include "mlmap/dds/fleet/submap_readers.h"

#include "mlmap_msgs/msg/FleetStatus_PubSubTypes.h"
#include "mlmap_msgs/msg/Submap_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include <cmath>
#include <cstring>
#include <sstream>

namespace mlmap::dds {
namespace {
namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

/// A colour per vehicle index (packed as PointCloud2's float `rgb`, as PCL and RViz read it).
float vehicleColour(int index) {
  const std::uint32_t rgb = fleet::vehicleColourRgb(index);
  float f = 0.0f;
  std::memcpy(&f, &rgb, sizeof(f));
  return f;
}

sensor_msgs::PointField_ field(const char* name, std::uint32_t offset, std::uint8_t datatype) {
  sensor_msgs::PointField_ f;
  f.name_(name);
  f.offset_(offset);
  f.datatype_(datatype);
  f.count_(1);
  return f;
}

/// The merged occupied voxels' centres with rgb (the lowest vehicle bit's colour) and
/// `vehicles` (bits of vehicles 0..31).
sensor_msgs::PointCloud2_ fleetCloud(const fleet::FleetMap& map, double stamp_s,
                                     const std::string& frame_id) {
  constexpr std::uint8_t kFloat32 = 7, kUint32 = 6;
  constexpr std::uint32_t kStep = 20;
  std::vector<std::uint8_t> data;
  data.reserve(map.voxelCount() * kStep);
  std::uint32_t count = 0;
  const double res = map.resolution_m();
  map.forEachOccupied([&](const VoxelIndex& g, LogOddsQ, std::uint64_t bits) {
    const Eigen::Vector3f c = voxelCenter(g, res).cast<float>();
    int first = 0;
    while (first < 63 && ((bits >> first) & 1u) == 0) ++first;
    const float rgb = vehicleColour(first);
    const auto low = static_cast<std::uint32_t>(bits & 0xffffffffu);
    std::uint8_t point[kStep];
    std::memcpy(point, c.data(), 12);
    std::memcpy(point + 12, &rgb, 4);
    std::memcpy(point + 16, &low, 4);
    data.insert(data.end(), point, point + kStep);
    ++count;
  });
  sensor_msgs::PointCloud2_ msg;
  msg.header_().stamp_(toRosTime(stamp_s));
  msg.header_().frame_id_(frame_id);
  msg.height_(1);
  msg.width_(count);
  msg.fields_({field("x", 0, kFloat32), field("y", 4, kFloat32), field("z", 8, kFloat32),
               field("rgb", 12, kFloat32), field("vehicles", 16, kUint32)});
  msg.is_bigendian_(false);
  msg.point_step_(kStep);
  msg.row_step_(kStep * count);
  msg.data_(std::move(data));
  msg.is_dense_(true);
  return msg;
}

}  // namespace

struct FleetMerger::Impl {
  FleetMergerConfig config;
  LogSink log;
  Clock::time_point started = Clock::now();
  mutable std::mutex mutex;  // guards map, counters
  FleetIntake intake;
  const fleet::FleetMap& map;
  std::uint64_t samples_received = 0;
  int publishers_matched = 0;
  std::uint64_t clouds_published = 0;
  std::uint64_t grids_published = 0;
  RateLimitedLog refusal_log;

  std::unique_ptr<SubmapReaders> readers;  // outlives the participant (its listeners)
  ParticipantPtr participant;
  fdds::DataWriter* cloud_writer = nullptr;
  fdds::DataWriter* grid_writer = nullptr;
  fdds::DataWriter* status_writer = nullptr;

  std::mutex wake_mutex;
  std::condition_variable wake;
  bool stopping = false;
  std::thread thread;
  bool stopped = false;

  Impl(const FleetMergerConfig& c, LogSink sink)
      : config(c),
        log(std::move(sink)),
        intake(c.trust, c.log_odds),
        map(intake.map()),
        refusal_log(log, kSubmapRefusals + 1) {}

  double now_s() const { return secondsBetween(started, Clock::now()); }

  void say(LogLevel level, const std::string& m) const {
    if (log) log(level, m);
  }

  void setUp() {
    const std::vector<std::string> problems = config.dds.validate();
    if (!problems.empty()) throw std::invalid_argument("dds configuration: " + problems.front());
    if (!std::isfinite(config.publish_hz) || config.publish_hz <= 0.0 ||
        !std::isfinite(config.stale_after_s) || config.stale_after_s <= 0.0) {
      throw std::invalid_argument("publish_hz and stale_after_s must be finite and > 0");
    }
    SubmapReadersConfig which;
    which.topic = config.submaps_topic;
    which.vehicles = config.trust.vehicles;
    readers = std::make_unique<SubmapReaders>(
        which,
        [this](const std::string& vehicle, mlmap_msgs::Submap_&& msg,
               const fdds::SampleInfo& info) { receive(vehicle, msg, info); },
        [this](const std::string& what) {
          std::lock_guard<std::mutex> lock(mutex);
          ++samples_received;
          intake.countUndecodable();
          logRefusal(SubmapRefusal::kMalformed, what);
        },
        [this](int matched) {
          std::lock_guard<std::mutex> lock(mutex);
          publishers_matched = matched;
        });
    participant = createParticipant(config.dds, "mlmap_fleet", readers->discoveryListener());
    auto* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    auto* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    if (publisher == nullptr || subscriber == nullptr) {
      throw std::runtime_error("cannot create the DDS publisher / subscriber");
    }
    const std::string& ns = config.dds.ns;
    cloud_writer = createWriter<sensor_msgs::PointCloud2_PubSubType>(
        publisher, ddsTopicName(ns, config.cloud_topic), latchedWriterQos());
    grid_writer = createWriter<nav_msgs::OccupancyGrid_PubSubType>(
        publisher, ddsTopicName(ns, config.grid_topic), latchedWriterQos());
    status_writer = createWriter<mlmap_msgs::FleetStatus_PubSubType>(
        publisher, ddsTopicName(ns, config.status_topic), reliableWriterQos(10));
    if (config.trust.vehicles.empty()) {
      say(LogLevel::kWarning,
          "open domain: any participant may join the fleet as a vehicle (list the vehicles to "
          "close it: --vehicle NAME; docs/fleet.md#trust)");
    }
    readers->start(subscriber);
  }

  /// Logs a refused sample, once a second at most per reason (with how many so far).
  void logRefusal(SubmapRefusal reason, const std::string& why) {
    refusal_log.log(LogLevel::kWarning, static_cast<int>(reason),
                    "submap sample refused: " + why + " (" +
                        std::to_string(intake.refused()[static_cast<std::size_t>(reason)]) + " " +
                        toString(reason) + " so far)");
  }

  /// Fast DDS's listener thread: the trust checks, decoding, fusion (FleetIntake::take()).
  void receive(const std::string& topic_vehicle, const mlmap_msgs::Submap_& msg,
               const fdds::SampleInfo& info) {
    SubmapWriterId writer{};
    const auto& handle = info.publication_handle.value;  // the writer's GUID, 16 octets
    for (std::size_t i = 0; i < writer.size(); ++i) writer[i] = handle[static_cast<unsigned>(i)];
    const auto wall_us =
        static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                       std::chrono::system_clock::now().time_since_epoch())
                                       .count());
    std::lock_guard<std::mutex> lock(mutex);
    ++samples_received;
    const SubmapIntake r = intake.take(msg, topic_vehicle, writer, now_s(), wall_us);
    if (!r.applied) {
      logRefusal(r.refusal, r.why);
      return;
    }
    if (r.joined) say(LogLevel::kInfo, "vehicle '" + msg.vehicle_() + "' joined the fleet");
    if (r.restarted) {
      const int v = map.findVehicle(msg.vehicle_());
      const std::uint64_t n = map.vehicles()[static_cast<std::size_t>(v)].restarts;
      refusal_log.log(LogLevel::kInfo, static_cast<int>(kSubmapRefusals),
                      "vehicle '" + msg.vehicle_() + "' restarted (samples from a new writer, " +
                          std::to_string(n) + " so far): they replace its earlier ones");
    }
  }

  void publishLoop() {
    const auto period = std::chrono::duration<double>(1.0 / config.publish_hz);
    std::uint64_t sent_changes = ~std::uint64_t{0};
    for (bool last = false; !last;) {
      {
        std::unique_lock<std::mutex> lock(wake_mutex);
        wake.wait_for(lock, period, [this] { return stopping; });
        last = stopping;
      }
      publishOnce(&sent_changes);
    }
  }

  /// Writes the cloud and grid when the map changed, and the status.
  void publishOnce(std::uint64_t* sent_changes) {
    const double stamp_s = wallClockNow_s();
    const std::string& frame = config.dds.world_frame;
    std::unique_ptr<sensor_msgs::PointCloud2_> cloud;
    std::unique_ptr<nav_msgs::OccupancyGrid_> grid;
    mlmap_msgs::FleetStatus_ status;
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (map.changes() != *sent_changes && map.hasGeometry()) {
        *sent_changes = map.changes();
        cloud = std::make_unique<sensor_msgs::PointCloud2_>(fleetCloud(map, stamp_s, frame));
        const ProjectedGrid g = map.projectGrid(config.grid_min_z_m, config.grid_max_z_m);
        if (!g.cells.empty()) {
          grid = std::make_unique<nav_msgs::OccupancyGrid_>(
              toOccupancyGrid(g, config.grid_min_z_m, stamp_s, frame));
        }
      }
      status = statusMessage(stamp_s);
    }
    if (cloud && cloud_writer->write(cloud.get())) ++clouds_published;
    if (grid && grid_writer->write(grid.get())) ++grids_published;
    status_writer->write(&status);
  }

  /// Under `mutex`.
  std::vector<FleetVehicleStatus> vehicleStatus() const {
    std::vector<FleetVehicleStatus> out;
    const double now = now_s();
    for (const fleet::FleetVehicle& v : map.vehicles()) {
      FleetVehicleStatus s;
      s.info = v;
      s.seconds_since_seen = now - v.last_seen_s;
      s.stale = s.seconds_since_seen > config.stale_after_s;
      out.push_back(s);
    }
    return out;
  }

  /// Under `mutex`.
  mlmap_msgs::FleetStatus_ statusMessage(double stamp_s) const {
    mlmap_msgs::FleetStatus_ m;
    m.header_().stamp_(toRosTime(stamp_s));
    m.header_().frame_id_(config.dds.world_frame);
    m.version_(2);
    for (const FleetVehicleStatus& v : vehicleStatus()) {
      m.vehicles_().push_back(v.info.name);
      m.last_seen_s_().push_back(v.seconds_since_seen);
      m.stale_().push_back(v.stale);
      m.bytes_received_().push_back(v.info.bytes);
      m.samples_received_().push_back(v.info.samples);
      m.submaps_().push_back(v.info.submaps);
      m.voxels_().push_back(v.info.voxels);
    }
    m.merged_voxels_(map.voxelCount());
    m.samples_rejected_(intake.refusedTotal());
    for (const fleet::FleetVehicle& v : map.vehicles()) m.restarts_().push_back(v.restarts);
    for (std::size_t r = 0; r < kSubmapRefusals; ++r) {
      m.refusal_reasons_().push_back(toString(static_cast<SubmapRefusal>(r)));
      m.samples_refused_().push_back(intake.refused()[r]);
    }
    return m;
  }

  void stop() {
    if (stopped) return;
    stopped = true;
    {
      std::lock_guard<std::mutex> lock(wake_mutex);
      stopping = true;
    }
    wake.notify_all();
    if (thread.joinable()) thread.join();
    // The final state reaches the readers before the participant leaves (bounded wait).
    for (fdds::DataWriter* w : {cloud_writer, grid_writer}) {
      if (w != nullptr) w->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(1, 0));
    }
    if (readers) readers->stop();
    participant.reset();
    readers.reset();
  }
};

FleetMerger::FleetMerger(const FleetMergerConfig& config, LogSink log)
    : impl_(std::make_unique<Impl>(config, std::move(log))) {
  try {
    impl_->setUp();
  } catch (...) {
    if (impl_->readers) impl_->readers->stop();
    impl_->participant.reset();
    impl_->readers.reset();
    throw;
  }
}

FleetMerger::~FleetMerger() { stop(); }

void FleetMerger::start() {
  impl_->thread = std::thread([this] { impl_->publishLoop(); });
}

void FleetMerger::stop() { impl_->stop(); }

FleetMergerStats FleetMerger::stats() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  FleetMergerStats s;
  s.vehicles = impl_->vehicleStatus();
  s.merged_voxels = impl_->map.voxelCount();
  s.submaps = impl_->map.submapCount();
  s.memory_bytes = impl_->map.memoryBytes();
  s.samples_received = impl_->samples_received;
  s.samples_rejected = impl_->intake.refusedTotal();
  s.refused = impl_->intake.refused();
  for (const fleet::FleetVehicle& v : impl_->map.vehicles()) s.restarts += v.restarts;
  s.publishers_matched = impl_->publishers_matched;
  s.topics_ignored = impl_->readers ? impl_->readers->topicsIgnored() : 0;
  s.clouds_published = impl_->clouds_published;
  s.grids_published = impl_->grids_published;
  return s;
}

std::vector<std::pair<VoxelIndex, std::uint64_t>> FleetMerger::occupiedVoxels() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  std::vector<std::pair<VoxelIndex, std::uint64_t>> out;
  impl_->map.forEachOccupied(
      [&](const VoxelIndex& g, LogOddsQ, std::uint64_t bits) { out.emplace_back(g, bits); });
  return out;
}

MapState FleetMerger::mapState() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  std::uint64_t applied = 0;
  for (const fleet::FleetVehicle& v : impl_->map.vehicles()) applied += v.samples_applied;
  if (applied == 0) {
    std::ostringstream m;
    m << "no vehicle's submap was merged (" << impl_->samples_received << " samples received, "
      << impl_->intake.refusedTotal() << " refused): nothing to save";
    throw std::runtime_error(m.str());
  }
  return fleet::fleetMapState(impl_->map);
}

std::string FleetMerger::statusLine() const {
  const FleetMergerStats s = stats();
  std::ostringstream m;
  m.setf(std::ios::fixed);
  m.precision(1);
  m << s.vehicles.size() << (s.vehicles.empty() ? " vehicles" : " vehicles:");
  for (const FleetVehicleStatus& v : s.vehicles) {
    if (v.info.samples == 0) {  // a listed vehicle not heard yet
      m << " " << v.info.name << " (not heard yet)";
      continue;
    }
    m << " " << v.info.name << " (seen " << v.seconds_since_seen << " s ago, "
      << static_cast<double>(v.info.bytes) / 1e3 << " kB, " << v.info.submaps << " submaps, "
      << v.info.voxels << " voxels";
    if (v.info.restarts > 0) m << ", " << v.info.restarts << " restarts";
    m << (v.stale ? ", STALE" : "") << ")";
  }
  m << "; " << s.publishers_matched << " submap writers matched";
  if (s.topics_ignored > 0) m << " (" << s.topics_ignored << " vehicle topics ignored)";
  m << "; merged " << s.merged_voxels << " voxels in " << s.submaps << " submaps, "
    << static_cast<double>(s.memory_bytes) / 1e6 << " MB; " << s.samples_rejected
    << " samples refused";
  const char* separator = " (";
  for (std::size_t r = 0; r < kSubmapRefusals; ++r) {
    if (s.refused[r] == 0) continue;
    m << separator << toString(static_cast<SubmapRefusal>(r)) << " " << s.refused[r];
    separator = ", ";
  }
  if (s.samples_rejected > 0) m << ")";
  return m.str();
}

int FleetMerger::domainId() const {
  return impl_->participant ? static_cast<int>(impl_->participant->get_domain_id()) : -1;
}

}  // namespace mlmap::dds
