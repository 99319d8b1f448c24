#include "mlmap/dds/mapping_node.h"

#include "mlmap/dds/cloud_sample.h"
#include "mlmap/dds/entities.h"
#include "mlmap/dds/ros_conversions.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "mlmap_msgs/msg/Status_PubSubTypes.h"
#include "mlmap_msgs/msg/VoxelBlock_PubSubTypes.h"
#include "nav_msgs/msg/OccupancyGrid_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"


#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <iomanip>
#include <mutex>
#include <sstream>
#include <thread>
#include <variant>

namespace mlmap::dds {

PoseBufferConfig poseBufferConfig(const DdsConfig& dds) {
  PoseBufferConfig config;
  config.tolerance_s = dds.pose_tolerance_s;
  config.horizon_s = dds.pose_buffer_s;
  config.max_future_s = dds.max_future_s;
  config.max_speed_mps = dds.max_pose_speed_mps;
  config.max_rotation_rate_dps = dds.max_pose_rotation_rate_dps;
  return config;
}

namespace fdds = eprosima::fastdds::dds;
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t kMaxQueuedFrames = 3;    // clouds / images waiting for the input thread
constexpr std::size_t kMaxQueuedOther = 1000;  // poses, camera infos
constexpr std::size_t kMaxPendingFrames = 8;   // decoded frames waiting for their pose
constexpr double kPoseWait_s = 0.5;            // wall time a frame may wait for its pose
// The publishing thread wakes when the engine announces a snapshot or a layer copy; this poll
// only serves the rate gates (status, a gated layer whose period ran out) and the ESDF the
// planning thread republishes.
constexpr std::chrono::milliseconds kPublishPoll{20};
// On shutdown, how long the reliable writers may wait for their readers to acknowledge the final
// state (a lost sample is repaired only while the participant lives).
constexpr std::chrono::milliseconds kShutdownAckWait{2000};

// Log reasons (one line per reason and second).
enum Reason : int {
  kReasonMalformed,
  kReasonNoPose,
  kReasonFuture,
  kReasonJump,
  kReasonPose,
  kReasonNoInfo,
  kReasonHandover,
  kReasonEngine,
  kReasonDds,
  kReasonQos,
  kReasonCount
};

/// A QoS policy's name as DDS (and ROS 2's QoS messages) spell it.
std::string qosPolicyName(fdds::QosPolicyId_t id) {
  switch (id) {
    case fdds::DURABILITY_QOS_POLICY_ID: return "DURABILITY";
    case fdds::PRESENTATION_QOS_POLICY_ID: return "PRESENTATION";
    case fdds::DEADLINE_QOS_POLICY_ID: return "DEADLINE";
    case fdds::LATENCYBUDGET_QOS_POLICY_ID: return "LATENCY_BUDGET";
    case fdds::OWNERSHIP_QOS_POLICY_ID: return "OWNERSHIP";
    case fdds::LIVELINESS_QOS_POLICY_ID: return "LIVELINESS";
    case fdds::RELIABILITY_QOS_POLICY_ID: return "RELIABILITY";
    case fdds::DESTINATIONORDER_QOS_POLICY_ID: return "DESTINATION_ORDER";
    case fdds::DATAREPRESENTATION_QOS_POLICY_ID: return "DATA_REPRESENTATION";
    case fdds::DISABLEPOSITIVEACKS_QOS_POLICY_ID: return "DISABLE_POSITIVE_ACKS";
    default: return "QoS policy " + std::to_string(static_cast<int>(id));
  }
}

/// Reports each subscriber that a writer cannot serve because it requests more than the writer
/// offers (e.g. TRANSIENT_LOCAL of a VOLATILE layer): DDS then matches nothing and says nothing,
/// and the subscriber just never receives.
class IncompatibleQosListener : public fdds::DataWriterListener {
 public:
  explicit IncompatibleQosListener(std::function<void(const std::string&)> report)
      : report_(std::move(report)) {}
  void on_offered_incompatible_qos(fdds::DataWriter* writer,
                                   const fdds::OfferedIncompatibleQosStatus& status) override {
    std::string offered;
    if (status.last_policy_id == fdds::DURABILITY_QOS_POLICY_ID) {
      offered = writer->get_qos().durability().kind == fdds::VOLATILE_DURABILITY_QOS
                    ? ", this writer offers VOLATILE"
                    : ", this writer offers TRANSIENT_LOCAL";
    }
    report_(writer->get_topic()->get_name() + ": a subscriber requests a QoS this writer does not offer (" +
            qosPolicyName(status.last_policy_id) + offered + "); it receives nothing");
  }

 private:
  std::function<void(const std::string&)> report_;
};

double secondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// Publishes at most at `rate_hz` (0: never).
struct RateGate {
  double period_s = 0.0;
  bool enabled = false;
  Clock::time_point last = Clock::time_point::min();
  explicit RateGate(double rate_hz) : period_s(rate_hz > 0 ? 1.0 / rate_hz : 0.0), enabled(rate_hz > 0) {}
  [[nodiscard]] bool due() const {
    return enabled && (last == Clock::time_point::min() || secondsSince(last) >= period_s);
  }
  void mark() { last = Clock::now(); }
};

}  // namespace

struct MappingNode::Impl {
  // Messages as the listeners hand them over.
  using Input = std::variant<CloudSample, sensor_msgs::Image_, sensor_msgs::CameraInfo_,
                             geometry_msgs::PoseStamped_, nav_msgs::Odometry_>;
  using Frame = std::variant<PointCloudFrame, DepthFrame>;
  struct Pending {
    Frame frame;
    Clock::time_point since;
  };
  /// A layer copy made on an engine thread for the publishing thread.
  struct LayerCopy {
    std::vector<Eigen::Vector3f> points_W;
    double stamp_s = 0.0;
    bool fresh = false;
  };

  NodeConfig config;
  LogSink sink;  // unlimited: rare messages that must not be merged (map files)
  RateLimitedLog log;
  bool setup_done = false;  // the map is loaded (if asked) and the node runs: it may be saved
  Clock::time_point started = Clock::now();
  ParticipantPtr participant;
  std::unique_ptr<MapEngine> engine;
  PoseBuffer poses;
  Transform T_B_S;

  // Listeners must outlive their readers and writers: the participant is reset in stop().
  std::vector<std::unique_ptr<fdds::DataReaderListener>> listeners;
  IncompatibleQosListener writer_listener{[this](const std::string& what) {
    count(&NodeCounters::subscribers_incompatible);
    log.log(LogLevel::kWarning, kReasonQos, what);
  }};
  fdds::DataWriter* tf_writer = nullptr;
  fdds::DataWriter* tf_static_writer = nullptr;
  fdds::DataWriter* awareness_writer = nullptr;
  fdds::DataWriter* local_writer = nullptr;
  fdds::DataWriter* global_writer = nullptr;
  fdds::DataWriter* grid_writer = nullptr;
  fdds::DataWriter* esdf_slice_writer = nullptr;
  fdds::DataWriter* esdf_block_writer = nullptr;
  fdds::DataWriter* status_writer = nullptr;

  // Hand-over queue (listeners -> input thread).
  std::mutex input_mutex;
  std::condition_variable input_cv;
  std::deque<Input> inputs;
  std::size_t queued_frames = 0;
  bool stopping = false;

  // Input thread state.
  std::deque<Pending> pending;
  sensor_msgs::CameraInfo_ camera_info;
  bool have_camera_info = false;

  // Layer copies (engine threads -> publishing thread).
  std::mutex layer_mutex;
  std::condition_variable publish_cv;
  LayerCopy awareness_copy;
  LayerCopy global_copy;
  RateGate awareness_copy_gate;
  RateGate global_copy_gate;
  std::uint64_t global_version_copied = ~std::uint64_t{0};
  bool snapshot_fresh = false;  // the engine published a snapshot since the last look
  bool publish_stop = false;

  mutable std::mutex counters_mutex;
  NodeCounters counters;

  std::thread input_thread;
  std::thread publish_thread;

  // Periodic map saving (map_file.save_period_s).
  std::thread save_thread;
  std::mutex save_mutex;
  std::condition_variable save_cv;
  bool save_stop = false;
  std::atomic<bool> stopped{false};
  int domain_id = -1;

  Impl(const NodeConfig& c, const LogSink& sink_in)
      : config(c),
        sink(sink_in),
        log(sink_in, kReasonCount),
        poses(poseBufferConfig(c.dds)),
        T_B_S(c.map.sensor.T_B_S()),
        awareness_copy_gate(c.dds.rates.awareness_hz),
        global_copy_gate(c.dds.rates.global_map_hz) {}

  void count(std::uint64_t NodeCounters::*field, std::uint64_t n = 1) {
    std::lock_guard<std::mutex> lock(counters_mutex);
    counters.*field += n;
  }

  std::string topic(const std::string& name) const { return ddsTopicName(config.dds.ns, name); }

  // ---- Set-up ------------------------------------------------------------------------------
  template <typename PubSubType>
  fdds::DataWriter* makeWriter(fdds::Publisher* publisher, const std::string& name,
                               const fdds::DataWriterQos& qos) {
    return name.empty() ? nullptr : createWriter<PubSubType>(publisher, topic(name), qos, &writer_listener);
  }

  template <typename PubSubType, typename Msg>
  void makeReader(fdds::Subscriber* subscriber, const std::string& name) {
    if (name.empty()) return;
    auto listener = std::make_unique<TakeListener<Msg>>(
        [this](Msg&& msg) { handOver(Input(std::move(msg))); },
        [this](const std::string& what) {
          count(&NodeCounters::inputs_malformed);
          log.log(LogLevel::kWarning, kReasonMalformed, what);
        },
        // This reader's own count, so that the total follows current_count exactly.
        [this, dds_topic = topic(name), mine = std::int64_t{0}](int now) mutable {
          std::int64_t change = 0;
          {
            std::lock_guard<std::mutex> lock(counters_mutex);
            change = now - mine;
            mine = now;
            counters.publishers_matched =
                static_cast<std::uint64_t>(static_cast<std::int64_t>(counters.publishers_matched) + change);
          }
          if (change == 0) return;
          if (sink) {  // rare (discovery), so never rate-limited
            sink(LogLevel::kInfo, dds_topic + ": a publisher " + (change > 0 ? "matched" : "left") +
                                      " (" + std::to_string(now) + " now)");
          }
        });
    fdds::DataReaderQos qos = sensorReaderQos();
    if (!config.dds.data_sharing) qos.data_sharing().off();
    createReader<PubSubType>(subscriber, topic(name), qos, listener.get());
    listeners.push_back(std::move(listener));
  }

  void setUp() {
    MapConfig map_config = config.map;
    map_config.pipeline.threaded = true;  // Figure 5: the node always runs both stages threaded
    EngineObservers observers;
    observers.awareness = [this](const AwarenessMap& map, double stamp_s, const Transform&) {
      copyAwareness(map, stamp_s);
    };
    observers.global = [this](const GlobalMap& map, double stamp_s, std::uint64_t version) {
      copyGlobal(map, stamp_s, version);
    };
    observers.snapshot = [this](std::uint64_t, double) { announceSnapshot(); };
    engine = std::make_unique<MapEngine>(
        map_config, [this](LogLevel level, const std::string& m) { log.log(level, kReasonEngine, m); },
        std::move(observers));
    const bool loaded = loadMap();

    participant = createParticipant(config.dds, "mlmap_node");
    domain_id = static_cast<int>(participant->get_domain_id());
    fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    fdds::Subscriber* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    if (publisher == nullptr || subscriber == nullptr) {
      throw std::runtime_error("cannot create the DDS publisher / subscriber");
    }

    using CloudType = CloudSamplePubSubType;  // one PointCloud2 type per participant
    using TfType = ::tf2_msgs::msg::dds_::TFMessage_PubSubType;
    const TopicNames& n = config.dds.topics;
    const PublishRates& r = config.dds.rates;
    auto when = [](double rate_hz, const std::string& name) { return rate_hz > 0 ? name : std::string(); };
    tf_writer = makeWriter<TfType>(publisher, "tf", reliableWriterQos(100));
    tf_static_writer = makeWriter<TfType>(publisher, "tf_static", latchedWriterQos());
    awareness_writer = makeWriter<CloudType>(publisher, when(r.awareness_hz, n.awareness), reliableWriterQos(2));
    local_writer = makeWriter<CloudType>(publisher, when(r.local_map_hz, n.local_map), reliableWriterQos(2));
    global_writer = makeWriter<CloudType>(publisher, when(r.global_map_hz, n.global_map), latchedWriterQos());
    grid_writer = makeWriter<nav_msgs::OccupancyGrid_PubSubType>(publisher, when(r.grid_hz, n.grid), latchedWriterQos());
    esdf_slice_writer = makeWriter<CloudType>(publisher, when(r.esdf_hz, n.esdf_slice), reliableWriterQos(2));
    esdf_block_writer = makeWriter<mlmap_msgs::VoxelBlock_PubSubType>(publisher, when(r.esdf_hz, n.esdf_block), reliableWriterQos(2));
    status_writer = makeWriter<mlmap_msgs::Status_PubSubType>(publisher, when(r.status_hz, n.status), reliableWriterQos(10));

    makeReader<CloudType, CloudSample>(subscriber, n.cloud);
    makeReader<geometry_msgs::PoseStamped_PubSubType, geometry_msgs::PoseStamped_>(subscriber, n.pose);
    makeReader<nav_msgs::Odometry_PubSubType, nav_msgs::Odometry_>(subscriber, n.odometry);
    makeReader<sensor_msgs::Image_PubSubType, sensor_msgs::Image_>(subscriber, n.depth_image);
    makeReader<sensor_msgs::CameraInfo_PubSubType, sensor_msgs::CameraInfo_>(subscriber, n.camera_info);

    // The sensor's mounting, latched for late joiners.
    ::tf2_msgs::msg::dds_::TFMessage_ tf_static;
    tf_static.transforms_().push_back(toTransformStamped(T_B_S, 0.0, config.dds.body_frame,
                                                         config.dds.sensor_frame));
    tf_static_writer->write(&tf_static);

    if (loaded) {
      // The loaded map goes out at once: the latched global map and grid for late joiners.
      const std::shared_ptr<const MapSnapshot> snap = engine->snapshot();
      copyGlobal(engine->globalMap(), snap ? snap->stamp_s() : 0.0, 0, true);
      announceSnapshot();
    }
    input_thread = std::thread([this] { inputLoop(); });
    publish_thread = std::thread([this] { publishLoop(); });
    if (config.map_file.save_period_s > 0.0) save_thread = std::thread([this] { saveLoop(); });
    setup_done = true;
  }

  void logAlways(LogLevel level, const std::string& message) {
    if (sink) sink(level, message);
  }

  // ---- Map files (start, shutdown, periodic) -------------------------------------------------
  /// Loads map_file.load_path into the engine; false when there is nothing to load. Throws
  /// std::runtime_error naming the file when it cannot be used.
  bool loadMap() {
    const MapFileOptions& o = config.map_file;
    if (o.load_path.empty()) return false;
    if (o.load_missing_ok && !std::filesystem::exists(o.load_path)) {
      logAlways(LogLevel::kInfo, "no map at '" + o.load_path + "' yet: starting empty");
      return false;
    }
    const auto start = Clock::now();
    const MapState state = io::loadMapFile(o.load_path);
    io::checkMapMatchesConfig(state, config.map, o.load_path);
    engine->restoreState(state);
    std::ostringstream m;
    m << std::fixed << std::setprecision(1) << "loaded map '" << o.load_path << "' in "
      << secondsSince(start) * 1e3 << " ms: "
      << io::occupiedVoxels(state).size() << " occupied voxels (" << state.globalVoxelCount()
      << " in the global map), " << state.frames_mapped << " frames mapped before";
    logAlways(LogLevel::kInfo, m.str());
    return true;
  }

  /// Saves the engine's layers to map_file.save_path; logs the outcome, never throws.
  void saveMap(const char* why) {
    const std::string& path = config.map_file.save_path;
    try {
      const auto start = Clock::now();
      const MapState state = engine->exportState();
      io::saveMapFile(state, path);
      {
        std::lock_guard<std::mutex> lock(counters_mutex);
        ++counters.map_saves;
        counters.last_map_save_failed = false;
      }
      std::ostringstream m;
      m << std::fixed << std::setprecision(1) << why << ": saved the map to '" << path << "' in "
        << secondsSince(start) * 1e3 << " ms ("
        << state.frames_mapped << " frames mapped, " << state.globalVoxelCount()
        << " global voxels)";
      logAlways(LogLevel::kInfo, m.str());
    } catch (const std::exception& e) {
      {
        std::lock_guard<std::mutex> lock(counters_mutex);
        ++counters.map_saves_failed;
        counters.last_map_save_failed = true;
      }
      logAlways(LogLevel::kError, std::string(why) + ": map not saved (the previous file, if any, is "
                                                     "unchanged): " + e.what());
    }
  }

  void saveLoop() {
    const auto period = std::chrono::duration<double>(config.map_file.save_period_s);
    std::unique_lock<std::mutex> lock(save_mutex);
    while (!save_cv.wait_for(lock, period, [this] { return save_stop; })) {
      lock.unlock();
      saveMap("periodic save");
      lock.lock();
    }
  }

  // ---- Listener threads: hand over only ----------------------------------------------------
  void handOver(Input&& input) {
    const bool is_frame = std::holds_alternative<CloudSample>(input) ||
                          std::holds_alternative<sensor_msgs::Image_>(input);
    bool dropped = false;
    {
      std::lock_guard<std::mutex> lock(input_mutex);
      if (stopping) return;
      if (is_frame) {
        if (queued_frames >= kMaxQueuedFrames) {
          for (auto it = inputs.begin(); it != inputs.end(); ++it) {
            if (std::holds_alternative<CloudSample>(*it) ||
                std::holds_alternative<sensor_msgs::Image_>(*it)) {
              inputs.erase(it);
              --queued_frames;
              dropped = true;
              break;
            }
          }
        }
        ++queued_frames;
      } else if (inputs.size() - queued_frames >= kMaxQueuedOther) {
        return;  // the input thread is stalled; poses are worthless by then
      }
      inputs.push_back(std::move(input));
    }
    input_cv.notify_one();
    if (dropped) {
      count(&NodeCounters::frames_handover_dropped);
      log.log(LogLevel::kWarning, kReasonHandover,
              "input thread behind: dropped the oldest waiting cloud / image");
    }
  }

  // ---- Input thread: decode, pair with poses, submit ---------------------------------------
  void inputLoop() {
    std::vector<Eigen::Vector3f> scratch;
    for (;;) {
      Input input;
      {
        std::unique_lock<std::mutex> lock(input_mutex);
        input_cv.wait_for(lock, std::chrono::milliseconds(50),
                          [this] { return stopping || !inputs.empty(); });
        if (inputs.empty()) {
          if (stopping) break;
          lock.unlock();
          expirePending();
          continue;
        }
        input = std::move(inputs.front());
        inputs.pop_front();
        if (std::holds_alternative<CloudSample>(input) ||
            std::holds_alternative<sensor_msgs::Image_>(input)) {
          --queued_frames;
        }
      }
      std::visit([this](auto& msg) { handle(msg); }, input);
      expirePending();
    }
    // Shutting down: what still waits for a pose will not get one.
    if (!pending.empty()) count(&NodeCounters::frames_without_pose, pending.size());
    pending.clear();
  }

  void malformed(const char* what, const DecodeStatus& status) {
    count(&NodeCounters::inputs_malformed);
    log.log(LogLevel::kWarning, kReasonMalformed,
            std::string("rejected a malformed ") + what + ": " + toString(status.error) +
                (status.detail.empty() ? "" : " (" + status.detail + ")"));
  }

  void handle(CloudSample& msg) {
    count(&NodeCounters::clouds_received);
    if (msg.header_().stamp_().nanosec_() >= 1000000000u) {
      return malformed("PointCloud2", DecodeStatus{DecodeError::kBadStamp, "nanosec >= 1e9"});
    }
    if (!msg.status.ok()) return malformed("PointCloud2", msg.status);  // decoded when taken
    PointCloudFrame frame;
    frame.points_S = std::move(msg.points_S);
    frame.stamp_s = toSeconds(msg.header_().stamp_());
    frame.T_B_S = T_B_S;
    place(Frame(std::move(frame)));
  }

  void handle(sensor_msgs::Image_& msg) {
    count(&NodeCounters::images_received);
    if (!have_camera_info) {
      count(&NodeCounters::images_without_info);
      log.log(LogLevel::kWarning, kReasonNoInfo, "depth image before any valid CameraInfo: dropped");
      return;
    }
    if (msg.header_().stamp_().nanosec_() >= 1000000000u) {
      return malformed("depth Image", DecodeStatus{DecodeError::kBadStamp, "nanosec >= 1e9"});
    }
    DepthFrame frame;
    const DecodeStatus status = decodeDepthImage(msg, camera_info, &frame);
    if (!status.ok()) return malformed("depth Image", status);
    frame.stamp_s = toSeconds(msg.header_().stamp_());
    frame.T_B_S = T_B_S;
    place(Frame(std::move(frame)));
  }

  void handle(sensor_msgs::CameraInfo_& msg) {
    // Checked with each image it is used for (decodeDepthImage()): a bad one rejects those.
    camera_info = std::move(msg);
    have_camera_info = true;
  }

  /// PoseStamped or Odometry.
  template <typename PoseMsg>
  void handle(PoseMsg& msg) {
    double stamp_s = 0.0;
    Transform T_W_B;
    count(&NodeCounters::poses_received);
    const DecodeStatus status = decodePose(msg, &stamp_s, &T_W_B);
    if (!status.ok()) return malformed("pose", status);
    addPose(stamp_s, T_W_B);
  }

  void addPose(double stamp_s, const Transform& T_W_B) {
    const std::uint64_t restarts = poses.counters().restarts;
    const PoseBuffer::AddResult result = poses.add(stamp_s, T_W_B);
    if (result != PoseBuffer::AddResult::kAdded) {
      count(&NodeCounters::poses_rejected);
      const char* why = result == PoseBuffer::AddResult::kOutOfOrder ? "not newer than the last pose"
                        : result == PoseBuffer::AddResult::kFuture
                            ? "far ahead of the last pose (used if the next pose confirms it)"
                            : "not a valid pose";
      std::ostringstream m;
      m << "rejected a pose stamped " << std::fixed << stamp_s << ": " << why;
      log.log(LogLevel::kWarning, kReasonPose, m.str());
      return;
    }
    if (poses.counters().restarts > restarts) {
      std::ostringstream m;
      m << "the pose stream resumed after a pause: pairing restarts from the poses stamped "
        << std::fixed << poses.oldestStamp() << " and " << stamp_s;
      logAlways(LogLevel::kWarning, m.str());
    }
    // Frames waiting for this pose, in stamp order.
    while (!pending.empty()) {
      const PoseBuffer::LookupResult found = tryPlace(pending.front().frame);
      if (found == PoseBuffer::LookupResult::kPending) break;
      pending.pop_front();
    }
  }

  static double stampOf(const Frame& frame) {
    return std::visit([](const auto& f) { return f.stamp_s; }, frame);
  }

  /// Submits the frame when its pose is known; kPending leaves it to the caller.
  PoseBuffer::LookupResult tryPlace(Frame& frame) {
    Transform T_W_B;
    const double stamp_s = stampOf(frame);
    const PoseBuffer::LookupResult found = poses.lookup(stamp_s, &T_W_B);
    if (found == PoseBuffer::LookupResult::kFound) {
      std::visit([&](auto& f) { f.T_W_B = T_W_B; }, frame);
      const FrameStatus status = std::visit([&](auto& f) { return engine->submit(std::move(f)); }, frame);
      count(status == FrameStatus::kAccepted ? &NodeCounters::frames_submitted
                                             : &NodeCounters::frames_engine_rejected);
    } else if (found == PoseBuffer::LookupResult::kNoPose) {
      noPose(stamp_s);
    } else if (found == PoseBuffer::LookupResult::kAcrossJump) {
      count(&NodeCounters::frames_across_pose_jump);
      std::ostringstream m;
      m << "dropped a frame stamped " << std::fixed << stamp_s
        << ": the pose stream jumps around it (faster than " << poses.config().max_speed_mps
        << " m/s or " << poses.config().max_rotation_rate_dps << " deg/s), not interpolated";
      log.log(LogLevel::kWarning, kReasonJump, m.str());
    }
    return found;
  }

  void noPose(double stamp_s) {
    count(&NodeCounters::frames_without_pose);
    std::ostringstream m;
    m << "dropped a frame stamped " << std::fixed << stamp_s << ": no pose within "
      << config.dds.pose_tolerance_s << " s of it";
    log.log(LogLevel::kWarning, kReasonNoPose, m.str());
  }

  void place(Frame&& frame) {
    double newest = 0.0;
    const double stamp_s = stampOf(frame);
    if (poses.newestStamp(&newest) && stamp_s > newest + config.dds.max_future_s) {
      count(&NodeCounters::frames_future);
      std::ostringstream m;
      m << "dropped a frame stamped " << std::fixed << stamp_s << ": " << stamp_s - newest
        << " s after the newest pose";
      log.log(LogLevel::kWarning, kReasonFuture, m.str());
      return;
    }
    if (!pending.empty() || tryPlace(frame) == PoseBuffer::LookupResult::kPending) {
      if (!pending.empty() && stamp_s <= stampOf(pending.back().frame)) {
        // Waiting frames stay in stamp order; the engine would refuse this one anyway.
        count(&NodeCounters::frames_engine_rejected);
        return;
      }
      if (pending.size() >= kMaxPendingFrames) {
        noPose(stampOf(pending.front().frame));
        pending.pop_front();
      }
      pending.push_back({std::move(frame), Clock::now()});
      // A pose may already cover it (frames queued behind an earlier waiting one).
      while (!pending.empty() && tryPlace(pending.front().frame) != PoseBuffer::LookupResult::kPending) {
        pending.pop_front();
      }
    }
  }

  void expirePending() {
    while (!pending.empty() && secondsSince(pending.front().since) > kPoseWait_s) {
      noPose(stampOf(pending.front().frame));
      pending.pop_front();
    }
  }

  // ---- Engine threads: copy layers for the publishing thread -------------------------------
  void copyAwareness(const AwarenessMap& map, double stamp_s) {
    std::lock_guard<std::mutex> lock(layer_mutex);
    if (!awareness_copy_gate.due()) return;
    awareness_copy_gate.mark();
    awareness_copy.points_W.clear();
    AwarenessCell cell;
    for (const Eigen::Vector3d& p : map.occupiedPoints()) {
      if (map.cellOf(p, &cell)) awareness_copy.points_W.push_back(map.cellCenter(cell).cast<float>());
    }
    awareness_copy.stamp_s = stamp_s;
    awareness_copy.fresh = true;
    publish_cv.notify_one();
  }

  void copyGlobal(const GlobalMap& map, double stamp_s, std::uint64_t version, bool force = false) {
    std::lock_guard<std::mutex> lock(layer_mutex);
    if (version == global_version_copied || (!force && !global_copy_gate.due())) return;
    global_copy_gate.mark();
    global_version_copied = version;
    global_copy.points_W.clear();
    global_copy.points_W.reserve(map.voxelCount());
    const double res = map.resolution_m();
    map.forEachVoxel([&](const VoxelIndex& g, double) {
      global_copy.points_W.push_back(voxelCenter(g, res).cast<float>());
    });
    global_copy.stamp_s = stamp_s;
    global_copy.fresh = true;
    publish_cv.notify_one();
  }

  /// Wakes the publishing thread: a frame's snapshot is out (a flag and a notify, so mapping
  /// never waits for publishing).
  void announceSnapshot() {
    {
      std::lock_guard<std::mutex> lock(layer_mutex);
      snapshot_fresh = true;
    }
    publish_cv.notify_one();
  }

  /// Gives the readers up to kShutdownAckWait in all to acknowledge what was written, so that a
  /// final state lost on the way is sent again before the participant goes (on a loaded machine
  /// the end-to-end test once received no global map at all: 1 run in 6 with the static analysis
  /// beside it, none in 8 with this wait).
  void waitForAcknowledgments() {
    const Clock::time_point deadline = Clock::now() + kShutdownAckWait;
    for (fdds::DataWriter* w : {global_writer, grid_writer, local_writer, status_writer, tf_writer,
                                tf_static_writer, awareness_writer, esdf_block_writer, esdf_slice_writer}) {
      if (w == nullptr) continue;
      const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - Clock::now());
      if (left.count() <= 0) break;
      const auto s = std::chrono::duration_cast<std::chrono::seconds>(left);
      if (w->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(
              static_cast<std::int32_t>(s.count()), static_cast<std::uint32_t>((left - s).count()))) !=
          eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
        log.log(LogLevel::kWarning, kReasonDds,
                "shutdown: " + w->get_topic()->get_name() + " not acknowledged by every reader in time");
      }
    }
  }

  // ---- Publishing thread -------------------------------------------------------------------
  void write(fdds::DataWriter* writer, void* msg) {
    if (writer == nullptr) return;
    if (writer->write(msg)) {
      count(&NodeCounters::messages_published);
    } else {
      log.log(LogLevel::kWarning, kReasonDds, "a DDS write failed on " + writer->get_topic()->get_name());
    }
  }

  void publishLoop() {
    const PublishRates& r = config.dds.rates;
    RateGate local_gate(r.local_map_hz), grid_gate(r.grid_hz), esdf_gate(r.esdf_hz),
        status_gate(r.status_hz);
    std::uint64_t tf_frame = 0, local_frame = 0;
    std::shared_ptr<const ProjectedGrid> grid_sent;  // held, so a new one never reuses its address
    std::shared_ptr<const EsdfMap> esdf_sent;
    const std::string& world = config.dds.world_frame;
    for (bool last = false; !last;) {
      LayerCopy awareness, global;
      {
        std::unique_lock<std::mutex> lock(layer_mutex);
        publish_cv.wait_for(lock, kPublishPoll, [this] {
          return publish_stop || snapshot_fresh || awareness_copy.fresh || global_copy.fresh;
        });
        last = publish_stop;
        snapshot_fresh = false;
        if (awareness_copy.fresh) std::swap(awareness, awareness_copy);
        if (global_copy.fresh) std::swap(global, global_copy);
        awareness_copy.fresh = global_copy.fresh = false;
      }
      if (awareness.fresh) {
        sensor_msgs::PointCloud2_ msg = encodePointCloud2(awareness.points_W, nullptr, awareness.stamp_s, world);
        write(awareness_writer, &msg);
      }
      if (global.fresh) {
        sensor_msgs::PointCloud2_ msg = encodePointCloud2(global.points_W, nullptr, global.stamp_s, world);
        write(global_writer, &msg);
      }
      const std::shared_ptr<const MapSnapshot> snap = engine->snapshot();
      if (snap && snap->frame() != tf_frame) {
        tf_frame = snap->frame();
        ::tf2_msgs::msg::dds_::TFMessage_ tf;
        tf.transforms_().push_back(toTransformStamped(snap->T_W_B(), snap->stamp_s(), world,
                                                      config.dds.body_frame));
        write(tf_writer, &tf);
      }
      if (snap && snap->frame() != local_frame && (last || local_gate.due()) && local_writer) {
        local_gate.mark();
        local_frame = snap->frame();
        sensor_msgs::PointCloud2_ msg =
            encodePointCloud2(occupiedCenters(snap->window()), nullptr, snap->stamp_s(), world);
        write(local_writer, &msg);
      }
      if (snap && snap->gridPtr() != grid_sent && !snap->grid().cells.empty() &&
          (last || grid_gate.due()) && grid_writer) {
        grid_gate.mark();
        grid_sent = snap->gridPtr();
        const double z_m = snap->grid().band_min_z_m;
        nav_msgs::OccupancyGrid_ msg = toOccupancyGrid(snap->grid(), z_m, snap->stamp_s(), world);
        write(grid_writer, &msg);
      }
      if (snap && snap->esdf() != nullptr && snap->esdfPtr() != esdf_sent && !snap->esdf()->empty() &&
          (last || esdf_gate.due())) {
        esdf_gate.mark();
        esdf_sent = snap->esdfPtr();
        if (esdf_block_writer) {
          mlmap_msgs::VoxelBlock_ block = toVoxelBlock(*snap->esdf(), snap->stamp_s(), world);
          write(esdf_block_writer, &block);
        }
        if (esdf_slice_writer) {
          const double z_m = snap->T_W_B().translation().z() + config.dds.esdf_slice_height_m;
          sensor_msgs::PointCloud2_ slice = esdfSliceCloud(*snap->esdf(), z_m, snap->stamp_s(), world);
          write(esdf_slice_writer, &slice);
        }
      }
      if ((last || status_gate.due()) && status_writer) {
        status_gate.mark();
        mlmap_msgs::Status_ status = statusMessage(snap ? snap->stamp_s() : 0.0);
        write(status_writer, &status);
      }
    }
  }

  static std::vector<Eigen::Vector3f> occupiedCenters(const LocalWindow& window) {
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

  mlmap_msgs::Status_ statusMessage(double stamp_s) const {
    const EngineStats s = engine->stats();
    const NodeCounters c = snapshotCounters();
    mlmap_msgs::Status_ m;
    m.header_().stamp_(toRosTime(stamp_s));
    m.header_().frame_id_(config.dds.world_frame);
    m.version_(1);
    m.uptime_s_(secondsSince(started));
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
    return m;
  }

  NodeCounters snapshotCounters() const {
    std::lock_guard<std::mutex> lock(counters_mutex);
    return counters;
  }

  void stop() {
    if (stopped.exchange(true)) return;
    {
      std::lock_guard<std::mutex> lock(input_mutex);
      stopping = true;
    }
    input_cv.notify_all();
    if (input_thread.joinable()) input_thread.join();  // drains the hand-over queue
    {
      std::lock_guard<std::mutex> lock(save_mutex);
      save_stop = true;
    }
    save_cv.notify_all();
    if (save_thread.joinable()) save_thread.join();
    if (engine) {
      engine->flush();
      if (!config.map_file.save_path.empty() && setup_done) saveMap("shutdown");
      // The engine is idle now: hand over the global map's last state, whatever the rate limit.
      const EngineStats s = engine->stats();
      const std::shared_ptr<const MapSnapshot> snap = engine->snapshot();
      if (global_writer != nullptr && s.frames_mapped > 0) {
        copyGlobal(engine->globalMap(), snap ? snap->stamp_s() : 0.0,
                   s.local.submaps_retired + s.local.submaps_restored, true);
      }
    }
    {
      std::lock_guard<std::mutex> lock(layer_mutex);
      publish_stop = true;
    }
    publish_cv.notify_all();
    if (publish_thread.joinable()) publish_thread.join();  // publishes the final state once
    waitForAcknowledgments();
    // Readers first (their listeners die with us), then everything else.
    participant.reset();
    listeners.clear();
  }
};

MappingNode::MappingNode(const NodeConfig& config, const LogSink& log)
    : impl_((throwIfInvalid(config.dds.validate(), "dds configuration"),
             std::make_unique<Impl>(config, log))) {
  try {
    impl_->setUp();
  } catch (...) {
    impl_->stop();
    throw;
  }
}

MappingNode::~MappingNode() { stop(); }

void MappingNode::stop() { impl_->stop(); }

NodeCounters MappingNode::counters() const { return impl_->snapshotCounters(); }

EngineStats MappingNode::engineStats() const { return impl_->engine->stats(); }

std::shared_ptr<const MapSnapshot> MappingNode::snapshot() const { return impl_->engine->snapshot(); }

int MappingNode::domainId() const { return impl_->domain_id; }

}  // namespace mlmap::dds
