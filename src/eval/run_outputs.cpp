#include "mlmap/eval/run_outputs.h"

#include "mlmap/config/config_yaml.h"
#include "mlmap/eval/json_output.h"
#include "mlmap/map_io/map_file.h"
#include "mlmap/pictures/map_image.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <sstream>
#include <stdexcept>

namespace mlmap::eval {
namespace {

double megabytes(std::size_t bytes) { return static_cast<double>(bytes) / 1e6; }

/// Voxel centres for the pictures, turned by `R_display_W` (identity, or optical -> FLU).
pictures::VoxelList voxelList(const std::vector<VoxelIndex>& voxels, double res,
                              const Eigen::Matrix3d& R_display_W) {
  pictures::VoxelList list{res, {}};
  list.centers_W.reserve(voxels.size());
  for (const VoxelIndex& v : voxels) list.centers_W.push_back(R_display_W * voxelCenter(v, res));
  return list;
}

/// report.json: the engine's figures after a run of `source`, with the accuracy when scored.
Json reportJson(const std::string& source, const EngineStats& s, std::size_t occupied, double res,
                const Accuracy* accuracy) {
  Json report;
  report["source"] = source;
  report["resolution_m"] = res;
  report["frames_mapped"] = s.frames_mapped;
  report["frames_dropped"] = s.frames_dropped;
  report["frames_rejected"] =
      s.rejected_invalid_pose + s.rejected_out_of_order + s.rejected_empty + s.rejected_bad_image;
  report["occupied_voxels"] = occupied;
  report["timing"] = {{"awareness", toJson(s.awareness)},
                      {"local_global", toJson(s.local_global)},
                      {"total", toJson(s.total)}};
  report["memory_bytes"] = {{"awareness", s.memory.awareness_bytes},
                            {"local", s.memory.local_bytes},
                            {"global", s.memory.global_bytes}};
  report["global_map"] = {{"occupied_voxels", s.global_voxels}, {"submaps", s.global_submaps}};
  report["local_map"] = {{"shifts", s.local.shifts},
                         {"submaps_retired", s.local.submaps_retired},
                         {"submaps_restored", s.local.submaps_restored}};
  report["points"] = {{"in", s.points.points_in},
                      {"no_data_or_non_finite", s.points.rejected_non_finite},
                      {"too_close", s.points.rejected_too_close},
                      {"beyond_max_range", s.points.beyond_max_range},
                      {"hit_voxels", s.points.hit_voxels},
                      {"hits_beyond_local_map", s.points.hits_beyond_local_map},
                      {"hits_above_or_below_local_map", s.points.hits_above_or_below_local_map},
                      {"hits_outside_window", s.local.hits_outside_window},
                      {"hits_to_global_map", s.hits_to_global},
                      {"hits_lost", s.hits_lost},
                      {"free_voxels", s.points.free_voxels}};
  if (accuracy != nullptr) {
    report["accuracy"] = {{"precision", accuracy->precision},
                          {"recall", accuracy->recall},
                          {"f1", accuracy->f1},
                          {"mapped", accuracy->mapped},
                          {"observed_truth", accuracy->observed_truth}};
  }
  return report;
}

}  // namespace

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)), tty_(isatty(2) != 0) {}

void ProgressBar::update(int done, int total) {
  if (total <= 0) return;
  const int percent = 100 * done / total;
  if (!tty_ && percent / 10 == last_decile_ && done != total) return;
  last_decile_ = percent / 10;
  constexpr int kWidth = 30;
  const int filled = kWidth * done / total;
  std::fprintf(stderr, "%s%s [%s%s] %3d%% %d/%d frames%s", tty_ ? "\r" : "", label_.c_str(),
               std::string(static_cast<std::size_t>(filled), '#').c_str(),
               std::string(static_cast<std::size_t>(kWidth - filled), '.').c_str(), percent, done,
               total, (tty_ && done != total) ? "" : "\n");
  std::fflush(stderr);
}

void setResolution(MapConfig* c, double resolution_m) {
  c->local_map.resolution_m = resolution_m;
  auto cells = [&](double extent_m) {
    const double n = std::min(extent_m / resolution_m, 250.0);
    return std::max(5, static_cast<int>(std::lround(n / 5.0)) * 5);
  };
  c->local_map.size_cells = {cells(19.0), cells(19.0), cells(7.0)};
}

namespace {

/// Widens the local window horizontally for `range_m` (adaptReplayConfig()); notes what it did.
void sizeWindowForRange(double range_m, MapConfig* config, ConfigNotes* notes) {
  LocalMapConfig& local_map = config->local_map;
  const int needed = local_map.horizontalCellsForRange(range_m);
  const Eigen::Vector3i before = local_map.size_cells;
  const double reach_before_m = local_map.horizontalReach_m();
  for (int a = 0; a < 2; ++a) local_map.size_cells[a] = std::max(local_map.size_cells[a], needed);
  if (local_map.size_cells == before) return;
  char line[400];
  if (!config->validate().empty()) {
    std::snprintf(line, sizeof(line),
                  "--max-range %g m: a local window of %d x %d voxels would hold it, more than the "
                  "configuration's limits allow; hits farther than %.1f m go to the global map as "
                  "hits only (their free space is not mapped)",
                  range_m, needed, needed, reach_before_m);
    notes->warnings.emplace_back(line);
    local_map.size_cells = before;
    return;
  }
  std::snprintf(line, sizeof(line),
                "--max-range %g m: the local window grows from %d x %d to %d x %d voxels (%.1f x "
                "%.1f m) so that every hit in range is mapped",
                range_m, before.x(), before.y(), local_map.size_cells.x(), local_map.size_cells.y(),
                local_map.size_cells.x() * local_map.resolution_m,
                local_map.size_cells.y() * local_map.resolution_m);
  notes->info.emplace_back(line);
}

}  // namespace

ConfigNotes adaptReplayConfig(const ReplayEngineOptions& options, MapConfig* config) {
  ConfigNotes notes;
  if (options.max_range_m > 0.0) {
    config->awareness.max_range_m = options.max_range_m;
    if (config->awareness.radius_m() < options.max_range_m) {
      config->awareness.rho_cells =
          static_cast<int>(std::ceil(options.max_range_m / config->awareness.rho_cell_m));
    }
    sizeWindowForRange(options.max_range_m, config, &notes);
  }
  if (options.awareness_threads > 0) {
    config->awareness.num_threads = options.awareness_threads;
  } else if (!options.config_file) {
    config->awareness.num_threads = options.default_awareness_threads;
  }
  if (config->pipeline.threaded) {
    notes.warnings.emplace_back(
        "pipeline.threaded: the replay runs synchronously (every frame is mapped, in order)");
    config->pipeline.threaded = false;
  }
  config->pipeline.planning_layers = options.grid_out;
  config->projected_grid.enabled = options.grid_out;
  config->esdf.enabled = false;
  return notes;
}

MapConfig runConfig(const std::string& config_path, DataKind kind, double resolution_m) {
  // mlmap_node's files work too: their dds and map_file sections do not concern the engine.
  MapConfig config = config_path.empty()
                         ? MapConfig{}
                         : config::loadConfigYaml(config_path, config::kNodeOnlySections);
  const bool frames = kind == DataKind::kFrameDirectory;
  if (resolution_m > 0.0 || config_path.empty()) {
    setResolution(&config, resolution_m > 0.0 ? resolution_m : (frames ? 0.02 : 0.1));
  }
  if (frames) {
    // The frame poses are camera poses: the camera is the body.
    config.sensor.translation_B_m.setZero();
    config.sensor.rotation_rpy_deg.setZero();
  }
  return config;
}

ScoredFlight flyAndScore(const datasets::Scenario& scenario, MapEngine& engine,
                         const FlightOptions& options) {
  ScoredFlight s;
  s.flight = flyScenario(scenario, engine, options);
  const double res = engine.config().local_map.resolution_m;
  const std::vector<VoxelIndex> mapped = engine.occupiedVoxels();
  s.accuracy = scoreOccupancy(mapped, s.flight.observed_truth, scenario.world, res);
  s.truth = s.flight.observed_truth;
  for (const VoxelIndex& v : mapped) {
    if (touchesSolid(scenario.world, v, res)) s.truth.insert(v);
  }
  return s;
}

std::vector<std::string> writeMapOutputs(const MapOutputs& outputs, const EngineStats& s,
                                         const std::vector<VoxelIndex>& occupied, double res) {
  const std::string& out_dir = outputs.out_dir;
  std::vector<std::string> written;
  pictures::MapImageOptions image_options;
  image_options.trajectory_W = outputs.trajectory_W;
  // The rotation is exact, so the voxels stay on one grid.
  Eigen::Matrix3d R_display_W = Eigen::Matrix3d::Identity();
  if (outputs.optical_world) R_display_W << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  for (Eigen::Vector3d& p : image_options.trajectory_W) p = R_display_W * p;
  const pictures::VoxelList list = voxelList(occupied, res, R_display_W);
  const std::string what = "mlmap, " + std::to_string(occupied.size()) + " occupied voxels";
  // The two views drawn and encoded at the same time (a second core halves the wait; the
  // future's get() passes on an error of its file).
  pictures::MapImageOptions side_options = image_options;
  side_options.title = what + " - side view";
  std::future<void> side = std::async(std::launch::async, [&out_dir, &list, &side_options] {
    pictures::writePng(out_dir + "/map_side.png", pictures::renderSide(list, side_options));
  });
  image_options.title = what + " - top view";
  pictures::writePng(out_dir + "/map_top.png", pictures::renderTopDown(list, image_options));
  side.get();
  written = {"map_top.png", "map_side.png"};
  const Accuracy* accuracy = outputs.scored != nullptr ? &outputs.scored->accuracy : nullptr;
  if (accuracy != nullptr) {
    pictures::VoxelList truth_list{res, {}};
    for (const VoxelIndex& v : outputs.scored->truth)
      truth_list.centers_W.push_back(voxelCenter(v, res));
    char title[160];
    std::snprintf(title, sizeof(title), "occupied voxels vs ground truth, F1 %.3f (report.json)",
                  accuracy->f1);
    image_options.title = title;
    pictures::writePng(out_dir + "/accuracy_top.png",
                       pictures::renderComparison(list, truth_list, image_options));
    written.push_back("accuracy_top.png");
  }

  writeJsonFile(out_dir + "/report.json",
                reportJson(outputs.source, s, occupied.size(), res, accuracy),
                /*expanded_levels=*/1);
  written.push_back("report.json");
  return written;
}

void printHitsOutsideWindow(const EngineStats& s, const LogSink& log) {
  const std::uint64_t points = s.points.hits_beyond_local_map;
  const std::uint64_t voxels = s.local.hits_outside_window;
  std::printf(
      "  beyond the window    %llu points beyond the local map's reach, %llu hit voxels outside "
      "its window: %llu hit updates to the global map, %llu hits lost\n",
      static_cast<unsigned long long>(points), static_cast<unsigned long long>(voxels),
      static_cast<unsigned long long>(s.hits_to_global),
      static_cast<unsigned long long>(s.hits_lost));
  if (points + voxels == 0 || !log) return;
  const std::uint64_t vertical = s.points.hits_above_or_below_local_map;
  std::ostringstream m;
  m << points << " points in range and " << voxels
    << " hit voxels fell outside the local window: their hits went to the global map ("
    << s.hits_to_global << " updates, " << s.hits_lost
    << " lost), their free space was not mapped. Of the points, " << points - vertical
    << " lay beyond its horizontal reach (a wider local_map.size_cells x, y, or --max-range, "
       "maps them whole) and "
    << vertical << " above or below it (a taller local_map.size_cells z does)";
  log(LogLevel::kWarning, m.str());
}

void printSummary(const EngineStats& s, double res, const Accuracy* accuracy) {
  std::printf(
      "\n  frames mapped        %llu (rejected: pose %llu, order %llu, empty %llu; dropped %llu)\n",
      static_cast<unsigned long long>(s.frames_mapped),
      static_cast<unsigned long long>(s.rejected_invalid_pose),
      static_cast<unsigned long long>(s.rejected_out_of_order),
      static_cast<unsigned long long>(s.rejected_empty),
      static_cast<unsigned long long>(s.frames_dropped));
  std::printf("  voxel size           %.3f m\n", res);
  std::printf("  per frame [ms]       median    p99\n");
  std::printf("    awareness          %7.2f %7.2f\n", s.awareness.median_ms, s.awareness.p99_ms);
  std::printf("    local-global       %7.2f %7.2f\n", s.local_global.median_ms,
              s.local_global.p99_ms);
  std::printf("    total              %7.2f %7.2f\n", s.total.median_ms, s.total.p99_ms);
  std::printf(
      "  memory [MB]          awareness %.1f, local %.1f, global %.2f (%zu occupied voxels in %zu "
      "submaps)\n",
      megabytes(s.memory.awareness_bytes), megabytes(s.memory.local_bytes),
      megabytes(s.memory.global_bytes), s.global_voxels, s.global_submaps);
  std::printf(
      "  points               %llu in, %llu without data/NaN, %llu too close, %llu beyond range\n",
      static_cast<unsigned long long>(s.points.points_in),
      static_cast<unsigned long long>(s.points.rejected_non_finite),
      static_cast<unsigned long long>(s.points.rejected_too_close),
      static_cast<unsigned long long>(s.points.beyond_max_range));
  if (accuracy != nullptr) {
    std::printf(
        "  accuracy             precision %.4f, recall %.4f, F1 %.4f (%zu mapped, %zu observed "
        "true voxels)\n",
        accuracy->precision, accuracy->recall, accuracy->f1, accuracy->mapped,
        accuracy->observed_truth);
  }
}

std::string jsonString(const std::string& s) {
  return Json(s).dump(-1, ' ', false, Json::error_handler_t::replace);
}

std::size_t peakRssBytes() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<std::size_t>(usage.ru_maxrss) * 1024u;  // Linux: kilobytes
}

void checkSaveMapTarget(const std::string& path, bool overwrite) {
  const std::filesystem::path target(path);
  const std::filesystem::path folder = target.has_parent_path() ? target.parent_path() : ".";
  if (!std::filesystem::is_directory(folder)) {
    throw std::runtime_error("--save-map: folder '" + folder.string() + "' does not exist");
  }
  const std::string conflict = io::outputConflict(path, {}, overwrite, "--overwrite");
  if (!conflict.empty()) throw std::runtime_error("--save-map: " + conflict);
}

void saveMap(const MapEngine& engine, const std::string& path) {
  const auto start = std::chrono::steady_clock::now();
  io::saveMapFile(engine.exportState(), path);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf("  saved the map to %s (%ju bytes, %.1f ms)\n", path.c_str(),
              static_cast<std::uintmax_t>(std::filesystem::file_size(path)), ms);
}

}  // namespace mlmap::eval
