#include "mlmap/planning/map_snapshot.h"
#include "../support/random_draws.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace mlmap {
namespace {

std::shared_ptr<const LocalWindow> sparseWindow(std::mt19937& rng, double res) {
  auto w = std::make_shared<LocalWindow>();
  w->min_index = VoxelIndex(-10, -6, -4);
  w->size = Eigen::Vector3i(20, 14, 9);
  w->resolution_m = res;
  std::uniform_int_distribution<int> kind(0, 99);
  for (int i = 0; i < w->size.prod(); ++i) {
    const int k = kind(rng);
    w->log_odds.push_back(k < 4    ? quantizeLogOdds(2.0)     // occupied
                          : k < 12 ? kUnknownLogOdds          // unknown
                                   : quantizeLogOdds(-1.0));  // free
  }
  return w;
}

bool blocks(const LocalWindow& w, const VoxelIndex& g, UnknownAs unknown) {
  const Occupancy s = w.state(g);
  return s == Occupancy::kOccupied || (s == Occupancy::kUnknown && unknown == UnknownAs::kOccupied);
}

// Does the segment a-b (voxel units) pass through the open interior of voxel g? Slab test.
bool segmentCrossesVoxel(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const VoxelIndex& g) {
  double t0 = 0.0;
  double t1 = 1.0;
  for (int k = 0; k < 3; ++k) {
    const double d = b[k] - a[k];
    const double lo = g[k];
    const double hi = g[k] + 1.0;
    if (d == 0.0) {
      if (!(a[k] > lo && a[k] < hi)) return false;
      continue;
    }
    double ta = (lo - a[k]) / d;
    double tb = (hi - a[k]) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 < t1;
}

bool bruteSegmentFree(const LocalWindow& w, const Eigen::Vector3d& a_W, const Eigen::Vector3d& b_W,
                      UnknownAs unknown) {
  const Eigen::Vector3d a = a_W / w.resolution_m;
  const Eigen::Vector3d b = b_W / w.resolution_m;
  const Eigen::Vector3d lo = a.cwiseMin(b).array().floor();
  const Eigen::Vector3d hi = a.cwiseMax(b).array().floor();
  for (int x = static_cast<int>(lo.x()); x <= static_cast<int>(hi.x()); ++x) {
    for (int y = static_cast<int>(lo.y()); y <= static_cast<int>(hi.y()); ++y) {
      for (int z = static_cast<int>(lo.z()); z <= static_cast<int>(hi.z()); ++z) {
        const VoxelIndex g(x, y, z);
        if (segmentCrossesVoxel(a, b, g) && blocks(w, g, unknown)) return false;
      }
    }
  }
  return true;
}

bool bruteBoxFree(const LocalWindow& w, const Eigen::Vector3d& min_W, const Eigen::Vector3d& max_W,
                  UnknownAs unknown) {
  // A voxel overlaps the box when its interval overlaps the box's on every axis: list the
  // overlapping indices of each axis over the whole test range, then visit their product.
  const double r = w.resolution_m;
  std::vector<int> overlapping[3];
  for (int axis = 0; axis < 3; ++axis) {
    for (int i = -40; i < 40; ++i) {
      if (i * r < max_W[axis] && (i + 1) * r > min_W[axis]) overlapping[axis].push_back(i);
    }
  }
  for (const int x : overlapping[0]) {
    for (const int y : overlapping[1]) {
      for (const int z : overlapping[2]) {
        if (blocks(w, VoxelIndex(x, y, z), unknown)) return false;
      }
    }
  }
  return true;
}

TEST(MapSnapshot, SegmentChecksMatchBruteForce) {
  std::mt19937 rng(11);
  const double res = 0.2;
  const auto window = sparseWindow(rng, res);
  const MapSnapshot snap(window, nullptr, nullptr, 1, 0.0, Transform::Identity());
  std::uniform_real_distribution<double> x(-2.4, 2.4);  // reaches beyond the window
  std::uniform_real_distribution<double> y(-1.5, 1.9);
  std::uniform_real_distribution<double> z(-1.0, 1.2);
  std::uniform_real_distribution<double> len(0.0, 1.0);
  int free_count[2] = {0, 0};
  for (int i = 0; i < 4000; ++i) {
    const Eigen::Vector3d a = test::draw3(x, y, z, rng);
    // Short and long segments, some axis-aligned.
    Eigen::Vector3d b = test::draw3(x, y, z, rng);
    const double stretch = len(rng);
    b = a + (b - a) * stretch * len(rng);
    if (i % 10 == 0) b.y() = a.y();
    if (i % 20 == 0) b.z() = a.z();
    for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
      const bool expected = bruteSegmentFree(*window, a, b, policy);
      ASSERT_EQ(snap.isSegmentFree(a, b, policy), expected)
          << "segment " << a.transpose() << " -> " << b.transpose();
      free_count[policy == UnknownAs::kFree] += expected;
    }
  }
  EXPECT_GT(free_count[0], 200);  // both outcomes are well represented
  EXPECT_LT(free_count[1], 3800);
  EXPECT_GT(free_count[1], free_count[0]);
  EXPECT_FALSE(snap.isSegmentFree(Eigen::Vector3d(NAN, 0, 0), Eigen::Vector3d::Zero()));
}

TEST(MapSnapshot, BoxChecksMatchBruteForce) {
  std::mt19937 rng(12);
  const double res = 0.2;
  const auto window = sparseWindow(rng, res);
  const MapSnapshot snap(window, nullptr, nullptr, 1, 0.0, Transform::Identity());
  std::uniform_real_distribution<double> c(-2.2, 2.2);
  std::uniform_real_distribution<double> half(0.01, 0.35);
  int free_count = 0;
  for (int i = 0; i < 1500; ++i) {
    const Eigen::Vector3d centre = test::draw3(c, rng).cwiseProduct(Eigen::Vector3d(1.0, 0.6, 0.4));
    const Eigen::Vector3d h = test::draw3(half, rng);
    for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
      const bool expected = bruteBoxFree(*window, centre - h, centre + h, policy);
      ASSERT_EQ(snap.isBoxFree(centre - h, centre + h, policy), expected)
          << "box " << (centre - h).transpose() << " .. " << (centre + h).transpose();
      free_count += expected;
    }
  }
  EXPECT_GT(free_count, 100);
  EXPECT_LT(free_count, 2900);
  EXPECT_FALSE(snap.isBoxFree(Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 1)));  // min > max
}

TEST(MapSnapshot, StateAndProbabilityFollowTheWindow) {
  std::mt19937 rng(13);
  const auto window = sparseWindow(rng, 0.1);
  const MapSnapshot snap(window, nullptr, nullptr, 7, 1.5, Transform::Identity());
  int seen[3] = {0, 0, 0};
  for (int x = -11; x <= 10; ++x) {
    for (int y = -7; y <= 8; ++y) {
      for (int z = -5; z <= 5; ++z) {
        const VoxelIndex g(x, y, z);
        const Eigen::Vector3d p = voxelCenter(g, 0.1);
        const Occupancy s = snap.state(p);
        ASSERT_EQ(s, window->state(g));
        ++seen[static_cast<int>(s)];
        double prob = -1.0;
        ASSERT_EQ(snap.probability(p, &prob), s != Occupancy::kUnknown);
        if (s == Occupancy::kOccupied) {
          EXPECT_GT(prob, 0.5);
        }
        if (s == Occupancy::kFree) {
          EXPECT_LE(prob, 0.5);
        }
      }
    }
  }
  EXPECT_GT(seen[0], 0);
  EXPECT_GT(seen[1], 0);
  EXPECT_GT(seen[2], 0);
  EXPECT_EQ(snap.frame(), 7u);
  EXPECT_TRUE(snap.windowMin_W().isApprox(Eigen::Vector3d(-1.0, -0.6, -0.4)));
  EXPECT_TRUE(snap.windowMax_W().isApprox(Eigen::Vector3d(1.0, 0.8, 0.5)));
  EXPECT_FALSE(snap.distance(Eigen::Vector3d::Zero()).valid);  // no ESDF in this snapshot
}

}  // namespace
}  // namespace mlmap
