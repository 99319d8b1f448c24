#include "mlmap/dds/transport/udp_send_guard.h"

#include <fastdds/rtps/common/LocatorList.hpp>
#include <fastdds/rtps/transport/ChainingTransport.h>
#include <fastdds/rtps/transport/ChainingTransportDescriptor.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/UDPv6TransportDescriptor.h>

#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>
#include <vector>

namespace mlmap::dds {
namespace {

namespace frtps = eprosima::fastrtps::rtps;
namespace rtps = eprosima::fastdds::rtps;
using TransportPtr = std::shared_ptr<rtps::TransportDescriptorInterface>;

std::atomic<std::uint64_t> g_destinations_opened{0};
std::atomic<std::uint64_t> g_destinations_refused{0};

struct UdpSendGuardDescriptor final : public rtps::ChainingTransportDescriptor {
  explicit UdpSendGuardDescriptor(const TransportPtr& udp) : ChainingTransportDescriptor(udp) {}
  rtps::TransportInterface* create_transport() const override;
};

/// The guard itself (see the header). Fast DDS calls OpenOutputChannel() and send() with the
/// participant's send-resources mutex held, but the guard does not rely on it: its own mutex
/// keeps the set of opened destinations.
class UdpSendGuardTransport final : public rtps::ChainingTransport {
 public:
  explicit UdpSendGuardTransport(const UdpSendGuardDescriptor& descriptor)
      : ChainingTransport(descriptor) {}

  rtps::TransportDescriptorInterface* get_configuration() override {
    return low_level_transport_->get_configuration();
  }

  bool OpenOutputChannel(rtps::SendResourceList& sender_resource_list,
                         const frtps::Locator_t& locator) override {
    const bool opened = ChainingTransport::OpenOutputChannel(sender_resource_list, locator);
    if (opened) {
      std::lock_guard<std::mutex> lock(mutex_);
      opened_.insert(locator);
    }
    return opened;
  }

  bool send(frtps::SenderResource* low_sender_resource, const frtps::octet* send_buffer,
            uint32_t send_buffer_size, frtps::LocatorsIterator* destination_locators_begin,
            frtps::LocatorsIterator* destination_locators_end,
            const std::chrono::steady_clock::time_point& timeout) override {
    std::lock_guard<std::mutex> lock(mutex_);
    destinations_.clear();
    for (frtps::LocatorsIterator& it = *destination_locators_begin; it != *destination_locators_end;
         ++it) {
      const frtps::Locator_t& locator = *it;
      // The UDP transport skips locators of other kinds itself, without looking them up.
      if (!low_level_transport_->IsLocatorSupported(locator)) continue;
      if (opened_.count(locator) != 0 || openLate(locator)) destinations_.push_back(locator);
    }
    if (destinations_.empty()) return true;  // as a datagram socket that had nowhere to send
    frtps::Locators begin(destinations_.cbegin());
    frtps::Locators end(destinations_.cend());
    return low_sender_resource->send(send_buffer, send_buffer_size, &begin, &end, timeout);
  }

  void receive(rtps::TransportReceiverInterface* next_receiver, const frtps::octet* receive_buffer,
               uint32_t receive_buffer_size, const frtps::Locator_t& local_locator,
               const frtps::Locator_t& remote_locator) override {
    next_receiver->OnDataReceived(receive_buffer, receive_buffer_size, local_locator,
                                  remote_locator);
  }

 private:
  /// Opens an output channel for `locator` in the UDP transport, so that it enters the transport's
  /// table of destinations; true when the transport took it. Called with mutex_ held.
  bool openLate(const frtps::Locator_t& locator) {
    rtps::SendResourceList spare;
    const bool opened = low_level_transport_->OpenOutputChannel(spare, locator);
    if (!spare.empty()) {
      // The transport was about to rescan the host's interfaces and made sockets for them here:
      // they are dropped, and the rescan is left for the participant's own next channel.
      spare.clear();
      low_level_transport_->update_network_interfaces();
    }
    if (!opened) {
      ++g_destinations_refused;
      return false;
    }
    opened_.insert(locator);
    ++g_destinations_opened;
    return true;
  }

  std::mutex mutex_;
  std::set<frtps::Locator_t> opened_;           ///< every destination the UDP transport has taken
  std::vector<frtps::Locator_t> destinations_;  ///< of the datagram being sent (reused)
};

rtps::TransportInterface* UdpSendGuardDescriptor::create_transport() const {
  return new UdpSendGuardTransport(*this);
}

bool isUdp(const TransportPtr& transport) {
  return std::dynamic_pointer_cast<rtps::UDPv4TransportDescriptor>(transport) != nullptr ||
         std::dynamic_pointer_cast<rtps::UDPv6TransportDescriptor>(transport) != nullptr;
}

}  // namespace

UdpSendGuardStats udpSendGuardStats() {
  return UdpSendGuardStats{g_destinations_opened.load(), g_destinations_refused.load()};
}

TransportPtr withUdpSendGuard(const TransportPtr& transport) {
  if (!isUdp(transport)) return transport;
  return std::make_shared<UdpSendGuardDescriptor>(transport);
}

TransportPtr unguarded(const TransportPtr& transport) {
  const auto guard = std::dynamic_pointer_cast<UdpSendGuardDescriptor>(transport);
  return guard ? guard->low_level_descriptor : transport;
}

bool isUdpSendGuard(const TransportPtr& transport) {
  return std::dynamic_pointer_cast<UdpSendGuardDescriptor>(transport) != nullptr;
}

void guardUdpSends(eprosima::fastdds::dds::DomainParticipantQos* qos) {
  if (qos->transport().use_builtin_transports) {
    throw std::logic_error(
        "guardUdpSends: the participant uses Fast DDS's built-in transports, which cannot be "
        "guarded; list them as user transports first");
  }
  for (TransportPtr& transport : qos->transport().user_transports) {
    transport = withUdpSendGuard(transport);
  }
}

}  // namespace mlmap::dds
