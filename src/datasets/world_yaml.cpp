#include "mlmap/datasets/world_yaml.h"

#include "mlmap/config/yaml_section.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace mlmap::datasets {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

/// Error in the YAML content; the message starts with the key path.
struct ParseError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw ParseError(path + ": " + what);
}

std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

std::string indexed(const std::string& path, std::size_t i) {
  return path + "[" + std::to_string(i) + "]";
}

std::string formatNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string describe(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a mapping";
  return "nothing";
}

/// True when `node` is a (non-null) mapping; null means "absent". Anything else is an error.
bool isPresentMap(const YAML::Node& node, const std::string& path) {
  if (!node || node.IsNull()) return false;
  if (!node.IsMap()) fail(path, "expected a mapping, got " + describe(node));
  return true;
}

/// Checks that `map` is a mapping with only `allowed` keys.
void checkKeys(const YAML::Node& map, const std::string& path,
               std::initializer_list<const char*> allowed) {
  if (!map.IsMap()) fail(path, "expected a mapping, got " + describe(map));
  for (const auto& item : map) {
    if (!item.first.IsScalar()) fail(path, "keys must be plain strings");
    const std::string key = item.first.Scalar();
    const bool known = std::any_of(allowed.begin(), allowed.end(),
                                   [&key](const char* name) { return key == name; });
    if (!known) {
      std::string list;
      for (const char* name : allowed) list += (list.empty() ? "" : ", ") + std::string(name);
      fail(path, "unknown key '" + key + "' (allowed: " + list + ")");
    }
  }
}

YAML::Node required(const YAML::Node& map, const char* key, const std::string& path) {
  YAML::Node child = map[key];
  if (!child) fail(path, std::string("missing required key '") + key + "'");
  return child;
}

double readNumber(const YAML::Node& node, const std::string& path) {
  if (!node.IsScalar()) fail(path, "expected a number, got " + describe(node));
  double value = 0.0;
  try {
    value = node.as<double>();
  } catch (const YAML::Exception&) {
    fail(path, "expected a number, got '" + node.Scalar() + "'");
  }
  if (!std::isfinite(value)) fail(path, "must be finite, got '" + node.Scalar() + "'");
  return value;
}

long long readInteger(const YAML::Node& node, const std::string& path) {
  if (!node.IsScalar()) fail(path, "expected an integer, got " + describe(node));
  try {
    return node.as<long long>();
  } catch (const YAML::Exception&) {
    fail(path, "expected an integer, got '" + node.Scalar() + "'");
  }
}

template <int N>
Eigen::Matrix<double, N, 1> readVector(const YAML::Node& node, const std::string& path) {
  if (!node.IsSequence() || node.size() != static_cast<std::size_t>(N)) {
    fail(path,
         "expected a list of " + std::to_string(N) + " numbers, got " +
             (node.IsSequence() ? "a list of " + std::to_string(node.size()) : describe(node)));
  }
  Eigen::Matrix<double, N, 1> v;
  for (int i = 0; i < N; ++i)
    v[i] =
        readNumber(node[static_cast<std::size_t>(i)], indexed(path, static_cast<std::size_t>(i)));
  return v;
}

double readPositive(const YAML::Node& node, const std::string& path) {
  const double value = readNumber(node, path);
  if (!(value > 0.0)) fail(path, "must be > 0, got " + formatNumber(value));
  return value;
}

/// Calls `parse_item(item, item_path)` for each element of an optional list.
template <typename Fn>
void forEachItem(const YAML::Node& parent, const char* key, const std::string& parent_path,
                 Fn&& parse_item) {
  const YAML::Node list = parent[key];
  const std::string path = join(parent_path, key);
  if (!list || list.IsNull()) return;
  if (!list.IsSequence()) fail(path, "expected a list, got " + describe(list));
  for (std::size_t i = 0; i < list.size(); ++i) parse_item(list[i], indexed(path, i));
}

void parseWorld(const YAML::Node& node, sim::World* world) {
  const std::string path = "world";
  if (!isPresentMap(node, path)) return;
  checkKeys(node, path, {"boxes", "cylinders", "spheres", "moving_boxes"});

  forEachItem(node, "boxes", path, [world](const YAML::Node& item, const std::string& p) {
    checkKeys(item, p, {"min_m", "max_m"});
    sim::Box box;
    box.min_W = readVector<3>(required(item, "min_m", p), join(p, "min_m"));
    box.max_W = readVector<3>(required(item, "max_m", p), join(p, "max_m"));
    if ((box.min_W.array() > box.max_W.array()).any()) {
      fail(p, "min_m must be <= max_m on every axis");
    }
    if (!world->addBox(box)) fail(p, "invalid box");
  });

  forEachItem(node, "cylinders", path, [world](const YAML::Node& item, const std::string& p) {
    checkKeys(item, p, {"center_xy_m", "radius_m", "z_min_m", "z_max_m"});
    sim::Cylinder c;
    c.center_xy_W = readVector<2>(required(item, "center_xy_m", p), join(p, "center_xy_m"));
    c.radius_m = readPositive(required(item, "radius_m", p), join(p, "radius_m"));
    c.z_min_m = readNumber(required(item, "z_min_m", p), join(p, "z_min_m"));
    c.z_max_m = readNumber(required(item, "z_max_m", p), join(p, "z_max_m"));
    if (c.z_min_m > c.z_max_m) {
      fail(p, "z_min_m (" + formatNumber(c.z_min_m) + ") must be <= z_max_m (" +
                  formatNumber(c.z_max_m) + ")");
    }
    if (!world->addCylinder(c)) fail(p, "invalid cylinder");
  });

  forEachItem(node, "spheres", path, [world](const YAML::Node& item, const std::string& p) {
    checkKeys(item, p, {"center_m", "radius_m"});
    sim::Sphere s;
    s.center_W = readVector<3>(required(item, "center_m", p), join(p, "center_m"));
    s.radius_m = readPositive(required(item, "radius_m", p), join(p, "radius_m"));
    if (!world->addSphere(s)) fail(p, "invalid sphere");
  });

  forEachItem(node, "moving_boxes", path, [world](const YAML::Node& item, const std::string& p) {
    checkKeys(item, p, {"size_m", "start_center_m", "velocity_mps", "t_start_s", "t_end_s"});
    sim::MovingBox m;
    m.size_m = readVector<3>(required(item, "size_m", p), join(p, "size_m"));
    if (!(m.size_m.array() > 0.0).all()) fail(join(p, "size_m"), "every size must be > 0");
    m.start_center_W =
        readVector<3>(required(item, "start_center_m", p), join(p, "start_center_m"));
    m.velocity_mps = readVector<3>(required(item, "velocity_mps", p), join(p, "velocity_mps"));
    m.t_start_s = readNumber(required(item, "t_start_s", p), join(p, "t_start_s"));
    m.t_end_s = readNumber(required(item, "t_end_s", p), join(p, "t_end_s"));
    if (m.t_start_s > m.t_end_s) {
      fail(p, "t_start_s (" + formatNumber(m.t_start_s) + ") must be <= t_end_s (" +
                  formatNumber(m.t_end_s) + ")");
    }
    if (!world->addMovingBox(m)) fail(p, "invalid moving box");
  });
}

void parseTrajectory(const YAML::Node& node, sim::Trajectory* trajectory) {
  const std::string path = "trajectory";
  if (!isPresentMap(node, path)) return;
  checkKeys(node, path, {"speed_mps", "waypoints"});
  double speed_mps = 1.0;
  if (const YAML::Node speed = node["speed_mps"]) {
    speed_mps = readPositive(speed, join(path, "speed_mps"));
  }
  const YAML::Node list = required(node, "waypoints", path);
  const std::string list_path = join(path, "waypoints");
  if (!list.IsSequence() || list.size() == 0) {
    fail(list_path, "expected a non-empty list of waypoints, got " + describe(list));
  }
  std::vector<sim::Waypoint> waypoints;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string p = indexed(list_path, i);
    const YAML::Node item = list[i];
    checkKeys(item, p, {"position_m", "yaw_deg"});
    sim::Waypoint wp;
    wp.position_W = readVector<3>(required(item, "position_m", p), join(p, "position_m"));
    if (const YAML::Node yaw = item["yaw_deg"]) {
      wp.yaw_rad = readNumber(yaw, join(p, "yaw_deg")) * kDegToRad;
      wp.has_yaw = true;
    }
    waypoints.push_back(wp);
  }
  try {
    *trajectory = sim::Trajectory(std::move(waypoints), speed_mps);
  } catch (const std::invalid_argument& e) {
    throw ParseError(e.what());  // already prefixed with "trajectory: ..."
  }
}

void parseCamera(const YAML::Node& node, sim::DepthCameraModel* camera) {
  const std::string path = "camera";
  if (!isPresentMap(node, path)) return;
  checkKeys(node, path,
            {"width", "height", "fx", "fy", "cx", "cy", "min_depth_m", "max_depth_m",
             "noise_coeff_per_m", "seed"});
  constexpr long long kMaxImageSide = 100000;
  auto readSide = [&](const char* key, int* value) {
    if (const YAML::Node n = node[key]) {
      const long long v = readInteger(n, join(path, key));
      if (v <= 0 || v > kMaxImageSide) {
        fail(join(path, key),
             "must be in [1, " + std::to_string(kMaxImageSide) + "], got " + std::to_string(v));
      }
      *value = static_cast<int>(v);
    }
  };
  auto readOptional = [&](const char* key, double* value, bool positive) {
    if (const YAML::Node n = node[key]) {
      *value = positive ? readPositive(n, join(path, key)) : readNumber(n, join(path, key));
    }
  };
  PinholeIntrinsics& K = camera->intrinsics;
  readSide("width", &K.width);
  readSide("height", &K.height);
  readOptional("fx", &K.fx, true);
  readOptional("fy", &K.fy, true);
  readOptional("cx", &K.cx, false);
  readOptional("cy", &K.cy, false);
  readOptional("min_depth_m", &camera->min_depth_m, false);
  readOptional("max_depth_m", &camera->max_depth_m, true);
  readOptional("noise_coeff_per_m", &camera->noise_coeff_per_m, false);
  if (camera->min_depth_m < 0.0) {
    fail(join(path, "min_depth_m"), "must be >= 0, got " + formatNumber(camera->min_depth_m));
  }
  if (camera->min_depth_m >= camera->max_depth_m) {
    fail(path, "min_depth_m (" + formatNumber(camera->min_depth_m) + ") must be < max_depth_m (" +
                   formatNumber(camera->max_depth_m) + ")");
  }
  if (camera->noise_coeff_per_m < 0.0) {
    fail(join(path, "noise_coeff_per_m"),
         "must be >= 0, got " + formatNumber(camera->noise_coeff_per_m));
  }
  if (const YAML::Node n = node["seed"]) {
    const long long seed = readInteger(n, join(path, "seed"));
    if (seed < 0 || seed > static_cast<long long>(std::numeric_limits<std::uint32_t>::max())) {
      fail(join(path, "seed"), "must be in [0, 4294967295], got " + std::to_string(seed));
    }
    camera->seed = static_cast<std::uint32_t>(seed);
  }
}

/// Longest chain of `base` files (a longer one is most likely a cycle).
constexpr int kMaxBaseDepth = 8;

Scenario loadWithDepth(const std::string& path, int depth);

/// `base` relative to the folder of the file that names it (`dir`; "" for the working folder).
std::string basePath(const YAML::Node& node, const std::string& dir) {
  if (!node.IsScalar() || node.Scalar().empty()) {
    fail("base", "expected a file name, got " + describe(node));
  }
  const std::string& name = node.Scalar();
  return name.front() == '/' || dir.empty() ? name : dir + "/" + name;
}

/// A section given here replaces the base's whole section (the base's own keys are not merged).
Scenario parseRoot(const YAML::Node& root, const std::string& dir, int depth) {
  Scenario scenario;
  if (!root || root.IsNull()) return scenario;
  checkKeys(root, "<root>", {"base", "world", "trajectory", "camera", "frame_rate_hz"});
  if (const YAML::Node base = root["base"]) {
    if (depth >= kMaxBaseDepth) {
      fail("base", "more than " + std::to_string(kMaxBaseDepth) + " bases in a chain (a cycle?)");
    }
    scenario = loadWithDepth(basePath(base, dir), depth + 1);
  }
  if (isPresentMap(root["world"], "world")) scenario.world = sim::World{};
  parseWorld(root["world"], &scenario.world);
  if (isPresentMap(root["trajectory"], "trajectory")) scenario.trajectory = sim::Trajectory{};
  parseTrajectory(root["trajectory"], &scenario.trajectory);
  if (isPresentMap(root["camera"], "camera")) scenario.camera = sim::DepthCameraModel{};
  parseCamera(root["camera"], &scenario.camera);
  if (const YAML::Node rate = root["frame_rate_hz"]) {
    scenario.frame_rate_hz = readPositive(rate, "frame_rate_hz");
  }
  return scenario;
}

Scenario parseWithName(const std::string& text, const std::string& source_name,
                       const std::string& dir, int depth) {
  const YAML::Node root =
      config::parseYamlDocument(text, source_name);  // one document, no duplicates
  try {
    return parseRoot(root, dir, depth);
  } catch (const ParseError& e) {
    throw std::runtime_error(source_name + ": " + e.what());
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(source_name + ": " + e.what());
  }
}

Scenario loadWithDepth(const std::string& path, int depth) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw std::runtime_error(path + ": read error");
  const std::size_t slash = path.rfind('/');
  const std::string dir = slash == std::string::npos ? "" : path.substr(0, slash == 0 ? 1 : slash);
  return parseWithName(text.str(), path, dir, depth);
}

}  // namespace

Scenario parseScenarioYaml(const std::string& yaml_text, const std::string& source_name) {
  return parseWithName(yaml_text, source_name, "", 0);
}

Scenario loadScenarioYaml(const std::string& path) { return loadWithDepth(path, 0); }

Scenario defaultScenario() {
  Scenario scenario;
  scenario.world = sim::World::defaultRoom();
  scenario.trajectory = sim::Trajectory::defaultRoomFlight();
  scenario.camera = sim::DepthCameraModel{};
  scenario.frame_rate_hz = 10.0;
  return scenario;
}

}  // namespace mlmap::datasets
