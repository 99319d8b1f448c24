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

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <vector>

namespace {

void reportFile(const std::string& what, const std::string& path, std::size_t occupied) {
  const auto bytes = static_cast<double>(std::filesystem::file_size(path));
  std::printf("wrote %-7s %s: %.0f bytes, %zu occupied voxels", what.c_str(), path.c_str(), bytes, occupied);
  if (occupied > 0) std::printf(" (%.2f bytes per occupied voxel)", bytes / static_cast<double>(occupied));
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mlmap;
  CLI::App app{"mlmap_map_tool: converts a saved mlmap map (mlmap_demo --save-map, mlmap_node "
               "map_file.save_path) to PLY / PCD point clouds of the occupied voxels, a map_server "
               "PGM + YAML 2D grid, or an OctoMap .bt tree; --info prints what the file holds."};
  std::string map_path;
  std::string ply_path;
  std::string pcd_path;
  std::string grid_base;
  std::string bt_path;
  bool info = false;
  std::vector<double> band;
  bool local_only = false;
  int bench_runs = 0;
  app.add_option("map", map_path, "the map file")->required()->check(CLI::ExistingFile);
  app.add_flag("--info", info, "print the header, the layers' sizes and the load time");
  app.add_option("--ply", ply_path, "write the occupied voxels (local + global) as binary PLY: "
                                    "float x y z (voxel centre, W, m), log_odds, probability");
  app.add_option("--pcd", pcd_path, "write the occupied voxels as binary PCD: float x y z intensity "
                                    "(= occupancy probability)");
  app.add_option("--grid", grid_base, "write the 2D grid as BASE.pgm + BASE.yaml (map_server / "
                                      "nav2 map_saver trinary format)");
  app.add_option("--band", band, "the grid's height band MIN MAX in W [m] (default: the engine's "
                                 "default band, -0.3..+0.3 m around the map's last body height)")
      ->expected(2);
  app.add_flag("--grid-local-only", local_only, "grid of the local window only (default: local + global)");
  app.add_option("--bt", bt_path, "write an OctoMap binary tree (.bt): occupied and known-free voxels");
  app.add_option("--bench", bench_runs, "load the map and save it (to MAP.bench, removed after) N "
                                       "times each; print median / p99 / best times")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  if (bench_runs == 0 && !info && ply_path.empty() && pcd_path.empty() && grid_base.empty() && bt_path.empty()) {
    std::cerr << "nothing to do: give --info, --ply, --pcd, --grid or --bt (see --help)\n";
    return 2;
  }
#if !MLMAP_HAVE_OCTOMAP
  if (!bt_path.empty()) {
    std::cerr << "--bt: this build has no OctoMap (install liboctomap-dev and build again)\n";
    return 2;
  }
#endif
  if (!band.empty() && !(band[0] < band[1])) {
    std::cerr << "--band: MIN must be below MAX\n";
    return 2;
  }

  try {
    const auto load_start = std::chrono::steady_clock::now();
    const MapState state = io::loadMapFile(map_path);
    const double load_ms = msSince(load_start);
    const std::vector<io::OccupiedVoxel> voxels = io::occupiedVoxels(state);
    const double res = state.local_map.resolution_m;
    if (info) {
      const LocalWindow& w = state.window;
      std::size_t known = 0;
      for (LogOddsQ v : w.log_odds) known += v != kUnknownLogOdds ? 1 : 0;
      std::printf("%s: mlmap map file version %u, %ju bytes, loaded in %.1f ms\n", map_path.c_str(),
                  io::kMapFileVersion, static_cast<std::uintmax_t>(std::filesystem::file_size(map_path)),
                  load_ms);
      std::printf("  configuration fingerprint %016jx: resolution %g m, window %d x %d x %d voxels, "
                  "log-odds hit %g miss %g clamp [%g, %g] occupied > %g\n",
                  static_cast<std::uintmax_t>(io::mapConfigFingerprint(state.local_map, state.log_odds)),
                  res, state.local_map.size_cells.x(), state.local_map.size_cells.y(),
                  state.local_map.size_cells.z(), state.log_odds.hit, state.log_odds.miss,
                  state.log_odds.clamp_min, state.log_odds.clamp_max, state.log_odds.occupied_threshold);
      std::printf("  local window from voxel (%d, %d, %d): %zu observed voxels of %zu\n", w.min_index.x(),
                  w.min_index.y(), w.min_index.z(), known, w.log_odds.size());
      std::printf("  global map: %zu occupied voxels in %zu submaps\n", state.globalVoxelCount(),
                  state.global_submaps.size());
      std::printf("  occupied voxels in all: %zu; %ju frames mapped, last stamp %s\n", voxels.size(),
                  static_cast<std::uintmax_t>(state.frames_mapped),
                  state.has_last_stamp ? std::to_string(state.last_stamp_s).c_str() : "none");
    }
    if (bench_runs > 0) {
      std::vector<double> load_times_ms;
      std::vector<double> save_times_ms;
      const std::string bench_path = map_path + ".bench";
      for (int i = 0; i < bench_runs; ++i) {
        auto start = std::chrono::steady_clock::now();
        const MapState again = io::loadMapFile(map_path);
        load_times_ms.push_back(msSince(start));
        start = std::chrono::steady_clock::now();
        io::saveMapFile(again, bench_path);
        save_times_ms.push_back(msSince(start));
      }
      std::filesystem::remove(bench_path);
      for (auto [what, values] : {std::pair{"load", load_times_ms}, std::pair{"save", save_times_ms}}) {
        const TimingSummary t = summarizeTimings(values);
        std::printf("%s (%d runs): median %.2f ms, p99 %.2f ms, best %.2f ms\n", what, bench_runs,
                    t.median_ms, t.p99_ms, *std::min_element(values.begin(), values.end()));
      }
    }
    if (!ply_path.empty()) {
      io::writePly(voxels, res, ply_path);
      reportFile("PLY", ply_path, voxels.size());
    }
    if (!pcd_path.empty()) {
      io::writePcd(voxels, res, pcd_path);
      reportFile("PCD", pcd_path, voxels.size());
    }
    if (!grid_base.empty()) {
      ProjectedGridConfig gc;
      gc.include_global = !local_only;
      if (!band.empty()) {
        gc.relative_band = false;
        gc.band_min_m = band[0];
        gc.band_max_m = band[1];
      }
      const ProjectedGrid grid = io::projectMap(state, gc);
      io::writeGridMap(grid, grid_base);
      std::printf("wrote grid  %s.pgm + %s.yaml: %d x %d cells of %g m, band %.2f..%.2f m\n",
                  grid_base.c_str(), grid_base.c_str(), grid.width, grid.height, grid.resolution_m,
                  grid.band_min_z_m, grid.band_max_z_m);
    }
    if (!bt_path.empty()) {
#if MLMAP_HAVE_OCTOMAP
      const io::OctomapExportCounts c = io::writeOctomapBinary(state, bt_path);
      reportFile("OctoMap", bt_path, c.occupied);
      std::printf("  %zu occupied, %zu free voxels", c.occupied, c.free);
      if (c.out_of_range > 0) std::printf(", %zu beyond OctoMap's key range left out", c.out_of_range);
      std::printf("\n");
#endif
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "mlmap_map_tool: " << e.what() << "\n";
    return 1;
  }
}
