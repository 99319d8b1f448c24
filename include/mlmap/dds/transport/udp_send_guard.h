#pragma once
/// @file
/// A guard around Fast DDS 2.9's UDP transports, so that no remote locator can abort the process.
///
/// Debian 12's Fast DDS 2.9.1 is built with its statistics module and with assertions left on.
/// Its UDP transport keeps a table of the destinations it may send to, filled only when an output
/// channel is opened for a locator, and asserts (aborts) when it is asked to send to a locator
/// missing from that table (OutputTrafficManager.hpp:87). Fast DDS opens a channel for the
/// locators its locator selection picks when a remote reader matches, but a reliable writer then
/// sends its first heartbeat or gap to the new reader's own unicast locators: when the selection
/// picked a multicast locator instead (one that the reader shares with another matched reader, as
/// every endpoint of a participant with a default multicast locator does, such as Cyclone DDS's
/// and rmw_cyclonedds_cpp's by default), that unicast locator may never have been opened. Fast
/// DDS 2.14.5 fixed this upstream (eProsima/Fast-DDS#5704); 2.9 has no such fix.
///
/// The guard is a chaining transport over each UDPv4 / UDPv6 transport: before a datagram goes
/// to the UDP transport, every destination it was never given through an output channel is
/// opened first (the UDP transport then adds it to its table; no socket is created when the
/// host's interfaces are already served). A destination the UDP transport refuses to open is
/// dropped from that datagram, never sent to, and counted. Everything else passes through
/// unchanged: locators, sockets, buffer sizes, discovery.

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/rtps/transport/TransportDescriptorInterface.h>

#include <cstdint>
#include <memory>

namespace mlmap::dds {

/// What the send guards of this process have done, over all participants.
struct UdpSendGuardStats {
  /// Destinations the UDP transport had not been given before a datagram was sent to them,
  /// opened by the guard (each once per transport).
  std::uint64_t destinations_opened = 0;
  /// Destinations left out of a datagram because the UDP transport refused to open them.
  std::uint64_t destinations_refused = 0;
};

/// The counts of every guard in this process so far.
UdpSendGuardStats udpSendGuardStats();

/// `transport` with its UDPv4 or UDPv6 transport behind the send guard; any other kind (shared
/// memory, TCP, a guard already) is returned as it is.
std::shared_ptr<eprosima::fastdds::rtps::TransportDescriptorInterface> withUdpSendGuard(
    const std::shared_ptr<eprosima::fastdds::rtps::TransportDescriptorInterface>& transport);

/// The transport below the guard when `transport` is a guard, else `transport` (for code that
/// inspects or replaces a participant's UDP transport).
std::shared_ptr<eprosima::fastdds::rtps::TransportDescriptorInterface> unguarded(
    const std::shared_ptr<eprosima::fastdds::rtps::TransportDescriptorInterface>& transport);

/// True when `transport` is a send guard.
bool isUdpSendGuard(
    const std::shared_ptr<eprosima::fastdds::rtps::TransportDescriptorInterface>& transport);

/// Puts every UDP transport of `qos` behind the guard. The QoS must list its transports
/// (use_builtin_transports false), as participantSetup() leaves it; the built-in ones cannot be
/// wrapped, so this throws std::logic_error when they are on.
void guardUdpSends(eprosima::fastdds::dds::DomainParticipantQos* qos);

}  // namespace mlmap::dds
