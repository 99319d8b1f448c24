#include "mlmap/dds/transport/dds_config.h"

#include "mlmap/core/key_list.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <stdexcept>

namespace mlmap::dds {
namespace {

constexpr int kMaxDomainId =
    232;  // ROS 2's limit: higher ids overflow the RTPS port range on Linux

std::string upper(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

std::string number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

/// "dds.<path>" of `field`, a member (or nested member) of `dds`, from the key list.
template <class T>
std::string ddsKey(const DdsConfig& dds, const T& field) {
  return std::string(DdsConfig::kSection) + "." + keyPath(dds, field);
}

/// "dds.security.<key>" of a SecurityConfig member, from the key lists.
template <class T>
std::string securityKey(T SecurityConfig::*member) {
  static const DdsConfig kDefaults;
  return ddsKey(kDefaults, kDefaults.security.*member);
}

void checkPositive(const std::string& key, double value, std::vector<std::string>* errors) {
  if (!std::isfinite(value) || value <= 0.0) {
    errors->push_back(key + ": must be > 0 (got " + number(value) + ")");
  }
}

void checkFrame(const std::string& key, const std::string& frame,
                std::vector<std::string>* errors) {
  if (frame.empty()) {
    errors->push_back(key + ": must not be empty");
  } else if (frame[0] == '/') {
    errors->push_back(key + ": tf2 frame ids must not start with '/' (got " + frame + ")");
  } else if (frame.find_first_of(" \t\n") != std::string::npos) {
    errors->push_back(key + ": must not contain whitespace (got '" + frame + "')");
  }
}

/// Checks every key of TopicNames (a visitor of its key list): empty, or a valid ROS name.
class TopicChecker {
 public:
  TopicChecker(std::string path, std::vector<std::string>* errors)
      : path_(std::move(path)), errors_(errors) {}
  void key(const char* name, const std::string& topic, const char* /*unit*/, const char* /*doc*/) {
    if (topic.empty()) return;  // disabled
    const std::string problem = rosNameProblem(topic);
    if (!problem.empty()) {
      errors_->push_back(path_ + "." + name + ": not a valid ROS topic name: " + problem +
                         " (got '" + topic + "')");
    }
  }

 private:
  std::string path_;
  std::vector<std::string>* errors_;
};

/// Checks every key of PublishRates (a visitor of its key list): finite and >= 0.
class RateChecker {
 public:
  RateChecker(std::string path, std::vector<std::string>* errors)
      : path_(std::move(path)), errors_(errors) {}
  void key(const char* name, double hz, const char* /*unit*/, const char* /*doc*/) {
    if (!std::isfinite(hz) || hz < 0.0) {
      errors_->push_back(path_ + "." + name + ": must be >= 0 (0 disables) (got " + number(hz) +
                         ")");
    }
  }

 private:
  std::string path_;
  std::vector<std::string>* errors_;
};

/// Why `enclave` is not a valid enclave name ("" when it is): "/" or an absolute ROS name.
std::string enclaveProblem(const std::string& enclave) {
  if (enclave == "/") return "";
  if (enclave.empty() || enclave[0] != '/') return "must be an absolute name starting with '/'";
  return rosNameProblem(enclave);
}

/// The value of environment variable `name`, "" when unset.
std::string environment(const char* name) {
  const char* value =
      std::getenv(name);  // NOLINT(concurrency-mt-unsafe): nothing here sets the environment
  return value == nullptr ? std::string() : std::string(value);
}

bool parseStrategy(const std::string& text, SecurityStrategy* strategy) {
  const std::string u = upper(text);
  if (u == "ENFORCE") {
    *strategy = SecurityStrategy::kEnforce;
  } else if (u == "PERMISSIVE") {
    *strategy = SecurityStrategy::kPermissive;
  } else {
    return false;
  }
  return true;
}

}  // namespace

std::string rosNameProblem(const std::string& name) {
  const std::size_t begin = (!name.empty() && name[0] == '/') ? 1 : 0;
  if (begin == name.size()) return "must contain at least one token";
  bool token_start = true;
  for (std::size_t i = begin; i < name.size(); ++i) {
    const char c = name[i];
    if (c == '/') {
      if (token_start) return "must not contain an empty token ('//')";
      token_start = true;
      continue;
    }
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') {
      return std::string("may only contain letters, digits, '_' and '/' (found '") + c + "')";
    }
    if (token_start && std::isdigit(static_cast<unsigned char>(c))) {
      return "a token must not start with a digit";
    }
    token_start = false;
  }
  if (token_start) return "must not end with '/'";
  return "";
}

void SecurityConfig::validate(std::vector<std::string>* errors) const {
  SecurityStrategy parsed{};
  if (!strategy.empty() && !parseStrategy(strategy, &parsed)) {
    errors->push_back(securityKey(&SecurityConfig::strategy) +
                      ": must be empty (ROS_SECURITY_STRATEGY), Enforce or Permissive (got '" +
                      strategy + "')");
  }
  if (!enclave.empty()) {
    const std::string problem = enclaveProblem(enclave);
    if (!problem.empty()) {
      errors->push_back(securityKey(&SecurityConfig::enclave) +
                        ": not a valid enclave name: " + problem + " (got '" + enclave + "')");
    }
  }
  if (keystore.find_first_of("\n\r") != std::string::npos) {
    errors->push_back(securityKey(&SecurityConfig::keystore) +
                      ": must not contain a line break (got '" + keystore + "')");
  }
}

SecuritySetup resolveSecurity(const SecurityConfig& config) {
  std::vector<std::string> errors;
  config.validate(&errors);
  if (!errors.empty()) throw std::invalid_argument(errors.front());

  SecuritySetup setup;
  // rcl: security is on only for the exact text "true", enforced only for the exact "Enforce".
  setup.requested = config.enable ? *config.enable : environment("ROS_SECURITY_ENABLE") == "true";
  if (!config.strategy.empty()) {
    parseStrategy(config.strategy, &setup.strategy);
  } else {
    setup.strategy = environment("ROS_SECURITY_STRATEGY") == "Enforce"
                         ? SecurityStrategy::kEnforce
                         : SecurityStrategy::kPermissive;
  }
  setup.enclave = config.enclave;
  if (setup.enclave.empty()) {
    setup.enclave = environment("ROS_SECURITY_ENCLAVE_OVERRIDE");
    if (setup.enclave.empty()) {
      setup.enclave = "/";
    } else if (const std::string problem = enclaveProblem(setup.enclave); !problem.empty()) {
      throw std::invalid_argument("ROS_SECURITY_ENCLAVE_OVERRIDE: not a valid enclave name: " +
                                  problem + " (got '" + setup.enclave + "')");
    }
  }
  setup.keystore = config.keystore.empty() ? environment("ROS_SECURITY_KEYSTORE") : config.keystore;
  if (!setup.requested) return setup;

  // Enforce: refuse. Permissive: warn and run unsecured (rcl / rmw_fastrtps).
  auto unusable = [&setup](const std::string& problem) {
    if (setup.strategy == SecurityStrategy::kEnforce) {
      throw std::invalid_argument("DDS Security (strategy Enforce): " + problem);
    }
    setup.warning = "DDS Security requested but " + problem +
                    ": running WITHOUT security (strategy Permissive; set " +
                    securityKey(&SecurityConfig::strategy) +
                    " or ROS_SECURITY_STRATEGY to Enforce to refuse instead)";
    return setup;
  };
  if (setup.keystore.empty()) {
    return unusable("no keystore is set (" + securityKey(&SecurityConfig::keystore) +
                    " or ROS_SECURITY_KEYSTORE)");
  }
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path dir = fs::absolute(fs::path(setup.keystore), ec) / "enclaves";
  if (setup.enclave != "/") dir /= setup.enclave.substr(1);
  dir = dir.lexically_normal();
  setup.enclave_dir = dir.string();
  if (!fs::is_directory(dir, ec)) {
    return unusable(
        "enclave '" + setup.enclave + "' has no folder " + setup.enclave_dir + " in keystore " +
        setup.keystore +
        " (make it with `ros2 security create_enclave` or tools/make_test_keystore.sh)");
  }
  std::string missing;
  for (const char* name : kSecurityFileNames) {
    if (!fs::is_regular_file(dir / name, ec))
      missing += (missing.empty() ? "" : ", ") + (dir / name).string();
  }
  if (!missing.empty()) {
    return unusable("enclave '" + setup.enclave + "' is missing " + missing);
  }
  auto uri = [&dir](const char* name) { return "file://" + (dir / name).string(); };
  setup.properties = {
      {"dds.sec.auth.plugin", "builtin.PKI-DH"},
      {"dds.sec.auth.builtin.PKI-DH.identity_ca", uri("identity_ca.cert.pem")},
      {"dds.sec.auth.builtin.PKI-DH.identity_certificate", uri("cert.pem")},
      {"dds.sec.auth.builtin.PKI-DH.private_key", uri("key.pem")},
      {"dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC"},
      {"dds.sec.access.plugin", "builtin.Access-Permissions"},
      {"dds.sec.access.builtin.Access-Permissions.permissions_ca", uri("permissions_ca.cert.pem")},
      {"dds.sec.access.builtin.Access-Permissions.governance", uri("governance.p7s")},
      {"dds.sec.access.builtin.Access-Permissions.permissions", uri("permissions.p7s")},
  };
  // A revocation list, when the enclave has one (as rmw_fastrtps: revoked identities are refused).
  if (fs::is_regular_file(dir / "crl.pem", ec)) {
    setup.properties.push_back({"dds.sec.auth.builtin.PKI-DH.identity_crl", uri("crl.pem")});
  }
  return setup;
}

std::string resolveFleetVehicle(const DdsConfig& config) {
  if (!config.fleet.vehicle.empty()) return config.fleet.vehicle;
  std::string name = config.ns;
  while (!name.empty() && name.front() == '/') name.erase(name.begin());
  while (!name.empty() && name.back() == '/') name.pop_back();
  return name;
}

bool parseDiscoveryRange(const std::string& text, DiscoveryRange* range) {
  const std::string u = upper(text);
  if (u == "LOCALHOST") {
    *range = DiscoveryRange::kLocalhost;
  } else if (u == "SUBNET") {
    *range = DiscoveryRange::kSubnet;
  } else if (u == "OFF") {
    *range = DiscoveryRange::kOff;
  } else if (u == "SYSTEM_DEFAULT") {
    *range = DiscoveryRange::kSystemDefault;
  } else {
    return false;
  }
  return true;
}

const char* toString(DiscoveryRange range) {
  switch (range) {
    case DiscoveryRange::kSystemDefault:
      return "SYSTEM_DEFAULT";
    case DiscoveryRange::kLocalhost:
      return "LOCALHOST";
    case DiscoveryRange::kSubnet:
      return "SUBNET";
    case DiscoveryRange::kOff:
      return "OFF";
  }
  return "?";
}

std::vector<std::string> DdsConfig::validate() const {
  std::vector<std::string> errors;
  const auto key = [this](const auto& field) { return ddsKey(*this, field); };
  if (domain_id < -1 || domain_id > kMaxDomainId) {
    errors.push_back(key(domain_id) + ": must be -1 (ROS_DOMAIN_ID, else 0) or 0.." +
                     std::to_string(kMaxDomainId) + " (got " + std::to_string(domain_id) + ")");
  }
  if (!ns.empty()) {
    const std::string problem = rosNameProblem(ns);
    if (!problem.empty()) {
      errors.push_back(key(ns) + ": not a valid ROS namespace: " + problem + " (got '" + ns + "')");
    }
  }
  DiscoveryRange range{};
  if (!discovery_range.empty() && !parseDiscoveryRange(discovery_range, &range)) {
    errors.push_back(key(discovery_range) +
                     ": must be empty, LOCALHOST, SUBNET, OFF or SYSTEM_DEFAULT (got " +
                     discovery_range + ")");
  }
  try {
    parseStaticPeers(static_peers, key(static_peers));
  } catch (const std::invalid_argument& e) {
    errors.emplace_back(e.what());
  }
  if (!profiles_file.empty() && participant_profile.empty()) {
    errors.push_back(key(participant_profile) + ": must name the participant profile to use from " +
                     key(profiles_file) + " (" + profiles_file + "), e.g. mlmap_loopback");
  }
  checkFrame(key(world_frame), world_frame, &errors);
  checkFrame(key(odom_frame), odom_frame, &errors);
  checkFrame(key(body_frame), body_frame, &errors);
  checkFrame(key(sensor_frame), sensor_frame, &errors);
  if (!frame_prefix.empty()) {
    checkFrame(key(frame_prefix), frame_prefix, &errors);
    if (frame_prefix.back() == '/') {
      errors.push_back(key(frame_prefix) + ": give it without the trailing '/' (got " +
                       frame_prefix + ")");
    }
  }
  TfMode mode{};
  const bool mode_ok = tf_mode == "auto" || parseTfMode(tf_mode, &mode);
  if (!mode_ok) {
    errors.push_back(key(tf_mode) + ": must be auto, none, map_odom or world_body (got " + tf_mode +
                     ")");
  }
  if (sensor_extrinsic != "config" && sensor_extrinsic != "tf_static") {
    errors.push_back(key(sensor_extrinsic) + ": must be config or tf_static (got " +
                     sensor_extrinsic + ")");
  } else if (sensor_extrinsic == "tf_static" && publish_sensor_tf) {
    errors.push_back(key(publish_sensor_tf) + ": must be false when " + key(sensor_extrinsic) +
                     " is tf_static (the node would read back the transform it publishes)");
  }
  if (mode_ok) {
    const FrameNames f = resolveFrames(*this);
    const TfMode resolved = resolveTfMode(*this);
    if (resolved != TfMode::kNone && f.world == f.body) {
      errors.push_back(key(world_frame) + " and " + key(body_frame) + ": must differ with " +
                       key(tf_mode) + " " + toString(resolved) + " (both " + f.world + ")");
    }
    if (resolved == TfMode::kMapOdom && (f.odom == f.world || f.odom == f.body)) {
      errors.push_back(key(odom_frame) + ": must differ from the world and body frames with " +
                       key(tf_mode) + " map_odom (got " + f.odom + ")");
    }
  }

  TopicChecker topic_checker(key(topics), &errors);
  visitConfig(topics, topic_checker);
  if (!topics.depth_image.empty() && topics.camera_info.empty()) {
    errors.push_back(key(topics.camera_info) + ": must be set when " + key(topics.depth_image) +
                     " is (the depth image is unprojected with its intrinsics)");
  }

  RateChecker rate_checker(key(rates), &errors);
  visitConfig(rates, rate_checker);

  if (!std::isfinite(fleet.rate_hz) || fleet.rate_hz < 0.0 ||
      (fleet.publish && fleet.rate_hz == 0.0)) {
    errors.push_back(key(fleet.rate_hz) + ": must be finite and > 0 (>= 0 when " +
                     key(fleet.publish) + " is false) (got " + number(fleet.rate_hz) + ")");
  }
  if (fleet.publish || fleet.subscribe || !fleet.topic.empty()) {
    const std::string problem = fleet.topic.empty() ? "empty" : rosNameProblem(fleet.topic);
    if (!problem.empty()) {
      errors.push_back(key(fleet.topic) + ": not a valid ROS topic name: " + problem + " (got '" +
                       fleet.topic + "')");
    }
  }
  if (!fleet.vehicle.empty()) {
    const std::string problem = rosNameProblem(fleet.vehicle);
    if (!problem.empty()) {
      errors.push_back(key(fleet.vehicle) + ": not a valid ROS name: " + problem + " (got '" +
                       fleet.vehicle + "')");
    }
  } else if ((fleet.publish || fleet.subscribe) && resolveFleetVehicle(*this).empty()) {
    errors.push_back(key(fleet.vehicle) + ": must name the vehicle when " + key(ns) +
                     " is empty and " + key(fleet.publish) + " or " + key(fleet.subscribe) +
                     " is true");
  }

  for (const double* positive : {&pose_tolerance_s, &pose_buffer_s, &max_future_s,
                                 &max_pose_speed_mps, &max_pose_rotation_rate_dps}) {
    checkPositive(key(*positive), *positive, &errors);
  }
  if (!std::isfinite(esdf_slice_height_m)) {
    errors.push_back(key(esdf_slice_height_m) + ": must be a finite number (got " +
                     number(esdf_slice_height_m) + ")");
  }
  security.validate(&errors);
  return errors;
}

bool parseTfMode(const std::string& text, TfMode* mode) {
  if (text == "none") {
    *mode = TfMode::kNone;
  } else if (text == "map_odom") {
    *mode = TfMode::kMapOdom;
  } else if (text == "world_body") {
    *mode = TfMode::kWorldBody;
  } else {
    return false;
  }
  return true;
}

const char* toString(TfMode mode) {
  switch (mode) {
    case TfMode::kNone:
      return "none";
    case TfMode::kMapOdom:
      return "map_odom";
    case TfMode::kWorldBody:
      return "world_body";
  }
  return "?";
}

TfMode resolveTfMode(const DdsConfig& config) {
  if (config.tf_mode == "auto") {
    return config.topics.odometry.empty() ? TfMode::kWorldBody : TfMode::kNone;
  }
  TfMode mode{};
  if (!parseTfMode(config.tf_mode, &mode)) {
    throw std::invalid_argument("dds.tf_mode: unknown value '" + config.tf_mode + "'");
  }
  return mode;
}

ExtrinsicSource resolveExtrinsicSource(const DdsConfig& config) {
  if (config.sensor_extrinsic == "config") return ExtrinsicSource::kConfig;
  if (config.sensor_extrinsic == "tf_static") return ExtrinsicSource::kTfStatic;
  throw std::invalid_argument("dds.sensor_extrinsic: unknown value '" + config.sensor_extrinsic +
                              "'");
}

FrameNames resolveFrames(const DdsConfig& config) {
  const auto prefixed = [&config](const std::string& frame) {
    return config.frame_prefix.empty() ? frame : config.frame_prefix + "/" + frame;
  };
  return FrameNames{config.world_frame, prefixed(config.odom_frame), prefixed(config.body_frame),
                    prefixed(config.sensor_frame)};
}

std::string ddsTopicName(const std::string& ns, const std::string& name) {
  std::string out = "rt";
  // Appends the '/'-separated tokens of `part`, dropping empty ones (leading, trailing, '//').
  auto append = [&out](const std::string& part) {
    std::size_t begin = 0;
    while (begin <= part.size()) {
      std::size_t end = part.find('/', begin);
      if (end == std::string::npos) end = part.size();
      if (end > begin) out += "/" + part.substr(begin, end - begin);
      begin = end + 1;
    }
  };
  append(ns);
  append(name);
  return out;
}

int resolveDomainId(const DdsConfig& config) {
  if (config.domain_id >= 0) return config.domain_id;
  const std::string text = environment("ROS_DOMAIN_ID");
  if (text.empty()) return 0;  // ROS 2 treats an empty value as unset
  const char* env = text.c_str();
  errno = 0;
  char* end = nullptr;
  const long value = std::strtol(env, &end, 10);
  while (end != nullptr && std::isspace(static_cast<unsigned char>(*end))) ++end;
  if (errno != 0 || end == env || *end != '\0' || value < 0 || value > kMaxDomainId) {
    throw std::invalid_argument(std::string("ROS_DOMAIN_ID must be an integer in 0..") +
                                std::to_string(kMaxDomainId) + " (got '" + env + "')");
  }
  return static_cast<int>(value);
}

DiscoveryRange resolveDiscoveryRange(const DdsConfig& config) {
  DiscoveryRange range = DiscoveryRange::kSystemDefault;
  if (!config.discovery_range.empty()) {
    if (!parseDiscoveryRange(config.discovery_range, &range)) {
      throw std::invalid_argument(ddsKey(config, config.discovery_range) +
                                  " must be LOCALHOST, SUBNET, OFF or SYSTEM_DEFAULT (got '" +
                                  config.discovery_range + "')");
    }
    return range;
  }
  const std::string env = environment("ROS_AUTOMATIC_DISCOVERY_RANGE");
  if (env.empty()) return DiscoveryRange::kSubnet;  // rcl's default when nothing sets it
  if (!parseDiscoveryRange(env, &range)) {
    throw std::invalid_argument(std::string("ROS_AUTOMATIC_DISCOVERY_RANGE must be LOCALHOST, "
                                            "SUBNET, OFF or SYSTEM_DEFAULT (got '") +
                                env + "')");
  }
  return range;
}

std::vector<std::string> parseStaticPeers(const std::string& text, const std::string& source) {
  std::vector<std::string> peers;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    std::size_t end = text.find(';', begin);
    if (end == std::string::npos) end = text.size();
    std::string peer = text.substr(begin, end - begin);
    const auto is_space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
    while (!peer.empty() && is_space(peer.back())) peer.pop_back();
    std::size_t first = 0;
    while (first < peer.size() && is_space(peer[first])) ++first;
    peer.erase(0, first);
    begin = end + 1;
    if (peer.empty()) continue;
    if (peer.size() > kMaxStaticPeerLength) {
      throw std::invalid_argument(source + ": a static peer is longer than " +
                                  std::to_string(kMaxStaticPeerLength) + " characters ('" +
                                  peer.substr(0, 40) + "...')");
    }
    if (std::any_of(peer.begin(), peer.end(), is_space)) {
      throw std::invalid_argument(
          source + ": static peers are separated by ';', not spaces (got '" + peer + "')");
    }
    if (peers.size() == kMaxStaticPeers) {
      throw std::invalid_argument(source + ": more than " + std::to_string(kMaxStaticPeers) +
                                  " static peers");
    }
    peers.push_back(std::move(peer));
  }
  return peers;
}

std::vector<std::string> resolveStaticPeers(const DdsConfig& config) {
  if (!config.static_peers.empty()) {
    return parseStaticPeers(config.static_peers, ddsKey(config, config.static_peers));
  }
  return parseStaticPeers(environment("ROS_STATIC_PEERS"), "ROS_STATIC_PEERS");
}

}  // namespace mlmap::dds
