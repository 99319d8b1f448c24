#include "mlmap/dds/node/discovery_pacing.h"

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/rtps/common/VendorId_t.hpp>

#include <vector>

namespace mlmap::dds {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;

DiscoveryPacing::DiscoveryPacing(fdds::DomainParticipant* participant,
                                 std::chrono::milliseconds delay,
                                 fdds::DomainParticipantListener* publishers)
    : participant_(participant), delay_(delay), publishers_(publishers) {
  fdds::DomainParticipantQos qos;
  participant_->get_qos(qos);
  const std::vector<rtps::octet>& data = qos.user_data().data_vec();
  user_data_.assign(data.begin(), data.end());
  if (!user_data_.empty() && user_data_.back() != ';') user_data_ += ';';  // key=value; pairs
  thread_ = std::thread([this] { run(); });
  participant_->set_listener(this, fdds::StatusMask::none());
}

DiscoveryPacing::~DiscoveryPacing() {
  participant_->set_listener(nullptr);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void DiscoveryPacing::on_participant_discovery(fdds::DomainParticipant*,
                                               rtps::ParticipantDiscoveryInfo&& info) {
  if (info.status != rtps::ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT) return;
  if (info.info.m_VendorId != rtps::c_VendorId_eProsima) {
    // Not from here: Fast DDS holds locks of its discovery while it calls this listener.
    {
      std::lock_guard<std::mutex> lock(mutex_);
      asked_ = true;
    }
    wake_.notify_all();
  }
  std::this_thread::sleep_for(delay_);  // Fast DDS answers the new participant when this returns
}

void DiscoveryPacing::on_publisher_discovery(fdds::DomainParticipant* participant,
                                             rtps::WriterDiscoveryInfo&& info) {
  if (publishers_ != nullptr) publishers_->on_publisher_discovery(participant, std::move(info));
}

void DiscoveryPacing::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait(lock, [this] { return stopping_ || asked_; });
    if (stopping_) return;
    asked_ = false;
    const std::uint64_t count = ++announcements_;
    lock.unlock();
    announce(count);
    lock.lock();
  }
}

void DiscoveryPacing::announce(std::uint64_t count) {
  fdds::DomainParticipantQos qos;
  participant_->get_qos(qos);
  const std::string text = user_data_ + kAnnouncementKey + "=" + std::to_string(count) + ";";
  qos.user_data().data_vec(std::vector<rtps::octet>(text.begin(), text.end()));
  participant_->set_qos(qos);
}

}  // namespace mlmap::dds
