#include "mlmap/dds/transport/participant.h"

#include "mlmap/dds/transport/udp_send_guard.h"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/rtps/common/Locator.h>
#include <fastdds/rtps/transport/TCPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/TCPv6TransportDescriptor.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/UDPv6TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/config.h>
#include <fastrtps/utils/IPFinder.h>
#include <fastrtps/utils/IPLocator.h>

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <iostream>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
namespace frtps = eprosima::fastrtps::rtps;
using eprosima::fastdds::rtps::SharedMemTransportDescriptor;
using eprosima::fastdds::rtps::TCPv4TransportDescriptor;
using eprosima::fastdds::rtps::TCPv6TransportDescriptor;
using eprosima::fastdds::rtps::TransportDescriptorInterface;
using eprosima::fastdds::rtps::UDPv4TransportDescriptor;
using eprosima::fastdds::rtps::UDPv6TransportDescriptor;
using TransportPtr = std::shared_ptr<TransportDescriptorInterface>;
using eprosima::fastrtps::types::ReturnCode_t;

constexpr const char* kLoopbackAddress = "127.0.0.1";
constexpr std::uint32_t kHeartbeatPeriod_ns =
    100'000'000;  // reliable writers: 0.1 s (Fast DDS: 3 s)

/// UDPv4 127.0.0.1 with port 0: Fast DDS fills in the well-known ports of the domain (for an
/// initial peer: one per participant index up to maxInitialPeersRange).
frtps::Locator_t loopbackLocator() {
  frtps::Locator_t locator;
  locator.kind = LOCATOR_KIND_UDPv4;
  frtps::IPLocator::setIPv4(locator, kLoopbackAddress);
  return locator;
}

fdds::DomainParticipantQos baseQos(const DdsConfig& config) {
  fdds::DomainParticipantFactory* factory = fdds::DomainParticipantFactory::get_instance();
  // FASTRTPS_DEFAULT_PROFILES_FILE / ./DEFAULT_FASTRTPS_PROFILES.xml, once per process.
  factory->load_profiles();
  if (!config.profiles_file.empty() &&
      factory->load_XML_profiles_file(config.profiles_file) != ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("dds.profiles_file: Fast DDS cannot load '" + config.profiles_file +
                             "' (missing file or invalid XML; see the Fast DDS log above)");
  }
  fdds::DomainParticipantQos qos;
  if (config.participant_profile.empty()) {
    factory->get_default_participant_qos(qos);
  } else if (factory->get_participant_qos_from_profile(config.participant_profile, qos) !=
             ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error(
        "dds.participant_profile: no participant profile '" + config.participant_profile +
        "' in the loaded XML profiles" +
        (config.profiles_file.empty() ? std::string() : " (" + config.profiles_file + ")"));
  }
  return qos;
}

/// Fast DDS 2.9's built-in UDPv4 transport as an explicit descriptor, with the participant-level
/// socket buffer sizes that apply only to the built-in one.
TransportPtr builtinUdp(const fdds::TransportConfigQos& transport) {
  auto udp = std::make_shared<UDPv4TransportDescriptor>();
  udp->sendBufferSize = transport.send_socket_buffer_size;
  udp->receiveBufferSize = transport.listen_socket_buffer_size;
  return udp;
}

/// IPv4 locator of `host` (a name or an address; port 0: Fast DDS tries the domain's well-known
/// ports). Throws std::runtime_error naming `source` when the name does not resolve to IPv4.
frtps::Locator_t staticPeerLocator(const std::string& host, const std::string& source) {
  frtps::Locator_t locator;
  locator.kind = LOCATOR_KIND_UDPv4;
  if (frtps::IPLocator::isIPv4(host)) {
    frtps::IPLocator::setIPv4(locator, host);
    return locator;
  }
  const auto resolved = frtps::IPLocator::resolveNameDNS(host);
  if (resolved.first.empty()) {
    throw std::runtime_error(source + ": cannot resolve static peer '" + host +
                             "' to an IPv4 address");
  }
  frtps::IPLocator::setIPv4(locator, *resolved.first.begin());
  return locator;
}

/// ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST as Jazzy's rmw_fastrtps_cpp applies it on top of the
/// base QoS (the profile's): no multicast discovery locators; the built-in transports off; the
/// profile's own transports kept and a UDPv4 transport added (maxInitialPeersRange 32, plus SHM
/// with `shared_memory`); 127.0.0.1 added to the initial peers. mlmap's one difference: without
/// static peers, the announced locators are this host's own addresses (localhostAddresses()).
void applyLocalhostRange(bool shared_memory, bool has_static_peers,
                         fdds::DomainParticipantQos* qos) {
  fdds::TransportConfigQos& transport = qos->transport();
  transport.use_builtin_transports = false;
  if (shared_memory)
    transport.user_transports.push_back(std::make_shared<SharedMemTransportDescriptor>());
  auto udp = std::make_shared<UDPv4TransportDescriptor>();
  udp->maxInitialPeersRange = kLocalhostMaxInitialPeersRange;
  transport.user_transports.push_back(udp);

  fdds::WireProtocolConfigQos& wire = qos->wire_protocol();
  wire.builtin.metatrafficMulticastLocatorList.clear();
  wire.builtin.initialPeersList.push_back(loopbackLocator());
  if (has_static_peers) {
    // Any address, computed port: the peers are on other hosts. (A unicast locator, so that Fast
    // DDS does not add the default multicast one.)
    wire.builtin.metatrafficUnicastLocatorList.push_back(frtps::Locator_t());
    return;
  }
  // Announced explicitly, with no whitelist: Fast DDS 2.9 sends every unicast datagram once
  // through each whitelisted interface's socket, so a whitelist of these addresses sent each
  // sample twice (and lost fragments of large clouds under that load).
  for (const std::string& address : localhostAddresses()) {
    frtps::Locator_t locator;  // port 0: Fast DDS computes the domain's ports
    locator.kind = LOCATOR_KIND_UDPv4;
    frtps::IPLocator::setIPv4(locator, address);
    wire.builtin.metatrafficUnicastLocatorList.push_back(locator);
    wire.default_unicast_locator_list.push_back(locator);
  }
}

/// ROS_STATIC_PEERS as Jazzy's rmw_fastrtps_cpp applies them (LOCALHOST and SUBNET only): each
/// peer's IPv4 address joins the initial peers; with SUBNET, the default multicast address too
/// (Fast DDS adds it only to an empty list).
void addStaticPeers(const std::vector<std::string>& peers, DiscoveryRange range,
                    fdds::DomainParticipantQos* qos) {
  frtps::LocatorList_t& initial = qos->wire_protocol().builtin.initialPeersList;
  for (const std::string& peer : peers) initial.push_back(staticPeerLocator(peer, "static peers"));
  if (range == DiscoveryRange::kSubnet && !peers.empty()) {
    frtps::Locator_t multicast;
    multicast.kind = LOCATOR_KIND_UDPv4;
    frtps::IPLocator::setIPv4(multicast, 239, 255, 0, 1);
    initial.push_back(multicast);
  }
}

/// Makes the built-in transports explicit (UDPv4, plus SHM with `shared_memory`) so that they can
/// be sized and so that no SHM transport comes in unasked; without `shared_memory`, also removes
/// the SHM transports a profile lists. Returns what was removed, for the log ("" for nothing).
/// Throws std::runtime_error when no transport is left.
std::string withSharedMemoryOnlyIfAsked(bool shared_memory, const std::string& profile,
                                        fdds::DomainParticipantQos* qos) {
  fdds::TransportConfigQos& transport = qos->transport();
  if (transport.use_builtin_transports) {
    transport.user_transports.insert(transport.user_transports.begin(), builtinUdp(transport));
    if (shared_memory) {
      transport.user_transports.insert(transport.user_transports.begin(),
                                       std::make_shared<SharedMemTransportDescriptor>());
    }
    transport.use_builtin_transports = false;
  }
  if (shared_memory) return "";
  std::vector<TransportPtr>& listed = transport.user_transports;
  const auto is_shm = [](const TransportPtr& t) {
    return std::dynamic_pointer_cast<SharedMemTransportDescriptor>(t) != nullptr;
  };
  const std::size_t removed =
      static_cast<std::size_t>(std::count_if(listed.begin(), listed.end(), is_shm));
  if (removed == 0) return "";
  listed.erase(std::remove_if(listed.begin(), listed.end(), is_shm), listed.end());
  if (listed.empty()) {
    throw std::runtime_error(
        profile +
        ": its only transport is shared memory, which dds.shared_memory "
        "(false) leaves out: add a UDP transport to the profile, or set dds.shared_memory: true "
        "when every Fast DDS peer on this host is version 2.9");
  }
  return profile +
         ": its shared-memory transport is left out (dds.shared_memory is false: a "
         "peer of another Fast DDS version on this host could crash this process through it); "
         "its other transports are used";
}

void withoutAutomaticDiscovery(fdds::DomainParticipantQos* qos) {
  fdds::WireProtocolConfigQos& wire = qos->wire_protocol();
  wire.builtin.metatrafficMulticastLocatorList.clear();
  wire.default_multicast_locator_list.clear();
  if (wire.builtin.metatrafficUnicastLocatorList.empty()) {
    // Any address, computed port. Without a unicast locator Fast DDS would add the default
    // multicast one again (and use it as the initial peer).
    wire.builtin.metatrafficUnicastLocatorList.push_back(frtps::Locator_t());
  }
}

/// A copy of `descriptor` of concrete type D with its socket buffers raised to the large-data
/// size, or nullptr when `descriptor` is not a D.
template <typename D>
TransportPtr withLargeSocketBuffers(const TransportPtr& descriptor) {
  const auto typed = std::dynamic_pointer_cast<D>(descriptor);
  if (!typed) return nullptr;
  auto copy = std::make_shared<D>(*typed);
  copy->sendBufferSize = std::max(copy->sendBufferSize, kLargeDataSocketBufferBytes);
  copy->receiveBufferSize = std::max(copy->receiveBufferSize, kLargeDataSocketBufferBytes);
  return copy;
}

TransportPtr sizedForLargeData(const TransportPtr& descriptor) {
  if (const auto shm = std::dynamic_pointer_cast<SharedMemTransportDescriptor>(descriptor)) {
    auto copy = std::make_shared<SharedMemTransportDescriptor>(*shm);
    copy->segment_size(std::max(copy->segment_size(), kLargeDataShmSegmentBytes));
    return copy;
  }
  using Sizer = TransportPtr (*)(const TransportPtr&);
  constexpr Sizer kSocketSizers[] = {withLargeSocketBuffers<UDPv4TransportDescriptor>,
                                     withLargeSocketBuffers<UDPv6TransportDescriptor>,
                                     withLargeSocketBuffers<TCPv4TransportDescriptor>,
                                     withLargeSocketBuffers<TCPv6TransportDescriptor>};
  for (const Sizer sized : kSocketSizers) {
    if (TransportPtr copy = sized(descriptor)) return copy;
  }
  return descriptor;  // unknown kind: left as the profile made it
}

void sizeForLargeData(fdds::DomainParticipantQos* qos) {
  for (TransportPtr& descriptor : qos->transport().user_transports) {
    descriptor = sizedForLargeData(descriptor);
  }
}

/// Adds the security properties of `security` to the QoS; a property the profile already sets
/// keeps the profile's value (an XML profile can configure or refine DDS Security itself).
void applySecurity(const SecuritySetup& security, fdds::DomainParticipantQos* qos) {
  std::vector<frtps::Property>& properties = qos->properties().properties();
  for (const auto& [name, value] : security.properties) {
    const bool set_by_profile =
        std::any_of(properties.begin(), properties.end(),
                    [&name = name](const frtps::Property& p) { return p.name() == name; });
    if (!set_by_profile) properties.emplace_back(name, value);
  }
}

/// True when the QoS (from mlmap or from the profile) enables Fast DDS's security plugins.
bool securityConfigured(const fdds::DomainParticipantQos& qos) {
  const std::vector<frtps::Property>& properties = qos.properties().properties();
  return std::any_of(properties.begin(), properties.end(), [](const frtps::Property& p) {
    return p.name().rfind("dds.sec.", 0) == 0 && p.name().find(".plugin") != std::string::npos;
  });
}

void checkDepth(int depth) {
  if (depth < 1) {
    throw std::invalid_argument("KEEP_LAST history depth must be >= 1 (got " +
                                std::to_string(depth) + ")");
  }
}

/// True when no socket of this host holds UDP `port` on any IPv4 address: a socket of ours binds
/// it without address reuse, as Fast DDS and Cyclone DDS bind their unicast ports.
bool udpPortFree(std::uint32_t port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return false;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_ANY);
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool free = ::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) == 0;
  ::close(fd);
  return free;
}

/// Participant indexes tried for a free pair of unicast ports: the 120 whose ports stay within the
/// domain's block of 250 (offsets 10 and 11, two ports per index).
constexpr std::int32_t kProbedParticipantIndexes = 120;

/// The first participant index whose discovery and data unicast ports on `domain` (as Fast DDS
/// computes them from `ports`) are both free on this host now; -1 when none is.
///
/// Fast DDS 2.9 numbers its participants per process and, when another process already holds
/// the ports of that number, binds the next ones but still announces the first ones too, for the
/// participant or for its endpoints. A Fast DDS peer sends to every locator (each sample also to
/// the other process), a Cyclone DDS peer to one of them: a node started after a ROS 2 node on
/// rmw_cyclonedds_cpp (which takes participant indexes from 0 with Jazzy's defaults) received
/// none of its samples. With a free index chosen first, nothing is moved and nothing stale is
/// announced.
std::int32_t freeParticipantIndex(int domain_id, const frtps::PortParameters& ports) {
  const std::uint32_t base =
      ports.portBase + ports.domainIDGain * static_cast<std::uint32_t>(domain_id);
  for (std::int32_t index = 0; index < kProbedParticipantIndexes; ++index) {
    const std::uint32_t step = ports.participantIDGain * static_cast<std::uint32_t>(index);
    const std::uint32_t discovery = base + ports.offsetd1 + step;
    const std::uint32_t data = base + ports.offsetd3 + step;
    if (data > 65535 || discovery > 65535) break;
    if (udpPortFree(discovery) && udpPortFree(data)) return index;
  }
  return -1;
}

/// True when Fast DDS will number the participant and derive its UDPv4 ports from that number:
/// simple discovery, no index set, a UDPv4 transport.
bool takesAParticipantIndex(const fdds::DomainParticipantQos& qos) {
  const fdds::WireProtocolConfigQos& wire = qos.wire_protocol();
  if (wire.participant_id >= 0) return false;
  if (wire.builtin.discovery_config.discoveryProtocol != frtps::DiscoveryProtocol_t::SIMPLE)
    return false;
  return std::any_of(qos.transport().user_transports.begin(), qos.transport().user_transports.end(),
                     [](const TransportPtr& t) {
                       return std::dynamic_pointer_cast<UDPv4TransportDescriptor>(unguarded(t)) !=
                              nullptr;
                     });
}

}  // namespace

std::vector<std::string> localhostAddresses() {
  std::vector<std::string> addresses{kLoopbackAddress};
  std::vector<frtps::IPFinder::info_IP> interfaces;
  if (!frtps::IPFinder::getIPs(&interfaces, false)) return addresses;
  for (const frtps::IPFinder::info_IP& i : interfaces) {
    if (i.type == frtps::IPFinder::IP4 &&
        std::find(addresses.begin(), addresses.end(), i.name) == addresses.end()) {
      addresses.push_back(i.name);
    }
  }
  return addresses;
}

std::uint16_t dataSharingDomainId() {
  // FNV-1a of the version text, folded to 16 bits; never 0 (Fast DDS's automatic id of a host
  // whose MAC address reads as zero).
  std::uint32_t hash = 2166136261u;
  for (const char c : std::string("mlmap data-sharing, Fast DDS ") + FASTRTPS_VERSION_STR) {
    hash = (hash ^ static_cast<std::uint8_t>(c)) * 16777619u;
  }
  const auto id = static_cast<std::uint16_t>((hash >> 16) ^ (hash & 0xffffu));
  return id == 0 ? 1 : id;
}

void ParticipantDeleter::operator()(fdds::DomainParticipant* participant) const {
  if (participant == nullptr) return;
  participant->delete_contained_entities();
  fdds::DomainParticipantFactory::get_instance()->delete_participant(participant);
}

ParticipantSetup participantSetup(const DdsConfig& config, const std::string& name) {
  ParticipantSetup setup;
  try {
    setup.domain_id = resolveDomainId(config);
    setup.discovery_range = resolveDiscoveryRange(config);
    setup.static_peers = resolveStaticPeers(config);
    setup.security = resolveSecurity(config.security);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  fdds::DomainParticipantQos& qos = setup.qos;
  qos = baseQos(config);
  if (!name.empty()) qos.name(name);

  const bool has_peers = !setup.static_peers.empty();
  switch (setup.discovery_range) {
    case DiscoveryRange::kLocalhost:
      applyLocalhostRange(config.shared_memory, has_peers, &qos);
      addStaticPeers(setup.static_peers, setup.discovery_range, &qos);
      break;
    case DiscoveryRange::kSubnet:
      addStaticPeers(setup.static_peers, setup.discovery_range, &qos);
      break;  // else the profile's (or Fast DDS's) transports and multicast discovery
    case DiscoveryRange::kOff:
      withoutAutomaticDiscovery(&qos);
      if (has_peers) {
        setup.warnings.emplace_back(
            "the discovery range is OFF: the static peers are ignored (as ROS 2 does)");
      }
      break;
    case DiscoveryRange::kSystemDefault:
      if (has_peers) {
        setup.warnings.emplace_back(
            "the discovery range is SYSTEM_DEFAULT: the static peers are ignored (as Jazzy's "
            "rmw_fastrtps_cpp does); set it to SUBNET or LOCALHOST to use them");
      }
      break;  // the profile's (or Fast DDS's) transports and multicast discovery
  }
  const std::string profile = config.participant_profile.empty()
                                  ? std::string("the default participant profile")
                                  : "participant profile '" + config.participant_profile + "'";
  const std::string removed = withSharedMemoryOnlyIfAsked(config.shared_memory, profile, &qos);
  if (!removed.empty()) setup.warnings.push_back(removed);
  if (config.large_data) sizeForLargeData(&qos);
  // Last, over the transports as sized: no remote locator may abort the process (see there).
  guardUdpSends(&qos);

  // As rmw_fastrtps: discovery data of participants with many endpoints can exceed the
  // preallocated 5000 bytes.
  qos.wire_protocol().builtin.readerHistoryMemoryPolicy =
      frtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
  qos.wire_protocol().builtin.writerHistoryMemoryPolicy =
      frtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
  if (qos.user_data().data_vec().empty()) {
    const std::string enclave = "enclave=" + setup.security.enclave + ";";
    qos.user_data().data_vec(std::vector<frtps::octet>(enclave.begin(), enclave.end()));
  }
  if (setup.security.enabled()) applySecurity(setup.security, &qos);
  return setup;
}

ParticipantPtr createParticipant(const DdsConfig& config, const std::string& name,
                                 fdds::DomainParticipantListener* listener) {
  const ParticipantSetup setup = participantSetup(config, name);
  // As rmw: a Permissive fallback is said, not silent.
  if (!setup.security.warning.empty())
    std::cerr << "[mlmap dds] warning: " << setup.security.warning << "\n";
  for (const std::string& warning : setup.warnings)
    std::cerr << "[mlmap dds] warning: " << warning << "\n";
  // The index is chosen and taken under one lock, so that two threads of this process never
  // choose the same one.
  static std::mutex creating;
  std::unique_lock<std::mutex> lock(creating);
  fdds::DomainParticipantQos qos = setup.qos;
  if (takesAParticipantIndex(qos)) {
    qos.wire_protocol().participant_id =
        freeParticipantIndex(setup.domain_id, qos.wire_protocol().port);
  }
  fdds::DomainParticipant* participant =
      fdds::DomainParticipantFactory::get_instance()->create_participant(
          static_cast<fdds::DomainId_t>(setup.domain_id), qos, listener, fdds::StatusMask::none());
  lock.unlock();
  if (participant == nullptr) {
    std::string security;
    if (setup.security.enabled()) {
      security = "; DDS Security as enclave '" + setup.security.enclave + "' from " +
                 setup.security.enclave_dir +
                 ": check that its certificates, key, governance and permissions belong together "
                 "and are signed by its CAs";
    } else if (securityConfigured(setup.qos)) {
      security = "; DDS Security as the profile's dds.sec.* properties set it";
    }
    throw std::runtime_error("Fast DDS refused to create participant '" + name + "' on domain " +
                             std::to_string(setup.domain_id) + " with discovery range " +
                             toString(setup.discovery_range) + security +
                             " (see the Fast DDS log above)");
  }
  return ParticipantPtr(participant);
}

// Payloads sized by each sample, reused. Not PREALLOCATED_WITH_REALLOC (rmw_fastrtps's choice):
// Fast DDS 2.9 turns that into PREALLOCATED, payloads of the type's size bound and larger samples
// dropped, for a type that says it is bounded, as CloudSamplePubSubType does.
constexpr auto kHistoryMemory = frtps::DYNAMIC_REUSABLE_MEMORY_MODE;

fdds::DataReaderQos sensorReaderQos(int depth) {
  checkDepth(depth);
  fdds::DataReaderQos qos = fdds::DATAREADER_QOS_DEFAULT;
  qos.reliability().kind = fdds::BEST_EFFORT_RELIABILITY_QOS;
  qos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = depth;
  qos.endpoint().history_memory_policy = kHistoryMemory;
  qos.data_sharing().automatic(
      std::vector<std::uint16_t>{dataSharingDomainId()});  // with mlmap's writers only
  return qos;
}

fdds::DataWriterQos reliableWriterQos(int depth) {
  checkDepth(depth);
  fdds::DataWriterQos qos = fdds::DATAWRITER_QOS_DEFAULT;
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.durability().kind =
      fdds::VOLATILE_DURABILITY_QOS;  // Fast DDS's writer default is TRANSIENT_LOCAL
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = depth;
  qos.publish_mode().kind = fdds::SYNCHRONOUS_PUBLISH_MODE;
  qos.endpoint().history_memory_policy = kHistoryMemory;
  // A data-sharing writer keeps its samples in fixed slots of the type's size bound, and
  // CloudSamplePubSubType's bound is no real one (see there): a map layer would not fit.
  qos.data_sharing().off();
  // A lost sample is repaired when a reader answers the writer's heartbeat; Fast DDS's default
  // period is 3 s, so a map layer lost once on a loaded machine stayed missing for seconds, or
  // for good when the node stopped first. Fast DDS sends periodic heartbeats only while a sample
  // is unacknowledged, so the short period costs little when nothing is lost.
  qos.reliable_writer_qos().times.heartbeatPeriod =
      eprosima::fastrtps::Duration_t(0, kHeartbeatPeriod_ns);
  return qos;
}

fdds::DataWriterQos latchedWriterQos() {
  fdds::DataWriterQos qos = reliableWriterQos(1);
  qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  return qos;
}

fdds::DataReaderQos reliableReaderQos(bool latched, int depth) {
  fdds::DataReaderQos qos = sensorReaderQos(depth);
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  if (latched) qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  return qos;
}

}  // namespace mlmap::dds
