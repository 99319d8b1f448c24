#include "mlmap/io/map_export.h"

#include "mlmap/io/map_file.h"

#include <cstring>
#include <filesystem>
#include <iomanip>
#include <sstream>

namespace mlmap::io {
namespace {

// map_saver's defaults (nav2 and ROS 1 map_server trinary mode).
constexpr double kOccupiedThresh = 0.65;
constexpr double kFreeThresh = 0.25;
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
      out.push_back({base + VoxelIndex(x, rest / s.z(), rest % s.z()), dequantizeLogOdds(r.log_odds), true});
    }
  }
  return out;
}

ProjectedGrid projectMap(const MapState& state, const ProjectedGridConfig& config) {
  GlobalMap global(state.local_map.submap_cells(), state.local_map.resolution_m);
  for (const auto& [m, records] : state.global_submaps) global.store(m, std::vector<VoxelRecord>(records));
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
    << "occupied_thresh: " << kOccupiedThresh << "\nfree_thresh: " << kFreeThresh << "\n";
  return y.str();
}

void writePly(const std::vector<OccupiedVoxel>& voxels, double resolution_m, const std::string& path) {
  writeFileAtomically(path, encodePly(voxels, resolution_m));
}

void writePcd(const std::vector<OccupiedVoxel>& voxels, double resolution_m, const std::string& path) {
  writeFileAtomically(path, encodePcd(voxels, resolution_m));
}

void writeGridMap(const ProjectedGrid& grid, const std::string& base) {
  const std::string image = base + ".pgm";
  writeFileAtomically(image, encodeGridPgm(grid));
  writeFileAtomically(base + ".yaml",
                      encodeGridYaml(grid, std::filesystem::path(image).filename().string()));
}

}  // namespace mlmap::io
