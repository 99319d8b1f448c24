#pragma once
/// @file
/// The JSON files of the offline programs and the inspector (report.json, stats.json,
/// summary.json), built as nlohmann::ordered_json documents (keys stay in the order they are
/// set) and written in one layout: the outer levels one member per line, deeper levels on one
/// line, so that a line tool (sed, grep) finds a whole topic or frame on one line.

#include "mlmap/pipeline/map_engine.h"

#include <nlohmann/json.hpp>

#include <string>

namespace mlmap::eval {

/// A JSON document whose object keys keep their insertion order.
using Json = nlohmann::ordered_json;

/// `json` as text: the first `expanded_levels` levels of objects and arrays one member per line
/// (indented by two spaces a level), deeper ones on one line with ", " and ": " separators.
/// Strings that are not valid UTF-8 get U+FFFD for their bad bytes. Ends without a newline.
[[nodiscard]] std::string formatJson(const Json& json, int expanded_levels);

/// Writes formatJson(`json`, `expanded_levels`) and a newline to `path`, atomically
/// (writeFileAtomically(): a failed write leaves no partial file).
/// @throws std::runtime_error naming `path` when it cannot be written.
void writeJsonFile(const std::string& path, const Json& json, int expanded_levels);

/// `{"median_ms": ..., "p99_ms": ..., "mean_ms": ..., "max_ms": ..., "frames": ...}`.
[[nodiscard]] Json toJson(const TimingSummary& timing);

/// The engine's counters as one flat object (stats.json's `counters`): frames mapped and
/// rejected by reason, points by fate, voxels, the local map's shifts and submaps, ESDF updates.
[[nodiscard]] Json engineCountersJson(const EngineStats& stats);

}  // namespace mlmap::eval
