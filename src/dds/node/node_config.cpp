#include "mlmap/dds/node_config.h"

#include "mlmap/config/config_yaml.h"
#include "mlmap/config/yaml_section.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <vector>

namespace mlmap::dds {
namespace {

/// Reads the `dds:` section (nested `topics:` and `rates:`) into `dds`.
void readDdsSection(io::Section& top, DdsConfig* dds) {
  std::vector<std::string>* errors = top.errors();
  io::Section s(top.child("dds"), "dds", errors);
  s.read("domain_id", &dds->domain_id);
  s.read("ns", &dds->ns);
  s.read("discovery_range", &dds->discovery_range);
  s.read("profiles_file", &dds->profiles_file);
  s.read("participant_profile", &dds->participant_profile);
  s.read("large_data", &dds->large_data);
  s.read("shared_memory", &dds->shared_memory);
  s.read("data_sharing", &dds->data_sharing);
  s.read("world_frame", &dds->world_frame);
  s.read("body_frame", &dds->body_frame);
  s.read("sensor_frame", &dds->sensor_frame);
  {
    io::Section t(s.child("topics"), "dds.topics", errors);
    TopicNames& n = dds->topics;
    t.read("cloud", &n.cloud);
    t.read("pose", &n.pose);
    t.read("odometry", &n.odometry);
    t.read("depth_image", &n.depth_image);
    t.read("camera_info", &n.camera_info);
    t.read("awareness", &n.awareness);
    t.read("local_map", &n.local_map);
    t.read("global_map", &n.global_map);
    t.read("grid", &n.grid);
    t.read("esdf_slice", &n.esdf_slice);
    t.read("esdf_block", &n.esdf_block);
    t.read("status", &n.status);
  }
  {
    io::Section r(s.child("rates"), "dds.rates", errors);
    PublishRates& p = dds->rates;
    r.read("awareness_hz", &p.awareness_hz);
    r.read("local_map_hz", &p.local_map_hz);
    r.read("global_map_hz", &p.global_map_hz);
    r.read("grid_hz", &p.grid_hz);
    r.read("esdf_hz", &p.esdf_hz);
    r.read("status_hz", &p.status_hz);
  }
  s.read("pose_tolerance_s", &dds->pose_tolerance_s);
  s.read("pose_buffer_s", &dds->pose_buffer_s);
  s.read("max_future_s", &dds->max_future_s);
  s.read("max_pose_speed_mps", &dds->max_pose_speed_mps);
  s.read("max_pose_rotation_rate_dps", &dds->max_pose_rotation_rate_dps);
  s.read("esdf_slice_height_m", &dds->esdf_slice_height_m);
  {
    io::Section sec(s.child("security"), "dds.security", errors);
    SecurityConfig& c = dds->security;
    const YAML::Node enable = sec.child("enable");
    if (enable && !enable.IsNull()) {  // absent or empty: the environment decides
      bool value = false;
      const std::size_t before = errors->size();
      sec.read("enable", &value);
      // cppcheck-suppress knownConditionTrueFalse ; sec.read appends to *errors on a bad value
      if (errors->size() == before) c.enable = value;
    }
    sec.read("keystore", &c.keystore);
    sec.read("enclave", &c.enclave);
    sec.read("strategy", &c.strategy);
  }
}

void readMapFileSection(io::Section& top, MapFileOptions* options) {
  io::Section s(top.child("map_file"), "map_file", top.errors());
  s.read("load_path", &options->load_path);
  s.read("load_missing_ok", &options->load_missing_ok);
  s.read("save_path", &options->save_path);
  s.read("save_period_s", &options->save_period_s);
}

}  // namespace

void MapFileOptions::validate(std::vector<std::string>* errors) const {
  if (!std::isfinite(save_period_s) || save_period_s < 0.0) {
    errors->push_back("map_file.save_period_s: must be >= 0 (0: only at shutdown) (got " +
                      std::to_string(save_period_s) + ")");
  } else if (save_period_s > 0.0 && save_path.empty()) {
    errors->push_back("map_file.save_period_s: periodic saving needs map_file.save_path");
  }
  if (!save_path.empty()) {
    const std::filesystem::path p(save_path);
    const std::filesystem::path dir = p.has_parent_path() ? p.parent_path() : ".";
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) {
      errors->push_back("map_file.save_path: folder '" + dir.string() + "' does not exist (got '" +
                        save_path + "')");
    } else if (!p.has_filename() || std::filesystem::is_directory(p, ec)) {
      errors->push_back("map_file.save_path: is a folder, not a file name (got '" + save_path + "')");
    }
  }
  if (!load_path.empty() && !load_missing_ok && !std::filesystem::exists(load_path)) {
    errors->push_back("map_file.load_path: no such file (got '" + load_path +
                      "'; set map_file.load_missing_ok to start empty when it is missing)");
  }
}

NodeConfig parseNodeConfigYaml(const std::string& text, const std::string& source_name) {
  const YAML::Node root = io::parseYamlDocument(text, source_name);
  NodeConfig c;
  std::vector<std::string> errors;
  std::size_t engine_problems = 0;
  std::size_t dds_problems = 0;
  {
    io::Section top(root, "", &errors);
    io::readEngineSections(top, &c.map);
    engine_problems = errors.size();
    readDdsSection(top, &c.dds);
    dds_problems = errors.size() - engine_problems;
    readMapFileSection(top, &c.map_file);
  }  // reports unknown top-level keys
  io::stripTopLevelDots(&errors);
  if (engine_problems == 0) {
    for (std::string& e : c.map.validate()) errors.push_back(std::move(e));
  }
  // cppcheck-suppress knownConditionTrueFalse ; readDdsSection appends to errors through `top`
  if (dds_problems == 0) {
    for (std::string& e : c.dds.validate()) errors.push_back(std::move(e));
  }
  c.map_file.validate(&errors);
  if (!errors.empty()) io::throwConfigErrors(source_name, errors);
  return c;
}

NodeConfig loadNodeConfigYaml(const std::string& path) {
  return parseNodeConfigYaml(io::readConfigFile(path), path);
}

std::string toYaml(const NodeConfig& config) {
  const DdsConfig& d = config.dds;
  YAML::Emitter out;
  out.SetDoublePrecision(15);  // as the engine sections: typed values round-trip
  auto text = [&out](const char* key, const std::string& value) {
    out << YAML::Key << key << YAML::Value << YAML::DoubleQuoted << value;
  };
  auto number = [&out](const char* key, double value) {
    out << YAML::Key << key << YAML::Value << value;
  };
  out << YAML::BeginMap << YAML::Key << "dds" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "domain_id" << YAML::Value << d.domain_id;
  text("ns", d.ns);
  text("discovery_range", d.discovery_range);
  text("profiles_file", d.profiles_file);
  text("participant_profile", d.participant_profile);
  out << YAML::Key << "large_data" << YAML::Value << d.large_data;
  out << YAML::Key << "shared_memory" << YAML::Value << d.shared_memory;
  out << YAML::Key << "data_sharing" << YAML::Value << d.data_sharing;
  text("world_frame", d.world_frame);
  text("body_frame", d.body_frame);
  text("sensor_frame", d.sensor_frame);
  out << YAML::Key << "topics" << YAML::Value << YAML::BeginMap;
  text("cloud", d.topics.cloud);
  text("pose", d.topics.pose);
  text("odometry", d.topics.odometry);
  text("depth_image", d.topics.depth_image);
  text("camera_info", d.topics.camera_info);
  text("awareness", d.topics.awareness);
  text("local_map", d.topics.local_map);
  text("global_map", d.topics.global_map);
  text("grid", d.topics.grid);
  text("esdf_slice", d.topics.esdf_slice);
  text("esdf_block", d.topics.esdf_block);
  text("status", d.topics.status);
  out << YAML::EndMap;
  out << YAML::Key << "rates" << YAML::Value << YAML::BeginMap;
  number("awareness_hz", d.rates.awareness_hz);
  number("local_map_hz", d.rates.local_map_hz);
  number("global_map_hz", d.rates.global_map_hz);
  number("grid_hz", d.rates.grid_hz);
  number("esdf_hz", d.rates.esdf_hz);
  number("status_hz", d.rates.status_hz);
  out << YAML::EndMap;
  number("pose_tolerance_s", d.pose_tolerance_s);
  number("pose_buffer_s", d.pose_buffer_s);
  number("max_future_s", d.max_future_s);
  number("max_pose_speed_mps", d.max_pose_speed_mps);
  number("max_pose_rotation_rate_dps", d.max_pose_rotation_rate_dps);
  number("esdf_slice_height_m", d.esdf_slice_height_m);
  out << YAML::Key << "security" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "enable" << YAML::Value;
  if (d.security.enable) {
    out << *d.security.enable;
  } else {
    out << YAML::Null;  // the environment decides
  }
  text("keystore", d.security.keystore);
  text("enclave", d.security.enclave);
  text("strategy", d.security.strategy);
  out << YAML::EndMap;
  out << YAML::EndMap;
  out << YAML::Key << "map_file" << YAML::Value << YAML::BeginMap;
  text("load_path", config.map_file.load_path);
  out << YAML::Key << "load_missing_ok" << YAML::Value << config.map_file.load_missing_ok;
  text("save_path", config.map_file.save_path);
  number("save_period_s", config.map_file.save_period_s);
  out << YAML::EndMap << YAML::EndMap;
  // Two block mappings at the top level, one after the other, are one mapping.
  return io::toYaml(config.map) + std::string(out.c_str()) + "\n";
}

}  // namespace mlmap::dds
