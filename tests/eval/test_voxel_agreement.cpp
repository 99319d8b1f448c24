#include "mlmap/eval/voxel_agreement.h"
#include "../support/random_draws.h"

#include <gtest/gtest.h>

#include <random>

namespace mlmap::eval {
namespace {

TEST(VoxelAgreement, HandComputedCase) {
  // A: (0,0,0) (1,0,0) (5,5,5) (9,0,0) and a duplicate; B: (0,0,0) (1,0,0) (6,6,6) (20,0,0)
  // (21,0,0).
  const std::vector<VoxelIndex> a = {{0, 0, 0}, {1, 0, 0}, {5, 5, 5}, {9, 0, 0}, {1, 0, 0}};
  const std::vector<VoxelIndex> b = {{0, 0, 0}, {1, 0, 0}, {6, 6, 6}, {20, 0, 0}, {21, 0, 0}};
  const VoxelAgreement r = compareVoxels(a, b);
  EXPECT_EQ(r.a, 4u);
  EXPECT_EQ(r.b, 5u);
  EXPECT_EQ(r.intersection, 2u);
  EXPECT_DOUBLE_EQ(r.iou, 2.0 / 7.0);  // union = 4 + 5 - 2
  EXPECT_DOUBLE_EQ(r.precision, 2.0 / 4.0);
  EXPECT_DOUBLE_EQ(r.recall, 2.0 / 5.0);
  // Within one cell: (5,5,5) <-> (6,6,6) match diagonally; (9,0,0), (20,0,0), (21,0,0) do not.
  EXPECT_EQ(r.matched_a_1, 3u);
  EXPECT_EQ(r.matched_b_1, 3u);
  EXPECT_DOUBLE_EQ(r.precision_1, 3.0 / 4.0);
  EXPECT_DOUBLE_EQ(r.recall_1, 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(r.iou_1, 3.0 / 6.0);  // m = 3, 4 + 5 - 3
}

TEST(VoxelAgreement, EmptyAndIdenticalSets) {
  const VoxelAgreement empty = compareVoxels({}, {});
  EXPECT_EQ(empty.a + empty.b + empty.intersection, 0u);
  EXPECT_EQ(empty.iou, 0.0);
  EXPECT_EQ(empty.precision_1, 0.0);
  const std::vector<VoxelIndex> s = {{-3, 2, 1}, {-2, 2, 1}, {100, -7, 0}};
  const VoxelAgreement same = compareVoxels(s, s);
  EXPECT_DOUBLE_EQ(same.iou, 1.0);
  EXPECT_DOUBLE_EQ(same.iou_1, 1.0);
  EXPECT_DOUBLE_EQ(same.precision, 1.0);
  EXPECT_DOUBLE_EQ(same.recall_1, 1.0);
  const VoxelAgreement one_sided = compareVoxels(s, {});
  EXPECT_EQ(one_sided.a, 3u);
  EXPECT_EQ(one_sided.recall, 0.0);
  EXPECT_EQ(one_sided.precision, 0.0);
}

TEST(VoxelAgreement, MatchesABruteForceOnRandomSets) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> coord(-6, 6);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<VoxelIndex> a, b;
    for (int i = 0; i < 150; ++i) a.push_back(test::draw3(coord, rng));
    for (int i = 0; i < 120; ++i) b.push_back(test::draw3(coord, rng));
    const VoxelSet sa(a.begin(), a.end()), sb(b.begin(), b.end());
    std::size_t inter = 0, ma = 0, mb = 0;
    auto near = [](const VoxelIndex& p, const VoxelSet& s) {
      for (const VoxelIndex& q : s) {
        if ((p - q).cwiseAbs().maxCoeff() <= 1) return true;
      }
      return false;
    };
    for (const VoxelIndex& v : sa) {
      inter += sb.count(v);
      ma += near(v, sb) ? 1 : 0;
    }
    for (const VoxelIndex& v : sb) mb += near(v, sa) ? 1 : 0;
    const VoxelAgreement r = compareVoxels(a, b);
    EXPECT_EQ(r.intersection, inter);
    EXPECT_EQ(r.matched_a_1, ma);
    EXPECT_EQ(r.matched_b_1, mb);
    EXPECT_DOUBLE_EQ(
        r.iou, static_cast<double>(inter) / static_cast<double>(sa.size() + sb.size() - inter));
  }
}

}  // namespace
}  // namespace mlmap::eval
