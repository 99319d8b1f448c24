#pragma once
/// @file
/// The ground side of mlmap_node's layers: a participant that subscribes to every layer the
/// node's `dds:` configuration enables (the four PointCloud2 layers, the 2D grid, the ESDF block,
/// the status and, in tf_mode world_body, the trajectory on tf) and keeps the latest of each,
/// with per topic what arrived (messages, bytes, the age of each at arrival). What mlmap_inspect
/// watches; it needs Fast DDS and the wire types only.

#include "mlmap/core/stopwatch.h"
#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include "mlmap_msgs/msg/Status_.h"

#include <Eigen/Core>

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace mlmap::dds {

class TakeReaders;

/// What arrived on one topic.
struct TopicLog {
  std::uint64_t messages = 0;  ///< samples taken
  /// Data bytes: a cloud's data, a grid's cells, 4 per ESDF block value, the status's size in
  /// memory, 0 for tf.
  std::uint64_t bytes = 0;
  std::size_t last_points = 0;       ///< points / cells / voxels / transforms of the last sample
  SteadyClock::time_point first_at;  ///< arrival of the first sample
  SteadyClock::time_point last_at;   ///< arrival of the last sample
  /// Per stamped sample: the wall clock at arrival minus its header stamp [ms] (a zero stamp,
  /// ROS's "no time", gives none).
  std::vector<double> age_ms;
};

/// The latest sample of each layer and what arrived per topic, keyed by the topic's name as in
/// the configuration (e.g. "mlmap/grid"; "tf" for the trajectory).
struct ReceivedLayers {
  std::map<std::string, TopicLog> topics;     ///< topics that something arrived on
  std::vector<Eigen::Vector3f> local_W;       ///< the last local map's occupied voxel centres
  std::vector<Eigen::Vector3f> global_W;      ///< the last (latched) global map's voxel centres
  std::vector<Eigen::Vector3f> awareness_W;   ///< the last awareness frame's occupied cells
  std::vector<Eigen::Vector3f> esdf_slice_W;  ///< the last ESDF slice's voxel centres
  /// The last ESDF slice's distances [m], one per point of esdf_slice_W (the clouds' float32
  /// `intensity` at offset 12); empty when its point step is shorter than 16 bytes.
  std::vector<float> esdf_slice_distance_m;
  nav_msgs::OccupancyGrid_ grid;              ///< the last 2D grid (empty data_: none)
  mlmap_msgs::Status_ status;                 ///< the node's last status (zeros: none)
  std::vector<Eigen::Vector3d> trajectory_W;  ///< every body position received on tf, in order
  /// Samples dropped: malformed CDR, a PointCloud2 that does not decode, a grid whose data size
  /// is not width x height.
  std::uint64_t malformed = 0;
};

/// Of `names`, those nothing arrived on in `layers` (in their order).
[[nodiscard]] std::vector<std::string> missingOf(const ReceivedLayers& layers,
                                                 const std::vector<std::string>& names);

/// What the receiver reports as it happens, on Fast DDS's listener threads (keep them short).
struct LayerReceiverEvents {
  /// A reader's number of matched publishers changed (the node found, handshakes included).
  std::function<void(const std::string& topic, int publishers)> on_matched;
  /// A sample was dropped as malformed, and why.
  std::function<void(const std::string& what)> on_malformed;
};

/// How to subscribe.
struct LayerReceiverOptions {
  /// Subscribe as the ROS 2 ground-station bridge does over a radio link: BEST_EFFORT (depth 1)
  /// for the awareness, local map and ESDF slice, no ESDF block. Otherwise those are RELIABLE,
  /// depth 2.
  bool as_bridge = false;
  std::string participant_name = "mlmap_inspect";  ///< the participant's (and node's) name
};

/// Subscribes to the layers of the mlmap_node that `dds` configures (same domain, namespace,
/// topics, rates: a layer whose topic is empty or whose rate is 0 is not subscribed) and keeps
/// the latest of each. Thread-safe: listener threads write, any thread reads.
class LayerReceiver {
 public:
  /// Joins the domain and creates the readers.
  /// @throws std::runtime_error when the participant or a reader cannot be created.
  LayerReceiver(const DdsConfig& dds, LayerReceiverOptions options, LayerReceiverEvents events);
  /// close()s.
  ~LayerReceiver();
  LayerReceiver(const LayerReceiver&) = delete;
  LayerReceiver& operator=(const LayerReceiver&) = delete;

  /// The names of the layers subscribed, in subscription order: the awareness, local map, global
  /// map, ESDF slice, grid, ESDF block, status, tf (those enabled).
  [[nodiscard]] const std::vector<std::string>& subscribed() const { return subscribed_; }
  /// True once any reader matched a publisher (the node was discovered).
  [[nodiscard]] bool nodeFound() const { return node_found_.load(); }
  /// Of `names`, those nothing arrived on (in their order).
  [[nodiscard]] std::vector<std::string> missingOf(const std::vector<std::string>& names) const;
  /// The arrival of the newest sample on any topic; none before the first.
  [[nodiscard]] std::optional<SteadyClock::time_point> lastArrival() const;
  /// Per topic that something arrived on, the number of samples.
  [[nodiscard]] std::map<std::string, std::uint64_t> messageCounts() const;
  /// A copy of everything received so far.
  [[nodiscard]] ReceivedLayers snapshot() const;

  /// Deletes the participant, its readers and then their listeners: no more samples from here
  /// on. Idempotent.
  void close();
  /// close()s and hands over everything received (the receiver keeps nothing).
  [[nodiscard]] ReceivedLayers finish();

 private:
  /// Counts a sample of `bytes` bytes with `points` points on `name`, aged from `stamp`; call
  /// with mutex_ held.
  void note(const std::string& name, std::size_t bytes, std::size_t points,
            const ros_time::Time_& stamp);
  /// Counts a dropped sample and reports `what` (takes mutex_).
  void dropMalformed(const std::string& what);
  /// Adds a reader of `PubSubType` on `name` (in the namespace unless `absolute`).
  template <typename PubSubType>
  void add(const std::string& name, const eprosima::fastdds::dds::DataReaderQos& qos,
           std::function<void(typename PubSubType::type&&)> sink, bool absolute = false);
  /// The four PointCloud2 layers.
  void subscribeClouds(const DdsConfig& dds);
  /// The grid and (not as_bridge) the ESDF block.
  void subscribeGridAndEsdf(const DdsConfig& dds);
  /// The status and, in tf_mode world_body, tf.
  void subscribeStatusAndTf(const DdsConfig& dds);

  LayerReceiverOptions options_;
  LayerReceiverEvents events_;
  std::string ns_;  ///< the node's DDS namespace
  std::vector<std::string> subscribed_;
  std::atomic<bool> node_found_{false};
  mutable std::mutex mutex_;  ///< guards received_
  ReceivedLayers received_;
  // Declared in this order so that, destroyed in reverse, the participant (and its readers) goes
  // before the listeners the readers call.
  std::unique_ptr<TakeReaders> readers_;
  ParticipantPtr participant_;
};

}  // namespace mlmap::dds
