// The carving's direction bins: their indices nest level by level (a bin's parent is its index
// shifted by two bits, its children consecutive), the radix sort that brings a frame's ends
// into bin order is a stable sort by bin, and the levels built from the sorted ends are the
// hierarchy a map of maps gives.
#include "../../src/awareness/direction_bins.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
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

struct TestBin {
  std::uint32_t index = 0;
  std::uint32_t parent = 0;
  std::uint32_t children = 0;
  double near = 0.0;
  int tag = 0;  // a field of the caller's: copied from the empty bin
};

// Every level equals the slow hierarchy: level 0 a bin per distinct finest key, level L + 1 a
// bin per distinct index >> 2 of level L's, in index order, each with its members' nearest
// distance and its count of children; every bin's parent and every item's place point at the
// bin of its key.
TEST(DirectionBins, LevelsBuiltFromSortedEndsAreTheHierarchyOfTheirKeys) {
  std::mt19937 rng(4401);
  std::vector<std::uint64_t> scratch;
  std::vector<std::vector<TestBin>> levels(7, std::vector<TestBin>(3));  // stale: dropped
  for (int lg = 0; lg <= 5; ++lg) {
    for (const std::size_t count : {0, 1, 2, 9, 300, 5000}) {
      const std::uint32_t bins = 6u << (2 * lg);
      // Few distinct keys in one corner too, so that bins share parents on every level.
      std::uniform_int_distribution<std::uint32_t> wide_key(0, bins - 1);
      std::uniform_int_distribution<std::uint32_t> corner_key(0, std::min(bins - 1, 37u));
      std::uniform_real_distribution<double> draw_near(0.0, 100.0);
      std::vector<std::uint32_t> keys(count);
      std::vector<double> near(count);
      std::vector<std::uint64_t> sorted(count);
      for (std::size_t i = 0; i < count; ++i) {
        keys[i] = (i % 3 == 0) ? wide_key(rng) : corner_key(rng);
        near[i] = draw_near(rng);
        sorted[i] = (std::uint64_t{keys[i]} << 32) | i;
      }
      sortByKey(3 + 2 * lg, &sorted, &scratch);
      TestBin empty;
      empty.tag = 7;
      std::vector<std::uint32_t> place(count, std::numeric_limits<std::uint32_t>::max());
      buildBinLevels(
          sorted, static_cast<std::size_t>(lg) + 1, empty,
          [&near](std::uint32_t i) { return near[i]; },
          [&place](std::uint32_t i, std::uint32_t p) { place[i] = p; }, &levels);
      const std::string what = "lg " + std::to_string(lg) + ", " + std::to_string(count) + " ends";
      ASSERT_EQ(levels.size(), static_cast<std::size_t>(lg) + 1) << what;

      // The slow hierarchy: key -> nearest distance and children, level by level.
      std::vector<std::map<std::uint32_t, double>> expected(static_cast<std::size_t>(lg) + 1);
      std::vector<std::map<std::uint32_t, std::set<std::uint64_t>>> children(expected.size());
      for (std::size_t i = 0; i < count; ++i) {
        std::uint64_t child = i;  // the item on level 0, the key of the level below above it
        std::uint32_t key = keys[i];
        for (std::size_t level = 0; level < expected.size(); ++level) {
          const auto [it, added] = expected[level].emplace(key, near[i]);
          if (!added) it->second = std::min(it->second, near[i]);
          children[level][key].insert(child);
          child = key;
          key >>= 2;
        }
      }
      for (std::size_t level = 0; level < expected.size(); ++level) {
        const std::vector<TestBin>& got = levels[level];
        ASSERT_EQ(got.size(), expected[level].size()) << what << ", level " << level;
        std::size_t at = 0;
        for (const auto& [key, nearest] : expected[level]) {
          const TestBin& bin = got[at++];
          EXPECT_EQ(bin.index, key) << what << ", level " << level;
          EXPECT_EQ(bin.near, nearest) << what << ", level " << level << ", key " << key;
          EXPECT_EQ(bin.children, children[level][key].size())
              << what << ", level " << level << ", key " << key;
          EXPECT_EQ(bin.tag, 7) << "the empty bin's other fields";
          if (level + 1 < expected.size()) {
            ASSERT_LT(bin.parent, levels[level + 1].size()) << what;
            EXPECT_EQ(levels[level + 1][bin.parent].index, key >> 2)
                << what << ", level " << level << ", key " << key;
          }
        }
      }
      for (std::size_t i = 0; i < count; ++i) {
        ASSERT_LT(place[i], levels[0].size()) << what << ", item " << i;
        EXPECT_EQ(levels[0][place[i]].index, keys[i]) << what << ", item " << i;
      }
    }
  }
}

}  // namespace
}  // namespace mlmap
