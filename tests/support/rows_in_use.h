#pragma once
// The slow reference for VoxelBitset's rows in use: every bit tested.

#include "mlmap/core/voxel_bitset.h"

#include <algorithm>
#include <cstdint>

namespace mlmap::test {

/// Lists the rows of `bits` that hold a set bit by testing every bit of its box, as the
/// awareness stage's count lists them (VoxelBitset::rowsInUse()), and declares the list valid.
inline void listRowsInUseSlowly(VoxelBitset* bits) {
  const Eigen::Vector3i dims = bits->dims();
  for (int i = 0; i < dims.x(); ++i) {
    std::uint64_t* in_use = bits->rowsInUse(i);
    std::fill(in_use, in_use + bits->rowsInUseWordsPerX(), std::uint64_t{0});
    for (int j = 0; j < dims.y(); ++j) {
      for (int k = 0; k < dims.z(); ++k) {
        if (bits->test(i, j, k)) in_use[j / 64] |= std::uint64_t{1} << (j % 64);
      }
    }
  }
  bits->setRowsInUseValid();
}

}  // namespace mlmap::test
