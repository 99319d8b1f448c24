#include "mlmap/dds/discovery_pacing.h"

#include <thread>

namespace mlmap::dds {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;

DiscoveryPacing::DiscoveryPacing(fdds::DomainParticipant* participant,
                                 std::chrono::milliseconds delay)
    : participant_(participant), delay_(delay) {
  participant_->set_listener(this, fdds::StatusMask::none());
}

DiscoveryPacing::~DiscoveryPacing() { participant_->set_listener(nullptr); }

void DiscoveryPacing::on_participant_discovery(fdds::DomainParticipant*,
                                               rtps::ParticipantDiscoveryInfo&& info) {
  if (info.status != rtps::ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT) return;
  std::this_thread::sleep_for(delay_);  // Fast DDS answers the new participant when this returns
}

}  // namespace mlmap::dds
