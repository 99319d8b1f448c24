// mlmap_config_tool: writes (or checks) the files generated from the configuration key lists,
// config/mlmap.yaml, config/mlmap_node.yaml and the key reference in docs/configuration.md.
// Run from the source tree after changing a key: `build/mlmap_config_tool --write`.

#include "mlmap/config/yaml_section.h"
#include "mlmap/dds/node/config_reference.h"

#include <CLI/CLI.hpp>

#include <fstream>
#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap_config_tool: the default configuration files and the key reference, "
      "generated from the key lists in code"};
  std::string source_dir = ".";
  bool write = false;
  app.add_option("--source-dir", source_dir, "the mlmap source tree (default: the current folder)")
      ->check(CLI::ExistingDirectory);
  app.add_flag("--write", write, "rewrite the files that differ (default: only list them, exit 1)");
  CLI11_PARSE(app, argc, argv);
  try {
    int differing = 0;
    for (const mlmap::dds::GeneratedFile& file : mlmap::dds::generatedConfigFiles(source_dir)) {
      const std::string path = source_dir + "/" + file.path;
      std::string current;
      try {
        current = mlmap::config::readConfigFile(path);
      } catch (const std::runtime_error&) {
        // a missing file differs
      }
      if (current == file.text) continue;
      ++differing;
      if (!write) {
        std::cout << file.path << ": differs from the key lists\n";
        continue;
      }
      std::ofstream out(path, std::ios::binary | std::ios::trunc);
      out << file.text;
      if (!out.flush()) throw std::runtime_error(path + ": cannot write");
      std::cout << file.path << ": written\n";
    }
    return (differing == 0 || write) ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "mlmap_config_tool: " << e.what() << "\n";
    return 2;
  }
}
