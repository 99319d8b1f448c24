#include "mlmap/map_io/voxel_text.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace mlmap::io {

std::vector<VoxelIndex> sortedUnique(std::vector<VoxelIndex> voxels) {
  auto less = [](const VoxelIndex& a, const VoxelIndex& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  };
  std::sort(voxels.begin(), voxels.end(), less);
  voxels.erase(std::unique(voxels.begin(), voxels.end()), voxels.end());
  return voxels;
}

void writeVoxelText(const std::string& path, const std::vector<VoxelIndex>& voxels,
                    double resolution_m) {
  const std::vector<VoxelIndex> sorted = sortedUnique(voxels);
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "w"), &std::fclose);
  if (!f) throw std::runtime_error(path + ": cannot open for writing");
  std::fprintf(f.get(),
               "# mlmap occupied voxels: ix iy iz, i = floor(coordinate / resolution), "
               "resolution_m %.17g, %zu voxels\n",
               resolution_m, sorted.size());
  for (const VoxelIndex& v : sorted) std::fprintf(f.get(), "%d %d %d\n", v.x(), v.y(), v.z());
  if (std::ferror(f.get()) != 0 || std::fclose(f.release()) != 0) {
    throw std::runtime_error(path + ": write error");
  }
}

std::vector<VoxelIndex> readVoxelText(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<VoxelIndex> out;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    VoxelIndex v;
    std::string rest;
    if (!(s >> v.x() >> v.y() >> v.z()) || (s >> rest)) {
      throw std::runtime_error(path + ": line " + std::to_string(line_no) +
                               ": expected three integers 'ix iy iz', got '" + line + "'");
    }
    out.push_back(v);
  }
  return out;
}

}  // namespace mlmap::io
