// The carving's direction bins: their indices nest level by level (a bin's parent is its index
// shifted by two bits, its children consecutive), and the radix sort that brings a frame's ends
// into bin order is a stable sort by bin.
#include "../../src/awareness/direction_bins.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <set>
#include <vector>

namespace mlmap {
namespace {

TEST(DirectionBins, IndicesAreDistinctAndNestLevelByLevel) {
  for (int lg = 0; lg <= 8; ++lg) {  // up to AwarenessConfig::kMaxBinsPerFaceSide = 2^8
    const int n = 1 << lg;
    std::set<std::uint32_t> seen;
    for (int face = 0; face < 6; ++face) {
      for (int iu = 0; iu < n; ++iu) {
        for (int iv = 0; iv < n; ++iv) {
          const std::uint32_t key = binKey(face, iu, iv, lg);
          ASSERT_LT(key, 6u << (2 * lg)) << "indices fit 3 + 2 lg bits";
          ASSERT_TRUE(seen.insert(key).second) << "face " << face << " iu " << iu << " iv " << iv;
          if (lg > 0) {
            ASSERT_EQ(key >> 2, binKey(face, iu / 2, iv / 2, lg - 1))
                << "the parent of face " << face << " iu " << iu << " iv " << iv << " lg " << lg;
          }
        }
      }
    }
    EXPECT_EQ(seen.size(), 6u * static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  }
}

// Radix-sorted entries equal std::stable_sort's by the upper 32 bits: the same keys, and equal
// keys in their first order (the ends' index in the low bits).
TEST(DirectionBins, SortByKeyIsAStableSortByTheUpperBits) {
  std::mt19937 rng(44);
  std::vector<std::uint64_t> scratch{7, 7, 7};  // stale contents must not matter
  for (const int key_bits : {1, 3, 11, 12, 19, 22, 32}) {
    for (const std::size_t count : {0, 1, 2, 100, 30000}) {
      const std::uint64_t limit = key_bits == 32 ? 0xFFFFFFFFull : (1ull << key_bits) - 1;
      // Few distinct keys for small counts too, so that equal keys meet.
      std::uniform_int_distribution<std::uint64_t> draw_key(
          0, std::min<std::uint64_t>(limit, count / 4 + 3));
      std::uniform_int_distribution<std::uint64_t> wide_key(0, limit);
      std::vector<std::uint64_t> entries;
      for (std::size_t i = 0; i < count; ++i) {
        const std::uint64_t key = (i % 2 == 0) ? draw_key(rng) : wide_key(rng);
        entries.push_back((key << 32) | static_cast<std::uint32_t>(i));
      }
      std::vector<std::uint64_t> expected = entries;
      std::stable_sort(expected.begin(), expected.end(),
                       [](std::uint64_t a, std::uint64_t b) { return (a >> 32) < (b >> 32); });
      sortByKey(key_bits, &entries, &scratch);
      EXPECT_EQ(entries, expected) << key_bits << " key bits, " << count << " entries";
    }
  }
}

}  // namespace
}  // namespace mlmap
