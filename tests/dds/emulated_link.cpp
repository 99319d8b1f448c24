#include "emulated_link.h"

#include "dds_test_support.h"

#include "mlmap/dds/transport/udp_send_guard.h"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/rtps/common/LocatorsIterator.hpp>
#include <fastdds/rtps/network/SenderResource.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>

#include <algorithm>
#include <utility>
#include <vector>

namespace mlmap::dds::test_support {
namespace {

namespace rtps = eprosima::fastdds::rtps;
namespace frtps = eprosima::fastrtps::rtps;

/// LocatorsIterator over a vector the delayed send owns.
class VectorLocators final : public rtps::LocatorsIterator {
 public:
  VectorLocators(const std::vector<frtps::Locator_t>& locators, std::size_t index)
      : locators_(&locators), index_(index) {}
  virtual ~VectorLocators() = default;
  VectorLocators(const VectorLocators&) = delete;
  VectorLocators& operator=(const VectorLocators&) = delete;
  LocatorsIterator& operator++() override {
    ++index_;
    return *this;
  }
  bool operator==(const LocatorsIterator& other) const override {
    return index_ == static_cast<const VectorLocators&>(other).index_;
  }
  bool operator!=(const LocatorsIterator& other) const override { return !(*this == other); }
  const frtps::Locator_t& operator*() const override { return (*locators_)[index_]; }

 private:
  const std::vector<frtps::Locator_t>* locators_;
  std::size_t index_;
};

/// Sends and receives through the link's two delay lines, the low-level UDPv4 transport below.
class EmulatedLinkTransport final : public rtps::ChainingTransport {
 public:
  explicit EmulatedLinkTransport(const EmulatedLinkTransportDescriptor& descriptor)
      : ChainingTransport(descriptor), link_(descriptor.link) {}

  rtps::TransportDescriptorInterface* get_configuration() override {
    return low_level_transport_->get_configuration();
  }

  bool send(frtps::SenderResource* low_sender_resource, const frtps::octet* send_buffer,
            uint32_t send_buffer_size, frtps::LocatorsIterator* destination_locators_begin,
            frtps::LocatorsIterator* destination_locators_end,
            const std::chrono::steady_clock::time_point& timeout) override {
    std::vector<frtps::Locator_t> to;
    for (frtps::LocatorsIterator& it = *destination_locators_begin; it != *destination_locators_end;
         ++it) {
      to.push_back(*it);
    }
    // The time a send may block, counted again from when the link hands the datagram on.
    const auto may_block = std::max(std::chrono::steady_clock::duration::zero(),
                                    timeout - std::chrono::steady_clock::now());
    auto deliver = [low_sender_resource,
                    data = std::vector<frtps::octet>(send_buffer, send_buffer + send_buffer_size),
                    to = std::move(to), may_block] {
      VectorLocators begin(to, 0);
      VectorLocators end(to, to.size());
      low_sender_resource->send(data.data(), static_cast<uint32_t>(data.size()), &begin, &end,
                                std::chrono::steady_clock::now() + may_block);
    };
    if (!link_->out().push(send_buffer_size, deliver)) deliver();
    return true;  // as a datagram socket: sent, whatever becomes of it on the way
  }

  void receive(rtps::TransportReceiverInterface* next_receiver, const frtps::octet* receive_buffer,
               uint32_t receive_buffer_size, const frtps::Locator_t& local_locator,
               const frtps::Locator_t& remote_locator) override {
    auto deliver =
        [next_receiver,
         data = std::vector<frtps::octet>(receive_buffer, receive_buffer + receive_buffer_size),
         local_locator, remote_locator] {
          next_receiver->OnDataReceived(data.data(), static_cast<uint32_t>(data.size()),
                                        local_locator, remote_locator);
        };
    if (!link_->in().push(receive_buffer_size, deliver)) deliver();
  }

 private:
  std::shared_ptr<EmulatedLink> link_;
};

}  // namespace

DelayLine::DelayLine(const LinkShape& shape)
    : shape_(shape), line_free_(Clock::now()), random_(shape.seed) {
  worker_ = std::thread([this] { run(); });
}

DelayLine::~DelayLine() { close(); }

bool DelayLine::push(std::size_t bytes, std::function<void()> deliver) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_) return false;
  if (down_) {
    ++stats_.lost_link_down;
    return true;
  }
  if (std::uniform_real_distribution<double>(0.0, 1.0)(random_) < shape_.loss_fraction) {
    ++stats_.lost_at_random;
    return true;
  }
  if (queued_bytes_ + bytes > shape_.queue_limit_bytes) {
    ++stats_.lost_queue_full;
    return true;
  }
  const Clock::time_point now = Clock::now();
  // The datagram leaves after the ones before it at the rate, then travels delay_s.
  const auto on_the_line = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(static_cast<double>(bytes) * 8.0 / shape_.rate_bit_s));
  line_free_ = std::max(line_free_, now) + on_the_line;
  const auto delay =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(shape_.delay_s));
  queue_.push_back(Datagram{bytes, now, line_free_ + delay, std::move(deliver)});
  queued_bytes_ += bytes;
  wake_.notify_one();
  return true;
}

void DelayLine::setDown(bool down) {
  std::lock_guard<std::mutex> lock(mutex_);
  down_ = down;
}

void DelayLine::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return;
    closed_ = true;
    queue_.clear();
    queued_bytes_ = 0;
  }
  wake_.notify_one();
  if (worker_.joinable()) worker_.join();
}

LinkDirectionStats DelayLine::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

void DelayLine::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!closed_) {
    if (queue_.empty()) {
      wake_.wait(lock);
      continue;
    }
    // Every datagram waits as long and leaves in order: the head is always due first.
    if (Clock::now() < queue_.front().due) {
      wake_.wait_until(lock, queue_.front().due);
      continue;
    }
    Datagram d = std::move(queue_.front());
    queue_.pop_front();
    queued_bytes_ -= d.bytes;
    const double delay_s = std::chrono::duration<double>(Clock::now() - d.sent).count();
    stats_.min_delay_s = stats_.delivered == 0 ? delay_s : std::min(stats_.min_delay_s, delay_s);
    stats_.max_delay_s = std::max(stats_.max_delay_s, delay_s);
    ++stats_.delivered;
    stats_.bytes_delivered += d.bytes;
    lock.unlock();
    d.deliver();  // outside the lock: a send may block, a receive runs Fast DDS's handlers
    lock.lock();
  }
}

rtps::TransportInterface* EmulatedLinkTransportDescriptor::create_transport() const {
  return new EmulatedLinkTransport(*this);
}

ParticipantPtr participantOverLink(int domain_id, const std::shared_ptr<EmulatedLink>& link) {
  ParticipantSetup setup = participantSetup(localhostConfig(domain_id), "over_a_link");
  // The link goes below the send guard, right above the UDPv4 transport.
  for (auto& transport : setup.qos.transport().user_transports) {
    const auto guard = std::dynamic_pointer_cast<rtps::ChainingTransportDescriptor>(transport);
    if (guard && isUdpSendGuard(transport) &&
        std::dynamic_pointer_cast<rtps::UDPv4TransportDescriptor>(guard->low_level_descriptor)) {
      guard->low_level_descriptor =
          std::make_shared<EmulatedLinkTransportDescriptor>(guard->low_level_descriptor, link);
    }
  }
  return ParticipantPtr(
      eprosima::fastdds::dds::DomainParticipantFactory::get_instance()->create_participant(
          domain_id, setup.qos));
}

}  // namespace mlmap::dds::test_support
