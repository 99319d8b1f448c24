#include "mlmap/map_io/map_export.h"

#include "mlmap/core/atomic_file.h"
#include "mlmap/map_io/map_file.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>

namespace mlmap::io {
namespace {

// Which grid values become occupied / free pixels: map_saver's defaults.
constexpr double kOccupiedThresh = 0.65;
constexpr double kFreeThresh = 0.25;
// The thresholds the YAML gives map_server for loading the pixels back. Unknown (205) reads as
// occupancy (255 - 205) / 255 = 0.196, and map_server calls a pixel free when it is below
// free_thresh: with 0.25 every unknown cell would load as free. ROS 1's map_saver writes 0.196
// for this reason, and nav2's does since ros-navigation/navigation2#5278.
constexpr double kYamlOccupiedThresh = 0.65;
constexpr double kYamlFreeThresh = 0.196;
constexpr std::uint8_t kPgmOccupied = 0;
constexpr std::uint8_t kPgmFree = 254;
constexpr std::uint8_t kPgmUnknown = 205;

void appendFloat(std::string* out, float v) {
  std::uint32_t u = 0;
  std::memcpy(&u, &v, sizeof u);
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((u >> (8 * i)) & 0xFFu));
}

}  // namespace

std::vector<OccupiedVoxel> occupiedVoxels(const MapState& state) {
  std::vector<OccupiedVoxel> out;
  const LocalWindow& w = state.window;
  for (int x = 0; x < w.size.x(); ++x) {
    for (int y = 0; y < w.size.y(); ++y) {
      for (int z = 0; z < w.size.z(); ++z) {
        const VoxelIndex g = w.min_index + VoxelIndex(x, y, z);
        const LogOddsQ v = w.at(g);
        if (w.model.isOccupied(v)) out.push_back({g, dequantizeLogOdds(v), false});
      }
    }
  }
  const Eigen::Vector3i s = state.local_map.submap_cells();
  const std::uint32_t plane = static_cast<std::uint32_t>(s.y() * s.z());
  for (const auto& [m, records] : state.global_submaps) {
    const VoxelIndex base = m.cwiseProduct(s);
    for (const VoxelRecord& r : records) {
      const int x = static_cast<int>(r.offset / plane);
      const int rest = static_cast<int>(r.offset % plane);
      out.push_back(
          {base + VoxelIndex(x, rest / s.z(), rest % s.z()), dequantizeLogOdds(r.log_odds), true});
    }
  }
  return out;
}

ProjectedGrid projectMap(const MapState& state, const ProjectedGridConfig& config) {
  // The grid spans every global submap in the band: refuse before allocating one that a map
  // with far-apart submaps would make enormous (an upper bound: whole submaps, band rounded out).
  if (config.include_global && !state.global_submaps.empty()) {
    const double res = state.local_map.resolution_m;
    const double offset = config.relative_band ? state.T_W_B.translation().z() : 0.0;
    const double k0 = std::floor((config.band_min_m + offset) / res);
    const double k1 = std::ceil((config.band_max_m + offset) / res);
    const Eigen::Vector3i cells = state.local_map.submap_cells();
    Eigen::Vector2d lo(std::numeric_limits<double>::max(), std::numeric_limits<double>::max());
    Eigen::Vector2d hi = -lo;
    if (state.window.size.prod() != 0) {
      lo = state.window.min_index.head<2>().cast<double>();
      hi = lo + state.window.size.head<2>().cast<double>();
    }
    for (const auto& entry : state.global_submaps) {
      const SubmapIndex& m = entry.first;
      const double z_lo = static_cast<double>(m.z()) * cells.z();
      if (z_lo + cells.z() <= k0 || z_lo >= k1) continue;
      const Eigen::Vector2d a =
          m.head<2>().cast<double>().cwiseProduct(cells.head<2>().cast<double>());
      lo = lo.cwiseMin(a);
      hi = hi.cwiseMax(a + cells.head<2>().cast<double>());
    }
    const double grid_cells = hi.x() > lo.x() ? (hi.x() - lo.x()) * (hi.y() - lo.y()) : 0.0;
    if (grid_cells > static_cast<double>(kMaxExportGridCells)) {
      std::ostringstream m;
      m << "the 2D grid of this map would span " << (hi.x() - lo.x()) << " x " << (hi.y() - lo.y())
        << " cells (more than " << kMaxExportGridCells << "): its global submaps lie far apart; "
        << "take the local window only or a narrower height band";
      throw std::runtime_error(m.str());
    }
  }
  GlobalMap global(state.local_map.submap_cells(), state.local_map.resolution_m);
  for (const auto& [m, records] : state.global_submaps)
    global.store(m, std::vector<VoxelRecord>(records));
  ProjectedGrid grid;
  projectToGrid(state.window, &global, config, state.T_W_B.translation().z(), &grid);
  return grid;
}

std::string encodePly(const std::vector<OccupiedVoxel>& voxels, double resolution_m) {
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment mlmap occupied voxels, centres in the "
            "world frame W [m], resolution "
         << resolution_m << " m\nelement vertex " << voxels.size()
         << "\nproperty float x\nproperty float y\nproperty float z\nproperty float log_odds\n"
            "property float probability\nend_header\n";
  std::string out = header.str();
  out.reserve(out.size() + voxels.size() * 20);
  for (const OccupiedVoxel& v : voxels) {
    const Eigen::Vector3d c = voxelCenter(v.index, resolution_m);
    for (int a = 0; a < 3; ++a) appendFloat(&out, static_cast<float>(c[a]));
    appendFloat(&out, static_cast<float>(v.log_odds));
    appendFloat(&out, static_cast<float>(probabilityFromLogOdds(v.log_odds)));
  }
  return out;
}

std::string encodePcd(const std::vector<OccupiedVoxel>& voxels, double resolution_m) {
  std::ostringstream header;
  header << "# .PCD v0.7 - Point Cloud Data file format\n# mlmap occupied voxels, resolution "
         << resolution_m << " m, intensity = occupancy probability\nVERSION 0.7\n"
         << "FIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH "
         << voxels.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << voxels.size()
         << "\nDATA binary\n";
  std::string out = header.str();
  out.reserve(out.size() + voxels.size() * 16);
  for (const OccupiedVoxel& v : voxels) {
    const Eigen::Vector3d c = voxelCenter(v.index, resolution_m);
    for (int a = 0; a < 3; ++a) appendFloat(&out, static_cast<float>(c[a]));
    appendFloat(&out, static_cast<float>(probabilityFromLogOdds(v.log_odds)));
  }
  return out;
}

std::string encodeGridPgm(const ProjectedGrid& grid) {
  std::ostringstream header;
  header << "P5\n# CREATOR: mlmap " << std::fixed << std::setprecision(3) << grid.resolution_m
         << " m/pix\n"
         << grid.width << ' ' << grid.height << "\n255\n";
  std::string out = header.str();
  const int free_max = static_cast<int>(std::lround(kFreeThresh * 100.0));
  const int occupied_min = static_cast<int>(std::lround(kOccupiedThresh * 100.0));
  for (int row = 0; row < grid.height; ++row) {
    const int y = grid.height - 1 - row;  // image rows go down, grid rows go up (+y)
    for (int x = 0; x < grid.width; ++x) {
      const int v = grid.at(x, y);
      std::uint8_t pixel = kPgmUnknown;
      if (v >= 0 && v <= 100) {
        if (v <= free_max) {
          pixel = kPgmFree;
        } else if (v >= occupied_min) {
          pixel = kPgmOccupied;
        }
      }
      out.push_back(static_cast<char>(pixel));
    }
  }
  return out;
}

std::string encodeGridYaml(const ProjectedGrid& grid, const std::string& image_name) {
  std::ostringstream y;
  y << std::setprecision(9);
  y << "image: " << image_name << "\nmode: trinary\nresolution: " << grid.resolution_m
    << "\norigin: [" << grid.origin_W.x() << ", " << grid.origin_W.y() << ", 0]\nnegate: 0\n"
    << "occupied_thresh: " << kYamlOccupiedThresh << "\nfree_thresh: " << kYamlFreeThresh << "\n";
  return y.str();
}

void writePly(const std::vector<OccupiedVoxel>& voxels, double resolution_m,
              const std::string& path) {
  writeFileAtomically(path, encodePly(voxels, resolution_m));
}

void writePcd(const std::vector<OccupiedVoxel>& voxels, double resolution_m,
              const std::string& path) {
  writeFileAtomically(path, encodePcd(voxels, resolution_m));
}

void writeGridMap(const ProjectedGrid& grid, const std::string& base) {
  const std::string image = base + ".pgm";
  writeFileAtomically(image, encodeGridPgm(grid));
  writeFileAtomically(base + ".yaml",
                      encodeGridYaml(grid, std::filesystem::path(image).filename().string()));
}

}  // namespace mlmap::io
