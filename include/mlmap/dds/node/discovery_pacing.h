#pragma once
/// @file
/// Lets a participant that just appeared see this participant's endpoints within milliseconds
/// instead of up to a few seconds.
///
/// When Fast DDS 2.9 discovers a new participant it answers with its own announcement (DATA(p))
/// and, a fraction of a millisecond later, a heartbeat of each built-in endpoint-discovery writer.
/// A peer that drops that heartbeat gets the next one only after the built-in writers' heartbeat
/// period (1 s, not configurable in 2.9), so a one-shot `ros2 topic info` (0.5 s) would often
/// miss this participant's endpoints. Two causes, two measures:
/// - A participant that has only just been created is often not ready for the heartbeat. Fast DDS
///   calls the participant listener's on_participant_discovery before it answers a new
///   participant; pausing there for kReplyDelay gives the newcomer that time. Measured against
///   mlmap_node on loopback: new Fast DDS 2.9 participants saw the writers after 0.5-2.7 s in 6 of
///   20 runs without the pause, within 42 ms in 20 of 20 with it.
/// - A Cyclone DDS peer (rmw_cyclonedds_cpp) drops a heartbeat of a writer it does not know yet,
///   and it learns of this participant's writers from the DATA(p) that arrives just before the
///   heartbeat, on another of its threads; its first ACKNACK after that (base 1, no bits) is not
///   one Fast DDS 2.9 answers with a heartbeat. So for a peer of another vendor the pacing has
///   this participant announce itself during the pause, by changing a counter in its USER_DATA
///   (`...;announcement=N;`, after the `enclave=` that ROS 2 reads): the peer knows the writers
///   when the heartbeat comes. Measured with tests/dds/discovery_latency.sh's Cyclone peers: over
///   0.1 s in 6 of 40 runs (up to 0.73 s) without it, 0 of 70 (max 28 ms) with it.

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

namespace mlmap::dds {

/// The participant listener that paces Fast DDS's answer to new participants and announces the
/// participant early to peers of other vendors (file comment). It becomes the participant's
/// listener; delete it before the participant (the destructor removes it).
class DiscoveryPacing : public eprosima::fastdds::dds::DomainParticipantListener {
 public:
  /// How long the answer to a new participant waits: far below what a person or a one-shot
  /// command notices, and long enough for a newly created participant to be ready.
  static constexpr std::chrono::milliseconds kReplyDelay{10};
  /// The USER_DATA key whose value counts the early announcements.
  static constexpr const char* kAnnouncementKey = "announcement";

  /// Takes over `participant`'s listener (discovery callbacks only). `publishers`, when given,
  /// hears every publisher discovery (the participant's listener until now, e.g.
  /// SubmapReaders::discoveryListener()); it must outlive this.
  explicit DiscoveryPacing(eprosima::fastdds::dds::DomainParticipant* participant,
                           std::chrono::milliseconds delay = kReplyDelay,
                           eprosima::fastdds::dds::DomainParticipantListener* publishers = nullptr);
  ~DiscoveryPacing() override;
  DiscoveryPacing(const DiscoveryPacing&) = delete;
  DiscoveryPacing& operator=(const DiscoveryPacing&) = delete;

  void on_participant_discovery(eprosima::fastdds::dds::DomainParticipant* participant,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override;
  void on_publisher_discovery(eprosima::fastdds::dds::DomainParticipant* participant,
                              eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override;

 private:
  /// The announcing thread: announces whenever asked, until the pacing is deleted.
  void run();
  /// Publishes the participant's USER_DATA with the next announcement count: Fast DDS sends its
  /// DATA(p) at once to every known participant and to its initial peers.
  void announce(std::uint64_t count);

  eprosima::fastdds::dds::DomainParticipant* participant_;
  std::chrono::milliseconds delay_;
  eprosima::fastdds::dds::DomainParticipantListener* publishers_;
  std::string user_data_;  ///< the participant's USER_DATA at construction (`enclave=...;`)

  std::mutex mutex_;
  std::condition_variable wake_;
  bool asked_ = false;  ///< a peer of another vendor appeared since the last announcement
  bool stopping_ = false;
  std::uint64_t announcements_ =
      0;                ///< made so far: the USER_DATA counter (peers close together share one)
  std::thread thread_;  ///< last: started when everything above exists
};

}  // namespace mlmap::dds
