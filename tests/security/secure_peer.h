#pragma once
// What the security tests share: the test keystore made into the build tree, the time a secure
// handshake may take, and a loopback participant's configuration as one of its enclaves.
#include "dds_test_support.h"

#include "mlmap/dds/transport/dds_config.h"

#include <chrono>
#include <optional>
#include <string>

namespace mlmap::dds::test_support {

/// The keystore tools/make_test_keystore.sh made (the ctest fixture).
inline const std::string kKeystore = MLMAP_TEST_KEYSTORE;
/// Handshakes (PKI-DH, permissions) on a loaded 2-core machine under sanitizers.
inline constexpr std::chrono::milliseconds kSecureTimeout{30000};

/// A loopback participant as `enclave` of the test keystore (Enforce); none: no credentials.
inline DdsConfig peerConfig(int domain_id, const std::optional<std::string>& enclave) {
  DdsConfig config = localhostConfig(domain_id);
  config.large_data = false;
  config.security.enable = enclave.has_value();
  if (enclave) {
    config.security.keystore = kKeystore;
    config.security.enclave = *enclave;
    config.security.strategy = "Enforce";
  }
  return config;
}

}  // namespace mlmap::dds::test_support
