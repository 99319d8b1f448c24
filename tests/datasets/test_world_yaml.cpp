#include "mlmap/datasets/world_yaml.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>

namespace mlmap::datasets {
namespace {

using Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;

std::string defaultRoomYamlPath() {
#ifdef MLMAP_SOURCE_DIR
  return std::string(MLMAP_SOURCE_DIR) + "/config/worlds/default_room.yaml";
#else
  // tests/datasets/test_world_yaml.cpp -> repository root.
  const std::filesystem::path here(__FILE__);
  return (here.parent_path().parent_path().parent_path() / "config/worlds/default_room.yaml")
      .string();
#endif
}

/// A YAML file in the temp directory, removed at scope exit.
class TempYaml {
 public:
  explicit TempYaml(const std::string& text) {
    static std::atomic<int> counter{0};
    path_ = (std::filesystem::temp_directory_path() /
             ("mlmap_world_yaml_test_" + std::to_string(std::random_device{}()) + "_" +
              std::to_string(counter++) + ".yaml"))
                .string();
    std::ofstream out(path_);
    out << text;
  }
  ~TempYaml() { std::remove(path_.c_str()); }
  TempYaml(const TempYaml&) = delete;
  TempYaml& operator=(const TempYaml&) = delete;
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// Loads `text` from a temp file and returns the error message ("" if it loaded).
std::string loadError(const std::string& text, std::string* path_out = nullptr) {
  TempYaml file(text);
  if (path_out != nullptr) *path_out = file.path();
  try {
    (void)loadScenarioYaml(file.path());
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

void expectErrorContains(const std::string& text, const std::string& expected) {
  std::string path;
  const std::string message = loadError(text, &path);
  EXPECT_NE(message.find(expected), std::string::npos)
      << "message: " << message << "\nexpected to contain: " << expected;
  EXPECT_EQ(message.rfind(path, 0), 0u) << "message should start with the file name: " << message;
}

TEST(WorldYaml, DefaultRoomFileEqualsDefaultScenario) {
  const Scenario loaded = loadScenarioYaml(defaultRoomYamlPath());
  const Scenario expected = defaultScenario();
  const sim::World& a = loaded.world;
  const sim::World& b = expected.world;
  ASSERT_EQ(a.boxes().size(), b.boxes().size());
  ASSERT_EQ(a.cylinders().size(), b.cylinders().size());
  ASSERT_EQ(a.spheres().size(), b.spheres().size());
  ASSERT_EQ(a.movingBoxes().size(), b.movingBoxes().size());
  for (std::size_t i = 0; i < a.boxes().size(); ++i) {
    EXPECT_EQ(a.boxes()[i].min_W, b.boxes()[i].min_W) << "box " << i;
    EXPECT_EQ(a.boxes()[i].max_W, b.boxes()[i].max_W) << "box " << i;
  }
  for (std::size_t i = 0; i < a.cylinders().size(); ++i) {
    EXPECT_EQ(a.cylinders()[i].center_xy_W, b.cylinders()[i].center_xy_W) << "cylinder " << i;
    EXPECT_EQ(a.cylinders()[i].radius_m, b.cylinders()[i].radius_m) << "cylinder " << i;
    EXPECT_EQ(a.cylinders()[i].z_min_m, b.cylinders()[i].z_min_m) << "cylinder " << i;
    EXPECT_EQ(a.cylinders()[i].z_max_m, b.cylinders()[i].z_max_m) << "cylinder " << i;
  }
  for (std::size_t i = 0; i < a.spheres().size(); ++i) {
    EXPECT_EQ(a.spheres()[i].center_W, b.spheres()[i].center_W) << "sphere " << i;
    EXPECT_EQ(a.spheres()[i].radius_m, b.spheres()[i].radius_m) << "sphere " << i;
  }
  for (std::size_t i = 0; i < a.movingBoxes().size(); ++i) {
    const sim::MovingBox& m = a.movingBoxes()[i];
    const sim::MovingBox& n = b.movingBoxes()[i];
    EXPECT_EQ(m.size_m, n.size_m);
    EXPECT_EQ(m.start_center_W, n.start_center_W);
    EXPECT_EQ(m.velocity_mps, n.velocity_mps);
    EXPECT_EQ(m.t_start_s, n.t_start_s);
    EXPECT_EQ(m.t_end_s, n.t_end_s);
  }
  const sim::Trajectory& ta = loaded.trajectory;
  const sim::Trajectory& tb = expected.trajectory;
  EXPECT_EQ(ta.speed_mps(), tb.speed_mps());
  EXPECT_DOUBLE_EQ(ta.duration_s(), tb.duration_s());
  ASSERT_EQ(ta.waypoints().size(), tb.waypoints().size());
  for (std::size_t i = 0; i < ta.waypoints().size(); ++i) {
    EXPECT_EQ(ta.waypoints()[i].position_W, tb.waypoints()[i].position_W) << "waypoint " << i;
    EXPECT_EQ(ta.waypoints()[i].has_yaw, tb.waypoints()[i].has_yaw) << "waypoint " << i;
  }
  for (double t = 0.0; t < tb.duration_s(); t += 1.3) {
    EXPECT_TRUE(ta.poseAt(t).isApprox(tb.poseAt(t), 1e-12)) << "t=" << t;
  }
  const sim::DepthCameraModel& ca = loaded.camera;
  const sim::DepthCameraModel& cb = expected.camera;
  EXPECT_EQ(ca.intrinsics.width, cb.intrinsics.width);
  EXPECT_EQ(ca.intrinsics.height, cb.intrinsics.height);
  EXPECT_EQ(ca.intrinsics.fx, cb.intrinsics.fx);
  EXPECT_EQ(ca.intrinsics.fy, cb.intrinsics.fy);
  EXPECT_EQ(ca.intrinsics.cx, cb.intrinsics.cx);
  EXPECT_EQ(ca.intrinsics.cy, cb.intrinsics.cy);
  EXPECT_EQ(ca.min_depth_m, cb.min_depth_m);
  EXPECT_EQ(ca.max_depth_m, cb.max_depth_m);
  EXPECT_EQ(ca.noise_coeff_per_m, cb.noise_coeff_per_m);
  EXPECT_EQ(ca.seed, cb.seed);
  EXPECT_EQ(loaded.frame_rate_hz, expected.frame_rate_hz);
}

TEST(WorldYaml, ParsesAllFieldsAndDefaults) {
  TempYaml file(R"(
world:
  spheres: [{center_m: [1, 2, 3], radius_m: 0.5}]
  moving_boxes:
    - {size_m: [1, 1, 2], start_center_m: [0, 0, 1], velocity_mps: [1, 0, 0], t_start_s: 2, t_end_s: 4}
trajectory:
  speed_mps: 2.5
  waypoints:
    - {position_m: [0, 0, 1], yaw_deg: 90}
    - {position_m: [5, 0, 1]}
camera: {width: 320, noise_coeff_per_m: 0.002, seed: 42}
)");
  const Scenario s = loadScenarioYaml(file.path());
  EXPECT_TRUE(s.world.boxes().empty());
  ASSERT_EQ(s.world.spheres().size(), 1u);
  EXPECT_EQ(s.world.spheres()[0].center_W, Vector3d(1, 2, 3));
  ASSERT_EQ(s.world.movingBoxes().size(), 1u);
  EXPECT_EQ(s.world.movingBoxes()[0].t_end_s, 4.0);
  EXPECT_EQ(s.trajectory.speed_mps(), 2.5);
  EXPECT_DOUBLE_EQ(s.trajectory.duration_s(), 2.0);
  ASSERT_TRUE(s.trajectory.waypoints()[0].has_yaw);
  EXPECT_NEAR(s.trajectory.waypoints()[0].yaw_rad, kPi / 2, 1e-12);
  EXPECT_FALSE(s.trajectory.waypoints()[1].has_yaw);
  EXPECT_EQ(s.camera.intrinsics.width, 320);
  EXPECT_EQ(s.camera.intrinsics.height, 480);  // default kept
  EXPECT_EQ(s.camera.intrinsics.fx, 385.0);
  EXPECT_EQ(s.camera.noise_coeff_per_m, 0.002);
  EXPECT_EQ(s.camera.seed, 42u);
  EXPECT_EQ(s.frame_rate_hz, 10.0);
}

TEST(WorldYaml, EmptyFileGivesDefaults) {
  TempYaml file("# nothing\n");
  const Scenario s = loadScenarioYaml(file.path());
  EXPECT_TRUE(s.world.boxes().empty());
  EXPECT_EQ(s.trajectory.duration_s(), 0.0);
  EXPECT_EQ(s.camera.intrinsics.width, 640);
}

TEST(WorldYaml, UnknownKeysAreErrorsNamingKeyAndPath) {
  expectErrorContains(R"(
world:
  boxes:
    - {min_m: [0, 0, 0], max_m: [1, 1, 1]}
    - {min_m: [0, 0, 0], max_m: [1, 1, 1]}
    - {min_m: [0, 0, 0], max_m: [1, 1, 1], sise_m: 3}
)",
                      "world.boxes[2]: unknown key 'sise_m'");
  expectErrorContains("wrold: {}\n", "<root>: unknown key 'wrold'");
  expectErrorContains("world: {cubes: []}\n", "world: unknown key 'cubes'");
  expectErrorContains("camera: {fov: 90}\n", "camera: unknown key 'fov'");
  expectErrorContains("trajectory: {speed: 1, waypoints: [{position_m: [0, 0, 1]}]}\n",
                      "trajectory: unknown key 'speed'");
  expectErrorContains("trajectory: {waypoints: [{position_m: [0, 0, 1], yaw: 3}]}\n",
                      "trajectory.waypoints[0]: unknown key 'yaw'");
  expectErrorContains("world: {spheres: [{center_m: [0, 0, 0], radius_m: 1, colour: red}]}\n",
                      "world.spheres[0]: unknown key 'colour'");
}

TEST(WorldYaml, BadValuesAreErrors) {
  expectErrorContains("world: {spheres: [{center_m: [0, 0, 0], radius_m: -1}]}\n",
                      "world.spheres[0].radius_m: must be > 0, got -1");
  expectErrorContains(
      "world: {cylinders: [{center_xy_m: [0, 0], radius_m: 0, z_min_m: 0, z_max_m: 1}]}\n",
      "world.cylinders[0].radius_m: must be > 0");
  expectErrorContains(
      "world: {cylinders: [{center_xy_m: [0, 0], radius_m: 1, z_min_m: 2, z_max_m: 1}]}\n",
      "world.cylinders[0]: z_min_m (2) must be <= z_max_m (1)");
  expectErrorContains("world: {boxes: [{min_m: [0, 2, 0], max_m: [1, 1, 1]}]}\n",
                      "world.boxes[0]: min_m must be <= max_m");
  expectErrorContains("world: {boxes: [{min_m: [0, 0, 0], max_m: [1, abc, 1]}]}\n",
                      "world.boxes[0].max_m[1]: expected a number, got 'abc'");
  expectErrorContains("world: {boxes: [{min_m: [0, 0], max_m: [1, 1, 1]}]}\n",
                      "world.boxes[0].min_m: expected a list of 3 numbers, got a list of 2");
  expectErrorContains("world: {boxes: [{min_m: [0, 0, 0]}]}\n",
                      "world.boxes[0]: missing required key 'max_m'");
  expectErrorContains("world: {boxes: [{min_m: [0, 0, .nan], max_m: [1, 1, 1]}]}\n",
                      "world.boxes[0].min_m[2]: must be finite");
  expectErrorContains("world: {boxes: {min_m: [0, 0, 0]}}\n", "world.boxes: expected a list");
  expectErrorContains(
      "world: {moving_boxes: [{size_m: [1, 0, 1], start_center_m: [0, 0, 0], "
      "velocity_mps: [0, 0, 0], t_start_s: 0, t_end_s: 1}]}\n",
      "world.moving_boxes[0].size_m: every size must be > 0");
  expectErrorContains(
      "world: {moving_boxes: [{size_m: [1, 1, 1], start_center_m: [0, 0, 0], "
      "velocity_mps: [0, 0, 0], t_start_s: 3, t_end_s: 1}]}\n",
      "world.moving_boxes[0]: t_start_s (3) must be <= t_end_s (1)");
  expectErrorContains("trajectory: {speed_mps: 0, waypoints: [{position_m: [0, 0, 1]}]}\n",
                      "trajectory.speed_mps: must be > 0, got 0");
  expectErrorContains("trajectory: {speed_mps: fast, waypoints: [{position_m: [0, 0, 1]}]}\n",
                      "trajectory.speed_mps: expected a number, got 'fast'");
  expectErrorContains("trajectory: {speed_mps: 1}\n",
                      "trajectory: missing required key 'waypoints'");
  expectErrorContains("trajectory: {waypoints: []}\n",
                      "trajectory.waypoints: expected a non-empty list");
  expectErrorContains(
      "trajectory: {waypoints: [{position_m: [0, 0, 1]}, {position_m: [0, 0, 1]}]}\n",
      "trajectory: waypoints[1] coincides with waypoints[0]");
  expectErrorContains("camera: {width: 0}\n", "camera.width: must be in [1, 100000], got 0");
  expectErrorContains("camera: {height: 480.5}\n", "camera.height: expected an integer");
  expectErrorContains("camera: {fx: -385}\n", "camera.fx: must be > 0");
  expectErrorContains("camera: {min_depth_m: 5, max_depth_m: 4}\n",
                      "camera: min_depth_m (5) must be < max_depth_m (4)");
  expectErrorContains("camera: {noise_coeff_per_m: -0.1}\n",
                      "camera.noise_coeff_per_m: must be >= 0");
  expectErrorContains("camera: {seed: -1}\n", "camera.seed: must be in [0, 4294967295]");
  expectErrorContains("frame_rate_hz: 0\n", "frame_rate_hz: must be > 0");
  expectErrorContains("frame_rate_hz: [10]\n", "frame_rate_hz: expected a number, got a list");
  expectErrorContains("world: [1, 2]\n", "world: expected a mapping");
}

TEST(WorldYaml, SyntaxErrorsAndMissingFiles) {
  expectErrorContains("world: {boxes: [\n", "not valid YAML");
  expectErrorContains("frame_rate_hz: 10\nframe_rate_hz: 20\n",
                      "line 2: key 'frame_rate_hz' appears twice (first on line 1)");
  expectErrorContains("frame_rate_hz: 10\n---\nframe_rate_hz: 20\n", "more than one YAML document");
  const std::string missing = "/nonexistent/dir/no_such_world.yaml";
  try {
    (void)loadScenarioYaml(missing);
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
  }
}

TEST(WorldYaml, ParseFromStringUsesSourceName) {
  try {
    (void)parseScenarioYaml("frame_rate_hz: -1\n", "inline.yaml");
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "inline.yaml: frame_rate_hz: must be > 0, got -1");
  }
  const Scenario s = parseScenarioYaml("frame_rate_hz: 30\n");
  EXPECT_EQ(s.frame_rate_hz, 30.0);
}

}  // namespace
}  // namespace mlmap::datasets

namespace mlmap::datasets {
namespace {

// The building of the OctoMap comparison's long walk (config/worlds/building.yaml).
TEST(WorldYaml, BuildingWalkIsAbout250MetresOverThreeFloorsAndKeepsClearOfSolids) {
  const Scenario s =
      loadScenarioYaml(std::string(MLMAP_SOURCE_DIR) + "/config/worlds/building.yaml");
  EXPECT_GT(s.trajectory.length_m(), 240.0);
  EXPECT_LT(s.trajectory.length_m(), 270.0);
  const Eigen::AlignedBox3d bounds = s.world.bounds();
  EXPECT_NEAR(bounds.min().z(), -0.2, 1e-9);
  EXPECT_NEAR(bounds.max().z(), 9.0, 1e-9);
  double min_clearance = 1e9, min_z = 1e9, max_z = -1e9;
  for (double t = 0.0; t <= s.trajectory.duration_s(); t += 0.05) {
    const Eigen::Vector3d p = s.trajectory.positionAt(t);
    min_clearance = std::min(min_clearance, s.world.distance(p));
    min_z = std::min(min_z, p.z());
    max_z = std::max(max_z, p.z());
  }
  EXPECT_GE(min_clearance, 0.5);  // the vehicle never touches a wall, door frame or slab
  EXPECT_LT(min_z, 2.0);          // it flies on the ground floor ...
  EXPECT_GT(max_z, 7.0);          // ... and on the top floor
  // Every floor is closed below the walk except at the two openings it climbs through.
  for (double t = 0.0; t <= s.trajectory.duration_s(); t += 0.5) {
    const Eigen::Vector3d p = s.trajectory.positionAt(t);
    double down = 0.0;
    ASSERT_TRUE(s.world.raycast(p, -Eigen::Vector3d::UnitZ(), 20.0, 0.0, &down)) << "t " << t;
  }
}

// The fleet's three flights (config/worlds/fleet/) share the building's world through `base`,
// keep clear of its solids, and see different rooms: each flight's positions are mostly far
// from the others'.
TEST(WorldYaml, FleetFlightsShareTheBuildingAndKeepClearOfSolids) {
  const std::string dir = std::string(MLMAP_SOURCE_DIR) + "/config/worlds/";
  const Scenario building = loadScenarioYaml(dir + "building.yaml");
  std::vector<std::vector<Eigen::Vector3d>> paths;
  for (const char* name : {"uav1", "uav2", "uav3"}) {
    SCOPED_TRACE(name);
    const Scenario s = loadScenarioYaml(dir + "fleet/" + name + ".yaml");
    EXPECT_EQ(s.world.boxes().size(), building.world.boxes().size());
    EXPECT_EQ(s.frame_rate_hz, building.frame_rate_hz);
    EXPECT_EQ(s.camera.intrinsics.width, building.camera.intrinsics.width);
    EXPECT_GT(s.trajectory.length_m(), 25.0);
    EXPECT_LT(s.trajectory.length_m(), building.trajectory.length_m() / 3.0);
    std::vector<Eigen::Vector3d> path;
    double min_clearance = 1e9;
    for (double t = 0.0; t <= s.trajectory.duration_s(); t += 0.05) {
      path.push_back(s.trajectory.positionAt(t));
      min_clearance = std::min(min_clearance, s.world.distance(path.back()));
      EXPECT_LT(path.back().z(), 2.8) << "the ground floor";
    }
    EXPECT_GE(min_clearance, 0.5);
    paths.push_back(path);
  }
  for (std::size_t a = 0; a < paths.size(); ++a) {
    for (std::size_t b = 0; b < paths.size(); ++b) {
      if (a == b) continue;
      std::size_t apart = 0;  // positions of a more than 5 m from every position of b
      for (const Eigen::Vector3d& p : paths[a]) {
        double nearest = 1e9;
        for (const Eigen::Vector3d& q : paths[b]) nearest = std::min(nearest, (p - q).norm());
        apart += nearest > 5.0 ? 1 : 0;
      }
      EXPECT_GT(apart, paths[a].size() / 3) << "flight " << a + 1 << " against " << b + 1;
    }
  }
}

/// The error message of loading the scenario file at `path` ("" if it loaded).
std::string fileError(const std::string& path) {
  try {
    (void)loadScenarioYaml(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(WorldYaml, ABaseGivesItsSectionsAndASectionGivenReplacesTheBases) {
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("mlmap_base_" + std::to_string(std::random_device{}())))
                              .string();
  std::filesystem::create_directories(dir + "/sub");
  std::ofstream(dir + "/base.yaml") << "world: {boxes: [{min_m: [0, 0, 0], max_m: [1, 1, 1]}]}\n"
                                       "trajectory: {waypoints: [{position_m: [3, 0, 0]}, "
                                       "{position_m: [4, 0, 0]}]}\n"
                                       "camera: {width: 320}\nframe_rate_hz: 4\n";
  std::ofstream(dir + "/sub/flight.yaml") << "base: ../base.yaml\n"
                                             "trajectory: {waypoints: [{position_m: [5, 0, 0]}, "
                                             "{position_m: [7, 0, 0]}]}\n";
  const Scenario s = loadScenarioYaml(dir + "/sub/flight.yaml");
  EXPECT_EQ(s.world.boxes().size(), 1u);
  EXPECT_EQ(s.camera.intrinsics.width, 320);
  EXPECT_EQ(s.frame_rate_hz, 4.0);
  EXPECT_NEAR(s.trajectory.length_m(), 2.0, 1e-12) << "this file's trajectory, not the base's";
  std::ofstream(dir + "/world_only.yaml") << "base: base.yaml\nworld: {}\n";
  EXPECT_TRUE(loadScenarioYaml(dir + "/world_only.yaml").world.boxes().empty()) << "replaced";
  std::ofstream(dir + "/cycle.yaml") << "base: cycle.yaml\n";
  EXPECT_NE(fileError(dir + "/cycle.yaml").find("bases in a chain (a cycle?)"), std::string::npos)
      << fileError(dir + "/cycle.yaml");
  std::ofstream(dir + "/missing.yaml") << "base: nowhere.yaml\n";
  EXPECT_EQ(fileError(dir + "/missing.yaml"), dir + "/nowhere.yaml: cannot open file");
  std::ofstream(dir + "/bad_base.yaml") << "base: base.yaml\n";
  std::ofstream(dir + "/base.yaml") << "world: {boxes: [{min_m: [0, 0, 0], sise_m: 1}]}\n";
  EXPECT_EQ(fileError(dir + "/bad_base.yaml").rfind(dir + "/base.yaml: world.boxes[0]", 0), 0u)
      << "the error names the base file: " << fileError(dir + "/bad_base.yaml");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mlmap::datasets
