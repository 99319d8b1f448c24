// dds.security: the YAML keys and their checks, the ROS 2 environment variables read as rcl reads
// them, the SROS2 file lookup, the properties rmw_fastrtps sets, and the Enforce / Permissive
// fallbacks. No participant talks to another here (test_secure_graph.cpp does that).
#include "mlmap/dds/node/node_config.h"
#include "mlmap/dds/transport/participant.h"

#include "expect_throw.h"
#include "scoped_env.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fs = std::filesystem;
using mlmap::testing::expectThrowWith;
using test_support::ScopedEnv;

const std::string kKeystore = MLMAP_TEST_KEYSTORE;

/// Every ROS_SECURITY_* variable unset (or set as given) for one test.
struct SecurityEnv {
  ScopedEnv enable, keystore, enclave, strategy;
  explicit SecurityEnv(std::optional<std::string> enable_value = std::nullopt,
                       std::optional<std::string> keystore_value = std::nullopt,
                       std::optional<std::string> enclave_value = std::nullopt,
                       std::optional<std::string> strategy_value = std::nullopt)
      : enable("ROS_SECURITY_ENABLE", enable_value),
        keystore("ROS_SECURITY_KEYSTORE", keystore_value),
        enclave("ROS_SECURITY_ENCLAVE_OVERRIDE", enclave_value),
        strategy("ROS_SECURITY_STRATEGY", strategy_value) {}
};

TEST(SecurityConfigYaml, KeysAreReadAndRoundTripAndAnUnsetEnableStaysUnset) {
  const NodeConfig c = parseNodeConfigYaml(
      "dds:\n  security: {enable: true, keystore: /ks, enclave: /mlmap/node, strategy: Enforce}\n",
      "node.yaml");
  ASSERT_TRUE(c.dds.security.enable.has_value());
  EXPECT_TRUE(*c.dds.security.enable);
  EXPECT_EQ(c.dds.security.keystore, "/ks");
  EXPECT_EQ(c.dds.security.enclave, "/mlmap/node");
  EXPECT_EQ(c.dds.security.strategy, "Enforce");
  const NodeConfig again = parseNodeConfigYaml(toYaml(c), "printed");
  EXPECT_EQ(again.dds.security.enable, c.dds.security.enable);
  EXPECT_EQ(again.dds.security.keystore, "/ks");
  EXPECT_EQ(again.dds.security.enclave, "/mlmap/node");
  EXPECT_EQ(again.dds.security.strategy, "Enforce");

  // Absent, or present without a value: the environment decides (also after printing).
  EXPECT_FALSE(parseNodeConfigYaml("dds: {security: {enable: }}\n", "n").dds.security.enable);
  const NodeConfig defaults;
  EXPECT_FALSE(defaults.dds.security.enable.has_value());
  EXPECT_FALSE(parseNodeConfigYaml(toYaml(defaults), "printed").dds.security.enable.has_value());
  const NodeConfig off = parseNodeConfigYaml("dds: {security: {enable: false}}\n", "n");
  ASSERT_TRUE(off.dds.security.enable.has_value());
  EXPECT_FALSE(*off.dds.security.enable);
}

TEST(SecurityConfigYaml, BadValuesAreErrorsNamingTheKey) {
  const std::pair<const char*, const char*> cases[] = {
      {"{strategy: Strict}",
       "dds.security.strategy: must be empty (ROS_SECURITY_STRATEGY), Enforce or Permissive"},
      {"{enclave: mlmap/node}", "dds.security.enclave: not a valid enclave name"},
      {"{enclave: /mlmap//node}", "dds.security.enclave: not a valid enclave name"},
      {"{enable: maybe}", "dds.security.enable: cannot read"},
      {"{keystor: /ks}", "dds.security.keystor: unknown key"}};
  for (const auto& c : cases) {
    const std::string yaml = std::string("dds: {security: ") + c.first + "}\n";
    expectThrowWith([&yaml] { parseNodeConfigYaml(yaml, "node.yaml"); }, {"node.yaml", c.second});
  }
  EXPECT_NO_THROW(
      parseNodeConfigYaml("dds: {security: {strategy: permissive, enclave: /}}\n", "n"));
}

/// The properties rmw_fastrtps sets for an enclave folder, written out by hand.
std::vector<std::pair<std::string, std::string>> rmwProperties(const std::string& dir) {
  const std::string f = "file://" + dir + "/";
  return {
      {"dds.sec.auth.plugin", "builtin.PKI-DH"},
      {"dds.sec.auth.builtin.PKI-DH.identity_ca", f + "identity_ca.cert.pem"},
      {"dds.sec.auth.builtin.PKI-DH.identity_certificate", f + "cert.pem"},
      {"dds.sec.auth.builtin.PKI-DH.private_key", f + "key.pem"},
      {"dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC"},
      {"dds.sec.access.plugin", "builtin.Access-Permissions"},
      {"dds.sec.access.builtin.Access-Permissions.permissions_ca", f + "permissions_ca.cert.pem"},
      {"dds.sec.access.builtin.Access-Permissions.governance", f + "governance.p7s"},
      {"dds.sec.access.builtin.Access-Permissions.permissions", f + "permissions.p7s"}};
}

TEST(ResolveSecurity, TheRos2VariablesAloneSecureAParticipantAsRmwFastrtps) {
  // cppcheck-suppress unreadVariable ; it sets the variables for its scope
  const SecurityEnv env("true", kKeystore, "/mlmap/node", "Enforce");
  const SecuritySetup s = resolveSecurity(SecurityConfig{});
  EXPECT_TRUE(s.requested);
  EXPECT_TRUE(s.enabled());
  EXPECT_EQ(s.strategy, SecurityStrategy::kEnforce);
  EXPECT_EQ(s.enclave, "/mlmap/node");
  const std::string dir =
      (fs::absolute(kKeystore) / "enclaves/mlmap/node").lexically_normal().string();
  EXPECT_EQ(s.enclave_dir, dir);
  EXPECT_EQ(s.properties, rmwProperties(dir));
  EXPECT_EQ(s.warning, "");

  // In the participant's QoS, with the user data ROS 2 graph tools read.
  DdsConfig dds;
  dds.domain_id = 199;
  dds.discovery_range = "LOCALHOST";
  const ParticipantSetup setup = participantSetup(dds, "secured");
  for (const auto& [name, value] : rmwProperties(dir)) {
    const std::string* found =
        eprosima::fastrtps::rtps::PropertyPolicyHelper::find_property(setup.qos.properties(), name);
    ASSERT_NE(found, nullptr) << name;
    EXPECT_EQ(*found, value);
  }
  const std::vector<unsigned char>& user_data = setup.qos.user_data().data_vec();
  EXPECT_EQ(std::string(user_data.begin(), user_data.end()), "enclave=/mlmap/node;");
}

TEST(ResolveSecurity, VariablesAreReadExactlyAsRclDoesAndTheConfigWins) {
  {
    const SecurityEnv env("True", kKeystore, "/mlmap/node");  // rcl: only "true" enables
    EXPECT_FALSE(resolveSecurity(SecurityConfig{}).requested);
  }
  {
    const SecurityEnv env("true", kKeystore, "/mlmap/node", "enforce");  // only "Enforce" enforces
    EXPECT_EQ(resolveSecurity(SecurityConfig{}).strategy, SecurityStrategy::kPermissive);
  }
  {
    const SecurityEnv env;  // nothing set: unsecured, enclave "/"
    const SecuritySetup s = resolveSecurity(SecurityConfig{});
    EXPECT_FALSE(s.requested);
    EXPECT_FALSE(s.enabled());
    EXPECT_EQ(s.enclave, "/");
    DdsConfig dds;
    dds.domain_id = 199;
    const ParticipantSetup setup = participantSetup(dds, "plain");
    EXPECT_EQ(eprosima::fastrtps::rtps::PropertyPolicyHelper::find_property(setup.qos.properties(),
                                                                            "dds.sec.auth.plugin"),
              nullptr);
  }
  {
    const SecurityEnv env("true", "/nowhere", "/stranger", "Permissive");
    SecurityConfig config;
    config.keystore = kKeystore;
    config.enclave = "/ground/monitor";
    config.strategy = "Enforce";
    const SecuritySetup s = resolveSecurity(config);
    EXPECT_TRUE(s.enabled());
    EXPECT_EQ(s.enclave, "/ground/monitor");
    EXPECT_EQ(s.strategy, SecurityStrategy::kEnforce);
    config.enable = false;
    EXPECT_FALSE(resolveSecurity(config).requested);
  }
  {
    const SecurityEnv env("true", kKeystore, "ground/monitor");
    expectThrowWith<std::invalid_argument>([] { resolveSecurity(SecurityConfig{}); },
                                           {"ROS_SECURITY_ENCLAVE_OVERRIDE", "ground/monitor"});
  }
}

/// A copy of the /ground/monitor enclave without `missing`, in its own keystore.
std::string keystoreWithout(const std::string& missing) {
  const fs::path root = fs::temp_directory_path() / ("mlmap_security_without_" + missing);
  fs::remove_all(root);
  fs::create_directories(root / "enclaves/ground/monitor");
  for (const char* name : kSecurityFileNames) {
    if (name != missing) {
      fs::copy_file(fs::path(kKeystore) / "enclaves/ground/monitor" / name,
                    root / "enclaves/ground/monitor" / name);
    }
  }
  return root.string();
}

TEST(ResolveSecurity, AMissingFileStopsEnforceNamingItAndPermissiveRunsUnsecuredWithAWarning) {
  const SecurityEnv env;
  for (const char* name : kSecurityFileNames) {
    SecurityConfig config;
    config.enable = true;
    config.keystore = keystoreWithout(name);
    config.enclave = "/ground/monitor";
    config.strategy = "Enforce";
    expectThrowWith<std::invalid_argument>(
        [&] { resolveSecurity(config); },
        {"Enforce", std::string("enclaves/ground/monitor/") + name});
    DdsConfig dds;
    dds.domain_id = 199;
    dds.discovery_range = "LOCALHOST";
    dds.security = config;
    EXPECT_THROW(participantSetup(dds, "enforced"), std::runtime_error);

    dds.security.strategy = "Permissive";
    const ParticipantSetup setup = participantSetup(dds, "permissive");
    EXPECT_TRUE(setup.security.requested);
    EXPECT_FALSE(setup.security.enabled());
    // The missing file's path (the keystore's folder name also holds `name`).
    EXPECT_NE(setup.security.warning.find(std::string("enclaves/ground/monitor/") + name),
              std::string::npos)
        << setup.security.warning;
    EXPECT_NE(setup.security.warning.find("WITHOUT security"), std::string::npos);
    EXPECT_EQ(eprosima::fastrtps::rtps::PropertyPolicyHelper::find_property(setup.qos.properties(),
                                                                            "dds.sec.auth.plugin"),
              nullptr);
    fs::remove_all(config.keystore);
  }
  // No keystore at all, and an enclave without a folder.
  SecurityConfig config;
  config.enable = true;
  config.strategy = "Enforce";
  expectThrowWith<std::invalid_argument>([&] { resolveSecurity(config); },
                                         {"ROS_SECURITY_KEYSTORE"});
  config.keystore = kKeystore;
  config.enclave = "/no/such/enclave";
  expectThrowWith<std::invalid_argument>([&] { resolveSecurity(config); },
                                         {"enclaves/no/such/enclave"});
  config.strategy = "Permissive";
  EXPECT_FALSE(resolveSecurity(config).enabled());
}

TEST(ResolveSecurity, ARevocationListInTheEnclaveIsPassedOnAsRmwFastrtpsDoes) {
  const SecurityEnv env;
  SecurityConfig config;
  config.enable = true;
  config.keystore = keystoreWithout("none");  // a complete copy of /ground/monitor
  config.enclave = "/ground/monitor";
  const fs::path dir = fs::path(config.keystore) / "enclaves/ground/monitor";
  EXPECT_EQ(resolveSecurity(config).properties.size(), rmwProperties(dir.string()).size());
  fs::copy_file(dir / "identity_ca.cert.pem", dir / "crl.pem");  // any file: only passed on here
  const SecuritySetup s = resolveSecurity(config);
  auto expected = rmwProperties(fs::absolute(dir).lexically_normal().string());
  expected.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_crl",
                        "file://" + fs::absolute(dir / "crl.pem").lexically_normal().string());
  EXPECT_EQ(s.properties, expected);
  fs::remove_all(config.keystore);
}

TEST(ResolveSecurity, AProfilesOwnSecurityPropertiesAreKept) {
  const SecurityEnv env;
  const fs::path xml = fs::temp_directory_path() / "mlmap_security_profile_keeps.xml";
  {
    std::ofstream out(xml);
    out << R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"><profiles>
  <participant profile_name="mlmap_security_keeps"><rtps><propertiesPolicy><properties>
    <property><name>dds.sec.access.builtin.Access-Permissions.permissions</name>
              <value>file:///elsewhere/permissions.p7s</value></property>
  </properties></propertiesPolicy></rtps></participant>
</profiles></dds>
)";
  }
  DdsConfig dds;
  dds.domain_id = 199;
  dds.profiles_file = xml.string();
  dds.participant_profile = "mlmap_security_keeps";
  dds.security.enable = true;
  dds.security.keystore = kKeystore;
  dds.security.enclave = "/mlmap/node";
  const ParticipantSetup setup = participantSetup(dds, "profiled");
  const auto& properties = setup.qos.properties();
  using eprosima::fastrtps::rtps::PropertyPolicyHelper;
  EXPECT_EQ(*PropertyPolicyHelper::find_property(
                properties, "dds.sec.access.builtin.Access-Permissions.permissions"),
            "file:///elsewhere/permissions.p7s");
  ASSERT_NE(PropertyPolicyHelper::find_property(properties, "dds.sec.auth.plugin"), nullptr);
  for (const auto& [name, value] : rmwProperties("")) {  // each once: the profile's not doubled
    std::size_t n = 0;
    for (const auto& p : properties.properties()) n += p.name() == name ? 1 : 0;
    EXPECT_EQ(n, 1u) << name;
  }
  fs::remove(xml);
}

}  // namespace
}  // namespace mlmap::dds
