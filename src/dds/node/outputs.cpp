#include "outputs.h"

#include "mlmap/core/stopwatch.h"
#include "mlmap/dds/wire/cloud_sample.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/dds/fleet/submap_messages.h"
#include "mlmap/planning/fixed_origin_grid.h"

#include "mlmap_msgs/msg/Status_PubSubTypes.h"
#include "mlmap_msgs/msg/VoxelBlock_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <cstdint>
#include <sstream>

namespace mlmap::dds::node {
namespace {

namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;
using TfMessage = ::tf2_msgs::msg::dds_::TFMessage_;

/// A QoS policy's name as DDS (and ROS 2's QoS messages) spell it.
std::string qosPolicyName(fdds::QosPolicyId_t id) {
  switch (id) {
    case fdds::DURABILITY_QOS_POLICY_ID:
      return "DURABILITY";
    case fdds::PRESENTATION_QOS_POLICY_ID:
      return "PRESENTATION";
    case fdds::DEADLINE_QOS_POLICY_ID:
      return "DEADLINE";
    case fdds::LATENCYBUDGET_QOS_POLICY_ID:
      return "LATENCY_BUDGET";
    case fdds::OWNERSHIP_QOS_POLICY_ID:
      return "OWNERSHIP";
    case fdds::LIVELINESS_QOS_POLICY_ID:
      return "LIVELINESS";
    case fdds::RELIABILITY_QOS_POLICY_ID:
      return "RELIABILITY";
    case fdds::DESTINATIONORDER_QOS_POLICY_ID:
      return "DESTINATION_ORDER";
    case fdds::DATAREPRESENTATION_QOS_POLICY_ID:
      return "DATA_REPRESENTATION";
    case fdds::DISABLEPOSITIVEACKS_QOS_POLICY_ID:
      return "DISABLE_POSITIVE_ACKS";
    default:
      return "QoS policy " + std::to_string(static_cast<int>(id));
  }
}

/// The awareness or the global layer, from the copies the engine's threads made.
class LayerCopyOutput : public OutputOperation {
 public:
  LayerCopyOutput(const CountedWriter& writer, LayerCopy LayerMailbox::News::*copy,
                  const std::string& world)
      : writer_(writer), copy_(copy), world_(world) {}
  void publish(const PublishRound& round) override {
    const LayerCopy& copy = round.news.*copy_;
    if (!copy.fresh) return;
    sensor_msgs::PointCloud2_ msg = encodePointCloud2(copy.points_W, nullptr, copy.stamp_s, world_);
    writer_.write(&msg);
  }

 private:
  CountedWriter writer_;
  LayerCopy LayerMailbox::News::*copy_;
  std::string world_;
};

/// rt/tf of each new snapshot: world -> body (tf_mode world_body), or world -> odom =
/// T_W_B * inverse(T_O_B) with T_O_B from the robot's own /tf at the pose's stamp (map_odom). A
/// stamp the robot's odometry has not reached yet is tried again for kOdomWait_s.
class TfOutput : public OutputOperation {
 public:
  /// How long a pose may wait for the robot's odom -> body at its stamp (wall time) [s].
  static constexpr double kOdomWait_s = 0.5;

  TfOutput(const CountedWriter& writer, const DdsConfig& dds, const TfListener* tf,
           CounterSink& counters, NodeLog& log)
      : writer_(writer),
        mode_(resolveTfMode(dds)),
        frames_(resolveFrames(dds)),
        tf_(tf),
        counters_(counters),
        log_(log) {}
  void publish(const PublishRound& round) override {
    if (!writer_ || !round.snap || round.snap->frame() == frame_) return;
    const double stamp_s = round.snap->stamp_s();
    TfMessage tf;
    if (mode_ == TfMode::kWorldBody) {
      tf.transforms_().push_back(
          toTransformStamped(round.snap->T_W_B(), stamp_s, frames_.world, frames_.body));
    } else {
      Transform T_O_B;
      const TfBuffer::Lookup found = tf_ == nullptr
                                         ? TfBuffer::Lookup::kUnknownFrame
                                         : tf_->lookup(frames_.odom, frames_.body, stamp_s, &T_O_B);
      if (found != TfBuffer::Lookup::kFound) {
        if (found == TfBuffer::Lookup::kNotYet && !round.last && mayWait(round.snap->frame())) {
          return;  // the robot's odometry may still come
        }
        frame_ = round.snap->frame();
        odomMissing(stamp_s, found);
        return;
      }
      const Transform T_W_O = round.snap->T_W_B() * T_O_B.inverse();
      tf.transforms_().push_back(toTransformStamped(T_W_O, stamp_s, frames_.world, frames_.odom));
    }
    frame_ = round.snap->frame();
    writer_.write(&tf);
  }

 private:
  /// True while the snapshot of `frame` may still wait for the robot's odometry.
  bool mayWait(std::uint64_t frame) {
    const Clock::time_point now = Clock::now();
    if (frame != waiting_frame_) {
      waiting_frame_ = frame;
      waiting_since_ = now;
    }
    return secondsBetween(waiting_since_, now) < kOdomWait_s;
  }
  void odomMissing(double stamp_s, TfBuffer::Lookup why) {
    counters_.add(&NodeCounters::tf_odom_missing);
    std::ostringstream m;
    m << "no " << frames_.world << " -> " << frames_.odom << " for the pose stamped " << std::fixed
      << stamp_s << ": the robot's " << frames_.odom << " -> " << frames_.body
      << " on /tf: " << toString(why);
    log_.limited(LogLevel::kWarning, kReasonTfMissing, m.str());
  }

  CountedWriter writer_;
  TfMode mode_;
  FrameNames frames_;
  const TfListener* tf_;
  CounterSink& counters_;
  NodeLog& log_;
  std::uint64_t frame_ = 0;
  std::uint64_t waiting_frame_ = 0;
  Clock::time_point waiting_since_;
};

/// The local window's occupied voxel centres.
std::vector<Eigen::Vector3f> occupiedCenters(const LocalWindow& window) {
  std::vector<Eigen::Vector3f> out;
  const Eigen::Vector3i& n = window.size;
  std::size_t i = 0;
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      for (int z = 0; z < n.z(); ++z, ++i) {
        if (window.model.state(window.log_odds[i]) == Occupancy::kOccupied) {
          out.push_back(voxelCenter(window.min_index + VoxelIndex(x, y, z), window.resolution_m)
                            .cast<float>());
        }
      }
    }
  }
  return out;
}

/// The local map's occupied voxels, of a new snapshot, at local_map_hz.
class LocalMapOutput : public OutputOperation {
 public:
  LocalMapOutput(const CountedWriter& writer, const DdsConfig& dds)
      : writer_(writer), gate_(dds.rates.local_map_hz), world_(dds.world_frame) {}
  void publish(const PublishRound& round) override {
    if (!writer_ || !round.snap || round.snap->frame() == frame_ || !(round.last || gate_.due()))
      return;
    gate_.mark();
    frame_ = round.snap->frame();
    sensor_msgs::PointCloud2_ msg = encodePointCloud2(occupiedCenters(round.snap->window()),
                                                      nullptr, round.snap->stamp_s(), world_);
    writer_.write(&msg);
  }

 private:
  CountedWriter writer_;
  RateGate gate_;
  std::string world_;
  std::uint64_t frame_ = 0;
};

/// The 2D grid, when the planning thread made a new one, at grid_hz.
class GridOutput : public OutputOperation {
 public:
  GridOutput(const CountedWriter& writer, const DdsConfig& dds)
      : writer_(writer), gate_(dds.rates.grid_hz), world_(dds.world_frame) {}
  void publish(const PublishRound& round) override {
    const auto& snap = round.snap;
    if (!writer_ || !snap || snap->gridPtr() == sent_ || snap->grid().cells.empty() ||
        !(round.last || gate_.due())) {
      return;
    }
    gate_.mark();
    sent_ = snap->gridPtr();
    nav_msgs::OccupancyGrid_ msg =
        toOccupancyGrid(snap->grid(), snap->grid().band_min_z_m, snap->stamp_s(), world_);
    writer_.write(&msg);
  }

 private:
  CountedWriter writer_;
  RateGate gate_;
  std::string world_;
  std::shared_ptr<const ProjectedGrid> sent_;  ///< held, so a new grid never reuses its address
};

/// The fixed-origin grid (a global costmap's static map): every new rolling grid is absorbed,
/// the grid goes out at map_grid_hz when it changed, and with the final state.
class MapGridOutput : public OutputOperation {
 public:
  MapGridOutput(const CountedWriter& writer, const DdsConfig& dds, NodeLog& log)
      : writer_(writer), gate_(dds.rates.map_grid_hz), world_(dds.world_frame), log_(log) {}
  void publish(const PublishRound& round) override {
    const auto& snap = round.snap;
    if (!writer_ || !snap) return;
    if (snap->gridPtr() != absorbed_ && !snap->grid().cells.empty()) {
      absorbed_ = snap->gridPtr();
      const std::uint64_t dropped = map_.cellsDropped();
      if (!map_.absorb(snap->grid())) {
        log_.limited(LogLevel::kWarning, kReasonMapGrid,
                     "map grid: a rolling grid of another resolution was not absorbed");
      } else if (map_.cellsDropped() > dropped) {
        log_.limited(LogLevel::kWarning, kReasonMapGrid,
                     "map grid: it reached its limit of " +
                         std::to_string(FixedOriginGrid::kDefaultMaxCells) + " cells; " +
                         std::to_string(map_.cellsDropped()) +
                         " known cells beyond it are not in it");
      }
    }
    if (map_.changes() == sent_changes_ || !(round.last || gate_.due())) return;
    gate_.mark();
    sent_changes_ = map_.changes();
    nav_msgs::OccupancyGrid_ msg =
        toOccupancyGrid(map_.grid(), map_.grid().band_min_z_m, snap->stamp_s(), world_);
    writer_.write(&msg);
  }

 private:
  CountedWriter writer_;
  RateGate gate_;
  std::string world_;
  NodeLog& log_;
  FixedOriginGrid map_;
  std::shared_ptr<const ProjectedGrid> absorbed_;  ///< held, so a new grid never reuses its address
  std::uint64_t sent_changes_ = 0;
};

/// The ESDF, when the planning thread made a new one, at esdf_hz: the whole block and a slice at
/// the body's height (+ esdf_slice_height_m).
class EsdfOutput : public OutputOperation {
 public:
  EsdfOutput(const CountedWriter& block, const CountedWriter& slice, const DdsConfig& dds)
      : block_(block),
        slice_(slice),
        gate_(dds.rates.esdf_hz),
        world_(dds.world_frame),
        slice_height_m_(dds.esdf_slice_height_m) {}
  void publish(const PublishRound& round) override {
    const auto& snap = round.snap;
    if (!snap || snap->esdf() == nullptr || snap->esdfPtr() == sent_ || snap->esdf()->empty() ||
        !(round.last || gate_.due())) {
      return;
    }
    gate_.mark();
    sent_ = snap->esdfPtr();
    if (block_) {
      mlmap_msgs::VoxelBlock_ block = toVoxelBlock(*snap->esdf(), snap->stamp_s(), world_);
      block_.write(&block);
    }
    if (slice_) {
      const double z_m = snap->T_W_B().translation().z() + slice_height_m_;
      sensor_msgs::PointCloud2_ slice = esdfSliceCloud(*snap->esdf(), z_m, snap->stamp_s(), world_);
      slice_.write(&slice);
    }
  }

 private:
  CountedWriter block_, slice_;
  RateGate gate_;
  std::string world_;
  double slice_height_m_;
  std::shared_ptr<const EsdfMap> sent_;  ///< held, so a new field never reuses its address
};

/// dds.fleet.publish: the submaps whose content (the vehicle's own evidence, fleet::ownEvidence())
/// changed since they last went out, from each collection of the global map's changes, the
/// window and the priors of the same frame.
class FleetOutput : public OutputOperation {
 public:
  FleetOutput(std::unique_ptr<SubmapWriter> writer, const Eigen::Vector3i& submap_cells,
              CounterSink& counters, NodeLog& log)
      : writer_(std::move(writer)), share_(submap_cells), counters_(counters), log_(log) {}
  void publish(const PublishRound& round) override {
    const FleetCopy& copy = round.news.fleet;
    if (!copy.fresh) return;
    fleet::GlobalMapDelta delta = copy.delta;
    const std::vector<fleet::SubmapUpdate> updates = share_.changes(
        std::move(delta), copy.snap ? &copy.snap->window() : nullptr, copy.priors.get());
    if (updates.empty()) return;
    const std::uint64_t failures = writer_->failures();
    const std::size_t bytes = writer_->write(updates, copy.snap ? copy.snap->stamp_s() : 0.0);
    const std::uint64_t failed = writer_->failures() - failures;
    counters_.add(&NodeCounters::fleet_submaps_sent, updates.size() - failed);
    counters_.add(&NodeCounters::fleet_bytes_sent, bytes);
    counters_.add(&NodeCounters::messages_published, updates.size() - failed);
    if (failed > 0) {
      log_.limited(LogLevel::kWarning, kReasonDds,
                   std::to_string(failed) + " submap samples could not be written on " +
                       writer_->get()->get_topic()->get_name());
    }
  }
  [[nodiscard]] eprosima::fastdds::dds::DataWriter* writer() const { return writer_->get(); }

 private:
  std::unique_ptr<SubmapWriter> writer_;
  fleet::SubmapShare share_;
  CounterSink& counters_;
  NodeLog& log_;
};

/// mlmap_msgs/Status at status_hz: the engine's statistics and the node's counters.
class StatusOutput : public OutputOperation {
 public:
  StatusOutput(const CountedWriter& writer, const DdsConfig& dds, const MapEngine& engine,
               const CounterSink& counters, Clock::time_point started)
      : writer_(writer),
        gate_(dds.rates.status_hz),
        world_(dds.world_frame),
        engine_(engine),
        counters_(counters),
        started_(started) {}
  void publish(const PublishRound& round) override {
    if (!writer_ || !(round.last || gate_.due())) return;
    gate_.mark();
    mlmap_msgs::Status_ status = message(round.snap ? round.snap->stamp_s() : 0.0);
    writer_.write(&status);
  }

 private:
  mlmap_msgs::Status_ message(double stamp_s) const {
    const EngineStats s = engine_.stats();
    const NodeCounters c = counters_.snapshot();
    mlmap_msgs::Status_ m;
    m.header_().stamp_(toRosTime(stamp_s));
    m.header_().frame_id_(world_);
    m.version_(3);
    m.uptime_s_(secondsBetween(started_, Clock::now()));
    m.frames_in_(s.frames_in);
    m.frames_mapped_(s.frames_mapped);
    m.frames_dropped_(s.frames_dropped + c.frames_handover_dropped);
    m.frames_rejected_(s.rejected_invalid_pose + s.rejected_out_of_order + s.rejected_empty +
                       s.rejected_bad_image);
    m.clouds_malformed_(c.inputs_malformed);
    m.clouds_without_pose_(c.frames_without_pose + c.frames_future + c.frames_across_pose_jump +
                           c.images_without_info);
    m.poses_rejected_(c.poses_rejected);
    m.points_rejected_(s.points.rejected_non_finite + s.points.rejected_too_close);
    m.awareness_median_ms_(s.awareness.median_ms);
    m.awareness_p99_ms_(s.awareness.p99_ms);
    m.local_global_median_ms_(s.local_global.median_ms);
    m.local_global_p99_ms_(s.local_global.p99_ms);
    m.total_median_ms_(s.total.median_ms);
    m.total_p99_ms_(s.total.p99_ms);
    m.esdf_last_ms_(s.planning.last_esdf_ms);
    m.awareness_bytes_(s.memory.awareness_bytes);
    m.local_bytes_(s.memory.local_bytes);
    m.global_bytes_(s.memory.global_bytes);
    m.planning_bytes_(s.memory.planning_bytes);
    m.global_voxels_(s.global_voxels);
    m.frames_unexpected_frame_id_(c.frames_unexpected_frame_id);
    m.frames_unresolved_frame_id_(c.frames_unresolved_frame_id);
    m.odometry_child_frame_mismatch_(c.odometry_child_frame_mismatch);
    m.tf_odom_missing_(c.tf_odom_missing);
    m.hits_beyond_local_map_(s.points.hits_beyond_local_map);
    m.hits_outside_window_(s.local.hits_outside_window);
    m.hits_to_global_map_(s.hits_to_global);
    m.hits_lost_(s.hits_lost);
    return m;
  }

  CountedWriter writer_;
  RateGate gate_;
  std::string world_;
  const MapEngine& engine_;
  const CounterSink& counters_;
  Clock::time_point started_;
};

}  // namespace

void CountedWriter::write(void* msg) const {
  if (writer_ == nullptr) return;
  if (writer_->write(msg)) {
    counters_->add(&NodeCounters::messages_published);
  } else {
    log_->limited(LogLevel::kWarning, kReasonDds,
                  "a DDS write failed on " + writer_->get_topic()->get_name());
  }
}

void IncompatibleQosListener::on_offered_incompatible_qos(
    fdds::DataWriter* writer, const fdds::OfferedIncompatibleQosStatus& status) {
  std::string offered;
  if (status.last_policy_id == fdds::DURABILITY_QOS_POLICY_ID) {
    offered = writer->get_qos().durability().kind == fdds::VOLATILE_DURABILITY_QOS
                  ? ", this writer offers VOLATILE"
                  : ", this writer offers TRANSIENT_LOCAL";
  }
  report_(writer->get_topic()->get_name() +
          ": a subscriber requests a QoS this writer does not offer (" +
          qosPolicyName(status.last_policy_id) + offered + "); it receives nothing");
}

std::set<std::pair<std::string, std::string>> Outputs::ownEdges(const DdsConfig& dds) {
  const FrameNames f = resolveFrames(dds);
  std::set<std::pair<std::string, std::string>> edges;
  const TfMode mode = resolveTfMode(dds);
  if (mode == TfMode::kWorldBody) edges.insert({f.world, f.body});
  if (mode == TfMode::kMapOdom) edges.insert({f.world, f.odom});
  if (dds.publish_sensor_tf) edges.insert({f.body, f.sensor});
  return edges;
}

Outputs::Outputs(fdds::Publisher* publisher, const DdsConfig& dds, const Transform& T_B_S,
                 const TfListener* tf_listener, MapEngine& engine, LayerMailbox& mailbox,
                 CounterSink& counters, NodeLog& log, Clock::time_point started)
    : mailbox_(mailbox),
      engine_(engine),
      log_(log),
      qos_listener_([&counters, &log](const std::string& what) {
        counters.add(&NodeCounters::subscribers_incompatible);
        log.limited(LogLevel::kWarning, kReasonQos, what);
      }) {
  using CloudType = CloudSamplePubSubType;  // one PointCloud2 type per participant
  using TfType = ::tf2_msgs::msg::dds_::TFMessage_PubSubType;
  const TopicNames& n = dds.topics;
  const PublishRates& r = dds.rates;
  // A writer on `name` when `rate_hz` publishes at all.
  auto writer = [&](auto type, const std::string& name, double rate_hz,
                    const fdds::DataWriterQos& qos) {
    using PubSubType = decltype(type);
    fdds::DataWriter* w =
        (name.empty() || rate_hz <= 0)
            ? nullptr
            : createWriter<PubSubType>(publisher, ddsTopicName(dds.ns, name), qos, &qos_listener_);
    return CountedWriter(w, counters, log);
  };
  // tf and tf_static are absolute, as tf2 listens to them: a namespace does not apply.
  auto tf_writer = [&](const char* name, bool on, const fdds::DataWriterQos& qos) {
    fdds::DataWriter* w =
        on ? createWriter<TfType>(publisher, ddsTopicName("", name), qos, &qos_listener_) : nullptr;
    return CountedWriter(w, counters, log);
  };
  const CountedWriter tf =
      tf_writer("tf", resolveTfMode(dds) != TfMode::kNone, reliableWriterQos(100));
  const CountedWriter tf_static = tf_writer("tf_static", dds.publish_sensor_tf, latchedWriterQos());
  const CountedWriter awareness =
      writer(CloudType(), n.awareness, r.awareness_hz, reliableWriterQos(2));
  const CountedWriter local =
      writer(CloudType(), n.local_map, r.local_map_hz, reliableWriterQos(2));
  const CountedWriter global =
      writer(CloudType(), n.global_map, r.global_map_hz, latchedWriterQos());
  const CountedWriter grid =
      writer(nav_msgs::OccupancyGrid_PubSubType(), n.grid, r.grid_hz, latchedWriterQos());
  const CountedWriter map_grid =
      writer(nav_msgs::OccupancyGrid_PubSubType(), n.map_grid, r.map_grid_hz, latchedWriterQos());
  const CountedWriter slice = writer(CloudType(), n.esdf_slice, r.esdf_hz, reliableWriterQos(2));
  const CountedWriter block =
      writer(mlmap_msgs::VoxelBlock_PubSubType(), n.esdf_block, r.esdf_hz, reliableWriterQos(2));
  const CountedWriter status =
      writer(mlmap_msgs::Status_PubSubType(), n.status, r.status_hz, reliableWriterQos(10));
  has_global_ = static_cast<bool>(global);
  writers_ = {global.get(), grid.get(),      map_grid.get(),  local.get(), status.get(),
              tf.get(),     tf_static.get(), awareness.get(), block.get(), slice.get()};

  operations_.push_back(std::make_unique<LayerCopyOutput>(awareness, &LayerMailbox::News::awareness,
                                                          dds.world_frame));
  operations_.push_back(
      std::make_unique<LayerCopyOutput>(global, &LayerMailbox::News::global, dds.world_frame));
  operations_.push_back(std::make_unique<TfOutput>(tf, dds, tf_listener, counters, log));
  operations_.push_back(std::make_unique<LocalMapOutput>(local, dds));
  operations_.push_back(std::make_unique<GridOutput>(grid, dds));
  operations_.push_back(std::make_unique<MapGridOutput>(map_grid, dds, log));
  operations_.push_back(std::make_unique<EsdfOutput>(block, slice, dds));
  operations_.push_back(std::make_unique<StatusOutput>(status, dds, engine, counters, started));
  if (dds.fleet.publish) {
    const LocalMapConfig& lm = engine.config().local_map;
    auto fleet = std::make_unique<FleetOutput>(
        std::make_unique<SubmapWriter>(publisher, dds.fleet.topic, resolveFleetVehicle(dds),
                                       SubmapGeometry{lm.resolution_m, lm.submap_cells()},
                                       dds.world_frame),
        lm.submap_cells(), counters, log);
    writers_.push_back(fleet->writer());
    operations_.push_back(std::move(fleet));
    has_fleet_ = true;
  }

  if (tf_static) {  // the sensor's mounting, latched for late joiners
    const FrameNames f = resolveFrames(dds);
    TfMessage mounting;
    mounting.transforms_().push_back(toTransformStamped(T_B_S, 0.0, f.body, f.sensor));
    tf_static.write(&mounting);
  }
}

Outputs::~Outputs() { finish(); }

void Outputs::start() {
  thread_ = std::thread([this] { publishLoop(); });
}

void Outputs::publishLoop() {
  for (bool last = false; !last;) {
    PublishRound round;
    round.news = mailbox_.take(kPoll);
    round.last = last = round.news.last;
    round.snap = engine_.snapshot();
    for (const auto& operation : operations_) operation->publish(round);
  }
}

void Outputs::finish() {
  if (finished_) return;
  finished_ = true;
  mailbox_.close();
  if (thread_.joinable()) thread_.join();  // publishes the final state once
  waitForAcknowledgments();
}

void Outputs::waitForAcknowledgments() {
  const Clock::time_point deadline = Clock::now() + kShutdownAckWait;
  for (fdds::DataWriter* w : writers_) {
    if (w == nullptr) continue;
    const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - Clock::now());
    if (left.count() <= 0) break;
    const auto s = std::chrono::duration_cast<std::chrono::seconds>(left);
    if (w->wait_for_acknowledgments(
            eprosima::fastrtps::Duration_t(static_cast<std::int32_t>(s.count()),
                                           static_cast<std::uint32_t>((left - s).count()))) !=
        eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
      log_.limited(
          LogLevel::kWarning, kReasonDds,
          "shutdown: " + w->get_topic()->get_name() + " not acknowledged by every reader in time");
    }
  }
}

}  // namespace mlmap::dds::node
