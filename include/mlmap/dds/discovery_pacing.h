#pragma once
/// @file
/// Lets a participant that just appeared see this participant's endpoints within milliseconds
/// instead of up to a few seconds.
///
/// When Fast DDS 2.9 discovers a new participant it answers at once with its own announcement
/// and, a fraction of a millisecond later, a heartbeat of each built-in endpoint-discovery writer.
/// A participant that has only just been created often drops that heartbeat (it has not finished
/// processing the announcement, or setting itself up), and Fast DDS sends the next one only after
/// its built-in writers' heartbeat period (1 s, not configurable in 2.9) or the peer's own
/// periodic traffic. Measured against mlmap_node on loopback: a new Fast DDS 2.9 participant saw
/// its writers after 0.5-2.7 s in 6 of 20 runs, a new Cyclone DDS one after 0.1-1 s in 5 of 20,
/// so a one-shot `ros2 topic info` (0.5 s) often missed them.
///
/// Fast DDS calls the participant listener's on_participant_discovery before it answers a new
/// participant. Pausing there for kReplyDelay gives the newcomer that time to get ready; the
/// answer then lands: Fast DDS peers saw the writers within 42 ms in 20 of 20 runs. What is left
/// for Cyclone DDS peers (3 of 20 runs still 0.4-0.75 s) comes from Fast DDS 2.9 taking Cyclone's
/// first ACKNACK (base 1, no bits) for a request of nothing and re-arming its 1 s heartbeat
/// (it recognises the pre-emptive form only with base 0): docs/dds-and-ros2.md.

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>

#include <chrono>

namespace mlmap::dds {

/// The participant listener that paces Fast DDS's answer to new participants (file comment).
/// It becomes the participant's listener; delete it after the participant is gone or after
/// removing it (the destructor removes it).
class DiscoveryPacing : public eprosima::fastdds::dds::DomainParticipantListener {
 public:
  /// How long the answer to a new participant waits: far below what a person or a one-shot
  /// command notices, and long enough for a newly created participant to be ready.
  static constexpr std::chrono::milliseconds kReplyDelay{10};

  /// Takes over `participant`'s listener (discovery callbacks only).
  explicit DiscoveryPacing(eprosima::fastdds::dds::DomainParticipant* participant,
                           std::chrono::milliseconds delay = kReplyDelay);
  ~DiscoveryPacing() override;
  DiscoveryPacing(const DiscoveryPacing&) = delete;
  DiscoveryPacing& operator=(const DiscoveryPacing&) = delete;

  void on_participant_discovery(eprosima::fastdds::dds::DomainParticipant* participant,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override;

 private:
  eprosima::fastdds::dds::DomainParticipant* participant_;
  std::chrono::milliseconds delay_;
};

}  // namespace mlmap::dds
