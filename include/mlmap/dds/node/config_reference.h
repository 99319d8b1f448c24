#pragma once
/// @file
/// The user-facing files generated from the configuration key lists: config/mlmap.yaml,
/// config/mlmap_node.yaml and the key reference in docs/configuration.md (between
/// kReferenceBegin and kReferenceEnd). They stay checked in; `build/mlmap_config_tool --write`
/// regenerates them and a test fails when a checked-in file differs.

#include <string>
#include <vector>

namespace mlmap::dds {

/// The line that opens the generated key reference in docs/configuration.md.
inline constexpr const char* kReferenceBegin =
    "<!-- BEGIN generated key reference: edit the key lists, then run `build/mlmap_config_tool "
    "--write` -->";
/// The line that closes it.
inline constexpr const char* kReferenceEnd = "<!-- END generated key reference -->";

/// One generated file: its path relative to the source tree and its text.
struct GeneratedFile {
  std::string path;  ///< e.g. "config/mlmap.yaml"
  std::string text;  ///< what the file must hold
};

/// The key reference (Markdown: a table of the engine keys and one of the node's) that goes
/// between the markers.
std::string keyReferenceMarkdown();

/// `document` with the text between the kReferenceBegin and kReferenceEnd lines replaced by
/// `reference`. Throws std::runtime_error when a marker is missing.
std::string withKeyReference(const std::string& document, const std::string& reference);

/// Every generated file as it must be, for the source tree at `source_dir` (whose
/// docs/configuration.md is read for the prose around the reference). Throws std::runtime_error
/// when that document cannot be read or lacks the markers.
std::vector<GeneratedFile> generatedConfigFiles(const std::string& source_dir);

}  // namespace mlmap::dds
