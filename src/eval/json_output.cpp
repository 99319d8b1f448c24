#include "mlmap/eval/json_output.h"

#include "mlmap/core/atomic_file.h"

#include <stdexcept>

namespace mlmap::eval {
namespace {

/// A scalar (or an empty container) as nlohmann prints it; bad UTF-8 replaced, not thrown.
std::string scalarText(const Json& json) {
  return json.dump(-1, ' ', false, Json::error_handler_t::replace);
}

void format(const Json& json, int expanded_levels, int depth, std::string* out);

/// The members of an object or array, separated by ", " on one line or one per line.
void formatMembers(const Json& json, int expanded_levels, int depth, std::string* out) {
  const bool expanded = depth < expanded_levels;
  const std::string indent(static_cast<std::size_t>(2 * (depth + 1)), ' ');
  bool first = true;
  for (auto it = json.begin(); it != json.end(); ++it) {
    *out += first ? "" : ",";
    *out += expanded ? "\n" + indent : std::string(first ? "" : " ");
    if (json.is_object()) *out += scalarText(Json(it.key())) + ": ";
    format(it.value(), expanded_levels, depth + 1, out);
    first = false;
  }
  if (expanded) *out += "\n" + std::string(static_cast<std::size_t>(2 * depth), ' ');
}

void format(const Json& json, int expanded_levels, int depth, std::string* out) {
  if (!json.is_structured() || json.empty()) {
    *out += scalarText(json);
    return;
  }
  *out += json.is_object() ? "{" : "[";
  formatMembers(json, expanded_levels, depth, out);
  *out += json.is_object() ? "}" : "]";
}

}  // namespace

std::string formatJson(const Json& json, int expanded_levels) {
  std::string text;
  format(json, expanded_levels, 0, &text);
  return text;
}

void writeJsonFile(const std::string& path, const Json& json, int expanded_levels) {
  writeFileAtomically(path, formatJson(json, expanded_levels) + '\n');
}

Json toJson(const TimingSummary& timing) {
  return Json{{"median_ms", timing.median_ms},
              {"p99_ms", timing.p99_ms},
              {"mean_ms", timing.mean_ms},
              {"max_ms", timing.max_ms},
              {"frames", timing.samples}};
}

Json engineCountersJson(const EngineStats& s) {
  return {{"frames_mapped", s.frames_mapped},
          {"rejected_invalid_pose", s.rejected_invalid_pose},
          {"rejected_out_of_order", s.rejected_out_of_order},
          {"rejected_empty", s.rejected_empty},
          {"rejected_bad_image", s.rejected_bad_image},
          {"points_in", s.points.points_in},
          {"no_data_or_non_finite", s.points.rejected_non_finite},
          {"too_close", s.points.rejected_too_close},
          {"beyond_max_range", s.points.beyond_max_range},
          {"hit_voxels", s.points.hit_voxels},
          {"hits_beyond_local_map", s.points.hits_beyond_local_map},
          {"hits_above_or_below_local_map", s.points.hits_above_or_below_local_map},
          {"hits_outside_window", s.local.hits_outside_window},
          {"hits_to_global_map", s.hits_to_global},
          {"hits_lost", s.hits_lost},
          {"free_outside_window", s.local.outside_window - s.local.hits_outside_window},
          {"free_voxels", s.points.free_voxels},
          {"global_voxels", s.global_voxels},
          {"global_submaps", s.global_submaps},
          {"local_shifts", s.local.shifts},
          {"submaps_retired", s.local.submaps_retired},
          {"submaps_restored", s.local.submaps_restored},
          {"esdf_updates", s.planning.esdf_updates}};
}

}  // namespace mlmap::eval
