#include "mlmap/sim/world.h"
#include "../support/random_draws.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace mlmap::sim {
namespace {

using Eigen::Vector3d;

constexpr double kStep_m = 1e-3;  // brute-force marching step

/// Brute-force reference: first k * kStep_m (k >= 1, <= t_max) where the ray point is occupied.
bool marchReference(const World& world, const Vector3d& o, const Vector3d& d, double t_max,
                    double time_s, double* t_ref) {
  const int steps = static_cast<int>(std::floor(t_max / kStep_m));
  for (int k = 1; k <= steps; ++k) {
    const double t = k * kStep_m;
    if (world.isOccupiedAt(o + t * d, time_s)) {
      *t_ref = t;
      return true;
    }
  }
  return false;
}

struct RayStats {
  int rays = 0;
  int hits = 0;
  int grazes = 0;  // analytic hit that the 1 mm march stepped over
};

/// Random rays from free points near `aabb` aimed at random points of the (expanded) box;
/// compares World::raycast against marching.
RayStats compareWithBruteForce(const World& world, const Eigen::AlignedBox3d& aabb, int num_rays,
                               double t_max, double time_s, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Vector3d margin = Vector3d::Constant(3.0);
  const Vector3d lo = aabb.min() - margin;
  const Vector3d hi = aabb.max() + margin;
  auto sample = [&](const Vector3d& a, const Vector3d& b) {
    return Vector3d(a + test::draw3(unit, rng).cwiseProduct(b - a));
  };
  RayStats stats;
  while (stats.rays < num_rays) {
    const Vector3d o = sample(lo, hi);
    if (world.isOccupiedAt(o, time_s)) continue;
    const Vector3d target =
        sample(aabb.min() - Vector3d::Constant(0.3), aabb.max() + Vector3d::Constant(0.3));
    if ((target - o).norm() < 1e-3) continue;
    const Vector3d d = (target - o).normalized();
    ++stats.rays;
    double t_ref = 0.0;
    double t_hit = -1.0;
    const bool ref = marchReference(world, o, d, t_max, time_s, &t_ref);
    const bool hit = world.raycast(o, d, t_max, time_s, &t_hit);
    if (ref) {
      ++stats.hits;
      EXPECT_TRUE(hit) << "ray " << stats.rays << " missed, march hit at " << t_ref;
      if (hit) {
        EXPECT_GE(t_hit, t_ref - kStep_m - 1e-9) << "ray " << stats.rays;
        EXPECT_LE(t_hit, t_ref + 1e-9) << "ray " << stats.rays;
      }
    } else if (hit) {
      ++stats.grazes;
    }
    if (hit) {
      EXPECT_GT(t_hit, 0.0);
      EXPECT_LE(t_hit, t_max);
      // The point just before the hit is free (origin is outside every solid) ...
      EXPECT_FALSE(world.isOccupiedAt(o + (t_hit - 1e-7) * d, time_s)) << "ray " << stats.rays;
      // ... and the hit point lies on a surface (static or the moving box).
      const Vector3d p = o + t_hit * d;
      bool on_surface = world.distance(p) < 1e-9;
      for (const MovingBox& m : world.movingBoxes()) {
        if (!m.isActiveAt(time_s)) continue;
        const Vector3d half = 0.5 * m.size_m;
        const Vector3d c = m.centerAt(time_s);
        on_surface = on_surface || ((p - c).cwiseAbs() - half).maxCoeff() < 1e-9;
      }
      EXPECT_TRUE(on_surface) << "ray " << stats.rays;
    }
  }
  return stats;
}

Eigen::AlignedBox3d boxOf(const Vector3d& lo, const Vector3d& hi) {
  return Eigen::AlignedBox3d(lo, hi);
}

TEST(WorldRaycast, BoxMatchesBruteForce) {
  World world;
  ASSERT_TRUE(world.addBox({Vector3d(1.0, -0.5, 0.2), Vector3d(2.5, 0.7, 1.1)}));
  const RayStats s = compareWithBruteForce(
      world, boxOf(Vector3d(1.0, -0.5, 0.2), Vector3d(2.5, 0.7, 1.1)), 400, 10.0, 0.0, 11);
  EXPECT_GT(s.hits, s.rays / 3);
  EXPECT_LE(s.grazes, s.rays / 100);
}

TEST(WorldRaycast, CylinderMatchesBruteForce) {
  World world;
  ASSERT_TRUE(world.addCylinder({Eigen::Vector2d(0.5, -1.0), 0.4, 0.0, 2.0}));
  const RayStats s = compareWithBruteForce(
      world, boxOf(Vector3d(0.1, -1.4, 0.0), Vector3d(0.9, -0.6, 2.0)), 400, 10.0, 0.0, 12);
  EXPECT_GT(s.hits, s.rays / 3);
  EXPECT_LE(s.grazes, s.rays / 100);
}

TEST(WorldRaycast, ThinPoleMatchesBruteForce) {
  World world;
  ASSERT_TRUE(world.addCylinder({Eigen::Vector2d(0.0, 0.0), 0.05, 0.0, 3.0}));
  const RayStats s = compareWithBruteForce(
      world, boxOf(Vector3d(-0.05, -0.05, 0.0), Vector3d(0.05, 0.05, 3.0)), 400, 10.0, 0.0, 13);
  EXPECT_GT(s.hits, s.rays / 10);
  EXPECT_LE(s.grazes, s.rays / 50);
}

TEST(WorldRaycast, SphereMatchesBruteForce) {
  World world;
  ASSERT_TRUE(world.addSphere({Vector3d(-1.0, 2.0, 1.5), 0.7}));
  const RayStats s = compareWithBruteForce(
      world, boxOf(Vector3d(-1.7, 1.3, 0.8), Vector3d(-0.3, 2.7, 2.2)), 400, 10.0, 0.0, 14);
  EXPECT_GT(s.hits, s.rays / 3);
  EXPECT_LE(s.grazes, s.rays / 100);
}

TEST(WorldRaycast, MovingBoxMatchesBruteForce) {
  World world;
  ASSERT_TRUE(world.addMovingBox(
      {Vector3d(0.5, 0.5, 1.8), Vector3d(0.0, 0.0, 0.9), Vector3d(1.0, 0.5, 0.0), 2.0, 6.0}));
  const double time_s = 4.0;  // centre (2, 1, 0.9)
  const RayStats s = compareWithBruteForce(
      world, boxOf(Vector3d(1.75, 0.75, 0.0), Vector3d(2.25, 1.25, 1.8)), 300, 10.0, time_s, 15);
  EXPECT_GT(s.hits, s.rays / 3);
  EXPECT_LE(s.grazes, s.rays / 100);
}

TEST(WorldRaycast, DefaultRoomMatchesBruteForce) {
  const World world = World::defaultRoom();
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> ux(0.3, 29.7);
  std::uniform_real_distribution<double> uy(0.3, 19.7);
  std::uniform_real_distribution<double> uz(0.1, 3.9);
  std::normal_distribution<double> n(0.0, 1.0);
  int hits = 0;
  int grazes = 0;
  const int kRays = 150;
  const double time_s = 10.0;  // the person is in the room
  for (int i = 0; i < kRays;) {
    const Vector3d o = test::draw3(ux, uy, uz, rng);
    if (world.isOccupiedAt(o, time_s)) continue;
    const Vector3d d = test::draw3(n, rng).cwiseProduct(Vector3d(1.0, 1.0, 0.3)).normalized();
    ++i;
    double t_ref = 0.0;
    double t_hit = 0.0;
    const bool ref = marchReference(world, o, d, 15.0, time_s, &t_ref);
    const bool hit = world.raycast(o, d, 15.0, time_s, &t_hit);
    if (ref) {
      ++hits;
      ASSERT_TRUE(hit) << "ray " << i;
      EXPECT_NEAR(t_hit, t_ref - 0.5 * kStep_m, 0.5 * kStep_m + 1e-9) << "ray " << i;
    } else if (hit) {
      ++grazes;
    }
  }
  EXPECT_GT(hits, kRays / 2);
  EXPECT_LE(grazes, 2);
}

TEST(WorldRaycast, FromInsideReportsExit) {
  World world;
  ASSERT_TRUE(world.addBox({Vector3d(0, 0, 0), Vector3d(2, 2, 2)}));
  ASSERT_TRUE(world.addSphere({Vector3d(10, 0, 0), 1.0}));
  ASSERT_TRUE(world.addCylinder({Eigen::Vector2d(20, 0), 0.5, 0.0, 3.0}));
  double t = 0.0;
  ASSERT_TRUE(world.raycast(Vector3d(0.5, 1, 1), Vector3d::UnitX(), 10.0, 0.0, &t));
  EXPECT_DOUBLE_EQ(t, 1.5);
  ASSERT_TRUE(world.raycast(Vector3d(10.2, 0, 0), -Vector3d::UnitX(), 100.0, 0.0, &t));
  EXPECT_NEAR(t, 1.2, 1e-12);
  ASSERT_TRUE(world.raycast(Vector3d(20, 0.1, 1.0), Vector3d::UnitZ(), 10.0, 0.0, &t));
  EXPECT_NEAR(t, 2.0, 1e-12);  // leaves through the top cap
  ASSERT_TRUE(world.raycast(Vector3d(20, 0.0, 1.0), Vector3d::UnitY(), 10.0, 0.0, &t));
  EXPECT_NEAR(t, 0.5, 1e-12);  // leaves through the side
  // Origin on the surface: pointing out is a miss, pointing in reports the far side.
  EXPECT_FALSE(world.raycast(Vector3d(2, 1, 1), Vector3d::UnitX(), 0.5, 0.0, &t));
  ASSERT_TRUE(world.raycast(Vector3d(2, 1, 1), -Vector3d::UnitX(), 10.0, 0.0, &t));
  EXPECT_DOUBLE_EQ(t, 2.0);
}

TEST(WorldRaycast, BehindAndBeyondRangeMiss) {
  World world;
  ASSERT_TRUE(world.addBox({Vector3d(5, -1, -1), Vector3d(6, 1, 1)}));
  double t = 123.0;
  EXPECT_FALSE(world.raycast(Vector3d::Zero(), -Vector3d::UnitX(), 100.0, 0.0, &t));
  EXPECT_EQ(t, 123.0);  // untouched on a miss
  EXPECT_FALSE(world.raycast(Vector3d::Zero(), Vector3d::UnitX(), 4.999, 0.0, &t));
  ASSERT_TRUE(world.raycast(Vector3d::Zero(), Vector3d::UnitX(), 5.0, 0.0, &t));  // inclusive
  EXPECT_DOUBLE_EQ(t, 5.0);
  EXPECT_FALSE(world.raycast(Vector3d::Zero(), Vector3d::UnitX(), 0.0, 0.0, &t));
  EXPECT_FALSE(world.raycast(Vector3d::Zero(), Vector3d::UnitX(), -1.0, 0.0, &t));
  EXPECT_FALSE(world.raycast(Vector3d::Zero(), Vector3d::UnitX(), std::nan(""), 0.0, &t));
}

TEST(WorldRaycast, TangentAndParallelToFace) {
  World world;
  ASSERT_TRUE(world.addSphere({Vector3d(5, 0, 0), 1.0}));
  ASSERT_TRUE(world.addBox({Vector3d(12, -1, -1), Vector3d(14, 1, 1)}));
  double t = 0.0;
  // Tangent to the sphere: the touching point belongs to the closed solid.
  ASSERT_TRUE(world.raycast(Vector3d(0, 1, 0), Vector3d::UnitX(), 10.0, 0.0, &t));
  EXPECT_NEAR(t, 5.0, 1e-9);
  EXPECT_FALSE(world.raycast(Vector3d(0, 1 + 1e-9, 0), Vector3d::UnitX(), 10.0, 0.0, &t));
  ASSERT_TRUE(world.raycast(Vector3d(0, 1 - 1e-6, 0), Vector3d::UnitX(), 10.0, 0.0, &t));
  EXPECT_NEAR(t, 5.0 - std::sqrt(1.0 - (1 - 1e-6) * (1 - 1e-6)), 1e-9);
  // Along a box face (y = 1) and along an edge (y = 1, z = 1): hit where the face starts.
  ASSERT_TRUE(world.raycast(Vector3d(8, 1, 0.3), Vector3d::UnitX(), 10.0, 0.0, &t));
  EXPECT_DOUBLE_EQ(t, 4.0);
  ASSERT_TRUE(world.raycast(Vector3d(8, 1, 1), Vector3d::UnitX(), 10.0, 0.0, &t));
  EXPECT_DOUBLE_EQ(t, 4.0);
  EXPECT_FALSE(world.raycast(Vector3d(8, 1 + 1e-12, 0.3), Vector3d::UnitX(), 10.0, 0.0, &t));
  // Through a box corner exactly.
  const Vector3d corner(12, 1, 1);
  const Vector3d o(10, 3, 1.5);
  ASSERT_TRUE(world.raycast(o, (corner - o).normalized(), 10.0, 0.0, &t));
  EXPECT_NEAR(t, (corner - o).norm(), 1e-9);
}

TEST(WorldRaycast, CylinderCapsAndSide) {
  World world;
  ASSERT_TRUE(world.addCylinder({Eigen::Vector2d(0, 0), 1.0, 1.0, 2.0}));
  double t = 0.0;
  // Straight down onto the top cap, off-axis.
  ASSERT_TRUE(world.raycast(Vector3d(0.5, 0.5, 5), -Vector3d::UnitZ(), 10.0, 0.0, &t));
  EXPECT_DOUBLE_EQ(t, 3.0);
  // Vertical ray outside the disc misses.
  EXPECT_FALSE(world.raycast(Vector3d(0.8, 0.8, 5), -Vector3d::UnitZ(), 10.0, 0.0, &t));
  // Up into the bottom cap.
  ASSERT_TRUE(world.raycast(Vector3d(0, 0.9, -1), Vector3d::UnitZ(), 10.0, 0.0, &t));
  EXPECT_DOUBLE_EQ(t, 2.0);
  // Horizontal onto the side; above and below the cylinder miss.
  ASSERT_TRUE(world.raycast(Vector3d(-5, 0, 1.5), Vector3d::UnitX(), 10.0, 0.0, &t));
  EXPECT_NEAR(t, 4.0, 1e-12);
  EXPECT_FALSE(world.raycast(Vector3d(-5, 0, 2.01), Vector3d::UnitX(), 10.0, 0.0, &t));
  EXPECT_FALSE(world.raycast(Vector3d(-5, 0, 0.99), Vector3d::UnitX(), 10.0, 0.0, &t));
  // Oblique ray entering through the top cap: from (-3, 0, 4) towards (0, 0, 2) hits z = 2 at x =
  // 0.
  const Vector3d o(-3, 0, 4);
  const Vector3d d = (Vector3d(0, 0, 2) - o).normalized();
  ASSERT_TRUE(world.raycast(o, d, 10.0, 0.0, &t));
  EXPECT_NEAR(t, std::sqrt(13.0), 1e-12);
  // Oblique ray hitting the side: from (-3, 0, 0.5) towards (-1, 0, 1.5) at x = -1.
  const Vector3d o2(-3, 0, 0.5);
  const Vector3d d2 = (Vector3d(-1, 0, 1.5) - o2).normalized();
  ASSERT_TRUE(world.raycast(o2, d2, 10.0, 0.0, &t));
  EXPECT_NEAR(t, std::sqrt(5.0), 1e-12);
}

TEST(WorldRaycast, NearestOfSeveral) {
  World world;
  ASSERT_TRUE(world.addBox({Vector3d(8, -1, -1), Vector3d(9, 1, 1)}));
  ASSERT_TRUE(world.addSphere({Vector3d(6, 0, 0), 0.5}));
  ASSERT_TRUE(world.addCylinder({Eigen::Vector2d(4, 0), 0.25, -1, 1}));
  double t = 0.0;
  ASSERT_TRUE(world.raycast(Vector3d::Zero(), Vector3d::UnitX(), 20.0, 0.0, &t));
  EXPECT_NEAR(t, 3.75, 1e-12);
  ASSERT_TRUE(world.raycast(Vector3d(0, 0.3, 0), Vector3d::UnitX(), 20.0, 0.0, &t));
  EXPECT_NEAR(t, 6.0 - std::sqrt(0.25 - 0.09), 1e-12);
  ASSERT_TRUE(world.raycast(Vector3d(0, 0.6, 0), Vector3d::UnitX(), 20.0, 0.0, &t));
  EXPECT_DOUBLE_EQ(t, 8.0);
}

TEST(WorldRaycast, CandidatesGiveTheSameHits) {
  const World world = World::defaultRoom();
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> n(0.0, 1.0);
  RayCandidates candidates;
  int hits = 0;
  for (int bundle = 0; bundle < 60; ++bundle) {
    const Vector3d o =
        Vector3d(1.0, 1.0, 0.2) + test::draw3(unit, rng).cwiseProduct(Vector3d(28.0, 18.0, 3.5));
    const double time_s = 16.0 * unit(rng);
    // A random pyramid: an axis with two orthogonal spreads.
    const Vector3d axis = test::draw3(n, rng).cwiseProduct(Vector3d(1.0, 1.0, 0.3)).normalized();
    const Vector3d side = axis.unitOrthogonal();
    const Vector3d up = axis.cross(side);
    const double a = 0.02 + 0.3 * unit(rng);
    const double b = 0.02 + 0.3 * unit(rng);
    const Vector3d corners[4] = {
        (axis - a * side - b * up).normalized(), (axis + a * side - b * up).normalized(),
        (axis + a * side + b * up).normalized(), (axis - a * side + b * up).normalized()};
    const double t_max = 2.0 + 10.0 * unit(rng);
    world.gatherCandidates(o, corners, t_max, time_s, &candidates);
    EXPECT_LE(candidates.size(), world.boxes().size() + world.cylinders().size() +
                                     world.spheres().size() + world.movingBoxes().size());
    for (int r = 0; r < 50; ++r) {
      const double s1 = 2 * unit(rng) - 1;
      const double s2 = 2 * unit(rng) - 1;
      const Vector3d d = (axis + s1 * a * side + s2 * b * up).normalized();
      double t_all = -1.0;
      double t_sub = -2.0;
      const bool hit_all = world.raycast(o, d, t_max, time_s, &t_all);
      const bool hit_sub = world.raycast(candidates, d, t_max, &t_sub);
      ASSERT_EQ(hit_all, hit_sub) << "bundle " << bundle << " ray " << r;
      if (hit_all) {
        ++hits;
        EXPECT_EQ(t_all, t_sub);
      }
    }
  }
  EXPECT_GT(hits, 1000);
}

TEST(WorldMovingBox, PresentOnlyInItsTimeWindow) {
  World world;
  // 0.5 x 0.5 x 1.8 person walking +y along x = 5 from y = -2 at 1 m/s during t in [1, 5].
  ASSERT_TRUE(world.addMovingBox(
      {Vector3d(0.5, 0.5, 1.8), Vector3d(5, -2, 0.9), Vector3d(0, 1, 0), 1.0, 5.0}));
  const Vector3d o(0, 0, 1.0);
  double t = 0.0;
  EXPECT_FALSE(world.raycast(o, Vector3d::UnitX(), 20.0, 0.0, &t));
  EXPECT_FALSE(world.raycast(o, Vector3d::UnitX(), 20.0, 0.999, &t));
  EXPECT_FALSE(world.raycast(o, Vector3d::UnitX(), 20.0, 2.5, &t));  // at y = -0.5, not on ray
  ASSERT_TRUE(world.raycast(o, Vector3d::UnitX(), 20.0, 3.0, &t));   // centred on the ray
  EXPECT_DOUBLE_EQ(t, 4.75);
  ASSERT_TRUE(world.raycast(o, Vector3d::UnitX(), 20.0, 2.75, &t));  // edge y = 0 touches ray
  EXPECT_DOUBLE_EQ(t, 4.75);
  EXPECT_FALSE(world.raycast(o, Vector3d::UnitX(), 20.0, 5.5, &t));
  // Window is closed at both ends.
  World late;
  ASSERT_TRUE(
      late.addMovingBox({Vector3d(1, 1, 1), Vector3d(3, 0, 1), Vector3d(0, 0, 0), 2.0, 4.0}));
  EXPECT_TRUE(late.raycast(o, Vector3d::UnitX(), 20.0, 2.0, &t));
  EXPECT_TRUE(late.raycast(o, Vector3d::UnitX(), 20.0, 4.0, &t));
  EXPECT_FALSE(late.raycast(o, Vector3d::UnitX(), 20.0, 4.0001, &t));
  // Static queries ignore moving boxes; isOccupiedAt does not.
  EXPECT_FALSE(late.isOccupied(Vector3d(3, 0, 1)));
  EXPECT_TRUE(late.isOccupiedAt(Vector3d(3, 0, 1), 3.0));
  EXPECT_FALSE(late.isOccupiedAt(Vector3d(3, 0, 1), 1.0));
  EXPECT_FALSE(late.intersectsBox(Vector3d(2, -1, 0), Vector3d(4, 1, 2)));
  EXPECT_TRUE(late.bounds().isEmpty());
}

TEST(WorldQueries, IsOccupiedIsClosed) {
  World world;
  ASSERT_TRUE(world.addBox({Vector3d(0, 0, 0), Vector3d(1, 1, 1)}));
  ASSERT_TRUE(world.addSphere({Vector3d(5, 0, 0), 1.0}));
  ASSERT_TRUE(world.addCylinder({Eigen::Vector2d(10, 0), 1.0, 0.0, 2.0}));
  EXPECT_TRUE(world.isOccupied(Vector3d(1, 1, 1)));
  EXPECT_TRUE(world.isOccupied(Vector3d(0.5, 0.5, 0.5)));
  EXPECT_FALSE(world.isOccupied(Vector3d(1.0001, 0.5, 0.5)));
  EXPECT_TRUE(world.isOccupied(Vector3d(6, 0, 0)));
  EXPECT_FALSE(world.isOccupied(Vector3d(6.0001, 0, 0)));
  EXPECT_TRUE(world.isOccupied(Vector3d(11, 0, 2)));
  EXPECT_FALSE(world.isOccupied(Vector3d(11, 0, 2.0001)));
  EXPECT_FALSE(world.isOccupied(Vector3d(10.8, 0.8, 1)));
}

TEST(WorldQueries, DistanceMatchesHandComputedValues) {
  World world;
  EXPECT_TRUE(std::isinf(world.distance(Vector3d::Zero())));
  ASSERT_TRUE(world.addBox({Vector3d(0, 0, 0), Vector3d(1, 1, 1)}));
  EXPECT_DOUBLE_EQ(world.distance(Vector3d(0.5, 0.5, 0.5)), 0.0);
  EXPECT_DOUBLE_EQ(world.distance(Vector3d(2, 0.5, 0.5)), 1.0);
  EXPECT_DOUBLE_EQ(world.distance(Vector3d(2, 2, 0.5)), std::sqrt(2.0));
  World round;
  ASSERT_TRUE(round.addCylinder({Eigen::Vector2d(0, 0), 1.0, 0.0, 2.0}));
  ASSERT_TRUE(round.addSphere({Vector3d(10, 0, 0), 1.0}));
  EXPECT_DOUBLE_EQ(round.distance(Vector3d(3, 0, 1)), 2.0);
  EXPECT_DOUBLE_EQ(round.distance(Vector3d(0.2, 0, 5)), 3.0);
  EXPECT_DOUBLE_EQ(round.distance(Vector3d(4, 0, 6)), 5.0);  // (3, 4) from the rim
  EXPECT_DOUBLE_EQ(round.distance(Vector3d(10, 3, 0)), 2.0);
}

/// intersectsBox against dense sampling of the query box, for random query boxes near `aabb`.
void checkIntersectsBox(const World& world, const Eigen::AlignedBox3d& aabb, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int kGrid = 12;
  int positives = 0;
  int negatives = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Vector3d lo;
    Vector3d size;
    for (int i = 0; i < 3; ++i) {
      size[i] = 0.05 + 0.5 * unit(rng);
      lo[i] = aabb.min()[i] - 0.7 + unit(rng) * (aabb.sizes()[i] + 1.4);
    }
    const Vector3d hi = lo + size;
    bool sampled = false;
    double min_distance = 1e9;
    for (int a = 0; a <= kGrid && !sampled; ++a) {
      for (int b = 0; b <= kGrid && !sampled; ++b) {
        for (int c = 0; c <= kGrid && !sampled; ++c) {
          const Vector3d p = lo + Vector3d(a, b, c).cwiseProduct(size) / kGrid;
          sampled = world.isOccupied(p);
          min_distance = std::min(min_distance, world.distance(p));
        }
      }
    }
    const bool exact = world.intersectsBox(lo, hi, 0.0);
    if (sampled) {
      EXPECT_TRUE(exact) << "trial " << trial;
    }
    if (exact && !sampled) {
      // A thin overlap between samples: some sample is within half a cell diagonal of a solid.
      EXPECT_LE(min_distance, 0.5 * (size / kGrid).norm() + 1e-12) << "trial " << trial;
    }
    (exact ? positives : negatives)++;
    // Tolerance grows the answer monotonically.
    if (exact) {
      EXPECT_TRUE(world.intersectsBox(lo, hi, 0.1));
    }
  }
  EXPECT_GT(positives, 30);
  EXPECT_GT(negatives, 30);
}

TEST(WorldQueries, IntersectsBoxMatchesSamplingForBox) {
  World world;
  ASSERT_TRUE(world.addBox({Vector3d(0, 0, 0), Vector3d(1, 0.5, 2)}));
  checkIntersectsBox(world, boxOf(Vector3d(0, 0, 0), Vector3d(1, 0.5, 2)), 31);
}

TEST(WorldQueries, IntersectsBoxMatchesSamplingForCylinder) {
  World world;
  ASSERT_TRUE(world.addCylinder({Eigen::Vector2d(0, 0), 0.6, 0.0, 1.5}));
  checkIntersectsBox(world, boxOf(Vector3d(-0.6, -0.6, 0), Vector3d(0.6, 0.6, 1.5)), 32);
}

TEST(WorldQueries, IntersectsBoxMatchesSamplingForSphere) {
  World world;
  ASSERT_TRUE(world.addSphere({Vector3d(0, 0, 1), 0.8}));
  checkIntersectsBox(world, boxOf(Vector3d(-0.8, -0.8, 0.2), Vector3d(0.8, 0.8, 1.8)), 33);
}

TEST(WorldQueries, IntersectsBoxToleranceIsEuclidean) {
  World world;
  ASSERT_TRUE(world.addBox({Vector3d(0, 0, 0), Vector3d(1, 1, 1)}));
  // Face gap 0.1.
  EXPECT_FALSE(world.intersectsBox(Vector3d(1.1, 0, 0), Vector3d(2, 1, 1), 0.09));
  EXPECT_TRUE(world.intersectsBox(Vector3d(1.1, 0, 0), Vector3d(2, 1, 1), 0.11));
  // Edge gap (0.1, 0.1): Euclidean 0.1414.
  EXPECT_FALSE(world.intersectsBox(Vector3d(1.1, 1.1, 0), Vector3d(2, 2, 1), 0.14));
  EXPECT_TRUE(world.intersectsBox(Vector3d(1.1, 1.1, 0), Vector3d(2, 2, 1), 0.15));
  // Touching counts with zero tolerance; the default tolerance absorbs round-off.
  EXPECT_TRUE(world.intersectsBox(Vector3d(1, 0, 0), Vector3d(2, 1, 1), 0.0));
  EXPECT_TRUE(world.intersectsBox(Vector3d(1 + 1e-9, 0, 0), Vector3d(2, 1, 1)));

  World round;
  ASSERT_TRUE(round.addSphere({Vector3d(0, 0, 0), 1.0}));
  ASSERT_TRUE(round.addCylinder({Eigen::Vector2d(10, 0), 1.0, 0.0, 1.0}));
  // Voxel whose nearest corner (0.8, 0.8, 0) is 1.1314 from the sphere centre.
  EXPECT_FALSE(round.intersectsBox(Vector3d(0.8, 0.8, 0), Vector3d(1, 1, 0.2), 0.13));
  EXPECT_TRUE(round.intersectsBox(Vector3d(0.8, 0.8, 0), Vector3d(1, 1, 0.2), 0.14));
  // Above the cylinder rim by 0.3 and outside radially by 0.4: gap 0.5.
  EXPECT_FALSE(round.intersectsBox(Vector3d(11.4, -0.1, 1.3), Vector3d(11.6, 0.1, 1.5), 0.49));
  EXPECT_TRUE(round.intersectsBox(Vector3d(11.4, -0.1, 1.3), Vector3d(11.6, 0.1, 1.5), 0.51));
}

TEST(WorldPrimitives, RejectsInvalidPrimitives) {
  World world;
  EXPECT_FALSE(world.addBox({Vector3d(1, 0, 0), Vector3d(0, 1, 1)}));
  EXPECT_FALSE(world.addBox({Vector3d(0, 0, 0), Vector3d(std::nan(""), 1, 1)}));
  EXPECT_FALSE(world.addCylinder({Eigen::Vector2d(0, 0), -0.1, 0, 1}));
  EXPECT_FALSE(world.addCylinder({Eigen::Vector2d(0, 0), 0.1, 2, 1}));
  EXPECT_FALSE(world.addSphere({Vector3d(0, 0, 0), 0.0}));
  EXPECT_FALSE(world.addMovingBox({Vector3d(0, 1, 1), Vector3d::Zero(), Vector3d::Zero(), 0, 1}));
  EXPECT_FALSE(world.addMovingBox({Vector3d(1, 1, 1), Vector3d::Zero(), Vector3d::Zero(), 2, 1}));
  EXPECT_TRUE(world.boxes().empty());
  EXPECT_TRUE(world.cylinders().empty());
  EXPECT_TRUE(world.spheres().empty());
  EXPECT_TRUE(world.movingBoxes().empty());
  EXPECT_TRUE(world.bounds().isEmpty());
  double t = 0.0;
  EXPECT_FALSE(world.raycast(Vector3d::Zero(), Vector3d::UnitX(), 100.0, 0.0, &t));
  // A degenerate (flat) box is allowed.
  EXPECT_TRUE(world.addBox({Vector3d(0, 0, 0), Vector3d(1, 1, 0)}));
}

TEST(WorldDefaultRoom, LayoutAsDocumented) {
  const World world = World::defaultRoom();
  EXPECT_GE(world.boxes().size(), 10u + 6u);
  EXPECT_GE(world.cylinders().size(), 6u);
  EXPECT_GE(world.spheres().size(), 3u);
  ASSERT_EQ(world.movingBoxes().size(), 1u);
  EXPECT_TRUE(world.movingBoxes()[0].size_m.isApprox(Vector3d(0.5, 0.5, 1.8)));
  const Eigen::AlignedBox3d b = world.bounds();
  EXPECT_TRUE(b.min().isApprox(Vector3d(0, 0, -0.2)));
  EXPECT_TRUE(b.max().isApprox(Vector3d(30, 20, 4)));
  // Floor top at z = 0, no ceiling: straight up from inside the room is free.
  double t = 0.0;
  ASSERT_TRUE(world.raycast(Vector3d(5, 5, 1), -Vector3d::UnitZ(), 10.0, 0.0, &t));
  EXPECT_DOUBLE_EQ(t, 1.0);
  EXPECT_FALSE(world.raycast(Vector3d(5, 5, 1), Vector3d::UnitZ(), 100.0, 0.0, &t));
  // A thin pole exists.
  const bool has_pole = std::any_of(world.cylinders().begin(), world.cylinders().end(),
                                    [](const Cylinder& c) { return c.radius_m <= 0.05; });
  EXPECT_TRUE(has_pole);
  // Doorway gaps in the interior walls are free at flight height.
  EXPECT_FALSE(world.intersectsBox(Vector3d(9.5, 3.1, 0.1), Vector3d(10.5, 5.9, 3.9), 0.0));
  EXPECT_FALSE(world.intersectsBox(Vector3d(9.5, 14.1, 0.1), Vector3d(10.5, 16.9, 3.9), 0.0));
  EXPECT_FALSE(world.intersectsBox(Vector3d(23.6, 9.5, 0.1), Vector3d(26.4, 10.5, 3.9), 0.0));
  EXPECT_TRUE(world.isOccupied(Vector3d(10, 10, 1)));
}

}  // namespace
}  // namespace mlmap::sim
