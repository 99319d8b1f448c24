#pragma once
/// @file
/// Configuration of the DDS component (the `dds` section of the node's YAML file) and the ROS 2
/// naming rules it follows.
///
/// Resolution order for the domain and the discovery range, as ROS 2 does: the config value when
/// set, else the environment (ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE), else the ROS 2
/// default (domain 0, SUBNET). FASTRTPS_DEFAULT_PROFILES_FILE is read by Fast DDS itself; a
/// `profiles_file` in the config is loaded on top of it.

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace mlmap::dds {

/// ROS_AUTOMATIC_DISCOVERY_RANGE.
enum class DiscoveryRange {
  kSystemDefault,  ///< not set anywhere: SUBNET
  kLocalhost,      ///< UDPv4 on 127.0.0.1 only, unicast discovery to 127.0.0.1 (no multicast)
  kSubnet,         ///< Fast DDS built-in transports, multicast discovery (a vehicle LAN)
  kOff,            ///< no automatic discovery: no multicast, and only the profile's own initial
                   ///< peers are contacted (none added); peers that list this host still find it
};
/// Parses "LOCALHOST", "SUBNET", "OFF", "SYSTEM_DEFAULT" (case-insensitive). False otherwise.
bool parseDiscoveryRange(const std::string& text, DiscoveryRange* range);
const char* toString(DiscoveryRange range);

/// Topic names (ROS names, without `rt/` and without the namespace). Empty input names disable
/// that input; empty output names disable that output.
struct TopicNames {
  // Inputs (BEST_EFFORT readers: they match any publisher).
  std::string cloud = "cloud";                          ///< sensor_msgs/PointCloud2, sensor frame
  std::string pose = "pose";                            ///< geometry_msgs/PoseStamped, T_W_B
  std::string odometry = "";                            ///< nav_msgs/Odometry (alternative to pose)
  std::string depth_image = "";                         ///< sensor_msgs/Image 16UC1 / 32FC1
  std::string camera_info = "";                         ///< sensor_msgs/CameraInfo of the depth image
  // Outputs (RELIABLE writers).
  std::string awareness = "mlmap/awareness/occupied";   ///< PointCloud2, awareness occupied cells
  std::string local_map = "mlmap/local_map/occupied";   ///< PointCloud2, local occupied voxels
  std::string global_map = "mlmap/global_map/occupied"; ///< PointCloud2, TRANSIENT_LOCAL
  std::string grid = "mlmap/grid";                      ///< nav_msgs/OccupancyGrid, TRANSIENT_LOCAL
  std::string esdf_slice = "mlmap/esdf/slice";          ///< PointCloud2 with `intensity` = distance
  std::string esdf_block = "mlmap/esdf/block";          ///< mlmap_msgs/VoxelBlock
  std::string status = "mlmap/status";                  ///< mlmap_msgs/Status
};

/// Publishing rates [Hz] of the outputs (0 disables that output). Outputs are published from
/// their own thread at most at these rates, and only when their content changed.
struct PublishRates {
  double awareness_hz = 10.0;
  double local_map_hz = 5.0;
  double global_map_hz = 0.5;
  double grid_hz = 2.0;
  double esdf_hz = 2.0;
  double status_hz = 1.0;
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
  std::optional<bool> enable;  ///< unset: ROS_SECURITY_ENABLE == "true"; default false
  std::string keystore;        ///< SROS2 keystore root (holds enclaves/); "": ROS_SECURITY_KEYSTORE
  std::string enclave;         ///< e.g. "/mlmap/node"; "": ROS_SECURITY_ENCLAVE_OVERRIDE, else "/"
  std::string strategy;        ///< "Enforce" or "Permissive" (any case); "": ROS_SECURITY_STRATEGY

  /// Problems as "dds.security.key: what is wrong (got X)", appended to `errors`: strategy empty,
  /// Enforce or Permissive; enclave empty or an absolute ROS name ("/a/b": tokens of letters,
  /// digits and '_'); keystore without newlines.
  void validate(std::vector<std::string>* errors) const;
};

/// The six files of an enclave, looked up in `<keystore>/enclaves/<enclave>/` as rmw does.
inline constexpr const char* kSecurityFileNames[] = {
    "identity_ca.cert.pem", "cert.pem", "key.pem", "permissions_ca.cert.pem", "governance.p7s",
    "permissions.p7s"};

/// Security as resolved from a SecurityConfig and the environment (resolveSecurity()).
struct SecuritySetup {
  bool requested = false;   ///< enable (or ROS_SECURITY_ENABLE) asked for security
  SecurityStrategy strategy = SecurityStrategy::kPermissive;
  std::string keystore;     ///< as resolved ("" when none)
  std::string enclave = "/";  ///< as resolved; also the participant's user data "enclave=<enclave>;"
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

/// The `dds` section.
struct DdsConfig {
  int domain_id = -1;              ///< -1: ROS_DOMAIN_ID, else 0. Valid: 0..232
  std::string ns;                  ///< topic namespace ("uav1" -> rt/uav1/...); "" for none
  std::string discovery_range;     ///< "" (environment / default) or LOCALHOST / SUBNET / OFF
  std::string profiles_file;       ///< Fast DDS XML profiles to load ("" for none); needs
                                   ///< participant_profile (its is_default_profile is not used)
  std::string participant_profile; ///< participant profile to use, from profiles_file or from
                                   ///< FASTRTPS_DEFAULT_PROFILES_FILE ("": the factory default)
  bool large_data = true;          ///< 4 MB socket buffers (16 MB SHM segment) for multi-MB clouds
  /// Fast DDS's shared-memory transport. Off: UDP only towards every participant, so that no
  /// other process on the host (a ROS 2 Jazzy node on Fast DDS 2.14, whose segments Fast DDS 2.9
  /// cannot read) can crash this one; mlmap's own clouds still go by data-sharing. On: only where
  /// every Fast DDS participant on the host is version 2.9 (see createParticipant()).
  bool shared_memory = false;
  /// Clouds from a same-host Fast DDS writer that offers data-sharing (mlmap_sensor_publisher
  /// does) are read from its history in shared memory, not through a transport; the publisher
  /// follows this key too. Other writers (a ROS 2 driver) reach the node as before.
  bool data_sharing = true;
  std::string world_frame = "map";         ///< frame_id of the maps and parent of rt/tf
  std::string body_frame = "base_link";    ///< child of rt/tf, parent of the sensor on rt/tf_static
  std::string sensor_frame = "camera_depth_optical_frame";  ///< child on rt/tf_static
  TopicNames topics;
  PublishRates rates;
  double pose_tolerance_s = 0.05;  ///< a cloud needs a pose within this of its stamp
  double pose_buffer_s = 2.0;      ///< poses kept for pairing
  double max_future_s = 1.0;       ///< stamps farther ahead of the newest pose are rejected
  /// Two consecutive poses implying a faster motion are a jump (a relocalisation, an odometry
  /// reset), not a flight: no cloud stamped between them is mapped [m/s]. Far above a multirotor.
  double max_pose_speed_mps = 50.0;
  double max_pose_rotation_rate_dps = 1800.0;  ///< the same for the rotation between them [deg/s]
  double esdf_slice_height_m = 0.0;  ///< slice height relative to the body [m]
  SecurityConfig security;         ///< DDS Security (SROS2 keystore); off unless enabled

  /// Every problem as "dds.key: what is wrong (got X)". Empty = valid. Checks: domain_id -1 or
  /// 0..232; ns and topic names valid ROS names (letters, digits, '_', tokens not starting with a
  /// digit, single '/' separators) or empty; discovery_range empty or parseable; frames
  /// non-empty, without a leading '/' or whitespace (tf2 rules); rates finite and >= 0;
  /// pose_tolerance_s, pose_buffer_s, max_future_s, max_pose_speed_mps,
  /// max_pose_rotation_rate_dps finite and > 0; esdf_slice_height_m finite;
  /// participant_profile set when profiles_file is; camera_info set when depth_image is;
  /// security as SecurityConfig::validate().
  [[nodiscard]] std::vector<std::string> validate() const;
};

/// The DDS topic of a ROS topic: "rt/" + ns + "/" + name (a leading '/' of name or ns and double
/// slashes are dropped). Example: ("uav1", "cloud") -> "rt/uav1/cloud".
std::string ddsTopicName(const std::string& ns, const std::string& name);

/// The domain to use: config value if >= 0, else ROS_DOMAIN_ID if set and valid, else 0.
/// Throws std::invalid_argument when ROS_DOMAIN_ID is set but not an integer in 0..232.
int resolveDomainId(const DdsConfig& config);
/// The discovery range to use: config value if set, else ROS_AUTOMATIC_DISCOVERY_RANGE, else
/// kSystemDefault. Throws std::invalid_argument on an unknown value.
DiscoveryRange resolveDiscoveryRange(const DdsConfig& config);

}  // namespace mlmap::dds
