#include "mlmap/map_io/voxel_text.h"

#include <gtest/gtest.h>

#include <climits>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace mlmap::io {
namespace {

/// The lines as snprintf writes them: the reference for the fast writer.
std::string referenceLines(const std::vector<VoxelIndex>& sorted) {
  std::string text;
  char line[64];
  for (const VoxelIndex& v : sorted) {
    const int n = std::snprintf(line, sizeof(line), "%d %d %d\n", v.x(), v.y(), v.z());
    text.append(line, static_cast<std::size_t>(n));
  }
  return text;
}

TEST(VoxelText, LinesAreWhatSnprintfWritesAndReadBack) {
  std::vector<VoxelIndex> voxels = {{INT_MIN, INT_MAX, 0},
                                    {-1, 0, 1},
                                    {INT_MAX, INT_MIN, INT_MIN},
                                    {0, 0, 0},
                                    {-1, 0, 1}};  // a duplicate, dropped
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> any(INT_MIN, INT_MAX);
  std::uniform_int_distribution<int> small(-3000, 3000);
  for (int i = 0; i < 2000; ++i) voxels.emplace_back(small(rng), small(rng), any(rng));
  const std::vector<VoxelIndex> sorted = sortedUnique(voxels);
  const std::string text = encodeVoxelText(voxels, 0.1);
  const std::size_t body = text.find('\n') + 1;
  ASSERT_EQ(text.compare(0, 1, "#"), 0);
  EXPECT_NE(text.find(std::to_string(sorted.size()) + " voxels\n"), std::string::npos);
  EXPECT_EQ(text.substr(body), referenceLines(sorted));
  EXPECT_EQ(encodeVoxelText({}, 0.1).find('\n') + 1, encodeVoxelText({}, 0.1).size());
}

}  // namespace
}  // namespace mlmap::io
