#include "mlmap/dds/node/node_config.h"

#include "mlmap/config/config_keys.h"
#include "mlmap/config/config_yaml.h"
#include "mlmap/config/yaml_section.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <vector>

namespace mlmap::dds {

void MapFileOptions::validate(std::vector<std::string>* errors) const {
  const auto key = [this](const auto& field) {
    return std::string(kSection) + "." + keyPath(*this, field);
  };
  if (!std::isfinite(save_period_s) || save_period_s < 0.0) {
    errors->push_back(key(save_period_s) + ": must be >= 0 (0: only at shutdown) (got " +
                      std::to_string(save_period_s) + ")");
  } else if (save_period_s > 0.0 && save_path.empty()) {
    errors->push_back(key(save_period_s) + ": periodic saving needs " + key(save_path));
  }
  if (!save_path.empty()) {
    const std::filesystem::path p(save_path);
    const std::filesystem::path dir = p.has_parent_path() ? p.parent_path() : ".";
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) {
      errors->push_back(key(save_path) + ": folder '" + dir.string() + "' does not exist (got '" +
                        save_path + "')");
    } else if (!p.has_filename() || std::filesystem::is_directory(p, ec)) {
      errors->push_back(key(save_path) + ": is a folder, not a file name (got '" + save_path +
                        "')");
    }
  }
  if (!load_path.empty() && !load_missing_ok && !std::filesystem::exists(load_path)) {
    errors->push_back(key(load_path) + ": no such file (got '" + load_path + "'; set " +
                      key(load_missing_ok) + " to start empty when it is missing)");
  }
}

NodeConfig parseNodeConfigYaml(const std::string& text, const std::string& source_name) {
  const YAML::Node root = config::parseYamlDocument(text, source_name);
  NodeConfig c;
  std::vector<std::string> errors;
  std::size_t engine_problems = 0;
  std::size_t dds_problems = 0;
  {
    config::Section top(root, "", &errors);
    config::readEngineSections(top, &c.map);
    engine_problems = errors.size();
    config::YamlReader reader(top);
    NodeConfig::visitNodeSections(c, reader);
    dds_problems = reader.problemsIn(&c.dds);
  }  // reports unknown top-level keys
  config::stripTopLevelDots(&errors);
  if (engine_problems == 0) {
    for (std::string& e : c.map.validate()) errors.push_back(std::move(e));
  }
  if (dds_problems == 0) {
    for (std::string& e : c.dds.validate()) errors.push_back(std::move(e));
  }
  c.map_file.validate(&errors);
  if (!errors.empty()) config::throwConfigErrors(source_name, errors);
  return c;
}

NodeConfig loadNodeConfigYaml(const std::string& path) {
  return parseNodeConfigYaml(config::readConfigFile(path), path);
}

NodeConfig nodeConfigOrDefaults(const std::string& path) {
  return path.empty() ? NodeConfig{} : loadNodeConfigYaml(path);
}

std::string toYaml(const NodeConfig& config) {
  YAML::Emitter out;
  out.SetDoublePrecision(15);  // as the engine sections: typed values round-trip
  out << YAML::BeginMap;
  config::YamlWriter writer(out);
  NodeConfig::visitNodeSections(config, writer);
  out << YAML::EndMap;
  // Two block mappings at the top level, one after the other, are one mapping.
  return config::toYaml(config.map) + std::string(out.c_str()) + "\n";
}

std::string nodeDefaultsYaml() {
  config::CommentedYamlWriter writer;
  const NodeConfig defaults;
  NodeConfig::visitNodeSections(defaults, writer);
  return std::string(kNodeDefaultsHeader) + "\n" + writer.text();
}

std::string nodeKeyReference() {
  config::MarkdownKeyTable table;
  const NodeConfig defaults;
  NodeConfig::visitNodeSections(defaults, table);
  return config::MarkdownKeyTable::header() + table.rows();
}

PoseBufferConfig poseBufferConfig(const DdsConfig& dds) {
  PoseBufferConfig config;
  config.tolerance_s = dds.pose_tolerance_s;
  config.horizon_s = dds.pose_buffer_s;
  config.max_future_s = dds.max_future_s;
  config.max_speed_mps = dds.max_pose_speed_mps;
  config.max_rotation_rate_dps = dds.max_pose_rotation_rate_dps;
  return config;
}

}  // namespace mlmap::dds
