#pragma once
// Helpers of the DDS tests: waiting for a condition, loopback-only participant settings, matching.

#include "mlmap/dds/transport/dds_config.h"

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastrtps/xmlparser/XMLProfileManager.h>

#include <chrono>
#include <functional>
#include <thread>

namespace mlmap::dds::test_support {

/// Discovery on loopback takes well under a second; this leaves room for a loaded machine.
constexpr std::chrono::milliseconds kDiscoveryTimeout{10000};

/// Polls `condition` until it holds (true) or `timeout` passed (false).
inline bool waitFor(const std::function<bool()>& condition,
                    std::chrono::milliseconds timeout = kDiscoveryTimeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

/// Fast DDS's delivery between participants of one process, which bypasses transports and
/// data-sharing alike, switched off while it lives (set before the participants are made).
class NoIntraprocessDelivery {
 public:
  NoIntraprocessDelivery()
      : saved_(eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings()) {
    eprosima::fastrtps::LibrarySettingsAttributes off = saved_;
    off.intraprocess_delivery = eprosima::fastrtps::INTRAPROCESS_OFF;
    eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings(off);
  }
  ~NoIntraprocessDelivery() {
    eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings(saved_);
  }
  NoIntraprocessDelivery(const NoIntraprocessDelivery&) = delete;
  NoIntraprocessDelivery& operator=(const NoIntraprocessDelivery&) = delete;

 private:
  eprosima::fastrtps::LibrarySettingsAttributes saved_;
};

/// Settings of a participant that never leaves the host (DiscoveryRange::kLocalhost).
inline DdsConfig localhostConfig(int domain_id) {
  DdsConfig config;
  config.domain_id = domain_id;
  config.discovery_range = "LOCALHOST";
  config.security.enable = false;  // not ROS_SECURITY_ENABLE of the shell running the tests
  return config;
}

inline bool writerMatched(eprosima::fastdds::dds::DataWriter* writer) {
  eprosima::fastdds::dds::PublicationMatchedStatus status;
  writer->get_publication_matched_status(status);
  return status.current_count > 0;
}

inline bool readerMatched(eprosima::fastdds::dds::DataReader* reader) {
  eprosima::fastdds::dds::SubscriptionMatchedStatus status;
  reader->get_subscription_matched_status(status);
  return status.current_count > 0;
}

}  // namespace mlmap::dds::test_support
