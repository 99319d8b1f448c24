#include "mlmap/dds/node/mapping_node.h"

#include "counter_sink.h"
#include "frame_pairer.h"
#include "input_queue.h"
#include "input_readers.h"
#include "layer_mailbox.h"
#include "map_persistence.h"
#include "node_log.h"
#include "node_services.h"
#include "outputs.h"
#include "tf_listener.h"

#include "mlmap/dds/node/discovery_pacing.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/graph/ros_graph.h"
#include "mlmap/dds/fleet/submap_messages.h"
#include "mlmap/dds/fleet/submap_readers.h"

#include "mlmap_msgs/msg/Submap_PubSubTypes.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace mlmap::dds {

/// The node's name in the ROS 2 graph (`ros2 node list`), and its participant's name.
constexpr const char* kNodeName = "mlmap_node";

/// The node's parts, composed: the engine; its map file; the inputs (readers -> queue -> the
/// input thread's pairing); the outputs (layer mailbox -> the publishing thread's operations);
/// its place in the ROS 2 graph (ros_discovery_info, /rosout); its services (save, clear, the
/// read-only parameters); the counters and the log every part writes to.
struct MappingNode::Impl {
  NodeConfig config;
  NodeConfig effective;     ///< what the node runs with (effectiveNodeConfig): the parameters
  std::mutex rosout_mutex;  ///< guards rosout against its deletion in stop()
  std::unique_ptr<RosoutWriter> rosout;
  node::NodeLog log;
  node::CounterSink counters;
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
  node::LayerMailbox mailbox;
  std::unique_ptr<MapEngine> engine;
  std::unique_ptr<node::MapPersistence> persistence;
  ParticipantPtr participant;
  std::unique_ptr<DiscoveryInfoPublisher> graph;
  std::unique_ptr<DiscoveryPacing> pacing;  ///< new peers learn of the endpoints at once
  std::unique_ptr<node::TfListener> tf;     ///< rt/tf and rt/tf_static, when the config needs them
  std::unique_ptr<node::Outputs> outputs;
  node::InputQueue queue;
  std::unique_ptr<node::InputReaders> readers;
  std::unique_ptr<node::FramePairer> pairer;
  std::unique_ptr<node::NodeServices> services;
  /// dds.fleet.subscribe: the readers of the other vehicles' submaps (deleted after the
  /// participant, which deletes the readers first).
  std::unique_ptr<SubmapReaders> fleet_readers;
  std::string fleet_vehicle = resolveFleetVehicle(config.dds);  ///< this vehicle's name
  /// Set by ~/clear_map: the emptied global map goes out at once, whatever the rate limit.
  std::atomic<bool> force_global_publish{false};
  /// The frame of the last snapshot announced (local-global thread): the fleet's collection
  /// pairs the global map with the window of the same frame.
  std::atomic<std::uint64_t> last_snapshot_frame{0};
  std::thread input_thread;
  bool setup_done = false;  ///< the map is loaded (if asked) and the node runs: it may be saved
  std::uint64_t idle_global_version = 0;  ///< the global map's version handed over when idle
  static constexpr int kIdlePolls = 20;   ///< empty 50 ms polls of the input queue: idle
  int idle_polls = 0;                     ///< empty polls since the last input
  std::atomic<bool> stopped{false};
  int domain_id = -1;

  Impl(const NodeConfig& c, const LogSink& sink)
      : config(c),
        effective(effectiveNodeConfig(c)),
        log(teeToRosout(sink)),
        mailbox(c.dds.rates, c.dds.fleet.publish ? c.dds.fleet.rate_hz : 0.0) {}

  /// `sink`, and /rosout once the node has its writer there.
  LogSink teeToRosout(const LogSink& sink) {
    return [this, sink](LogLevel level, const std::string& message) {
      if (sink) sink(level, message);
      std::lock_guard<std::mutex> lock(rosout_mutex);
      if (rosout) rosout->write(level, message);
    };
  }

  void setUp() {
    // The participant first, so that the node's log lines from here on reach /rosout too.
    if (config.dds.fleet.subscribe) makeFleetReaders();
    participant = createParticipant(config.dds, kNodeName,
                                    fleet_readers ? fleet_readers->discoveryListener() : nullptr);
    domain_id = static_cast<int>(participant->get_domain_id());
    auto* publisher = participant->create_publisher(eprosima::fastdds::dds::PUBLISHER_QOS_DEFAULT);
    auto* subscriber =
        participant->create_subscriber(eprosima::fastdds::dds::SUBSCRIBER_QOS_DEFAULT);
    if (publisher == nullptr || subscriber == nullptr) {
      throw std::runtime_error("cannot create the DDS publisher / subscriber");
    }
    const std::string node_namespace = rosNodeNamespace(config.dds.ns);
    {
      auto writer =
          std::make_unique<RosoutWriter>(publisher, rosLoggerName(node_namespace, kNodeName));
      std::lock_guard<std::mutex> lock(rosout_mutex);
      rosout = std::move(writer);
    }
    graph = std::make_unique<DiscoveryInfoPublisher>(participant.get(), kNodeName, node_namespace);
    pacing = std::make_unique<DiscoveryPacing>(
        participant.get(), DiscoveryPacing::kReplyDelay,
        fleet_readers ? fleet_readers->discoveryListener() : nullptr);
    graph->announce({publisher}, {subscriber});

    logMemoryEstimate();
    warnIfRangeExceedsWindow();
    engine = makeEngine();
    persistence =
        std::make_unique<node::MapPersistence>(config.map_file, config.map, *engine, counters, log);
    const bool loaded = persistence->load();

    const Transform T_B_S = config.map.sensor.T_B_S();
    tf = std::make_unique<node::TfListener>(subscriber, config.dds,
                                            node::Outputs::ownEdges(config.dds), counters, log);
    outputs = std::make_unique<node::Outputs>(publisher, config.dds, T_B_S, tf.get(), *engine,
                                              mailbox, counters, log, started);
    pairer =
        std::make_unique<node::FramePairer>(config.dds, T_B_S, tf.get(), *engine, counters, log);
    readers = std::make_unique<node::InputReaders>(subscriber, config.dds, queue, counters, log);
    services = std::make_unique<node::NodeServices>(publisher, subscriber, node_namespace,
                                                    kNodeName, effective, *engine, *persistence,
                                                    log, [this] { force_global_publish = true; });
    if (fleet_readers) fleet_readers->start(subscriber);
    graph->announce({publisher}, {subscriber});  // the ROS graph learns of the new endpoints
    warnAboutMissingInputs(loaded);
    if (loaded) {
      // The loaded map goes out at once: the latched global map and grid for late joiners.
      const std::shared_ptr<const MapSnapshot> snap = engine->snapshot();
      mailbox.copyGlobal(engine->globalMap(), snap ? snap->stamp_s() : 0.0, 0, true);
      mailbox.announceSnapshot();
    }
    input_thread = std::thread([this] { inputLoop(); });
    outputs->start();
    persistence->startPeriodicSaves();
    services->start();
    setup_done = true;
  }

  /// What the configured layers will take, said before they are allocated; a warning when it
  /// is more than most of this machine's memory.
  void logMemoryEstimate() {
    const MemoryEstimate estimate = estimateMemory(config.map);
    log.always(LogLevel::kInfo, "memory of the configured layers (global map not included): " +
                                    describeMemory(estimate));
    const long pages = ::sysconf(_SC_PHYS_PAGES);
    const long page_bytes = ::sysconf(_SC_PAGE_SIZE);
    const double physical = pages > 0 && page_bytes > 0
                                ? static_cast<double>(pages) * static_cast<double>(page_bytes)
                                : 0.0;
    if (physical > 0.0 && static_cast<double>(estimate.total()) > 0.8 * physical) {
      log.always(LogLevel::kWarning,
                 "the configured layers need more than 80 % of this machine's " +
                     std::to_string(static_cast<long long>(physical / 1e6)) +
                     " MB: lower local_map.size_cells, or set esdf.box_size_m");
    }
  }

  /// The local window is centred on the body's submap (5 per axis): a hit more than 3 submaps
  /// from the body horizontally lies outside it wherever the body is in its submap (between 2
  /// submaps, horizontalReach_m(), and 3 it depends on where the body is); its occupied evidence
  /// goes to the global map, counted, and its free space is not mapped. A range beyond 3 submaps
  /// is said at start, with the window that would hold every hit in range.
  void warnIfRangeExceedsWindow() {
    const LocalMapConfig& lm = config.map.local_map;
    const double range_m = config.map.awareness.max_range_m;
    if (range_m <= 1.5 * lm.horizontalReach_m()) return;  // 3 submaps
    const int needed = lm.horizontalCellsForRange(range_m);
    std::ostringstream m;
    m << "awareness.max_range_m (" << range_m << " m) reaches beyond the local window: hits "
      << "farther than " << lm.horizontalReach_m() << " to " << 1.5 * lm.horizontalReach_m()
      << " m from the body (by where it is in its submap) go to the global map "
      << "without their free space (counted in the status: hits_to_global_map); "
      << "local_map.size_cells " << needed << " x " << needed << " horizontally holds the range";
    log.always(LogLevel::kWarning, m.str());
  }

  /// A configuration without a sensor or a pose topic is legal (a node that serves a loaded
  /// map) but rarely meant: it is said at start.
  void warnAboutMissingInputs(bool loaded) {
    const TopicNames& t = config.dds.topics;
    if (t.cloud.empty() && t.depth_image.empty()) {
      log.always(LogLevel::kWarning, std::string("no sensor topic is configured (dds.topics.cloud, "
                                                 "dds.topics.depth_image): the node maps nothing") +
                                         (loaded ? " and publishes the loaded map only" : ""));
    } else if (t.pose.empty() && t.odometry.empty()) {
      log.always(LogLevel::kWarning,
                 "no pose topic is configured (dds.topics.pose, dds.topics.odometry): every "
                 "frame will be dropped for want of a pose");
    }
  }

  /// The engine, both stages threaded (Figure 5), its layers copied into the mailbox.
  std::unique_ptr<MapEngine> makeEngine() {
    const MapConfig& map_config = effective.map;  // both stages threaded
    EngineObservers observers;
    observers.awareness = [this](const AwarenessMap& map, double stamp_s, const Transform&) {
      mailbox.copyAwareness(map, stamp_s);
    };
    observers.global = [this](const GlobalMap& map, double stamp_s, std::uint64_t version) {
      mailbox.copyGlobal(map, stamp_s, version, force_global_publish.exchange(false));
      if (config.dds.fleet.publish) shareWithFleet(map, false);
    };
    observers.snapshot = [this](std::uint64_t frame, double) {
      last_snapshot_frame = frame;
      mailbox.announceSnapshot();
    };
    // The ESDF, made on the planning thread after the snapshot, goes out as soon as it is made
    // (not at the publishing thread's next poll, up to 20 ms later).
    observers.esdf = [this](std::uint64_t, double) { mailbox.announceSnapshot(); };
    return std::make_unique<MapEngine>(
        map_config,
        [this](LogLevel level, const std::string& m) {
          log.limited(level, node::kReasonEngine, m);
        },
        std::move(observers));
  }

  /// dds.fleet.publish: hands the global map's changes, the window and the priors of the same
  /// frame to the fleet output (at fleet.rate_hz, or now with `force`). On the local-global thread,
  /// or on any thread with `force` while the engine is idle. Nothing before the first snapshot, nor
  /// while the engine's latest snapshot is not the one of `map`'s frame (the planning thread's).
  void shareWithFleet(const GlobalMap& map, bool force) {
    std::shared_ptr<const MapSnapshot> snap = engine ? engine->snapshot() : nullptr;
    if (!snap || snap->frame() == 0) return;
    if (!force && snap->frame() != last_snapshot_frame) return;
    mailbox.copyFleet(map, std::move(snap), engine->priors(), force);
  }

  /// dds.fleet.subscribe: readers of the other vehicles' submap topics, found by discovery; their
  /// samples go to the engine as prior knowledge (MapEngine::addPrior).
  void makeFleetReaders() {
    SubmapReadersConfig which;
    which.topic = config.dds.fleet.topic;
    which.own_vehicle = fleet_vehicle;
    fleet_readers = std::make_unique<SubmapReaders>(
        which,
        [this](const std::string& vehicle, ::mlmap_msgs::msg::dds_::Submap_&& msg,
               const eprosima::fastdds::dds::SampleInfo&) { takePrior(vehicle, msg); },
        [this](const std::string& what) {
          counters.add(&NodeCounters::fleet_samples_refused);
          log.limited(LogLevel::kWarning, node::kReasonFleet, what);
        });
  }

  /// Fast DDS's listener thread: checks another vehicle's submap (from the topic of
  /// `topic_vehicle`) and hands it to the engine.
  void takePrior(const std::string& topic_vehicle, const ::mlmap_msgs::msg::dds_::Submap_& msg) {
    // The name, the header and the grid first: a sample of another grid is refused before its
    // payload is decoded (a submap of up to 2^24 voxels).
    DecodedSubmap submap;
    std::string problem;
    if (msg.vehicle_() != topic_vehicle) problem = "named for another vehicle than its topic's";
    if (problem.empty()) problem = submapHeaderProblem(msg);
    const LocalMapConfig& lm = config.map.local_map;
    const Eigen::Vector3i cells(static_cast<int>(msg.size_x_()), static_cast<int>(msg.size_y_()),
                                static_cast<int>(msg.size_z_()));
    if (problem.empty() && (msg.resolution_() != lm.resolution_m || cells != lm.submap_cells())) {
      problem = "another voxel grid than this vehicle's";
    }
    if (problem.empty()) problem = decodeSubmapMessage(msg, &submap);
    if (!problem.empty()) {
      counters.add(&NodeCounters::fleet_samples_refused);
      log.limited(LogLevel::kWarning, node::kReasonFleet,
                  "fleet: a submap of '" + msg.vehicle_().substr(0, kMaxVehicleNameBytes) +
                      "' refused: " + problem);
      return;
    }
    counters.add(&NodeCounters::fleet_priors_received);
    engine->addPrior(submap.index, std::move(submap.records));
  }

  /// The input thread: takes what the listeners handed over, pairs it, submits it.
  void inputLoop() {
    for (;;) {
      std::optional<node::Input> input = queue.pop(std::chrono::milliseconds(50));
      if (!input) {
        if (queue.finished()) break;
        // A second without input (20 polls): the stream paused or ended.
        if (++idle_polls == kIdlePolls) {
          handOverIdleGlobalMap();
          if (outputs && outputs->sharesWithFleet()) {
            engine->flush();  // idle: what the rate held back goes out
            shareWithFleet(engine->globalMap(), true);
          }
        }
      } else {
        idle_polls = 0;
        pairer->handle(*input);
      }
      pairer->expireWaiting();
    }
    pairer->dropWaiting();
  }

  void stop() {
    if (stopped.exchange(true)) return;
    if (services) services->stop();  // no save or clear from here on
    queue.close();
    if (input_thread.joinable()) input_thread.join();  // drains the hand-over queue
    if (persistence) persistence->stopPeriodicSaves();
    if (engine) {
      engine->flush();
      if (!config.map_file.save_path.empty() && setup_done) persistence->save("shutdown");
      handOverFinalGlobalMap();
      if (outputs && outputs->sharesWithFleet()) shareWithFleet(engine->globalMap(), true);
    }
    if (outputs) outputs->finish();  // publishes the final state once, waits for the readers
    {
      std::lock_guard<std::mutex> lock(rosout_mutex);
      rosout.reset();  // from here on the log goes to the sink only
    }
    pacing.reset();  // the participant's listener, removed before the participant goes
    // Readers and writers first (their listeners die with the parts), then everything else.
    if (fleet_readers) fleet_readers->stop();  // no more readers created
    participant.reset();
    readers.reset();
    fleet_readers.reset();
    outputs.reset();
    services.reset();
    tf.reset();
  }

  /// No input for a while: the global map's changes that the rate limit held back (hits beyond
  /// the window change it in most frames) go out, once per change.
  void handOverIdleGlobalMap() {
    if (!engine || !outputs || !outputs->publishesGlobalMap()) return;
    engine->flush();  // the input thread is the only submitter: the engine is idle after it
    const std::uint64_t version = engine->globalMap().modifications();
    if (version == idle_global_version) return;
    idle_global_version = version;
    handOverFinalGlobalMap();
  }

  /// The engine is idle: the global map's last state goes out, whatever the rate limit.
  void handOverFinalGlobalMap() {
    const EngineStats s = engine->stats();
    if (!outputs || !outputs->publishesGlobalMap() || s.frames_mapped == 0) return;
    const std::shared_ptr<const MapSnapshot> snap = engine->snapshot();
    mailbox.copyGlobal(engine->globalMap(), snap ? snap->stamp_s() : 0.0,
                       engine->globalMap().modifications(), true);
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

NodeCounters MappingNode::counters() const { return impl_->counters.snapshot(); }

EngineStats MappingNode::engineStats() const { return impl_->engine->stats(); }

std::shared_ptr<const MapSnapshot> MappingNode::snapshot() const {
  return impl_->engine->snapshot();
}

int MappingNode::domainId() const { return impl_->domain_id; }

void MappingNode::log(LogLevel level, const std::string& message) const {
  impl_->log.always(level, message);
}

ServiceCounters MappingNode::serviceCounters() const {
  return impl_->services ? impl_->services->counters() : ServiceCounters{};
}

}  // namespace mlmap::dds
