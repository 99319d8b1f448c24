// mlmap_map_tool: reads a saved mlmap map file and converts it to the formats other tools open
// (PLY, PCD, PGM + YAML for map_server / nav2, OctoMap .bt), or prints what it holds.

#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"
#if MLMAP_HAVE_OCTOMAP
#include "mlmap/map_io/octomap_export.h"
#endif
#include "mlmap/core/stopwatch.h"
#include "mlmap/pipeline/map_engine.h"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <vector>

namespace {

using namespace mlmap;

/// The command line of mlmap_map_tool.
struct Options {
  std::string map_path;      ///< the map file
  bool info = false;         ///< --info: print what the file holds
  std::string ply_path;      ///< --ply (empty: none)
  std::string pcd_path;      ///< --pcd (empty: none)
  std::string grid_base;     ///< --grid: BASE of BASE.pgm + BASE.yaml (empty: none)
  std::vector<double> band;  ///< --band MIN MAX [m] (empty: the engine's default band)
  bool local_only = false;   ///< --grid-local-only
  std::string bt_path;       ///< --bt (empty: none)
  int bench_runs = 0;        ///< --bench: load and save N times (0: no benchmark)
  bool overwrite = false;    ///< --overwrite: outputs may replace existing mlmap map files

  /// Every file the options write.
  [[nodiscard]] std::vector<std::string> outputs() const {
    std::vector<std::string> paths;
    for (const std::string* p : {&ply_path, &pcd_path, &bt_path}) {
      if (!p->empty()) paths.push_back(*p);
    }
    if (!grid_base.empty()) {
      paths.push_back(grid_base + ".pgm");
      paths.push_back(grid_base + ".yaml");
    }
    return paths;
  }
};

/// Adds every option of mlmap_map_tool to `app`.
void addOptions(CLI::App& app, Options& o) {
  app.add_option("map", o.map_path, "the map file")->required()->check(CLI::ExistingFile);
  app.add_flag("--info", o.info, "print the header, the layers' sizes and the load time");
  app.add_option("--ply", o.ply_path,
                 "write the occupied voxels (local + global) as binary PLY: "
                 "float x y z (voxel centre, W, m), log_odds, probability");
  app.add_option("--pcd", o.pcd_path,
                 "write the occupied voxels as binary PCD: float x y z intensity "
                 "(= occupancy probability)");
  app.add_option("--grid", o.grid_base,
                 "write the 2D grid as BASE.pgm + BASE.yaml (map_server / "
                 "nav2 map_saver trinary format)");
  app.add_option("--band", o.band,
                 "the grid's height band MIN MAX in W [m] (default: the engine's "
                 "default band, -0.3..+0.3 m around the map's last body height)")
      ->expected(2);
  app.add_flag("--grid-local-only", o.local_only,
               "grid of the local window only (default: local + global)");
  app.add_option("--bt", o.bt_path,
                 "write an OctoMap binary tree (.bt): occupied and known-free voxels");
  app.add_option("--bench", o.bench_runs,
                 "load the map and save it (to a new temporary file "
                 "beside it, removed after) N times each; print median / "
                 "p99 / best times")
      ->check(CLI::PositiveNumber);
  app.add_flag("--overwrite", o.overwrite,
               "outputs may replace existing mlmap map files (never "
               "the input map)");
}

/// False (the reason printed) when the options ask for nothing or for what this build cannot do.
bool checkOptions(const Options& o) {
  if (o.bench_runs == 0 && !o.info && o.ply_path.empty() && o.pcd_path.empty() &&
      o.grid_base.empty() && o.bt_path.empty()) {
    std::cerr << "nothing to do: give --info, --ply, --pcd, --grid or --bt (see --help)\n";
    return false;
  }
#if !MLMAP_HAVE_OCTOMAP
  if (!o.bt_path.empty()) {
    std::cerr << "--bt: this build has no OctoMap (install liboctomap-dev and build again)\n";
    return false;
  }
#endif
  if (!o.band.empty()) {
    const auto inRange = [](double z) {
      return std::isfinite(z) && std::abs(z) < kMaxAbsCoordinate_m;
    };
    if (!inRange(o.band[0]) || !inRange(o.band[1])) {
      std::cerr << "--band: heights must be finite and within " << kMaxAbsCoordinate_m
                << " m of the origin\n";
      return false;
    }
    if (!(o.band[0] < o.band[1])) {
      std::cerr << "--band: MIN must be below MAX\n";
      return false;
    }
  }
  for (const std::string& out : o.outputs()) {
    const std::string conflict = io::outputConflict(out, {o.map_path}, o.overwrite, "--overwrite");
    if (!conflict.empty()) {
      std::cerr << "not writing " << conflict << "\n";
      return false;
    }
  }
  return true;
}

/// Prints a written file's size and its bytes per occupied voxel.
void reportFile(const std::string& what, const std::string& path, std::size_t occupied) {
  const auto bytes = static_cast<double>(std::filesystem::file_size(path));
  std::printf("wrote %-7s %s: %.0f bytes, %zu occupied voxels", what.c_str(), path.c_str(), bytes,
              occupied);
  if (occupied > 0)
    std::printf(" (%.2f bytes per occupied voxel)", bytes / static_cast<double>(occupied));
  std::printf("\n");
}

/// --info: the header, the layers' sizes and the load time `load_ms` [ms].
void printInfo(const std::string& map_path, const MapState& state, std::size_t occupied,
               double load_ms) {
  const LocalWindow& w = state.window;
  const double res = state.local_map.resolution_m;
  std::size_t known = 0;
  for (LogOddsQ v : w.log_odds) known += v != kUnknownLogOdds ? 1 : 0;
  std::printf("%s: mlmap map file version %u, %ju bytes, loaded in %.1f ms\n", map_path.c_str(),
              io::kMapFileVersion,
              static_cast<std::uintmax_t>(std::filesystem::file_size(map_path)), load_ms);
  std::printf(
      "  configuration fingerprint %016jx: resolution %g m, window %d x %d x %d voxels, "
      "log-odds hit %g miss %g clamp [%g, %g] occupied > %g\n",
      static_cast<std::uintmax_t>(io::mapConfigFingerprint(state.local_map, state.log_odds)), res,
      state.local_map.size_cells.x(), state.local_map.size_cells.y(),
      state.local_map.size_cells.z(), state.log_odds.hit, state.log_odds.miss,
      state.log_odds.clamp_min, state.log_odds.clamp_max, state.log_odds.occupied_threshold);
  std::printf("  local window from voxel (%d, %d, %d): %zu observed voxels of %zu\n",
              w.min_index.x(), w.min_index.y(), w.min_index.z(), known, w.log_odds.size());
  std::printf("  global map: %zu occupied voxels in %zu submaps\n", state.globalVoxelCount(),
              state.global_submaps.size());
  std::printf("  occupied voxels in all: %zu; %ju frames mapped, last stamp %s\n", occupied,
              static_cast<std::uintmax_t>(state.frames_mapped),
              state.has_last_stamp ? std::to_string(state.last_stamp_s).c_str() : "none");
}

/// A new empty file beside `path` ("<path>.bench-XXXXXX") that nothing else uses.
std::string newFileBeside(const std::string& path) {
  std::string name = path + ".bench-XXXXXX";
  const int fd = ::mkstemp(name.data());
  if (fd < 0) throw std::runtime_error("cannot create a file beside '" + path + "' for --bench");
  ::close(fd);
  return name;
}

/// --bench: loads and saves the map `runs` times each and prints the times. The saves go to a
/// new file of its own, removed after: no existing file is touched.
void benchmark(const std::string& map_path, int runs) {
  std::vector<double> load_times_ms;
  std::vector<double> save_times_ms;
  struct RemovedAtExit {
    std::string path;
    ~RemovedAtExit() {
      std::error_code ignored;
      std::filesystem::remove(path, ignored);
    }
  } bench_file{newFileBeside(map_path)};
  const std::string& bench_path = bench_file.path;
  for (int i = 0; i < runs; ++i) {
    auto start = SteadyClock::now();
    const MapState again = io::loadMapFile(map_path);
    load_times_ms.push_back(msSince(start));
    start = SteadyClock::now();
    io::saveMapFile(again, bench_path);
    save_times_ms.push_back(msSince(start));
  }
  for (auto [what, values] : {std::pair{"load", load_times_ms}, std::pair{"save", save_times_ms}}) {
    const TimingSummary t = summarizeTimings(values);
    std::printf("%s (%d runs): median %.2f ms, p99 %.2f ms, best %.2f ms\n", what, runs,
                t.median_ms, t.p99_ms, *std::min_element(values.begin(), values.end()));
  }
}

/// --grid: the 2D grid as BASE.pgm + BASE.yaml.
void writeGrid(const Options& o, const MapState& state) {
  ProjectedGridConfig gc;
  gc.include_global = !o.local_only;
  if (!o.band.empty()) {
    gc.relative_band = false;
    gc.band_min_m = o.band[0];
    gc.band_max_m = o.band[1];
  }
  const ProjectedGrid grid = io::projectMap(state, gc);
  io::writeGridMap(grid, o.grid_base);
  std::printf("wrote grid  %s.pgm + %s.yaml: %d x %d cells of %g m, band %.2f..%.2f m\n",
              o.grid_base.c_str(), o.grid_base.c_str(), grid.width, grid.height, grid.resolution_m,
              grid.band_min_z_m, grid.band_max_z_m);
}

/// --bt: the OctoMap binary tree (only in builds with OctoMap; checkOptions() refuses it
/// otherwise).
void writeOctomap([[maybe_unused]] const MapState& state,
                  [[maybe_unused]] const std::string& bt_path) {
#if MLMAP_HAVE_OCTOMAP
  const io::OctomapExportCounts c = io::writeOctomapBinary(state, bt_path);
  reportFile("OctoMap", bt_path, c.occupied);
  std::printf("  %zu occupied, %zu free voxels", c.occupied, c.free);
  if (c.out_of_range > 0) std::printf(", %zu beyond OctoMap's key range left out", c.out_of_range);
  std::printf("\n");
#endif
}

/// Loads the map and does what the options ask; returns the exit status (1: an error, printed).
int run(const Options& o) {
  try {
    const auto load_start = SteadyClock::now();
    const MapState state = io::loadMapFile(o.map_path);
    const double load_ms = msSince(load_start);
    const std::vector<io::OccupiedVoxel> voxels = io::occupiedVoxels(state);
    const double res = state.local_map.resolution_m;
    if (o.info) printInfo(o.map_path, state, voxels.size(), load_ms);
    if (o.bench_runs > 0) benchmark(o.map_path, o.bench_runs);
    if (!o.ply_path.empty()) {
      io::writePly(voxels, res, o.ply_path);
      reportFile("PLY", o.ply_path, voxels.size());
    }
    if (!o.pcd_path.empty()) {
      io::writePcd(voxels, res, o.pcd_path);
      reportFile("PCD", o.pcd_path, voxels.size());
    }
    if (!o.grid_base.empty()) writeGrid(o, state);
    if (!o.bt_path.empty()) writeOctomap(state, o.bt_path);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "mlmap_map_tool: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap_map_tool: converts a saved mlmap map (mlmap_demo --save-map, mlmap_node "
      "map_file.save_path) to PLY / PCD point clouds of the occupied voxels, a map_server "
      "PGM + YAML 2D grid, or an OctoMap .bt tree; --info prints what the file holds."};
  Options options;
  addOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  if (!checkOptions(options)) return 2;
  return run(options);
}
