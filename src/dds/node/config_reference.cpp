#include "mlmap/dds/node/config_reference.h"

#include "mlmap/config/config_yaml.h"
#include "mlmap/config/yaml_section.h"
#include "mlmap/dds/node/node_config.h"

#include <stdexcept>

namespace mlmap::dds {

std::string keyReferenceMarkdown() {
  return "### Engine keys (`config/mlmap.yaml`)\n\n" + config::engineKeyReference() +
         "\n### Node keys (`config/mlmap_node.yaml`)\n\n" + nodeKeyReference();
}

std::string withKeyReference(const std::string& document, const std::string& reference) {
  const std::string begin = std::string(kReferenceBegin) + "\n";
  const std::string end = std::string(kReferenceEnd) + "\n";
  const std::size_t b = document.find(begin);
  const std::size_t e = b == std::string::npos ? b : document.find(end, b);
  if (e == std::string::npos) {
    throw std::runtime_error(std::string("the key reference markers are missing: a line '") +
                             kReferenceBegin + "' followed later by a line '" + kReferenceEnd +
                             "'");
  }
  return document.substr(0, b + begin.size()) + reference + document.substr(e);
}

std::vector<GeneratedFile> generatedConfigFiles(const std::string& source_dir) {
  const std::string doc_path = "docs/configuration.md";
  const std::string doc = config::readConfigFile(source_dir + "/" + doc_path);
  return {{"config/mlmap.yaml", config::engineDefaultsYaml()},
          {"config/mlmap_node.yaml", nodeDefaultsYaml()},
          {doc_path, withKeyReference(doc, keyReferenceMarkdown())}};
}

}  // namespace mlmap::dds
