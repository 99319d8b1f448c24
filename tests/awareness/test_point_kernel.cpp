#include "mlmap/awareness/point_kernel.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace mlmap {
namespace {

// What the kernel promises for one point, written out branch by branch (the kernels are
// branch-free and vectorised).
void referencePoint(const PointKernel& k, float xf, float yf, float zf, std::uint32_t* key,
                    float coord[4]) {
  double p[3] = {xf, yf, zf};
  const double r2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
  const bool finite =
      std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]) && std::isfinite(r2);
  const bool cut = finite && r2 > k.max_range * k.max_range;
  if (!finite) {
    p[0] = p[1] = p[2] = 0.0;  // documented: a non-finite point gets the origin's coordinates
  } else if (cut) {
    const double scale = k.max_range / std::sqrt(r2);
    for (double& c : p) c *= scale;
  }
  double b[3];
  std::int64_t index[3];
  for (std::size_t a = 0; a < 3; ++a) {
    b[a] = (k.o[a] + k.m[3 * a] * p[0] + k.m[3 * a + 1] * p[1] + k.m[3 * a + 2] * p[2]) -
           k.box_origin[a];
    index[a] = static_cast<std::int64_t>(std::floor(b[a]));
    coord[a] = static_cast<float>(b[a]);
  }
  coord[3] = 0.0f;
  bool inside = true;
  for (int a = 0; a < 3; ++a) inside = inside && index[a] >= 0 && index[a] < k.dims[a];
  if (!finite) {
    *key = kPointNonFiniteKey;
  } else if (r2 <= k.min_range2) {
    *key = kPointTooCloseKey;
  } else if (!inside) {
    *key = cut ? kPointOutsideCutKey : kPointOutsideHitKey;
  } else {
    *key = static_cast<std::uint32_t>((index[0] * k.dims[1] + index[1]) * k.dims[2] + index[2]) |
           (cut ? kPointCutFlag : 0u);
  }
}

struct Block {
  std::vector<float> xs, ys, zs;
  void add(float x, float y, float z) {
    xs.push_back(x);
    ys.push_back(y);
    zs.push_back(z);
  }
};

PointKernel randomKernel(std::mt19937& rng, double resolution_m) {
  std::uniform_real_distribution<double> angle(-3.2, 3.2);
  std::uniform_real_distribution<double> position(-50.0, 50.0);
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(angle(rng) / 4.0, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(angle(rng) / 4.0, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  PointKernel k;
  const Eigen::Matrix3d M = R / resolution_m;
  for (Eigen::Index r = 0; r < 3; ++r) {
    for (Eigen::Index c = 0; c < 3; ++c) k.m[static_cast<std::size_t>(3 * r + c)] = M(r, c);
  }
  k.max_range = 6.0;
  k.min_range2 = 0.1 * 0.1;
  // The awareness stage's box: the sensor voxel +- the range.
  const int half = static_cast<int>(std::ceil(k.max_range / resolution_m)) + 1;
  for (std::size_t a = 0; a < 3; ++a) {
    k.o[a] = position(rng) / resolution_m;
    k.box_origin[a] = std::floor(k.o[a]) - half;
    k.dims[a] = static_cast<std::uint32_t>(2 * half + 1) - (a == 2 ? 20u : 0u);  // z: shorter
  }
  return k;
}

// Points of every kind: within range, beyond it, within the minimum range, zero, NaN, Inf,
// absurd, and points whose world coordinate lies on a voxel face (as simulated walls do: the
// key and the float coordinate must then agree on the side, as the double arithmetic puts it).
Block randomBlock(std::mt19937& rng, const PointKernel& k, std::size_t n) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_int_distribution<int> kind(0, 19);
  std::uniform_int_distribution<int> cell(-40, 40);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  Block b;
  while (b.xs.size() < n) {
    const float x = 6.5f * u(rng);
    const float y = 6.5f * u(rng);
    const float z = 6.5f * u(rng);
    switch (kind(rng)) {
      case 0:
        b.add(nan, y, z);
        break;
      case 1:
        b.add(x, -inf, z);
        break;
      case 2:
        b.add(0.0f, 0.0f, 0.0f);
        break;
      case 3:
        b.add(0.05f * x, 0.05f * y, 0.05f * z);
        break;  // within the minimum range
      case 4:
        b.add(1e30f * x, y, z);
        break;  // absurd: cut at the range
      case 5:
        b.add(3e38f, -3e38f, 1.0f);
        break;  // the largest floats: cut
      case 6: {
        // A point whose first world coordinate is an integer in voxel units: on a face.
        using RowMajor3d = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
        const Eigen::Matrix3d M = Eigen::Map<const RowMajor3d>(k.m.data());
        Eigen::Vector3d w(std::floor(k.o[0]) + cell(rng), k.o[1] + y, k.o[2] + z);
        const Eigen::Vector3d p = M.inverse() * (w - Eigen::Vector3d(k.o[0], k.o[1], k.o[2]));
        b.add(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
        break;
      }
      default:
        b.add(x, y, z);
        break;  // within and beyond the range
    }
  }
  return b;
}

std::uint32_t bitsOf(float f) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &f, sizeof bits);
  return bits;
}

void expectSameBits(const std::vector<std::uint32_t>& keys_a, const std::vector<float>& coords_a,
                    const std::vector<std::uint32_t>& keys_b, const std::vector<float>& coords_b,
                    const Block& block, const char* what) {
  ASSERT_EQ(keys_a.size(), keys_b.size());
  for (std::size_t i = 0; i < keys_a.size(); ++i) {
    ASSERT_EQ(keys_a[i], keys_b[i]) << what << ": point " << i << " (" << block.xs[i] << ", "
                                    << block.ys[i] << ", " << block.zs[i] << ")";
    bool same = true;
    for (std::size_t j = 4 * i; j < 4 * i + 4; ++j) {
      same = same && bitsOf(coords_a[j]) == bitsOf(coords_b[j]);
    }
    ASSERT_TRUE(same) << what << ": point " << i << " (" << block.xs[i] << ", " << block.ys[i]
                      << ", " << block.zs[i] << ") coordinates " << coords_a[4 * i] << " "
                      << coords_a[4 * i + 1] << " " << coords_a[4 * i + 2] << " against "
                      << coords_b[4 * i] << " " << coords_b[4 * i + 1] << " "
                      << coords_b[4 * i + 2];
  }
}

// Every implementation this machine runs gives, point for point, the reference's key and
// coordinates, bit for bit; in blocks of every length (the AVX2 kernel's 4-point groups and its
// tail), mixed kinds and blocks that are all within range (the portable kernel's fast branch).
TEST(PointKernel, EveryImplementationMatchesTheReferenceBitForBit) {
  std::vector<PointKernelIsa> isas = {PointKernelIsa::kPortable};
  if (pointKernelAvx2Supported()) isas.push_back(PointKernelIsa::kAvx2);
  std::mt19937 rng(42);
  std::size_t checked = 0;
  // Box voxel, cut box voxel, outside, too close, non-finite; and box voxels of points on a face.
  std::size_t kinds[5] = {0, 0, 0, 0, 0};
  std::size_t on_face = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const double resolution_m = trial % 2 == 0 ? 0.1 : 0.2;
    const PointKernel k = randomKernel(rng, resolution_m);
    const std::size_t n = static_cast<std::size_t>(trial % 37) + (trial % 3 == 0 ? 1000 : 0);
    Block block = randomBlock(rng, k, n);
    if (trial % 5 == 0) {  // all within range: no cut, no bad point
      for (std::size_t i = 0; i < n; ++i) {
        const float s = 0.4f;
        block.xs[i] = std::isfinite(block.xs[i]) ? std::fmod(block.xs[i], 2.0f) * s + 0.5f : 1.0f;
        block.ys[i] = std::isfinite(block.ys[i]) ? std::fmod(block.ys[i], 2.0f) * s : 0.0f;
        block.zs[i] = std::isfinite(block.zs[i]) ? std::fmod(block.zs[i], 2.0f) * s : 0.0f;
      }
    }
    std::vector<std::uint32_t> want_keys(n);
    std::vector<float> want_coords(4 * n);
    for (std::size_t i = 0; i < n; ++i) {
      referencePoint(k, block.xs[i], block.ys[i], block.zs[i], &want_keys[i], &want_coords[4 * i]);
      const std::uint32_t key = want_keys[i];
      ++kinds[key == kPointNonFiniteKey    ? 4
              : key == kPointTooCloseKey   ? 3
              : key >= kPointOutsideCutKey ? 2
              : (key & kPointCutFlag) != 0 ? 1
                                           : 0];
      const float x = want_coords[4 * i];
      if (key < kPointOutsideCutKey && std::abs(x - std::round(x)) < 1e-9f) ++on_face;
    }
    for (const PointKernelIsa isa : isas) {
      std::vector<std::uint32_t> keys(n, 0x12345678u);
      std::vector<float> coords(4 * n, -7.0f);
      classifyPoints(k, block.xs.data(), block.ys.data(), block.zs.data(), n, keys.data(),
                     coords.data(), isa);
      expectSameBits(keys, coords, want_keys, want_coords, block,
                     isa == PointKernelIsa::kAvx2 ? "AVX2" : "portable");
      if (HasFatalFailure()) return;
      checked += n;
    }
  }
  // The cases were all there.
  for (const std::size_t count : kinds) EXPECT_GT(count, 500u);
  EXPECT_GT(on_face, 500u);
  std::printf(
      "%zu points checked (%zu in box voxels, %zu cut there, %zu outside the box, %zu too "
      "close, %zu non-finite; %zu on a voxel face); AVX2 kernel %s\n",
      checked, kinds[0], kinds[1], kinds[2], kinds[3], kinds[4], on_face,
      pointKernelAvx2Supported() ? "checked" : "not run (this CPU has no AVX2)");
}

// Every implementation packs a row of millimetre depth pixels as the branchy reference does: the
// pixels with data (neither 0 nor 0xFFFF) in order, each z = raw * 0.001f, x = ray_x z,
// y = ray_y z, bit for bit; rows of every length (the AVX2 form's 8-pixel groups and its tail),
// dense, sparse (a RealSense's alternation), empty and random patterns, nothing written at or
// beyond the row's length.
TEST(PointKernel, DepthPixelPackingMatchesTheReferenceBitForBit) {
  std::vector<PointKernelIsa> isas = {PointKernelIsa::kPortable};
  if (pointKernelAvx2Supported()) isas.push_back(PointKernelIsa::kAvx2);
  std::mt19937 rng(7);
  std::size_t with_data = 0;
  std::size_t without = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const std::size_t count = static_cast<std::size_t>(trial % 67) + (trial % 4 == 0 ? 640 : 0);
    std::vector<std::uint16_t> raw(count);
    std::vector<float> ray_x(count);
    const int pattern = trial % 5;
    for (std::size_t k = 0; k < count; ++k) {
      std::uint16_t r = static_cast<std::uint16_t>(1 + rng() % 65534);  // data
      const unsigned pick = rng() % 8;
      if (pattern == 1) r = 0;                                    // empty
      if (pattern == 2 && k % 3 != 0) r = pick < 4 ? 0 : 0xFFFF;  // sparse
      if (pattern == 3 && pick < 3) r = pick == 0 ? 0xFFFF : 0;   // random holes
      if (pattern == 4 && pick < 2) r = pick == 0 ? 0 : 0xFFFF;   // mostly data
      raw[k] = r;
      ray_x[k] = std::uniform_real_distribution<float>(-0.8f, 0.8f)(rng);
    }
    const float ray_y = std::uniform_real_distribution<float>(-0.6f, 0.6f)(rng);
    std::vector<float> want_x, want_y, want_z;
    for (std::size_t k = 0; k < count; ++k) {
      if (raw[k] == 0 || raw[k] == 0xFFFF) {
        ++without;
        continue;
      }
      ++with_data;
      const float z = static_cast<float>(raw[k]) * 0.001f;
      want_x.push_back(ray_x[k] * z);
      want_y.push_back(ray_y * z);
      want_z.push_back(z);
    }
    for (const PointKernelIsa isa : isas) {
      const char* name = isa == PointKernelIsa::kAvx2 ? "AVX2" : "portable";
      // One guard value past the row: nothing may be written there.
      std::vector<float> xs(count + 1, -9.0f), ys(count + 1, -9.0f), zs(count + 1, -9.0f);
      const std::size_t n = packDepthPixelsMm(raw.data(), ray_x.data(), ray_y, count, xs.data(),
                                              ys.data(), zs.data(), isa);
      ASSERT_EQ(n, want_z.size()) << name << ", trial " << trial;
      // Bit for bit (a row without data leaves the expected vectors empty: nothing to compare).
      auto sameBits = [n](const std::vector<float>& got, const std::vector<float>& want) {
        return n == 0 || std::memcmp(got.data(), want.data(), n * sizeof(float)) == 0;
      };
      EXPECT_TRUE(sameBits(xs, want_x)) << name << ", trial " << trial;
      EXPECT_TRUE(sameBits(ys, want_y)) << name << ", trial " << trial;
      EXPECT_TRUE(sameBits(zs, want_z)) << name << ", trial " << trial;
      EXPECT_EQ(xs[count], -9.0f) << name << ", trial " << trial;
      EXPECT_EQ(ys[count], -9.0f) << name << ", trial " << trial;
      EXPECT_EQ(zs[count], -9.0f) << name << ", trial " << trial;
    }
  }
  EXPECT_GT(with_data, 10000u);
  EXPECT_GT(without, 10000u);
}

// Every implementation splits a block into the runs of equal keys and boxes them as a slow
// reference does (a run starts at point 0 and wherever the key changes; min and max of each
// coordinate over the run, compared as floats), bit for bit: blocks of every length (the AVX2
// form's 8-key groups and its tail), runs of one point (a LiDAR's scan, the AVX2 form's
// point-a-step path) and of 1-40 points (its 8-point steps, one or several a run), the same key
// again after a different one, the keys outside the box, and stale values in the padding.
TEST(PointKernel, RunGroupingMatchesTheReferenceBitForBit) {
  std::vector<PointKernelIsa> isas = {PointKernelIsa::kPortable};
  if (pointKernelAvx2Supported()) isas.push_back(PointKernelIsa::kAvx2);
  constexpr std::size_t kMaxPoints = 1024;
  std::mt19937 rng(11);
  std::size_t runs_checked = 0;
  std::size_t long_runs = 0;  // more than eight points
  std::size_t single_runs = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const std::size_t n = 1 + static_cast<std::size_t>(trial % 70) +
                          (trial % 3 == 0 ? kMaxPoints - 71 : 0);  // 1-70 or 954-1023 points
    const int max_run = trial % 4 == 0 ? 1 : trial % 4 == 1 ? 3 : 40;
    const std::uint32_t specials[4] = {kPointOutsideCutKey, kPointOutsideHitKey, kPointTooCloseKey,
                                       kPointNonFiniteKey};
    // Padding with values a run must never take in.
    std::vector<std::uint32_t> keys(n + PointRuns::kPadding, 0xDEADBEEFu);
    std::vector<float> coords(4 * (n + PointRuns::kPadding), -1e30f);
    for (std::size_t i = 0; i < n;) {
      const int pick = std::uniform_int_distribution<int>(0, 9)(rng);
      // A new key, one of a few (so a key comes back after others), or outside the box.
      const std::uint32_t key =
          pick < 6   ? std::uniform_int_distribution<std::uint32_t>(0, 1u << 30)(rng)
          : pick < 9 ? static_cast<std::uint32_t>(pick)
                     : specials[std::uniform_int_distribution<int>(0, 3)(rng)];
      const std::size_t len = std::min<std::size_t>(
          n - i, static_cast<std::size_t>(std::uniform_int_distribution<int>(1, max_run)(rng)));
      for (std::size_t j = 0; j < len; ++j, ++i) {
        keys[i] = key;
        for (int a = 0; a < 3; ++a) {
          coords[4 * i + a] = std::uniform_real_distribution<float>(-300.0f, 300.0f)(rng);
        }
        coords[4 * i + 3] = 0.0f;
      }
    }
    // The reference: runs as maximal stretches of one key, boxes by comparison.
    std::vector<std::uint32_t> want_first;
    for (std::size_t i = 0; i < n; ++i) {
      if (i == 0 || keys[i] != keys[i - 1]) want_first.push_back(static_cast<std::uint32_t>(i));
    }
    want_first.push_back(static_cast<std::uint32_t>(n));
    std::vector<float> want_box(8 * (want_first.size() - 1));
    for (std::size_t r = 0; r + 1 < want_first.size(); ++r) {
      float* box = &want_box[8 * r];
      for (int a = 0; a < 4; ++a) box[a] = box[4 + a] = coords[4 * want_first[r] + a];
      for (std::size_t i = want_first[r] + 1; i < want_first[r + 1]; ++i) {
        for (int a = 0; a < 4; ++a) {
          if (coords[4 * i + a] < box[a]) box[a] = coords[4 * i + a];
          if (coords[4 * i + a] > box[4 + a]) box[4 + a] = coords[4 * i + a];
        }
      }
    }
    for (std::size_t r = 0; r + 1 < want_first.size(); ++r) {
      const std::uint32_t len = want_first[r + 1] - want_first[r];
      long_runs += len > 8 ? 1 : 0;
      single_runs += len == 1 ? 1 : 0;
    }
    for (const PointKernelIsa isa : isas) {
      const char* name = isa == PointKernelIsa::kAvx2 ? "AVX2" : "portable";
      PointRuns runs(kMaxPoints);
      groupPointRuns(keys.data(), coords.data(), n, &runs, isa);
      ASSERT_EQ(runs.count + 1, want_first.size()) << name << ", trial " << trial;
      EXPECT_EQ(std::memcmp(runs.first.data(), want_first.data(),
                            want_first.size() * sizeof(std::uint32_t)),
                0)
          << name << ", trial " << trial;
      EXPECT_EQ(std::memcmp(runs.box.data(), want_box.data(), want_box.size() * sizeof(float)), 0)
          << name << ", trial " << trial;
      if (HasFailure()) return;
      runs_checked += runs.count;
    }
  }
  EXPECT_GT(long_runs, 1000u);
  EXPECT_GT(single_runs, 10000u);
  std::printf("%zu runs checked (%zu of one point, %zu of more than eight); AVX2 form %s\n",
              runs_checked, single_runs, long_runs,
              pointKernelAvx2Supported() ? "checked" : "not run (this CPU has no AVX2)");
}

}  // namespace
}  // namespace mlmap
