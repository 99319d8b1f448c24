#include "mlmap/awareness/cone_carver.h"

#include "../support/reference.h"
#include "../support/random_draws.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace mlmap {
namespace {

// All in box-relative voxel units (resolution 1, box origin 0).
constexpr int kBox = 40;

TEST(ConeCarver, MarksEveryVoxelAnyRayIntoTheEndVoxelCrosses) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(2.0, kBox - 2.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  VoxelBitset free;
  int checked_voxels = 0;
  for (int trial = 0; trial < 300; ++trial) {
    free.reset(VoxelIndex::Zero(), Eigen::Vector3i::Constant(kBox));
    Eigen::Vector3d origin = test::draw3(coord, rng);
    // Degenerate cases first: axis-aligned rays, origins on voxel corners, short rays.
    if (trial == 0) origin = {10.0, 10.0, 10.0};
    if (trial == 1) origin = {10.5, 10.5, 10.5};
    Eigen::Vector3i end = test::draw3(coord, rng).cast<int>();
    if (trial == 0) end = {30, 10, 10};
    if (trial == 1) end = {10, 10, 30};
    if (trial == 2) end = origin.cast<int>() + Eigen::Vector3i(1, 0, 0);
    carveCone(origin, end, &free);
    std::vector<Eigen::Vector3d> targets;
    for (int c = 0; c < 8; ++c) {
      // Corners, a hair inside: a point on a far face belongs to the next voxel.
      const Eigen::Vector3d corner(c & 1, (c >> 1) & 1, (c >> 2) & 1);
      targets.push_back(end.cast<double>() + corner * (1.0 - 1e-9));
    }
    for (int r = 0; r < 20; ++r) {
      targets.push_back(end.cast<double>() + test::draw3(unit, rng));
    }
    for (const Eigen::Vector3d& target : targets) {
      for (const test::Key& k : test::referenceRayVoxels(origin, target, 1.0)) {
        const VoxelIndex v = test::index(k);
        ++checked_voxels;
        ASSERT_TRUE(free.test(v.x(), v.y(), v.z()))
            << "trial " << trial << ": voxel " << v.transpose() << " on the ray from "
            << origin.transpose() << " to " << target.transpose() << " was not carved";
      }
    }
  }
  EXPECT_GT(checked_voxels, 10000);
}

TEST(ConeCarver, TailFromSMinCoversTheRestOfEveryRayIntoTheBox) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> coord(2.0, kBox - 2.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  VoxelBitset free;
  for (int trial = 0; trial < 200; ++trial) {
    free.reset(VoxelIndex::Zero(), Eigen::Vector3i::Constant(kBox));
    const Eigen::Vector3d origin = test::draw3(coord, rng);
    const Eigen::Vector3d corner = test::draw3(coord, rng);
    const Eigen::Vector3d size = 0.5 * test::draw3(unit, rng);
    const VoxelSpaceBox box{corner.cast<float>(), (corner + size).cast<float>()};
    const double s_min = 0.5 * unit(rng);
    carveCone(origin, box, s_min, &free);
    std::size_t tail_voxels = 0;
    for (int r = 0; r < 20; ++r) {
      const Eigen::Vector3d p = corner + size.cwiseProduct(test::draw3(unit, rng));
      for (const test::Key& k : test::referenceRayVoxels(origin + s_min * (p - origin), p, 1.0)) {
        const VoxelIndex v = test::index(k);
        ++tail_voxels;
        ASSERT_TRUE(free.test(v.x(), v.y(), v.z())) << "trial " << trial;
      }
    }
    // The part before s_min is not carved (away from the tail's first slab).
    const Eigen::Vector3d c = 0.5 * (box.min + box.max).cast<double>();
    if (s_min > 0.3 && (c - origin).norm() > 10.0) {
      const VoxelIndex near = (origin + 0.1 * (c - origin)).array().floor().cast<int>();
      EXPECT_FALSE(free.test(near.x(), near.y(), near.z())) << "trial " << trial;
    }
    EXPECT_GT(tail_voxels, 0u);
  }
}

TEST(ConeCarver, CarvesLittleMoreThanTheRays) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coord(2.0, kBox - 2.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  VoxelBitset free;
  std::size_t marked_total = 0;
  std::size_t crossed_total = 0;
  double worst_distance = 0.0;
  for (int trial = 0; trial < 80; ++trial) {
    free.reset(VoxelIndex::Zero(), Eigen::Vector3i::Constant(kBox));
    const Eigen::Vector3d origin = test::draw3(coord, rng);
    const Eigen::Vector3i end = test::draw3(coord, rng).cast<int>();
    const Eigen::Vector3d c = end.cast<double>().array() + 0.5;
    carveCone(origin, end, &free);
    std::set<test::Key> crossed;  // what dense rays into the end voxel cross
    for (int r = 0; r < 150; ++r) {
      const Eigen::Vector3d target = end.cast<double>() + test::draw3(unit, rng);
      for (const auto& k : test::referenceRayVoxels(origin, target, 1.0, 0.01)) crossed.insert(k);
    }
    crossed_total += crossed.size();
    marked_total += free.count();
    const Eigen::Vector3d d = c - origin;
    free.forEach([&](int i, int j, int k) {
      const Eigen::Vector3d p(i + 0.5, j + 0.5, k + 0.5);
      const double s = std::clamp((p - origin).dot(d) / d.squaredNorm(), 0.0, 1.0);
      worst_distance = std::max(worst_distance, (origin + s * d - p).norm());
    });
  }
  const double ratio = static_cast<double>(marked_total) / static_cast<double>(crossed_total);
  std::printf(
      "cone carving: %zu voxels marked for %zu crossed by dense rays (x%.2f), farthest "
      "marked voxel centre %.2f voxels from the central ray\n",
      marked_total, crossed_total, ratio, worst_distance);
  EXPECT_LT(ratio, 1.6);
  EXPECT_LT(worst_distance, 2.5);
}

// The AVX2 slab walk against the portable one, word for word, on cones of every direction and
// length: thin ones (one or two rows a slab, the AVX2 walk's own marking), wider ones and z runs
// across a word boundary (the box is 150 voxels high: three words a row), which it hands to the
// portable marking, clamped parts from s_min, and cones reaching out of the box.
TEST(ConeCarver, Avx2SlabWalkMarksThePortableOnesBitForBit) {
  if (!coneCarverAvx2Supported()) GTEST_SKIP() << "no AVX2 on this CPU or build";
  const Eigen::Vector3i dims(48, 40, 150);
  std::mt19937 rng(44);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  VoxelBitset portable;
  VoxelBitset avx2;
  std::size_t marked = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    Eigen::Vector3d origin;
    Eigen::Vector3d corner;
    for (int k = 0; k < 3; ++k) {
      origin[k] = -8.0 + unit(rng) * (dims[k] + 16.0);
      corner[k] = -8.0 + unit(rng) * (dims[k] + 16.0);
    }
    const double size = trial % 4 == 0 ? 8.0 : 1.5;  // mostly thin cones, as a scan's
    const Eigen::Vector3f lo = corner.cast<float>();
    const Eigen::Vector3f hi =
        lo + (size * Eigen::Vector3d(unit(rng), unit(rng), unit(rng))).cast<float>();
    const double s_min = trial % 3 == 0 ? 0.0 : unit(rng);
    portable.reset(VoxelIndex::Zero(), dims);
    avx2.reset(VoxelIndex::Zero(), dims);
    const std::size_t slabs =
        carveCone(origin, {lo, hi}, s_min, &portable, ConeCarverIsa::kPortable);
    ASSERT_EQ(carveCone(origin, {lo, hi}, s_min, &avx2, ConeCarverIsa::kAvx2), slabs);
    const std::size_t words = static_cast<std::size_t>(dims.x()) * dims.y() * avx2.wordsPerRow();
    for (std::size_t w = 0; w < words; ++w) {
      ASSERT_EQ(avx2.data()[w], portable.data()[w]) << "trial " << trial << ", word " << w;
    }
    marked += portable.count();
  }
  EXPECT_GT(marked, 100000u);
}

// The reference: the float nearest to x, one step toward -infinity when that lies above x.
float referenceFloatBelow(double x) {
  const float f = static_cast<float>(x);
  return static_cast<double>(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity())
                                    : f;
}

// Threads split the box by x: the cone clipped to each of a partition of x
// ranges marks, over the ranges, exactly the bits of the whole cone, and
// nothing outside its range. Cones of every dominant axis, with and without a
// tail start, some with the origin inside the box, some reaching past the
// bitset's box.
TEST(ConeCarver, XRangesOfAPartitionMarkTheWholeConeBitForBit) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> coord(-4.0, kBox + 4.0);
  std::uniform_real_distribution<double> size(0.0, 3.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> cut(0, kBox);
  VoxelBitset whole;
  VoxelBitset parts;
  VoxelBitset part;
  int compared = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector3d origin = test::draw3(coord, rng);
    const Eigen::Vector3d corner = trial % 50 == 0
                                       ? Eigen::Vector3d(origin - Eigen::Vector3d::Constant(0.3))
                                       : test::draw3(coord, rng);  // origin inside, or not
    const Eigen::Vector3f lo = corner.cast<float>();
    const Eigen::Vector3f hi = lo + Eigen::Vector3d(size(rng), size(rng), size(rng)).cast<float>();
    const VoxelSpaceBox box{lo, hi};
    const double s_min = trial % 3 == 0 ? 0.0 : unit(rng);
    whole.reset(VoxelIndex::Zero(), Eigen::Vector3i::Constant(kBox));
    const std::size_t slabs = carveCone(origin, box, s_min, &whole);
    // A partition of [0, kBox) into up to four ranges (some empty), and one
    // range past the box.
    int borders[5] = {0, cut(rng), cut(rng), cut(rng), kBox};
    std::sort(borders + 1, borders + 4);
    parts.reset(VoxelIndex::Zero(), Eigen::Vector3i::Constant(kBox));
    for (int r = 0; r < 4; ++r) {
      part.reset(VoxelIndex::Zero(), Eigen::Vector3i::Constant(kBox));
      EXPECT_EQ(carveCone(origin, box, s_min, borders[r], borders[r + 1], &part), slabs);
      for (int x = 0; x < kBox; ++x) {
        for (int y = 0; y < kBox; ++y) {
          for (int z = 0; z < kBox; ++z) {
            if (!part.test(x, y, z)) continue;
            ASSERT_TRUE(x >= borders[r] && x < borders[r + 1])
                << "marked outside its range, trial " << trial;
            parts.testAndSet(x, y, z);
          }
        }
      }
    }
    part.reset(VoxelIndex::Zero(), Eigen::Vector3i::Constant(kBox));
    carveCone(origin, box, s_min, kBox, kBox + 10, &part);
    EXPECT_EQ(part.count(), 0u);
    ASSERT_EQ(parts.count(), whole.count()) << "trial " << trial;
    for (int x = 0; x < kBox; ++x) {
      for (int y = 0; y < kBox; ++y) {
        for (int z = 0; z < kBox; ++z) {
          ASSERT_EQ(parts.test(x, y, z), whole.test(x, y, z)) << "trial " << trial;
        }
      }
    }
    compared += whole.count() > 0 ? 1 : 0;
  }
  EXPECT_GT(compared, 1000);
}

TEST(ConeCarver, FloatBelowIsTheLargestFloatNotAboveItsArgument) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> coord(-300.0, 300.0);
  std::uniform_real_distribution<double> tiny(-1e-40, 1e-40);  // around zero, denormals
  std::vector<double> xs = {0.0,
                            -0.0,
                            1.0,
                            -1.0,
                            0.5,
                            -0.5,
                            1e-50,
                            -1e-50,
                            3.0000001,
                            -3.0000001,
                            std::numeric_limits<float>::max(),
                            -std::numeric_limits<float>::max() + 1e20};
  for (int i = 0; i < 20000; ++i) xs.push_back(coord(rng));
  for (int i = 0; i < 2000; ++i) xs.push_back(tiny(rng));
  int stepped = 0;
  for (const double x : xs) {
    const float below = floatBelow(x);
    ASSERT_EQ(std::signbit(below), std::signbit(referenceFloatBelow(x))) << "x = " << x;
    ASSERT_EQ(below, referenceFloatBelow(x)) << "x = " << x;
    ASSERT_LE(static_cast<double>(below), x);
    ASSERT_GT(static_cast<double>(std::nextafter(below, std::numeric_limits<float>::infinity())),
              x);
    stepped += static_cast<double>(static_cast<float>(x)) > x ? 1 : 0;
  }
  // Both ways of rounding were exercised, on both signs.
  EXPECT_GT(stepped, 5000);
  EXPECT_LT(stepped, static_cast<int>(xs.size()) - 5000);
  EXPECT_EQ(floatBelow(-1e-50), -std::numeric_limits<float>::denorm_min());
}

// roundOutwards() (two coordinates at a time where there is SSE2) gives the floats that
// floatBelow() gives per coordinate, bit for bit: both rounding ways, both signs, zeros of both
// signs, denormals, exact floats and the ends of the float range, in every slot of the box.
TEST(ConeCarver, RoundOutwardsIsFloatBelowPerCoordinate) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> coord(-300.0, 300.0);
  std::uniform_real_distribution<double> tiny(-1e-40, 1e-40);
  const std::vector<double> special = {0.0,
                                       -0.0,
                                       1.0,
                                       -1.0,
                                       1e-50,
                                       -1e-50,
                                       3.0000001,
                                       -3.0000001,
                                       0.5,
                                       -0.5,
                                       std::numeric_limits<float>::max(),
                                       -std::numeric_limits<float>::max()};
  std::uniform_int_distribution<std::size_t> pick(0, special.size() - 1);
  std::uniform_int_distribution<int> kind(0, 3);
  auto draw = [&] {
    switch (kind(rng)) {
      case 0:
        return special[pick(rng)];
      case 1:
        return tiny(rng);
      case 2:
        return static_cast<double>(static_cast<float>(coord(rng)));  // exact float
      default:
        return coord(rng);
    }
  };
  auto sameBits = [](float a, float b) {
    std::uint32_t x = 0;
    std::uint32_t y = 0;
    std::memcpy(&x, &a, sizeof x);
    std::memcpy(&y, &b, sizeof y);
    return x == y;
  };
  int stepped = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d lo(draw(), draw(), draw());
    const Eigen::Vector3d hi(draw(), draw(), draw());
    const VoxelSpaceBox box = roundOutwards(lo, hi);
    for (int k = 0; k < 3; ++k) {
      ASSERT_TRUE(sameBits(box.min[k], floatBelow(lo[k]))) << "lo = " << lo[k];
      ASSERT_TRUE(sameBits(box.max[k], -floatBelow(-hi[k]))) << "hi = " << hi[k];
      stepped += static_cast<double>(static_cast<float>(lo[k])) > lo[k] ? 1 : 0;
    }
  }
  EXPECT_GT(stepped, 5000);  // rounding up was corrected often, in every slot over the draws
}

}  // namespace
}  // namespace mlmap
