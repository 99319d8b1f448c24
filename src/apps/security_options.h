#pragma once
/// @file
/// The DDS Security options of the tools that join mlmap_node's DDS graph as peers
/// (mlmap_inspect, mlmap_sensor_publisher): the keystore, enclave and strategy of the node's
/// `dds.security` section, from the command line. Unset options leave the configuration (and,
/// through it, the ROS 2 environment variables) in charge.

#include "mlmap/dds/transport/dds_config.h"

#include <CLI/CLI.hpp>

#include <string>

namespace mlmap::apps {

struct SecurityOptions {
  std::string keystore;  ///< --keystore: SROS2 keystore root; given, it also enables security
  std::string enclave;   ///< --enclave: e.g. /ground/monitor
  std::string strategy;  ///< --security-strategy: Enforce or Permissive

  /// Adds --keystore, --enclave and --security-strategy to `app`.
  void add(CLI::App& app) {
    app.add_option("--keystore", keystore,
                   "DDS Security: SROS2 keystore root (enables security; default: dds.security, "
                   "else ROS_SECURITY_KEYSTORE with ROS_SECURITY_ENABLE=true)")
        ->check(CLI::ExistingDirectory);
    app.add_option("--enclave", enclave,
                   "DDS Security: enclave of this program, e.g. /ground/monitor (default: "
                   "dds.security.enclave, else ROS_SECURITY_ENCLAVE_OVERRIDE)");
    app.add_option("--security-strategy", strategy,
                   "DDS Security: Enforce (refuse to start without the enclave's files) or "
                   "Permissive (warn, run unsecured) (default: dds.security.strategy, else "
                   "ROS_SECURITY_STRATEGY)")
        ->transform(
            CLI::IsMember({"Enforce", "Permissive"}, CLI::ignore_case));  // any case, as the YAML
  }

  /// Writes the options given into `security` (the command line wins over the file).
  void apply(dds::SecurityConfig* security) const {
    if (!keystore.empty()) {
      security->keystore = keystore;
      security->enable = true;
    }
    if (!enclave.empty()) security->enclave = enclave;
    if (!strategy.empty()) security->strategy = strategy;
  }
};

}  // namespace mlmap::apps
