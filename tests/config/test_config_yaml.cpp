#include "mlmap/config/config_yaml.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace mlmap {
namespace {

std::string errorOf(const std::string& yaml) {
  try {
    config::parseConfigYaml(yaml, "test.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

bool sameConfig(const MapConfig& a, const MapConfig& b) {
  return config::toYaml(a) == config::toYaml(b);
}

TEST(ConfigYaml, EmptyDocumentGivesThePaperDefaults) {
  const MapConfig c = config::parseConfigYaml("{}");
  EXPECT_EQ(c.awareness.rho_cells, 100);
  EXPECT_EQ(c.awareness.phi_cells, 180);
  EXPECT_EQ(c.awareness.z_cells, 25);
  EXPECT_DOUBLE_EQ(c.local_map.resolution_m, 0.2);
  EXPECT_EQ(c.local_map.size_cells, Eigen::Vector3i(95, 95, 35));
  EXPECT_EQ(c.awareness.sample_count, 0);
  EXPECT_TRUE(c.validate().empty());
}

TEST(ConfigYaml, PrintedConfigReadsBackIdentically) {
  MapConfig c;
  c.local_map.resolution_m = 0.1;
  c.local_map.size_cells = {165, 165, 75};
  c.pipeline.threaded = true;
  c.sensor.translation_B_m = {0.05, -0.02, 0.1};
  EXPECT_TRUE(sameConfig(config::parseConfigYaml(config::toYaml(c)), c));
}

TEST(ConfigYaml, ShippedDefaultFileEqualsTheDefaultsInCode) {
  EXPECT_TRUE(
      sameConfig(config::loadConfigYaml(MLMAP_SOURCE_DIR "/config/mlmap.yaml"), MapConfig{}));
}

TEST(ConfigYaml, OfflineProgramsReadTheEngineSectionsOfANodeConfiguration) {
  const std::string node =
      "local_map: {resolution_m: 0.2}\ndds: {domain_id: 7}\nmap_file: {save_path: m}\n";
  EXPECT_DOUBLE_EQ(
      config::parseConfigYaml(node, "node.yaml", config::kNodeOnlySections).local_map.resolution_m,
      0.2);
  // Skipped means not read, not anything goes: typos elsewhere are still errors.
  EXPECT_NE(errorOf(node).find("dds: unknown key"), std::string::npos);
  try {
    (void)config::parseConfigYaml(node + "lokal_map: {}\n", "node.yaml", config::kNodeOnlySections);
    ADD_FAILURE() << "a typo next to skipped sections was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("lokal_map: unknown key"), std::string::npos) << e.what();
  }
  // The shipped node configurations load this way.
  for (const char* name : {"mlmap_node.yaml", "mlmap_node_replay.yaml", "mlmap_node_depth.yaml"}) {
    EXPECT_NO_THROW((void)config::loadConfigYaml(std::string(MLMAP_SOURCE_DIR "/config/") + name,
                                                 config::kNodeOnlySections))
        << name;
  }
}

TEST(ConfigYaml, UnknownKeysAndBadValuesAreClearErrors) {
  // Keys that are lists, mappings or null used to throw out of a destructor, which terminated
  // the program (tests/fuzz/regressions/fuzz_config_yaml).
  EXPECT_NE(errorOf("[a, b]: 1").find("(top level): a key must be plain text, not a list"),
            std::string::npos);
  EXPECT_NE(errorOf("local_map: {? {x: 1} : 2}")
                .find("local_map: a key must be plain text, not a mapping"),
            std::string::npos);
  EXPECT_NE(errorOf("~: 1").find("a key must be plain text, not null"), std::string::npos);
  EXPECT_NE(errorOf("local_map: {resolutoin_m: 0.1}").find("local_map.resolutoin_m: unknown key"),
            std::string::npos);
  EXPECT_NE(errorOf("lokal_map: {}").find("lokal_map: unknown key"), std::string::npos);
  EXPECT_NE(errorOf("local_map: {size_cells: [96, 95, 35]}").find("multiple of 5"),
            std::string::npos);
  EXPECT_NE(errorOf("local_map: {size_cells: [95, 95]}").find("list of 3 numbers"),
            std::string::npos);
  EXPECT_NE(errorOf("awareness: {rho_cells: many}").find("awareness.rho_cells: cannot read"),
            std::string::npos);
  EXPECT_NE(errorOf("awareness: {phi_cells: 0}").find("awareness.phi_cells"), std::string::npos);
  EXPECT_NE(errorOf("awareness: {max_range_m: 20}").find("awareness radius"), std::string::npos);
  for (const char* width : {"0.5", "3", ".nan"}) {
    EXPECT_NE(errorOf(std::string("awareness: {bin_width_voxels: ") + width + "}")
                  .find("awareness.bin_width_voxels: must be in [1, 2] voxels"),
              std::string::npos)
        << width;
  }
  EXPECT_NE(errorOf("log_odds: {miss: 0.4}").find("log_odds.miss"), std::string::npos);
  EXPECT_NE(errorOf("local_map: {resolution_m: 0.01, size_cells: [2000, 2000, 50]}")
                .find("free-space scratch box"),
            std::string::npos);
  EXPECT_NE(errorOf("local_map: {resolution_m: .nan}").find("local_map.resolution_m"),
            std::string::npos);
  EXPECT_NE(errorOf("awareness: [1, 2]").find("must be a mapping"), std::string::npos);
  EXPECT_NE(errorOf("a: b: c").find("not valid YAML"), std::string::npos);
  // Several problems are reported together.
  const std::string both = errorOf("awareness: {rho_cells: -1}\nlog_odds: {hit: -1}");
  EXPECT_NE(both.find("awareness.rho_cells"), std::string::npos);
  EXPECT_NE(both.find("log_odds.hit"), std::string::npos);
  EXPECT_THROW(config::loadConfigYaml("/nonexistent/mlmap.yaml"), std::runtime_error);
}

// YAML forbids a key twice in a mapping; yaml-cpp keeps the first value without a word, so the
// second (the one a user just added at the end of the file) would be ignored.
TEST(ConfigYaml, DuplicateKeysAndExtraDocumentsAreErrors) {
  const std::string twice = errorOf("local_map:\n  resolution_m: 0.1\n  resolution_m: 0.2\n");
  EXPECT_NE(twice.find("line 3: key 'local_map.resolution_m' appears twice (first on line 2)"),
            std::string::npos)
      << twice;
  const std::string sections = errorOf("esdf: {enabled: false}\nawareness: {}\nesdf: {}\n");
  EXPECT_NE(sections.find("key 'esdf' appears twice"), std::string::npos) << sections;
  const std::string documents = errorOf("local_map: {resolution_m: 0.1}\n---\nesdf: {}\n");
  EXPECT_NE(documents.find("more than one YAML document"), std::string::npos) << documents;
  // Equal keys in different mappings, and a lone document marker, are fine.
  EXPECT_EQ(errorOf("---\nlocal_map: {resolution_m: 0.1}\nesdf: {max_distance_m: 2.0}\n"), "");
}

}  // namespace
}  // namespace mlmap
