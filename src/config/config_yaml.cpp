#include "mlmap/config/config_yaml.h"

#include "mlmap/config/config_keys.h"
#include "mlmap/config/yaml_section.h"

#include <yaml-cpp/yaml.h>

#include <stdexcept>

namespace mlmap::config {

void readEngineSections(Section& top, MapConfig* config) {
  YamlReader reader(top);
  visitConfig(*config, reader);
}

MapConfig parseConfigYaml(const std::string& text, const std::string& source_name,
                          const std::vector<std::string>& skipped_sections) {
  const YAML::Node root = parseYamlDocument(text, source_name);
  MapConfig c;
  std::vector<std::string> errors;
  {
    Section top(root, "", &errors);
    readEngineSections(top, &c);
    for (const std::string& key : skipped_sections) (void)top.child(key);
  }  // reports unknown top-level keys
  stripTopLevelDots(&errors);
  if (errors.empty()) errors = c.validate();
  if (!errors.empty()) throwConfigErrors(source_name, errors);
  return c;
}

MapConfig loadConfigYaml(const std::string& path,
                         const std::vector<std::string>& skipped_sections) {
  return parseConfigYaml(readConfigFile(path), path, skipped_sections);
}

std::string toYaml(const MapConfig& config) {
  YAML::Emitter out;
  out.SetDoublePrecision(15);  // 0.1 prints as 0.1; anything typed with <= 15 digits round-trips
  out << YAML::BeginMap;
  YamlWriter writer(out);
  visitConfig(config, writer);
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::string engineDefaultsYaml() {
  CommentedYamlWriter writer;
  const MapConfig defaults;
  visitConfig(defaults, writer);
  return std::string(kEngineDefaultsHeader) + "\n" + writer.text();
}

std::string engineKeyReference() {
  MarkdownKeyTable table;
  const MapConfig defaults;
  visitConfig(defaults, table);
  return MarkdownKeyTable::header() + table.rows();
}

}  // namespace mlmap::config
