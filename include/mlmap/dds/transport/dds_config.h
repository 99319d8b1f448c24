#pragma once
/// @file
/// Configuration of the DDS component (the `dds` section of the node's YAML file) and the ROS 2
/// naming rules it follows.
///
/// Resolution order for the domain, the discovery range and the static peers, as ROS 2 does: the
/// config value when set, else the environment (ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE,
/// ROS_STATIC_PEERS), else the ROS 2 default (domain 0, SUBNET, no peers).
/// FASTRTPS_DEFAULT_PROFILES_FILE is read by Fast DDS itself; a
/// `profiles_file` in the config is loaded on top of it.

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace mlmap::dds {

/// ROS_AUTOMATIC_DISCOVERY_RANGE.
enum class DiscoveryRange {
  kSystemDefault,  ///< SYSTEM_DEFAULT: the middleware's own defaults (the static peers ignored)
  kLocalhost,      ///< unicast discovery to 127.0.0.1 (and the static peers), no multicast
  kSubnet,         ///< Fast DDS built-in transports, multicast discovery (a vehicle LAN)
  kOff,            ///< no automatic discovery: no multicast, and only the profile's own initial
                   ///< peers are contacted (none added); peers that list this host still find it
};
/// Parses "LOCALHOST", "SUBNET", "OFF", "SYSTEM_DEFAULT" (case-insensitive). False otherwise.
bool parseDiscoveryRange(const std::string& text, DiscoveryRange* range);
const char* toString(DiscoveryRange range);

/// Topic names (ROS names, without `rt/` and without the namespace). Empty input names disable
/// that input; empty output names disable that output. Inputs are BEST_EFFORT readers (they
/// match any publisher), outputs RELIABLE writers. Keys and meanings: visit() (as the engine's
/// config structs, mlmap/core/config.h).
struct TopicNames {
  std::string cloud = "cloud";                           ///< key cloud (input)
  std::string pose = "pose";                             ///< key pose (input)
  std::string odometry = "";                             ///< key odometry (input)
  std::string depth_image = "";                          ///< key depth_image (input)
  std::string camera_info = "";                          ///< key camera_info (input)
  std::string awareness = "mlmap/awareness/occupied";    ///< key awareness (output)
  std::string local_map = "mlmap/local_map/occupied";    ///< key local_map (output)
  std::string global_map = "mlmap/global_map/occupied";  ///< key global_map (output)
  std::string grid = "mlmap/grid";                       ///< key grid (output)
  std::string map_grid = "mlmap/map";                    ///< key map_grid (output)
  std::string esdf_slice = "mlmap/esdf/slice";           ///< key esdf_slice (output)
  std::string esdf_block = "mlmap/esdf/block";           ///< key esdf_block (output)
  std::string status = "mlmap/status";                   ///< key status (output)

  /// The keys of `dds.topics`: visitor.key(name, field, unit, doc) for each.
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("cloud", c.cloud, "",
          "in: sensor_msgs/PointCloud2 in the sensor frame (BEST_EFFORT reader: matches any "
          "publisher)");
    v.key("pose", c.pose, "", "in: geometry_msgs/PoseStamped, T_W_B");
    v.key("odometry", c.odometry, "", "in: nav_msgs/Odometry, alternative to pose");
    v.key("depth_image", c.depth_image, "",
          "in: sensor_msgs/Image 16UC1 [mm] or 32FC1 [m]; needs camera_info");
    v.key("camera_info", c.camera_info, "", "in: sensor_msgs/CameraInfo of the depth image");
    v.key("awareness", c.awareness, "", "out: PointCloud2 of the awareness map's occupied cells");
    v.key("local_map", c.local_map, "", "out: PointCloud2 of the local map's occupied voxels");
    v.key("global_map", c.global_map, "",
          "out: PointCloud2, TRANSIENT_LOCAL (late joiners get the last one)");
    v.key("grid", c.grid, "", "out: nav_msgs/OccupancyGrid, TRANSIENT_LOCAL");
    v.key("map_grid", c.map_grid, "",
          "out: OccupancyGrid with a fixed origin that grows in 64-cell chunks as the vehicle\n"
          "explores (every rolling grid's known cells, the latest winning): a static map for\n"
          "a global costmap (nav2's static layer, docs/planners.md)");
    v.key("esdf_slice", c.esdf_slice, "",
          "out: PointCloud2 with `intensity` = signed distance [m]");
    v.key("esdf_block", c.esdf_block, "", "out: mlmap_msgs/VoxelBlock");
    v.key("status", c.status, "", "out: mlmap_msgs/Status");
  }
};

/// Publishing rates [Hz] of the outputs (0 disables that output). Outputs are published from
/// their own thread at most at these rates, and only when their content changed. Keys: visit().
struct PublishRates {
  double awareness_hz = 10.0;  ///< key awareness_hz
  double local_map_hz = 5.0;   ///< key local_map_hz
  double global_map_hz = 0.5;  ///< key global_map_hz
  double grid_hz = 2.0;        ///< key grid_hz
  double map_grid_hz = 0.5;    ///< key map_grid_hz
  double esdf_hz = 2.0;        ///< key esdf_hz
  double status_hz = 1.0;      ///< key status_hz

  /// The keys of `dds.rates`: visitor.key(name, field, unit, doc) for each.
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("awareness_hz", c.awareness_hz, "Hz", "topics.awareness");
    v.key("local_map_hz", c.local_map_hz, "Hz", "topics.local_map");
    v.key("global_map_hz", c.global_map_hz, "Hz", "topics.global_map");
    v.key("grid_hz", c.grid_hz, "Hz", "topics.grid");
    v.key("map_grid_hz", c.map_grid_hz, "Hz", "topics.map_grid");
    v.key("esdf_hz", c.esdf_hz, "Hz", "topics.esdf_slice and topics.esdf_block");
    v.key("status_hz", c.status_hz, "Hz", "topics.status");
  }
};

/// The `dds.fleet` section: sharing this vehicle's map with the fleet (docs/fleet.md). Each
/// submap whose occupied content changed goes out as one mlmap_msgs/Submap sample on the
/// vehicle's own keyed topic /<vehicle>/<topic> (vehicleSubmapTopic(): the vehicle's name, not
/// dds.ns, is its namespace, so that DDS Security permissions can let a vehicle publish only its
/// own), RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1 per submap, at most `rate_hz` times a second.
/// Keys: visit().
struct FleetShareConfig {
  bool publish = false;                 ///< key publish
  bool subscribe = false;               ///< key subscribe
  std::string vehicle;                  ///< key vehicle ("": the namespace, resolveFleetVehicle())
  double rate_hz = 1.0;                 ///< key rate_hz
  std::string topic = "mlmap/submaps";  ///< key topic

  /// The keys of `dds.fleet`: visitor.key(name, field, unit, doc) for each.
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("publish", c.publish, "",
          "share the map: each changed submap's occupied voxels on /<vehicle>/<topic>\n"
          "(mlmap_fleet merges them)");
    v.key("subscribe", c.subscribe, "",
          "take the other vehicles' submaps (each on its /<vehicle>/<topic>, found by\n"
          "discovery) as prior knowledge: entering an area another vehicle mapped restores\n"
          "its obstacles before this sensor sees them");
    v.key("vehicle", c.vehicle, "", "this vehicle's name in the fleet; \"\": the namespace dds.ns");
    v.key("rate_hz", c.rate_hz, "Hz", "changed submaps go out at most this often");
    v.key("topic", c.topic, "",
          "keyed mlmap_msgs/Submap topic, under the vehicle's name: /<vehicle>/<topic>");
  }
};

/// ROS_SECURITY_STRATEGY: what a participant does when security is enabled but its enclave's
/// files are missing.
enum class SecurityStrategy {
  kPermissive,  ///< warn and run unsecured (ROS 2's default)
  kEnforce,     ///< refuse to start, naming the missing file
};

/// The `dds.security` section: DDS Security from an SROS2 keystore, as rmw_fastrtps applies it
/// (authentication builtin.PKI-DH, access control builtin.Access-Permissions with signed
/// governance and permissions, encryption builtin.AES-GCM-GMAC), so a ROS 2 node with an enclave
/// in the same keystore is a peer. What is protected (encryption, join access control, ...) is
/// the keystore's governance; who may publish or read which topic is the enclave's permissions.
///
/// Each field left unset takes the ROS 2 environment variable, read exactly as rcl does:
/// `enable` <- ROS_SECURITY_ENABLE (only the exact text "true" enables), `keystore` <-
/// ROS_SECURITY_KEYSTORE, `enclave` <- ROS_SECURITY_ENCLAVE_OVERRIDE (else "/", ROS 2's default
/// enclave), `strategy` <- ROS_SECURITY_STRATEGY (only "Enforce" enforces; else Permissive).
/// A value set here wins over the environment (as for `domain_id`).
struct SecurityConfig {
  std::optional<bool> enable;  ///< key enable (unset: ROS_SECURITY_ENABLE == "true")
  std::string keystore;        ///< key keystore
  std::string enclave;         ///< key enclave
  std::string strategy;        ///< key strategy

  /// The keys of `dds.security`: visitor.key(name, field, unit, doc) for each.
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("enable", c.enable, "",
          "true / false; empty: ROS_SECURITY_ENABLE (\"true\" enables), else off");
    v.key("keystore", c.keystore, "",
          "keystore root (holds enclaves/); \"\": ROS_SECURITY_KEYSTORE");
    v.key("enclave", c.enclave, "",
          "this node's enclave, e.g. /mlmap/node; \"\": ROS_SECURITY_ENCLAVE_OVERRIDE, else \"/\"");
    v.key("strategy", c.strategy, "",
          "Enforce: refuse to start when a file is missing; Permissive: warn, run unsecured;\n"
          "\"\": ROS_SECURITY_STRATEGY (\"Enforce\" enforces, anything else is Permissive)");
  }

  /// Problems as "dds.security.key: what is wrong (got X)", appended to `errors`: strategy empty,
  /// Enforce or Permissive; enclave empty or an absolute ROS name ("/a/b": tokens of letters,
  /// digits and '_'); keystore without newlines.
  void validate(std::vector<std::string>* errors) const;
};

/// The six files of an enclave, looked up in `<keystore>/enclaves/<enclave>/` as rmw does.
inline constexpr const char* kSecurityFileNames[] = {
    "identity_ca.cert.pem",    "cert.pem",       "key.pem",
    "permissions_ca.cert.pem", "governance.p7s", "permissions.p7s"};

/// Security as resolved from a SecurityConfig and the environment (resolveSecurity()).
struct SecuritySetup {
  bool requested = false;  ///< enable (or ROS_SECURITY_ENABLE) asked for security
  SecurityStrategy strategy = SecurityStrategy::kPermissive;
  std::string keystore;  ///< as resolved ("" when none)
  std::string enclave =
      "/";                  ///< as resolved; also the participant's user data "enclave=<enclave>;"
  std::string enclave_dir;  ///< <keystore>/enclaves<enclave> (absolute)
  /// The participant properties rmw_fastrtps sets (dds.sec.*, `file://` URIs); empty when not
  /// enabled.
  std::vector<std::pair<std::string, std::string>> properties;
  /// Why a requested security is off (Permissive strategy, files missing); "" otherwise.
  std::string warning;
  /// The participant is secured (requested and every file found).
  [[nodiscard]] bool enabled() const { return !properties.empty(); }
};

/// Resolves `config` against the environment and finds the enclave's files. Throws
/// std::invalid_argument naming the key or variable when a value is invalid, and, with the
/// Enforce strategy, when the keystore is not set or an enclave file is missing (naming the
/// file); with Permissive the same problems give a warning and an unsecured setup, as rmw.
SecuritySetup resolveSecurity(const SecurityConfig& config);

/// What the node publishes on /tf (key `tf_mode`; REP-105 frames, see docs/dds-and-ros2.md).
enum class TfMode {
  kNone,       ///< nothing: another node (an odometry, an EKF, a localisation) owns the tree
  kMapOdom,    ///< world -> odom = T_W_B * inverse(T_O_B), T_O_B from the robot's own /tf
  kWorldBody,  ///< world -> body = T_W_B (a vehicle with nothing else, as the simulator)
};
/// Parses "none", "map_odom", "world_body" (exactly). False otherwise ("auto" is resolved by
/// resolveTfMode()).
bool parseTfMode(const std::string& text, TfMode* mode);
const char* toString(TfMode mode);

/// Where the sensor's mounting T_B_S of each cloud or image comes from (key `sensor_extrinsic`).
enum class ExtrinsicSource {
  kConfig,    ///< sensor.* of the config; a message in another frame than sensor_frame is counted
  kTfStatic,  ///< /tf_static (robot_state_publisher, a camera driver): body -> the message's
              ///< frame_id
};

/// The frame names the node uses, the prefix applied (resolveFrames()).
struct FrameNames {
  std::string world;   ///< frame_id of the maps (not prefixed: the frame vehicles share)
  std::string odom;    ///< the robot's odometry frame (REP-105 `odom`)
  std::string body;    ///< the vehicle's body (REP-105 `base_link`)
  std::string sensor;  ///< the configured sensor frame
};

/// The `dds` section. Keys, units and meanings: visit().
struct DdsConfig {
  /// Its top-level section in the node's YAML file (NodeConfig::visitNodeSections()).
  static constexpr const char* kSection = "dds";

  int domain_id = -1;               ///< key domain_id
  std::string ns;                   ///< key ns
  std::string discovery_range;      ///< key discovery_range
  std::string static_peers;         ///< key static_peers ("a;b", as ROS_STATIC_PEERS)
  std::string profiles_file;        ///< key profiles_file (its is_default_profile unused)
  std::string participant_profile;  ///< key participant_profile
  bool large_data = true;           ///< key large_data
  /// Key shared_memory. Off: UDP only towards every participant, so that no other process on
  /// the host can crash this one; mlmap's own clouds still go by data-sharing (see
  /// createParticipant()).
  bool shared_memory = false;
  /// Key data_sharing; mlmap_sensor_publisher follows it too. Other writers (a ROS 2 driver)
  /// reach the node through a transport as before.
  bool data_sharing = true;
  std::string world_frame = "map";                          ///< key world_frame
  std::string odom_frame = "odom";                          ///< key odom_frame
  std::string body_frame = "base_link";                     ///< key body_frame
  std::string sensor_frame = "camera_depth_optical_frame";  ///< key sensor_frame
  std::string frame_prefix;                                 ///< key frame_prefix
  std::string tf_mode = "auto";                             ///< key tf_mode (resolveTfMode())
  bool publish_sensor_tf = false;                           ///< key publish_sensor_tf
  std::string sensor_extrinsic = "config";                  ///< key sensor_extrinsic
  TopicNames topics;                                        ///< section topics
  PublishRates rates;                                       ///< section rates
  double pose_tolerance_s = 0.05;                           ///< key pose_tolerance_s
  double pose_buffer_s = 2.0;                               ///< key pose_buffer_s
  double max_future_s = 1.0;                                ///< key max_future_s
  double max_pose_speed_mps = 50.0;            ///< key max_pose_speed_mps (far above a multirotor)
  double max_pose_rotation_rate_dps = 1800.0;  ///< key max_pose_rotation_rate_dps
  double esdf_slice_height_m = 0.0;            ///< key esdf_slice_height_m
  SecurityConfig security;                     ///< section security (off unless enabled)
  FleetShareConfig fleet;                      ///< section fleet (off unless publish)

  /// The keys of the `dds` section: visitor.key(name, field, unit, doc) for each key and
  /// visitor.section(name, sub, doc) for topics, rates and security (see mlmap/core/config.h).
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("domain_id", c.domain_id, "",
          "DDS domain = ROS_DOMAIN_ID; -1: the ROS_DOMAIN_ID variable, else 0. Valid: 0..232");
    v.key("ns", c.ns, "", "topic namespace: \"uav1\" -> rt/uav1/cloud; \"\" for none");
    v.key("discovery_range", c.discovery_range, "",
          "\"\" (ROS_AUTOMATIC_DISCOVERY_RANGE, else SUBNET), LOCALHOST, SUBNET or OFF.\n"
          "LOCALHOST: UDPv4 on 127.0.0.1 only, unicast discovery (up to 32 participants).\n"
          "SUBNET: the profile's (default: Fast DDS's) transports, multicast discovery.\n"
          "OFF: no multicast, only the profile's own initial peers.");
    v.key("static_peers", c.static_peers, "",
          "hosts to discover by unicast, \"a;b\" (names or IPv4 addresses), with LOCALHOST or\n"
          "SUBNET (radio links without multicast); \"\": ROS_STATIC_PEERS, else none");
    v.key("profiles_file", c.profiles_file, "",
          "Fast DDS XML profiles to load, e.g. config/dds/udp_only.xml (\"\" for none)");
    v.key("participant_profile", c.participant_profile, "",
          "participant profile to use (needed with profiles_file), e.g. mlmap_udp_only;\n"
          "\"\": Fast DDS's default (FASTRTPS_DEFAULT_PROFILES_FILE's default profile)");
    v.key("large_data", c.large_data, "",
          "raise socket buffers to 4 MB and SHM segments to 16 MB (multi-MB point clouds)");
    v.key("shared_memory", c.shared_memory, "",
          "Fast DDS's SHM transport: true only if every Fast DDS on this host is 2.9\n"
          "(Jazzy's default rmw, Fast DDS 2.14, crashes a 2.9 peer through it)");
    v.key("data_sharing", c.data_sharing, "",
          "read same-host clouds from a Fast DDS writer that offers data-sharing\n"
          "(mlmap_sensor_publisher) in its shared memory, with no transport copies");
    v.key("world_frame", c.world_frame, "",
          "frame_id of the maps (REP-105 map); the parent tf_mode\n"
          "publishes on /tf");
    v.key("odom_frame", c.odom_frame, "",
          "the robot's odometry frame (REP-105 odom): tf_mode map_odom\n"
          "reads odom -> body on /tf and publishes world -> odom");
    v.key("body_frame", c.body_frame, "",
          "the vehicle (REP-105 base_link): the pose's child frame,\n"
          "Odometry's child_frame_id");
    v.key("sensor_frame", c.sensor_frame, "",
          "frame_id of the clouds and images; with publish_sensor_tf\n"
          "the child of body on /tf_static (sensor.* gives T_B_S)");
    v.key("frame_prefix", c.frame_prefix, "",
          "per-vehicle prefix of odom_frame, body_frame and sensor_frame:\n"
          "uav1 -> uav1/base_link (\"\": none); world_frame is used as written");
    v.key("tf_mode", c.tf_mode, "",
          "what the node publishes on /tf. none: nothing (another node\n"
          "owns the tree); map_odom: world -> odom (the robot publishes\n"
          "odom -> body); world_body: world -> body (nothing else does);\n"
          "auto: none when topics.odometry is set, else world_body");
    v.key("publish_sensor_tf", c.publish_sensor_tf, "",
          "publish body -> sensor (sensor.*) on /tf_static, latched;\n"
          "false when a camera driver or robot_state_publisher does");
    v.key("sensor_extrinsic", c.sensor_extrinsic, "",
          "config: T_B_S from sensor.* (a message in another frame is\n"
          "counted and warned about); tf_static: body -> each message's\n"
          "frame_id, from /tf_static");
    v.section("topics", c.topics,
              "ROS topic names relative to ns; \"\" disables that input or output");
    v.section("rates", c.rates,
              "outputs are published at most this often, and only when changed; 0 disables");
    v.key("pose_tolerance_s", c.pose_tolerance_s, "s",
          "a cloud needs a pose within this of its stamp");
    v.key("pose_buffer_s", c.pose_buffer_s, "s", "poses kept for that pairing");
    v.key("max_future_s", c.max_future_s, "s",
          "stamps farther than this ahead of the newest pose are rejected");
    v.key("max_pose_speed_mps", c.max_pose_speed_mps, "m/s",
          "two consecutive poses implying a faster motion are a jump (relocalisation,\n"
          "odometry reset): no cloud stamped between them is mapped");
    v.key("max_pose_rotation_rate_dps", c.max_pose_rotation_rate_dps, "deg/s",
          "the same for the rotation between them");
    v.key("esdf_slice_height_m", c.esdf_slice_height_m, "m",
          "height of the ESDF slice relative to the body");
    v.section("security", c.security,
              "DDS Security from an SROS2 keystore, as rmw_fastrtps (docs/security.md)");
    v.section("fleet", c.fleet, "sharing the map with a fleet (docs/fleet.md)");
  }

  /// Every problem as "dds.key: what is wrong (got X)". Empty = valid. Checks: domain_id -1 or
  /// 0..232; ns and topic names valid ROS names (letters, digits, '_', tokens not starting with a
  /// digit, single '/' separators) or empty; discovery_range empty or parseable; frames
  /// non-empty, without a leading '/' or whitespace (tf2 rules); rates finite and >= 0;
  /// pose_tolerance_s, pose_buffer_s, max_future_s, max_pose_speed_mps,
  /// max_pose_rotation_rate_dps finite and > 0; esdf_slice_height_m finite;
  /// participant_profile set when profiles_file is; camera_info set when depth_image is;
  /// security as SecurityConfig::validate(); frame_prefix empty or a frame without a trailing
  /// '/'; tf_mode auto or parseable; sensor_extrinsic config or tf_static, and not tf_static with
  /// publish_sensor_tf (the node would read back its own transform); the frames of the resolved
  /// tf_mode distinct.
  [[nodiscard]] std::vector<std::string> validate() const;
};

/// The TF mode to use: `tf_mode`, where "auto" is kNone when topics.odometry is set (the
/// odometry's source owns its TF) and kWorldBody otherwise. Throws std::invalid_argument on an
/// unknown value.
TfMode resolveTfMode(const DdsConfig& config);
/// `sensor_extrinsic` parsed. Throws std::invalid_argument on an unknown value.
ExtrinsicSource resolveExtrinsicSource(const DdsConfig& config);
/// The vehicle's name in the fleet: fleet.vehicle when set, else the namespace without its
/// leading and trailing '/' ("" when both are empty).
std::string resolveFleetVehicle(const DdsConfig& config);
/// The frame names with frame_prefix applied ("uav1" + "base_link" -> "uav1/base_link").
FrameNames resolveFrames(const DdsConfig& config);

/// Why `name` is not a valid ROS topic name or namespace ("" when it is): tokens of letters,
/// digits and '_' that do not start with a digit, separated by single '/', optionally starting
/// with '/', not ending with '/' (rcl's rules, without substitutions such as `~` or `{node}`).
std::string rosNameProblem(const std::string& name);

/// The DDS topic of a ROS topic: "rt/" + ns + "/" + name (a leading '/' of name or ns and double
/// slashes are dropped). Example: ("uav1", "cloud") -> "rt/uav1/cloud".
std::string ddsTopicName(const std::string& ns, const std::string& name);

/// The domain to use: config value if >= 0, else ROS_DOMAIN_ID if set and valid, else 0.
/// Throws std::invalid_argument when ROS_DOMAIN_ID is set but not an integer in 0..232.
int resolveDomainId(const DdsConfig& config);
/// The discovery range to use: config value if set, else ROS_AUTOMATIC_DISCOVERY_RANGE, else
/// kSubnet (rcl's default). Throws std::invalid_argument on an unknown value (where rcl warns and
/// assumes LOCALHOST).
DiscoveryRange resolveDiscoveryRange(const DdsConfig& config);
/// Longest static peer name ROS 2 accepts (RMW_DISCOVERY_OPTIONS_STATIC_PEERS_MAX_LENGTH - 1).
inline constexpr std::size_t kMaxStaticPeerLength = 255;
/// Most static peers mlmap accepts (each costs maxInitialPeersRange announcement ports).
inline constexpr std::size_t kMaxStaticPeers = 64;
/// The static peers to use: config value `static_peers` if set, else ROS_STATIC_PEERS, split at
/// ';' as rcl does (empty entries dropped, surrounding spaces trimmed). Throws
/// std::invalid_argument naming the source when an entry is longer than kMaxStaticPeerLength,
/// contains whitespace, or there are more than kMaxStaticPeers (rcl skips too-long entries with a
/// warning; a peer silently dropped is a vehicle never found, so mlmap refuses).
std::vector<std::string> resolveStaticPeers(const DdsConfig& config);
/// `text` split at ';' as resolveStaticPeers() does; `source` names it in errors.
std::vector<std::string> parseStaticPeers(const std::string& text, const std::string& source);

}  // namespace mlmap::dds
