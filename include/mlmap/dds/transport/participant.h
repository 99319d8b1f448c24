#pragma once
/// @file
/// Creating a DomainParticipant the way a ROS 2 Jazzy node does, and the QoS presets ROS 2 users
/// expect (sensor data, default, maps / tf_static).

#include "mlmap/dds/transport/dds_config.h"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace mlmap::dds {

/// Deletes a participant and every entity it holds.
struct ParticipantDeleter {
  void operator()(eprosima::fastdds::dds::DomainParticipant* participant) const;
};
using ParticipantPtr =
    std::unique_ptr<eprosima::fastdds::dds::DomainParticipant, ParticipantDeleter>;

/// Creates the participant named `name` on the resolved domain (resolveDomainId) with the
/// resolved discovery range (resolveDiscoveryRange), as rmw_fastrtps does for a ROS 2 node.
///
/// Base QoS: `participant_profile` when set (from `profiles_file`, loaded first when set, or from
/// FASTRTPS_DEFAULT_PROFILES_FILE), else the factory's default participant QoS (Fast DDS's
/// defaults, or the is_default_profile of FASTRTPS_DEFAULT_PROFILES_FILE). The QoS name becomes
/// `name` (when not empty); discovery history memory becomes PREALLOCATED_WITH_REALLOC and the
/// user data "enclave=<enclave>;" (enclave "/" unless security sets one) when the profile sets
/// none (both as rmw_fastrtps).
///
/// Shared memory (`shared_memory`, false by default): Fast DDS 2.x sends through its SHM
/// transport to every peer on the same host that announces SHM locators, and does not fall back
/// to UDP when that fails; Fast DDS 2.9 aborts in Boost.Interprocess when it opens a segment made
/// by Fast DDS 2.14 (ROS 2 Jazzy's rmw_fastrtps_cpp). So by default the participant has no SHM
/// transport at all: it announces UDP locators only and never maps another process's transport
/// segment. Fast DDS's built-in transports become an explicit UDPv4 transport, and SHM
/// transports of a profile are left out (ParticipantSetup::warnings says so; a profile with SHM
/// alone is an error). mlmap's own fast path between its processes is data-sharing, which only
/// mlmap's endpoints of the same Fast DDS version accept (dataSharingDomainId()). With
/// `shared_memory` true the SHM transport is used as Fast DDS does (for a host where every Fast
/// DDS participant is 2.9).
///
/// Discovery range:
/// - kLocalhost, as Jazzy's rmw_fastrtps_cpp applies it on top of the base QoS (also a
///   profile's): the built-in transports are switched off, the profile's own transports are
///   kept, and a UDPv4 transport with maxInitialPeersRange 32 is added (plus SHM with
///   `shared_memory`); the multicast discovery locators are removed, a unicast one is added, and
///   127.0.0.1 joins the initial peers: up to 32 participants on the host find each other with no
///   multicast. mlmap's one difference: without static peers the participant announces this
///   host's own addresses (localhostAddresses()), 127.0.0.1 first, as its unicast locators
///   (rmw_fastrtps's announces the network interfaces' addresses only).
/// - Static peers (resolveStaticPeers: `static_peers`, else ROS_STATIC_PEERS), as Jazzy's
///   rmw_fastrtps_cpp: with kLocalhost or kSubnet each peer's IPv4 address (names resolved) joins
///   the initial peers (port 0: the domain's well-known ports, maxInitialPeersRange of them), and
///   with kSubnet the default multicast address 239.255.0.1 too; with kOff or kSystemDefault they
///   are ignored with a warning. A name that does not resolve is an error.
/// - kSubnet / kSystemDefault: the profile's transports and discovery are left as they are (but
///   for shared memory, above).
/// - kOff: the profile's transports stay (but for shared memory); multicast locators (discovery
///   and user data) are removed and nothing is added to the initial peers, so the participant
///   only announces itself to the profile's own initial peers (none by default): it finds nobody
///   by itself, but a participant that lists this host as a peer still finds it. (rmw_fastrtps
///   switches discovery off entirely instead, which also ignores the profile's peers.)
///
/// DDS Security (`security`, resolveSecurity()): when enabled, the dds.sec.* properties of
/// rmw_fastrtps are added to the QoS (a property the profile already sets keeps the profile's
/// value), and the user data is "enclave=<enclave>;". A profile whose own `<propertiesPolicy>`
/// sets the dds.sec.* properties is secured by Fast DDS without `security`. A Permissive
/// fallback (files missing) is printed to stderr as a warning; with Enforce the missing file is
/// the exception's message.
///
/// `large_data` raises (never lowers) the SHM segment to 16 MB and the socket buffers to 4 MB on
/// the transports in use: SHM / UDPv4 / UDPv6 / TCP descriptors are copied and sized (a profile
/// itself is not modified); other transports are left alone. Over SHM the sender's
/// segment decides, over UDP the receiver's buffer (bounded by net.core.rmem_max).
///
/// Last, every UDPv4 / UDPv6 transport is put behind the send guard (udp_send_guard.h): Fast DDS
/// 2.9.1 aborts when a reliable writer sends to a locator it never opened, which a second ROS 2
/// node on rmw_cyclonedds_cpp with Jazzy's defaults makes happen; the guard opens it first.
///
/// Participant index: with simple discovery over UDPv4 and no index set by the profile, the
/// participant gets the first index (0..119) whose discovery and data unicast ports on the domain
/// no socket of this host holds (probed by binding them). Fast DDS 2.9 would number it per
/// process, and when another process (a ROS 2 node on rmw_cyclonedds_cpp, which takes indexes
/// from 0) holds those ports it moves to others but still announces the first ones, so a Cyclone
/// peer sent its samples to the other process. Creation is serialised within the process, so
/// that two threads never pick the same index.
///
/// `listener`, when given, hears the participant's discovery from its creation on (it must
/// outlive the participant); no entity status goes to it.
///
/// Throws std::runtime_error with the reason when the profiles file, the profile or the
/// environment is invalid, or Fast DDS refuses to create the participant.
ParticipantPtr createParticipant(
    const DdsConfig& config, const std::string& name,
    eprosima::fastdds::dds::DomainParticipantListener* listener = nullptr);

/// What createParticipant() creates, without creating it (for logs, `--print-config` and tests).
struct ParticipantSetup {
  int domain_id = 0;
  DiscoveryRange discovery_range = DiscoveryRange::kSystemDefault;  ///< as resolved
  std::vector<std::string> static_peers;  ///< as resolved (resolveStaticPeers)
  SecuritySetup security;                 ///< as resolved (its properties are in qos when enabled)
  eprosima::fastdds::dds::DomainParticipantQos qos;
  /// What createParticipant() prints as warnings (a profile's transport left out, static peers
  /// ignored by the discovery range).
  std::vector<std::string> warnings;
};
/// Resolves the domain, the discovery range and the QoS exactly as createParticipant() does
/// (loading `profiles_file` when set). Throws std::runtime_error like it.
ParticipantSetup participantSetup(const DdsConfig& config, const std::string& name);

/// The addresses a kLocalhost participant without static peers announces: 127.0.0.1, then this
/// host's other IPv4 addresses (as Fast DDS lists its interfaces). A ROS 2 node on
/// rmw_fastrtps_cpp with LOCALHOST announces only the latter on a host that has one, and Fast DDS
/// sends to an address of its own host only when its UDP transport has no whitelist or one that
/// holds the address (over loopback then); a whitelist of several addresses would send every
/// datagram once per address, so the transport has none. Datagrams to the host's own addresses
/// never leave it.
std::vector<std::string> localhostAddresses();

/// The data-sharing domain of mlmap's endpoints: a readers' and a writer's data-sharing is used
/// only when they list a common domain id, and Fast DDS's automatic id is the host's MAC address
/// in the upper 48 bits of 64 (low 16 bits zero). mlmap's readers and writers list only this
/// nonzero 16-bit id, derived from the Fast DDS version mlmap is built with, so that data-sharing
/// happens between mlmap endpoints built with the same Fast DDS and never with another process's
/// (whose segments may have another format); those are served through the transports.
std::uint16_t dataSharingDomainId();

/// Segment size of the SHM transport with `large_data` [bytes].
inline constexpr std::uint32_t kLargeDataShmSegmentBytes = 16u * 1024u * 1024u;
/// Socket send / receive buffer size with `large_data` [bytes].
inline constexpr std::uint32_t kLargeDataSocketBufferBytes = 4u * 1024u * 1024u;
/// Participants per host that find each other with kLocalhost (ports tried per initial peer).
inline constexpr std::uint32_t kLocalhostMaxInitialPeersRange = 32;

// The QoS helpers throw std::invalid_argument for depth < 1. Every one uses DYNAMIC_REUSABLE
// history memory (payloads sized by each sample, then reused), so samples of any size fit, also
// of a type that claims a size bound (CloudSamplePubSubType).

/// ROS 2 "sensor data" QoS: BEST_EFFORT, VOLATILE, KEEP_LAST depth (5); data-sharing AUTO in
/// mlmap's domain (dataSharingDomainId(): used with a same-host mlmap writer that offers it, for a
/// type that says it is bounded).
eprosima::fastdds::dds::DataReaderQos sensorReaderQos(int depth = 5);
/// ROS 2 default QoS for a writer: RELIABLE, VOLATILE, KEEP_LAST depth (10), synchronous publish
/// mode, no data-sharing; heartbeats every 0.1 s instead of Fast DDS's 3 s, so that a lost sample
/// is repaired quickly.
eprosima::fastdds::dds::DataWriterQos reliableWriterQos(int depth = 10);
/// Latched ("map") writer: RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1 (late joiners get the last one).
eprosima::fastdds::dds::DataWriterQos latchedWriterQos();
/// Readers matching those writers (RELIABLE; TRANSIENT_LOCAL with `latched`).
eprosima::fastdds::dds::DataReaderQos reliableReaderQos(bool latched = false, int depth = 10);

}  // namespace mlmap::dds
