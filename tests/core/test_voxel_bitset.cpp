// The per-frame free set: reset() clears exactly what was set, by the rows listed in use when
// they are (the awareness stage lists them while counting), else by the marked rectangle; any
// write that could set a bit elsewhere makes the listed rows unknown again.
#include "mlmap/core/voxel_bitset.h"

#include "../support/rows_in_use.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>

namespace mlmap {
namespace {

const Eigen::Vector3i kDims(9, 150, 70);  // three words of rows in use per x, two per row

// Sets `n` random bits inside rows [2, 7) x [10, 140) through data(), as the carving does.
void markRandomBits(VoxelBitset* bits, int n, std::mt19937& rng) {
  std::uniform_int_distribution<int> x(2, 6);
  std::uniform_int_distribution<int> y(10, 139);
  std::uniform_int_distribution<int> z(0, kDims.z() - 1);
  bits->setMarkedRows({2, 7, 10, 140});
  for (int k = 0; k < n; ++k) {
    const int zk = z(rng);
    bits->data()[bits->rowWord(x(rng), y(rng)) + static_cast<std::size_t>(zk / 64)] |=
        std::uint64_t{1} << (zk % 64);
  }
}

bool allClear(const VoxelBitset& bits) {
  const std::size_t words = static_cast<std::size_t>(kDims.x() * kDims.y()) * bits.wordsPerRow();
  return std::all_of(bits.data(), bits.data() + words, [](std::uint64_t w) { return w == 0; });
}

TEST(VoxelBitset, ResetClearsEveryBitByTheRowsInUseOrTheMarkedRows) {
  std::mt19937 rng(44);
  VoxelBitset bits;
  bits.reset(VoxelIndex(-3, 5, 2), kDims);
  EXPECT_EQ(bits.rowsInUseWordsPerX(), 3u);
  for (int frame = 0; frame < 20; ++frame) {
    markRandomBits(&bits, 1 + frame * 37, rng);
    ASSERT_FALSE(bits.rowsInUseValid()) << "marking rows makes the rows in use unknown";
    if (frame % 2 == 0) {
      test::listRowsInUseSlowly(&bits);
      ASSERT_TRUE(bits.rowsInUseValid());
    }
    bits.reset(VoxelIndex(-3, 5, 2), kDims);
    ASSERT_TRUE(allClear(bits)) << "frame " << frame;
    EXPECT_FALSE(bits.rowsInUseValid());
  }
}

TEST(VoxelBitset, TestAndSetMakesTheRowsInUseUnknown) {
  VoxelBitset bits;
  bits.reset(VoxelIndex::Zero(), kDims);
  test::listRowsInUseSlowly(&bits);  // none in use
  ASSERT_TRUE(bits.rowsInUseValid());
  EXPECT_FALSE(bits.testAndSet(4, 100, 65));
  EXPECT_FALSE(bits.rowsInUseValid());
  bits.reset(VoxelIndex::Zero(), kDims);  // by the marked rectangle: the whole box
  EXPECT_TRUE(allClear(bits));
}

}  // namespace
}  // namespace mlmap
