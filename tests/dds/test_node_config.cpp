#include "mlmap/dds/node/node_config.h"

#include "mlmap/dds/node/mapping_node.h"

#include "mlmap/config/config_yaml.h"
#include "mlmap/config/yaml_section.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace mlmap::dds {
namespace {

std::string errorOf(const std::string& yaml) {
  try {
    parseNodeConfigYaml(yaml, "node.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

bool sameConfig(const NodeConfig& a, const NodeConfig& b) { return toYaml(a) == toYaml(b); }

TEST(NodeConfigYaml, EmptyDocumentGivesTheDefaultsOfBothParts) {
  const NodeConfig c = parseNodeConfigYaml("{}");
  EXPECT_EQ(config::toYaml(c.map), config::toYaml(MapConfig{}));
  EXPECT_EQ(c.dds.domain_id, -1);
  EXPECT_EQ(c.dds.topics.cloud, "cloud");
  EXPECT_EQ(c.dds.topics.grid, "mlmap/grid");
  EXPECT_DOUBLE_EQ(c.dds.rates.awareness_hz, 10.0);
  EXPECT_TRUE(c.dds.large_data);
  EXPECT_FALSE(c.dds.shared_memory);
  EXPECT_TRUE(c.dds.data_sharing);
  EXPECT_TRUE(sameConfig(parseNodeConfigYaml(""), NodeConfig{}));
  EXPECT_TRUE(sameConfig(parseNodeConfigYaml("dds:\n"), NodeConfig{}));
}

TEST(NodeConfigYaml, NoConfigPathGivesTheDefaultsAndAPathIsLoaded) {
  EXPECT_TRUE(sameConfig(nodeConfigOrDefaults(""), NodeConfig{}));
  const std::string path = std::string(MLMAP_SOURCE_DIR) + "/config/mlmap_node_depth.yaml";
  const NodeConfig shipped = nodeConfigOrDefaults(path);
  EXPECT_FALSE(sameConfig(shipped, NodeConfig{})) << "the depth config differs from the defaults";
  EXPECT_TRUE(sameConfig(shipped, loadNodeConfigYaml(path)));
  EXPECT_THROW(nodeConfigOrDefaults("/no/such/mlmap.yaml"), std::runtime_error);
}

TEST(NodeConfigYaml, EveryDdsKeyIsRead) {
  const NodeConfig c = parseNodeConfigYaml(R"(
local_map: {resolution_m: 0.1, size_cells: [165, 165, 75]}
dds:
  domain_id: 17
  ns: uav1
  discovery_range: LOCALHOST
  profiles_file: /etc/mlmap/profiles.xml
  participant_profile: mine
  large_data: false
  shared_memory: true
  data_sharing: false
  world_frame: odom
  body_frame: fcu
  sensor_frame: depth_optical
  topics:
    cloud: camera/points
    pose: mavros/local_position/pose
    odometry: odom
    depth_image: camera/depth
    camera_info: camera/info
    awareness: a/occupied
    local_map: l/occupied
    global_map: g/occupied
    grid: g/grid
    esdf_slice: e/slice
    esdf_block: e/block
    status: s
  rates: {awareness_hz: 11, local_map_hz: 6, global_map_hz: 0.25, grid_hz: 3, esdf_hz: 4, status_hz: 0}
  pose_tolerance_s: 0.02
  pose_buffer_s: 3.5
  max_future_s: 0.5
  max_pose_speed_mps: 12.5
  max_pose_rotation_rate_dps: 720
  esdf_slice_height_m: -0.25
)",
                                           "all.yaml");
  EXPECT_DOUBLE_EQ(c.map.local_map.resolution_m, 0.1);
  const DdsConfig& d = c.dds;
  EXPECT_EQ(d.domain_id, 17);
  EXPECT_EQ(d.ns, "uav1");
  EXPECT_EQ(d.discovery_range, "LOCALHOST");
  EXPECT_EQ(d.profiles_file, "/etc/mlmap/profiles.xml");
  EXPECT_EQ(d.participant_profile, "mine");
  EXPECT_FALSE(d.large_data);
  EXPECT_TRUE(d.shared_memory);
  EXPECT_FALSE(d.data_sharing);
  EXPECT_EQ(d.world_frame, "odom");
  EXPECT_EQ(d.body_frame, "fcu");
  EXPECT_EQ(d.sensor_frame, "depth_optical");
  EXPECT_EQ(d.topics.cloud, "camera/points");
  EXPECT_EQ(d.topics.pose, "mavros/local_position/pose");
  EXPECT_EQ(d.topics.odometry, "odom");
  EXPECT_EQ(d.topics.depth_image, "camera/depth");
  EXPECT_EQ(d.topics.camera_info, "camera/info");
  EXPECT_EQ(d.topics.awareness, "a/occupied");
  EXPECT_EQ(d.topics.local_map, "l/occupied");
  EXPECT_EQ(d.topics.global_map, "g/occupied");
  EXPECT_EQ(d.topics.grid, "g/grid");
  EXPECT_EQ(d.topics.esdf_slice, "e/slice");
  EXPECT_EQ(d.topics.esdf_block, "e/block");
  EXPECT_EQ(d.topics.status, "s");
  EXPECT_DOUBLE_EQ(d.rates.awareness_hz, 11.0);
  EXPECT_DOUBLE_EQ(d.rates.local_map_hz, 6.0);
  EXPECT_DOUBLE_EQ(d.rates.global_map_hz, 0.25);
  EXPECT_DOUBLE_EQ(d.rates.grid_hz, 3.0);
  EXPECT_DOUBLE_EQ(d.rates.esdf_hz, 4.0);
  EXPECT_DOUBLE_EQ(d.rates.status_hz, 0.0);
  EXPECT_DOUBLE_EQ(d.pose_tolerance_s, 0.02);
  EXPECT_DOUBLE_EQ(d.pose_buffer_s, 3.5);
  EXPECT_DOUBLE_EQ(d.max_future_s, 0.5);
  EXPECT_DOUBLE_EQ(d.max_pose_speed_mps, 12.5);
  EXPECT_DOUBLE_EQ(d.max_pose_rotation_rate_dps, 720.0);
  EXPECT_DOUBLE_EQ(d.esdf_slice_height_m, -0.25);
}

TEST(NodeConfigYaml, EmptyOrNullTextDisablesATopic) {
  const NodeConfig c = parseNodeConfigYaml("dds:\n  topics:\n    status: \"\"\n    grid:\n");
  EXPECT_EQ(c.dds.topics.status, "");
  EXPECT_EQ(c.dds.topics.grid, "");
  EXPECT_EQ(c.dds.topics.cloud, "cloud");
}

TEST(NodeConfigYaml, UnknownKeysAreErrorsNamingThem) {
  EXPECT_TRUE(contains(errorOf("dds: {domian_id: 3}"), "dds.domian_id: unknown key"));
  EXPECT_TRUE(
      contains(errorOf("dds: {topics: {clouds: points}}"), "dds.topics.clouds: unknown key"));
  EXPECT_TRUE(contains(errorOf("dds: {rates: {grid: 2}}"), "dds.rates.grid: unknown key"));
  EXPECT_TRUE(contains(errorOf("ddss: {}"), "ddss: unknown key"));
  // The message lists the known keys of that section.
  EXPECT_TRUE(contains(errorOf("dds: {topics: {clouds: points}}"), "camera_info"));
  // The engine loader alone still rejects a `dds` section (it is the node's, not the engine's).
  EXPECT_THROW(config::parseConfigYaml("dds: {}"), std::runtime_error);
}

TEST(NodeConfigYaml, WrongTypesAreErrorsNamingTheKey) {
  EXPECT_TRUE(contains(errorOf("dds: {domain_id: three}"), "dds.domain_id: cannot read"));
  EXPECT_TRUE(contains(errorOf("dds: {domain_id: 1.5}"), "dds.domain_id: cannot read"));
  EXPECT_TRUE(contains(errorOf("dds: {large_data: maybe}"), "dds.large_data: cannot read"));
  EXPECT_TRUE(contains(errorOf("dds: {ns: [a, b]}"), "dds.ns: cannot read"));
  EXPECT_TRUE(contains(errorOf("dds: {rates: {grid_hz: fast}}"), "dds.rates.grid_hz: cannot read"));
  EXPECT_TRUE(contains(errorOf("dds: {topics: {cloud: {a: b}}}"), "dds.topics.cloud: cannot read"));
  EXPECT_TRUE(contains(errorOf("dds: {topics: [cloud]}"), "dds.topics: must be a mapping"));
  EXPECT_TRUE(contains(errorOf("dds: 5"), "dds: must be a mapping"));
}

TEST(NodeConfigYaml, BadValuesAreValidated) {
  EXPECT_TRUE(contains(errorOf("dds: {domain_id: 300}"), "dds.domain_id: must be"));
  EXPECT_TRUE(contains(errorOf("dds: {discovery_range: LAN}"), "dds.discovery_range"));
  EXPECT_TRUE(contains(errorOf("dds: {topics: {cloud: 'a b'}}"), "dds.topics.cloud"));
  EXPECT_TRUE(contains(errorOf("dds: {rates: {esdf_hz: -1}}"), "dds.rates.esdf_hz"));
  EXPECT_TRUE(contains(errorOf("dds: {pose_tolerance_s: .nan}"), "dds.pose_tolerance_s"));
  EXPECT_TRUE(contains(errorOf("dds: {max_pose_speed_mps: 0}"), "dds.max_pose_speed_mps"));
  EXPECT_TRUE(
      contains(errorOf("dds: {max_pose_rotation_rate_dps: -5}"), "dds.max_pose_rotation_rate_dps"));
  EXPECT_TRUE(contains(errorOf("a: b: c"), "not valid YAML"));
  EXPECT_THROW(loadNodeConfigYaml("/nonexistent/mlmap_node.yaml"), std::runtime_error);
}

TEST(NodeConfigYaml, PoseKeysReachTheNodesPosePairing) {
  const NodeConfig c = parseNodeConfigYaml(
      "dds: {pose_tolerance_s: 0.03, pose_buffer_s: 3.5, max_future_s: 0.5, "
      "max_pose_speed_mps: 12.5, max_pose_rotation_rate_dps: 720}",
      "poses.yaml");
  const PoseBufferConfig p = poseBufferConfig(c.dds);
  EXPECT_DOUBLE_EQ(p.tolerance_s, 0.03);
  EXPECT_DOUBLE_EQ(p.horizon_s, 3.5);
  EXPECT_DOUBLE_EQ(p.max_future_s, 0.5);
  EXPECT_DOUBLE_EQ(p.max_speed_mps, 12.5);
  EXPECT_DOUBLE_EQ(p.max_rotation_rate_dps, 720.0);
  // The node applying them: NodeFaults.PoseJumpLimitsComeFromTheConfiguration.
}

TEST(NodeConfigYaml, EngineAndDdsProblemsAreReportedTogether) {
  // Unknown keys / wrong types in both parts.
  const std::string parse = errorOf(
      "local_map: {resolutoin_m: 0.1}\nawareness: {rho_cells: many}\n"
      "dds: {domian_id: 3, rates: {grid_hz: x}}");
  EXPECT_TRUE(contains(parse, "node.yaml: invalid mlmap configuration"));
  EXPECT_TRUE(contains(parse, "local_map.resolutoin_m: unknown key"));
  EXPECT_TRUE(contains(parse, "awareness.rho_cells: cannot read"));
  EXPECT_TRUE(contains(parse, "dds.domian_id: unknown key"));
  EXPECT_TRUE(contains(parse, "dds.rates.grid_hz: cannot read"));
  // Values that fail validation in both parts.
  const std::string values = errorOf("awareness: {phi_cells: 0}\ndds: {domain_id: 300}");
  EXPECT_TRUE(contains(values, "awareness.phi_cells"));
  EXPECT_TRUE(contains(values, "dds.domain_id"));
  // A typo in one part does not hide the bad values of the other.
  const std::string mixed = errorOf("lokal_map: {}\nlog_odds: {hit: 0.5x}\ndds: {domain_id: 300}");
  EXPECT_TRUE(contains(mixed, "lokal_map: unknown key"));
  EXPECT_TRUE(contains(mixed, "log_odds.hit: cannot read"));
  EXPECT_TRUE(contains(mixed, "dds.domain_id: must be"));
  const std::string mixed2 = errorOf("local_map: {resolution_m: -1}\ndds: {nss: a}");
  EXPECT_TRUE(contains(mixed2, "local_map.resolution_m"));
  EXPECT_TRUE(contains(mixed2, "dds.nss: unknown key"));
}

TEST(NodeConfigYaml, PrintedConfigReadsBackIdentically) {
  NodeConfig c;
  c.map.local_map.resolution_m = 0.1;
  c.map.local_map.size_cells = {165, 165, 75};
  c.map.pipeline.threaded = true;
  c.dds.domain_id = 42;
  c.dds.ns = "/fleet/uav_2";
  c.dds.discovery_range = "OFF";  // must stay text, not YAML 1.1's boolean
  c.dds.profiles_file = "/opt/profiles: x.xml";
  c.dds.participant_profile = "true";
  c.dds.large_data = false;
  c.dds.shared_memory = true;
  c.dds.data_sharing = false;
  c.dds.world_frame = "odom";
  c.dds.topics.cloud = "";
  c.dds.topics.odometry = "odom";
  c.dds.topics.esdf_block = "null";
  c.dds.rates.grid_hz = 0.1;
  c.dds.rates.status_hz = 0.0;
  c.dds.pose_tolerance_s = 1e-3;
  c.dds.esdf_slice_height_m = -0.3;
  const std::string yaml = toYaml(c);
  const NodeConfig back = parseNodeConfigYaml(yaml, "printed");
  EXPECT_TRUE(sameConfig(back, c)) << yaml;
  EXPECT_EQ(back.dds.discovery_range, "OFF");
  EXPECT_EQ(back.dds.participant_profile, "true");
  EXPECT_EQ(back.dds.topics.esdf_block, "null");
  EXPECT_EQ(back.dds.topics.cloud, "");
  EXPECT_DOUBLE_EQ(back.dds.rates.grid_hz, 0.1);
  EXPECT_DOUBLE_EQ(back.map.local_map.resolution_m, 0.1);
  // Default values print and read back too, and the printout differs when a value does.
  EXPECT_TRUE(sameConfig(parseNodeConfigYaml(toYaml(NodeConfig{})), NodeConfig{}));
  EXPECT_FALSE(sameConfig(back, NodeConfig{}));
}

TEST(NodeConfigYaml, MapFileSectionIsReadValidatedAndPrinted) {
  const NodeConfig defaults = parseNodeConfigYaml("{}");
  EXPECT_EQ(defaults.map_file.load_path, "");
  EXPECT_EQ(defaults.map_file.save_path, "");
  EXPECT_DOUBLE_EQ(defaults.map_file.save_period_s, 0.0);
  EXPECT_FALSE(defaults.map_file.load_missing_ok);
  const NodeConfig c = parseNodeConfigYaml(
      "map_file: {load_path: /nonexistent/map.mlmap, load_missing_ok: true, save_path: "
      "/tmp/map.mlmap, save_period_s: 30}");
  EXPECT_EQ(c.map_file.load_path, "/nonexistent/map.mlmap");
  EXPECT_TRUE(c.map_file.load_missing_ok);
  EXPECT_EQ(c.map_file.save_path, "/tmp/map.mlmap");
  EXPECT_DOUBLE_EQ(c.map_file.save_period_s, 30.0);
  EXPECT_TRUE(sameConfig(parseNodeConfigYaml(toYaml(c)), c));

  EXPECT_TRUE(contains(errorOf("map_file: {save_path: /tmp/m.mlmap, save_period_s: -1}"),
                       "map_file.save_period_s: must be >= 0"));
  EXPECT_TRUE(contains(errorOf("map_file: {save_period_s: 10}"),
                       "map_file.save_period_s: periodic saving needs map_file.save_path"));
  EXPECT_TRUE(contains(errorOf("map_file: {save_path: /nonexistent/dir/m.mlmap}"),
                       "map_file.save_path: folder '/nonexistent/dir' does not exist"));
  EXPECT_TRUE(contains(errorOf("map_file: {save_path: /tmp}"), "map_file.save_path: is a folder"));
  EXPECT_TRUE(contains(errorOf("map_file: {load_path: /nonexistent/map.mlmap}"),
                       "map_file.load_path: no such file (got '/nonexistent/map.mlmap'"));
  EXPECT_TRUE(contains(errorOf("map_file: {save_paht: x}"),
                       "map_file.save_paht: unknown key (known keys: load_missing_ok, load_path, "
                       "overwrite, save_path, save_period_s)"));
  EXPECT_TRUE(contains(errorOf("map_file: {save_period_s: soon}"),
                       "map_file.save_period_s: cannot read 'soon'"));
}

TEST(NodeConfigYaml, ShippedFilesEqualTheDefaultsInCode) {
  EXPECT_TRUE(
      sameConfig(loadNodeConfigYaml(MLMAP_SOURCE_DIR "/config/mlmap_node.yaml"), NodeConfig{}));
  // The engine file and the node file together are one valid node configuration.
  const std::string both = config::readConfigFile(MLMAP_SOURCE_DIR "/config/mlmap.yaml") + "\n" +
                           config::readConfigFile(MLMAP_SOURCE_DIR "/config/mlmap_node.yaml");
  EXPECT_TRUE(sameConfig(parseNodeConfigYaml(both, "both"), NodeConfig{}));
}

}  // namespace
}  // namespace mlmap::dds
