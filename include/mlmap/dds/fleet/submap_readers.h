#pragma once
/// @file
/// Readers of the fleet's submaps: one reader per vehicle topic rt/<vehicle>/<topic>
/// (vehicleSubmapTopic()), so every sample arrives with the vehicle its topic belongs to. Under
/// DDS Security a vehicle's permissions let it publish its own topic only, so the topic is the
/// publisher's authenticated identity, and a sample whose name differs from it is refused
/// (docs/fleet.md#trust). Used by mlmap_fleet's merger and by mlmap_node's prior knowledge.
///
/// Which topics are read: the listed vehicles' (a closed fleet: every other topic is never
/// matched), or, with no list, each vehicle topic discovery finds (a DomainParticipantListener
/// given to the participant when it is created), up to a bound; entities are never created on
/// Fast DDS's discovery thread, but on a thread of this class.

#include "mlmap/dds/transport/entities.h"

#include "mlmap_msgs/msg/Submap_.h"

#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace mlmap::dds {

/// Which vehicles' submap topics to read.
struct SubmapReadersConfig {
  std::string topic = "mlmap/submaps";  ///< each vehicle's topic under its name
  /// Read exactly these vehicles' topics. Empty: every vehicle topic discovery finds.
  std::vector<std::string> vehicles;
  std::string own_vehicle;  ///< never read (a node's own submaps); "" for none
  /// Discovered vehicle topics read at most; later ones are ignored and counted.
  std::size_t max_discovered = 128;
};

/// The readers. Create it, create the participant with discoveryListener(), then start() with a
/// subscriber of that participant; stop() before the participant is deleted, and delete this
/// after it (the readers' listeners live here).
class SubmapReaders {
 public:
  /// A sample and the vehicle whose topic it came on (Fast DDS's listener thread).
  using Sink =
      std::function<void(const std::string& topic_vehicle, ::mlmap_msgs::msg::dds_::Submap_&& msg,
                         const eprosima::fastdds::dds::SampleInfo& info)>;

  /// `on_error`: a sample that failed to deserialise, with why; `on_matched`: the number of
  /// writers matched over all readers, each time it changes. Throws std::invalid_argument for a
  /// listed name that is not a valid vehicle name (vehicleOfSubmapTopic()).
  SubmapReaders(SubmapReadersConfig config, Sink sink,
                std::function<void(const std::string&)> on_error,
                std::function<void(int)> on_matched = {});
  ~SubmapReaders();
  SubmapReaders(const SubmapReaders&) = delete;
  SubmapReaders& operator=(const SubmapReaders&) = delete;

  /// The listener to create the participant with (discovers vehicle topics); nullptr with a
  /// list of vehicles. Outlives the participant with this object.
  [[nodiscard]] eprosima::fastdds::dds::DomainParticipantListener* discoveryListener();
  /// Creates the listed vehicles' readers now (throws std::runtime_error when one cannot be
  /// created), and, with no list, the discovered ones from now on, on a thread of its own.
  void start(eprosima::fastdds::dds::Subscriber* subscriber);
  /// Ends the thread (no more readers are created). Idempotent.
  void stop();

  /// The vehicles whose topics are read.
  [[nodiscard]] std::vector<std::string> vehicles() const;
  /// Discovered vehicle topics not read: beyond max_discovered, or whose reader could not be
  /// created.
  [[nodiscard]] std::uint64_t topicsIgnored() const;

 private:
  class Discovery;
  void found(const std::string& vehicle);
  void createLoop();
  void addReader(const std::string& vehicle);
  void matched(std::size_t reader, int count);

  SubmapReadersConfig config_;
  Sink sink_;
  std::function<void(int)> on_matched_;
  std::unique_ptr<Discovery> discovery_;
  std::unique_ptr<TakeReaders> readers_;

  mutable std::mutex mutex_;  // guards the members below
  std::condition_variable wake_;
  std::set<std::string> known_;       // read or queued
  std::vector<std::string> pending_;  // discovered, reader not created yet
  std::vector<std::string> read_;     // readers created, in order
  std::vector<int> matched_;          // per reader
  std::uint64_t ignored_ = 0;
  bool stopping_ = false;
  std::thread thread_;
  std::function<void(const std::string&)> on_error_;
};

}  // namespace mlmap::dds
