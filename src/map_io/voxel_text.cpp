#include "mlmap/map_io/voxel_text.h"

#include "mlmap/core/atomic_file.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace mlmap::io {

std::vector<VoxelIndex> sortedUnique(std::vector<VoxelIndex> voxels) {
  auto less = [](const VoxelIndex& a, const VoxelIndex& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  };
  // A local map lists its voxels in this order already (a replay whose window held everything).
  if (!std::is_sorted(voxels.begin(), voxels.end(), less))
    std::sort(voxels.begin(), voxels.end(), less);
  voxels.erase(std::unique(voxels.begin(), voxels.end()), voxels.end());
  return voxels;
}

void writeVoxelText(const std::string& path, const std::vector<VoxelIndex>& voxels,
                    double resolution_m) {
  writeFileAtomically(path, encodeVoxelText(voxels, resolution_m));
}

std::string encodeVoxelText(const std::vector<VoxelIndex>& voxels, double resolution_m) {
  const std::vector<VoxelIndex> sorted = sortedUnique(voxels);
  char line[128];
  std::snprintf(line, sizeof(line),
                "# mlmap occupied voxels: ix iy iz, i = floor(coordinate / resolution), "
                "resolution_m %.17g, %zu voxels\n",
                resolution_m, sorted.size());
  std::string text = line;
  // Written with std::to_chars into the string's own storage (snprintf per line cost five times
  // as much): at most 3 x 11 characters and 3 separators per line.
  constexpr std::size_t kMaxLine = 36;
  std::size_t size = text.size();
  text.resize(size + sorted.size() * kMaxLine);
  for (const VoxelIndex& v : sorted) {
    char* out = text.data() + size;
    char* const end = out + kMaxLine;
    out = std::to_chars(out, end, v.x()).ptr;
    *out++ = ' ';
    out = std::to_chars(out, end, v.y()).ptr;
    *out++ = ' ';
    out = std::to_chars(out, end, v.z()).ptr;
    *out++ = '\n';
    size = static_cast<std::size_t>(out - text.data());
  }
  text.resize(size);
  return text;
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
