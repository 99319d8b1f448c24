#include "mlmap/dds/node/config_reference.h"

#include "mlmap/config/config_keys.h"
#include "mlmap/config/config_yaml.h"
#include "mlmap/config/yaml_section.h"
#include "mlmap/dds/node/node_config.h"

#include <gtest/gtest.h>

#include <set>
#include <stdexcept>
#include <string>

namespace mlmap::dds {
namespace {

TEST(ConfigReference, CheckedInFilesEqualTheKeyLists) {
  for (const GeneratedFile& file : generatedConfigFiles(MLMAP_SOURCE_DIR)) {
    EXPECT_EQ(config::readConfigFile(std::string(MLMAP_SOURCE_DIR "/") + file.path), file.text)
        << file.path << " differs from the key lists in code. Regenerate it from the source tree "
        << "with `build/mlmap_config_tool --write` (after building mlmap_config_tool), then "
        << "review and commit the diff.";
  }
}

TEST(ConfigReference, GeneratedDefaultsReadBackAsTheDefaultsInCode) {
  const auto printed = [](const NodeConfig& c) { return toYaml(c); };
  EXPECT_EQ(printed(parseNodeConfigYaml(config::engineDefaultsYaml() + "\n" + nodeDefaultsYaml())),
            printed(NodeConfig{}));
}

TEST(ConfigReference, TheNodeOnlySectionsAreTheNodesOwnSections) {
  config::SectionNames names;
  const NodeConfig defaults;
  NodeConfig::visitNodeSections(defaults, names);
  EXPECT_EQ(names.names(), config::kNodeOnlySections);
}

/// Every key path once, with a meaning.
class KeyChecker {
 public:
  explicit KeyChecker(std::string path = "") : path_(std::move(path)) {}
  template <class T>
  void key(const char* name, const T& /*field*/, const char* /*unit*/, const char* doc) {
    record(name, doc);
  }
  template <class S>
  void section(const char* name, const S& sub, const char* doc) {
    record(name, doc);
    KeyChecker nested(config::childPath(path_, name));
    visitConfig(sub, nested);
  }

 private:
  void record(const char* name, const char* doc) {
    const std::string path = config::childPath(path_, name);
    EXPECT_TRUE(seen_.insert(path).second) << path << " is listed twice";
    EXPECT_NE(std::string(doc), "") << path << " has no meaning";
  }
  std::string path_;
  std::set<std::string> seen_;
};

TEST(ConfigReference, EveryKeyIsListedOnceWithAMeaning) {
  KeyChecker checker;
  const NodeConfig defaults;
  NodeConfig::visit(defaults, checker);
}

TEST(ConfigReference, TheReferenceGoesBetweenTheMarkers) {
  const std::string doc =
      std::string("# Title\n") + kReferenceBegin + "\nold\n" + kReferenceEnd + "\nafter\n";
  EXPECT_EQ(withKeyReference(doc, "new\n"),
            std::string("# Title\n") + kReferenceBegin + "\nnew\n" + kReferenceEnd + "\nafter\n");
  EXPECT_THROW((void)withKeyReference("# Title\n", "new\n"), std::runtime_error);
  EXPECT_NE(keyReferenceMarkdown().find("| `dds.topics.cloud` | `cloud` |"), std::string::npos);
  EXPECT_NE(keyReferenceMarkdown().find("| `awareness.rho_cell_m` | `0.1` | m |"),
            std::string::npos);
}

TEST(ConfigReference, DefaultValuesPrintAsTheyReadBack) {
  EXPECT_EQ(config::DefaultText::of(10.0), "10.0");
  EXPECT_EQ(config::DefaultText::of(0.05), "0.05");
  EXPECT_EQ(config::DefaultText::of(-1), "-1");
  EXPECT_EQ(config::DefaultText::of(std::string()), "\"\"");
  EXPECT_EQ(config::DefaultText::of(std::string("mlmap/grid")), "mlmap/grid");
  EXPECT_EQ(config::DefaultText::of(std::string("true")), "\"true\"");
  EXPECT_EQ(config::DefaultText::of(std::string("/a b")), "\"/a b\"");
  EXPECT_EQ(config::DefaultText::of(Eigen::Vector3i(95, 95, 35)), "[95, 95, 35]");
  EXPECT_EQ(config::DefaultText::of(std::optional<bool>()), "");
}

}  // namespace
}  // namespace mlmap::dds
