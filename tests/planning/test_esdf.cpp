#include "mlmap/planning/esdf.h"
#include "mlmap/planning/esdf_query_grid.h"
#include "../support/random_draws.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

namespace mlmap {
namespace {

bool isObstacle(Occupancy s, UnknownAs unknown_as) {
  return s == Occupancy::kOccupied ||
         (s == Occupancy::kUnknown && unknown_as == UnknownAs::kOccupied);
}

/// The definition, literally: for every voxel the nearest voxel centre of the other kind over
/// all pairs of the box (double precision), signed, unclamped; +-infinity when there is none.
/// Costs (obstacle voxels) x (other voxels).
std::vector<double> bruteForceUnclamped(const OccupancyBox& box, UnknownAs unknown_as) {
  const std::size_t n = box.states.size();
  std::vector<Eigen::Vector3d> centre(n);
  std::vector<std::size_t> obstacles;
  std::vector<std::size_t> others;
  for (int x = 0; x < box.size.x(); ++x) {
    for (int y = 0; y < box.size.y(); ++y) {
      for (int z = 0; z < box.size.z(); ++z) {
        const VoxelIndex g = box.min_index + VoxelIndex(x, y, z);
        const std::size_t i = box.offsetOf(g);
        centre[i] = voxelCenter(g, box.resolution_m);
        (isObstacle(box.states[i], unknown_as) ? obstacles : others).push_back(i);
      }
    }
  }
  std::vector<double> out(n);
  const auto nearest = [&](const std::vector<std::size_t>& from, const std::vector<std::size_t>& to,
                           double sign) {
    for (const std::size_t i : from) {
      double best = std::numeric_limits<double>::infinity();
      for (const std::size_t j : to) best = std::min(best, (centre[i] - centre[j]).squaredNorm());
      out[i] = sign * std::sqrt(best);
    }
  };
  nearest(others, obstacles, 1.0);
  nearest(obstacles, others, -1.0);
  return out;
}

double clampTo(double d, double max_m) { return std::max(-max_m, std::min(max_m, d)); }

/// Compares every cell of `map` with the clamped reference: equal within float rounding, same sign.
void expectMatches(const EsdfMap& map, const OccupancyBox& box,
                   const std::vector<double>& unclamped, const std::string& what) {
  const double max_m = map.config().max_distance_m;
  int failures = 0;
  for (int x = 0; x < box.size.x(); ++x) {
    for (int y = 0; y < box.size.y(); ++y) {
      for (int z = 0; z < box.size.z(); ++z) {
        const VoxelIndex g = box.min_index + VoxelIndex(x, y, z);
        const double expected = clampTo(unclamped[box.offsetOf(g)], max_m);
        const double actual = map.distanceAt(g);
        const bool ok = std::abs(actual - expected) <= 1e-5 * std::abs(expected) &&
                        (actual < 0.0) == (expected < 0.0);
        if (!ok && ++failures <= 5) {
          ADD_FAILURE() << what << ": voxel (" << x << ", " << y << ", " << z << ") state "
                        << toString(box.states[box.offsetOf(g)]) << ": got " << actual
                        << ", expected " << expected;
        }
      }
    }
  }
  EXPECT_EQ(failures, 0) << what;
}

OccupancyBox randomBox(const VoxelIndex& min_index, const Eigen::Vector3i& size, double res,
                       double p_occupied, double p_unknown, std::mt19937* rng) {
  OccupancyBox box;
  box.reset(min_index, size, res, Occupancy::kFree);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (Occupancy& s : box.states) {
    const double r = u(*rng);
    s = r < p_occupied ? Occupancy::kOccupied
                       : (r < p_occupied + p_unknown ? Occupancy::kUnknown : Occupancy::kFree);
  }
  return box;
}

/// Fills the world-index box [lo, hi] (inclusive, clipped to the box) with `state`.
void fill(OccupancyBox* box, const VoxelIndex& lo, const VoxelIndex& hi, Occupancy state) {
  for (int x = lo.x(); x <= hi.x(); ++x) {
    for (int y = lo.y(); y <= hi.y(); ++y) {
      for (int z = lo.z(); z <= hi.z(); ++z) {
        if (box->contains({x, y, z})) box->at({x, y, z}) = state;
      }
    }
  }
}

EsdfConfig config(double max_m, UnknownAs unknown_as, int threads = 1) {
  EsdfConfig c;
  c.max_distance_m = max_m;
  c.unknown_as = unknown_as;
  c.num_threads = threads;
  return c;
}

// Random scenes of several densities and sizes (non-cubic; more y rows than one 32-row block of
// the x pass), negative and positive corners, both unknown policies, three clamps (one never
// reached), one and two threads, the windowed passes and the envelope code. One map per
// configuration is reused across the scenes.
TEST(Esdf, RandomScenesMatchBruteForce) {
  std::mt19937 rng(11);
  struct Shape {
    VoxelIndex min_index;
    Eigen::Vector3i size;
    double res;
  };
  const std::vector<Shape> shapes = {{{-7, 4, -12}, {17, 13, 9}, 0.2},
                                     {{3, -20, 5}, {9, 11, 37}, 0.37},
                                     {{-40, -1, 0}, {33, 5, 20}, 0.1},
                                     {{-2, -50, 3}, {6, 35, 7}, 0.3}};
  const std::vector<std::pair<double, double>> densities = {
      {0.01, 0.0}, {0.05, 0.2}, {0.2, 0.1}, {0.45, 0.0}, {0.7, 0.2}};
  struct Setup {
    UnknownAs policy;
    double max_m;
    int threads;
    bool envelope_only;  ///< setEnvelopeOnly() (the windowed passes otherwise, where they apply)
  };
  std::vector<Setup> setups;
  std::vector<EsdfMap> maps;
  for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
    for (const double max_m : {0.45, 2.0, 1000.0}) {
      for (const int threads : {1, 2}) {
        for (const bool envelope_only : {false, true}) {
          setups.push_back({policy, max_m, threads, envelope_only});
          maps.emplace_back(config(max_m, policy, threads));
          maps.back().setEnvelopeOnly(envelope_only);
        }
      }
    }
  }
  for (const Shape& shape : shapes) {
    for (const auto& [p_occ, p_unk] : densities) {
      const OccupancyBox box =
          randomBox(shape.min_index, shape.size, shape.res, p_occ, p_unk, &rng);
      for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
        const std::vector<double> reference = bruteForceUnclamped(box, policy);
        for (std::size_t i = 0; i < setups.size(); ++i) {
          if (setups[i].policy != policy) continue;
          ASSERT_TRUE(maps[i].compute(box));
          std::ostringstream what;
          what << "policy " << toString(policy) << ", max " << setups[i].max_m << " m, "
               << setups[i].threads << " threads, "
               << (setups[i].envelope_only ? "envelope code" : "windowed passes") << ", size "
               << shape.size.transpose() << ", occupied " << p_occ << ", unknown " << p_unk;
          expectMatches(maps[i], box, reference, what.str());
        }
      }
    }
  }
}

TEST(Esdf, StructuredScenesMatchBruteForce) {
  std::vector<std::pair<std::string, OccupancyBox>> scenes;
  const VoxelIndex lo(-9, -6, -4);
  const Eigen::Vector3i size(19, 14, 11);
  OccupancyBox box;
  box.reset(lo, size, 0.25, Occupancy::kFree);
  scenes.push_back({"empty", box});
  box.reset(lo, size, 0.25, Occupancy::kOccupied);
  scenes.push_back({"all occupied", box});
  box.reset(lo, size, 0.25, Occupancy::kUnknown);
  scenes.push_back({"all unknown", box});
  box.reset(lo, size, 0.25, Occupancy::kFree);
  box.at({0, 0, 0}) = Occupancy::kOccupied;
  scenes.push_back({"single occupied voxel", box});
  box.reset(lo, size, 0.25, Occupancy::kOccupied);
  box.at({1, -2, 3}) = Occupancy::kFree;
  scenes.push_back({"single free voxel", box});
  box.reset(lo, size, 0.25, Occupancy::kFree);
  fill(&box, {2, -100, -100}, {3, 100, 100}, Occupancy::kOccupied);
  scenes.push_back({"wall", box});
  box.reset(lo, size, 0.25, Occupancy::kFree);
  fill(&box, {-9, -6, -4}, {9, 7, -3}, Occupancy::kOccupied);         // floor
  fill(&box, {-6, -3, -2}, {-2, 1, 3}, Occupancy::kOccupied);         // a solid block on it
  fill(&box, {3, 2, 0}, {6, 5, 2}, Occupancy::kOccupied);             // a floating block
  fill(&box, {7, -100, -100}, {100, 100, 100}, Occupancy::kUnknown);  // unseen slab
  scenes.push_back({"boxes, floor and unknown slab", box});
  box.reset({5, 5, 5}, {1, 1, 40}, 0.2, Occupancy::kFree);
  box.at({5, 5, 20}) = Occupancy::kOccupied;
  scenes.push_back({"z line", box});
  box.reset({-30, 5, 5}, {40, 1, 1}, 0.2, Occupancy::kFree);
  box.at({-3, 5, 5}) = Occupancy::kOccupied;
  box.at({4, 5, 5}) = Occupancy::kUnknown;
  scenes.push_back({"x line", box});
  box.reset({5, -30, 5}, {1, 40, 1}, 0.2, Occupancy::kOccupied);
  box.at({5, -20, 5}) = Occupancy::kFree;
  scenes.push_back({"y line", box});
  box.reset({2, 2, 2}, {1, 1, 1}, 0.2, Occupancy::kFree);
  scenes.push_back({"one voxel", box});
  box.reset({-3, -4, -5}, {30, 25, 1}, 0.2, Occupancy::kFree);
  fill(&box, {5, -100, -100}, {5, 100, 100}, Occupancy::kOccupied);
  fill(&box, {-100, 8, -100}, {100, 8, 100}, Occupancy::kOccupied);
  scenes.push_back({"flat slab with two walls", box});

  for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
    for (const double max_m : {0.6, 1.5, 100.0}) {
      EsdfMap map(config(max_m, policy));
      for (const auto& [name, scene] : scenes) {
        ASSERT_TRUE(map.compute(scene)) << name;
        expectMatches(map, scene, bruteForceUnclamped(scene, policy),
                      name + " (" + toString(policy) + ", max " + std::to_string(max_m) + ")");
      }
    }
  }
}

TEST(Esdf, DefinitionCornerCases) {
  OccupancyBox box;
  box.reset({0, 0, 0}, {10, 8, 6}, 0.2, Occupancy::kFree);
  EsdfMap map(config(1.0, UnknownAs::kOccupied));
  ASSERT_TRUE(map.compute(box));
  EXPECT_FLOAT_EQ(map.distanceAt({3, 3, 3}), 1.0f);  // nothing to hit: +max
  box.at({3, 3, 3}) = Occupancy::kOccupied;
  ASSERT_TRUE(map.compute(box));
  EXPECT_FLOAT_EQ(map.distanceAt({3, 3, 3}), -0.2f);  // obstacle next to free space: -res
  EXPECT_FLOAT_EQ(map.distanceAt({4, 3, 3}), 0.2f);   // free next to it: +res
  EXPECT_FLOAT_EQ(map.distanceAt({4, 4, 4}), static_cast<float>(0.2 * std::sqrt(3.0)));
  EXPECT_FLOAT_EQ(map.distanceAt({9, 7, 5}), 1.0f);  // sqrt(36 + 16 + 4) * 0.2 = 1.497: clamped
  EXPECT_TRUE(std::isnan(map.distanceAt({10, 0, 0})));
  EXPECT_TRUE(std::isnan(map.distanceAt({-1, 0, 0})));
  // Unknown voxels are obstacles only under kOccupied.
  box.at({3, 3, 3}) = Occupancy::kUnknown;
  ASSERT_TRUE(map.compute(box));
  EXPECT_FLOAT_EQ(map.distanceAt({4, 3, 3}), 0.2f);
  EXPECT_TRUE(map.isUnknown({3, 3, 3}));
  EXPECT_FALSE(map.isUnknown({4, 3, 3}));
  EsdfMap optimistic(config(1.0, UnknownAs::kFree));
  ASSERT_TRUE(optimistic.compute(box));
  EXPECT_FLOAT_EQ(optimistic.distanceAt({4, 3, 3}), 1.0f);
}

// A larger box than brute force over all pairs allows: compared with a search of every voxel
// within 4 voxels, exact once clamped at 3.5 voxels; 38 y rows are two row blocks of the x pass.
TEST(Esdf, LargeRandomSceneMatchesWindowedReference) {
  std::mt19937 rng(3);
  const OccupancyBox box = randomBox({-20, 7, -3}, {45, 38, 35}, 0.2, 0.03, 0.02, &rng);
  const double max_m = 0.7;  // 3.5 voxels
  for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
    EsdfMap map(config(max_m, policy, policy == UnknownAs::kOccupied ? 1 : 2));
    ASSERT_TRUE(map.compute(box));
    std::vector<char> obstacle_at(box.states.size());
    for (std::size_t i = 0; i < box.states.size(); ++i) {
      obstacle_at[i] = isObstacle(box.states[i], policy) ? 1 : 0;
    }
    const auto at = [&](int x, int y, int z) {
      return obstacle_at[(static_cast<std::size_t>(x) * box.size.y() + y) * box.size.z() + z];
    };
    const int r = 4;
    int failures = 0;
    for (int x = 0; x < box.size.x(); ++x) {
      for (int y = 0; y < box.size.y(); ++y) {
        for (int z = 0; z < box.size.z(); ++z) {
          const VoxelIndex g = box.min_index + VoxelIndex(x, y, z);
          const bool obstacle = at(x, y, z) != 0;
          int best_sq = std::numeric_limits<int>::max();
          for (int ox = std::max(0, x - r); ox <= std::min(box.size.x() - 1, x + r); ++ox) {
            for (int oy = std::max(0, y - r); oy <= std::min(box.size.y() - 1, y + r); ++oy) {
              for (int oz = std::max(0, z - r); oz <= std::min(box.size.z() - 1, z + r); ++oz) {
                if ((at(ox, oy, oz) != 0) == obstacle) continue;
                const int sq = (ox - x) * (ox - x) + (oy - y) * (oy - y) + (oz - z) * (oz - z);
                best_sq = std::min(best_sq, sq);
              }
            }
          }
          const double best = best_sq == std::numeric_limits<int>::max()
                                  ? std::numeric_limits<double>::infinity()
                                  : std::sqrt(static_cast<double>(best_sq)) * box.resolution_m;
          const double expected = clampTo(obstacle ? -best : best, max_m);
          const double actual = map.distanceAt(g);
          const bool ok = std::abs(actual - expected) <= 1e-5 * std::abs(expected) &&
                          (actual < 0.0) == (expected < 0.0);
          if (!ok && ++failures <= 5) {
            ADD_FAILURE() << "voxel " << g.transpose() << ": got " << actual << ", expected "
                          << expected;
          }
        }
      }
    }
    EXPECT_EQ(failures, 0);
  }
}

// Lines so long and a clamp so far that the envelope needs 64-bit arithmetic and the metres
// table is not used; sparse obstacles keep the brute force cheap.
TEST(Esdf, LongLinesAndFarClampMatchBruteForce) {
  std::mt19937 rng(8);
  OccupancyBox box = randomBox({-3, 11, -700}, {2, 20, 900}, 0.1, 0.0008, 0.0004, &rng);
  for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
    for (const double max_m : {3.0, 1000.0}) {
      EsdfMap map(config(max_m, policy, 2));
      ASSERT_TRUE(map.compute(box));
      expectMatches(
          map, box, bruteForceUnclamped(box, policy),
          std::string("long lines, ") + toString(policy) + ", max " + std::to_string(max_m));
    }
  }
}

TEST(Esdf, TwoThreadsAreBitIdenticalToOne) {
  std::mt19937 rng(7);
  std::vector<OccupancyBox> boxes;
  boxes.push_back(randomBox({-30, -20, -5}, {64, 48, 40}, 0.1, 0.02, 0.05, &rng));
  boxes.push_back(randomBox({0, 0, 0}, {3, 70, 17}, 0.2, 0.3, 0.1, &rng));
  OccupancyBox sparse;
  sparse.reset({-10, -10, -10}, {40, 33, 21}, 0.2, Occupancy::kFree);
  sparse.at({0, 0, 0}) = Occupancy::kOccupied;
  boxes.push_back(sparse);
  for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
    EsdfMap one(config(1.5, policy, 1));
    EsdfMap two(config(1.5, policy, 2));
    EsdfMap three(config(1.5, policy, 3));
    for (const OccupancyBox& box : boxes) {
      ASSERT_TRUE(one.compute(box));
      ASSERT_TRUE(two.compute(box));
      ASSERT_TRUE(three.compute(box));
      ASSERT_EQ(one.distances().size(), box.states.size());
      ASSERT_EQ(two.distances().size(), box.states.size());
      EXPECT_EQ(std::memcmp(one.distances().data(), two.distances().data(),
                            box.states.size() * sizeof(float)),
                0);
      EXPECT_EQ(std::memcmp(one.distances().data(), three.distances().data(),
                            box.states.size() * sizeof(float)),
                0);
      // The unknown mask too (each thread writes its own slabs of it).
      for (int x = 0; x < box.size.x(); ++x) {
        for (int y = 0; y < box.size.y(); ++y) {
          for (int z = 0; z < box.size.z(); ++z) {
            const VoxelIndex g = box.min_index + VoxelIndex(x, y, z);
            const bool unknown = box.at(g) == Occupancy::kUnknown;
            ASSERT_EQ(one.isUnknown(g), unknown);
            ASSERT_EQ(two.isUnknown(g), unknown);
            ASSERT_EQ(three.isUnknown(g), unknown);
          }
        }
      }
    }
  }
}

// The windowed 16-bit passes against the envelope code (both exact): bit-identical fields for
// clamps from one voxel to the windowed passes' largest, flat boxes (one voxel along an axis)
// included; beyond that clamp compute() keeps the envelope code.
TEST(Esdf, WindowedPassesEqualTheEnvelopeCode) {
  std::mt19937 rng(23);
  const std::vector<Eigen::Vector3i> sizes = {{31, 45, 27}, {1, 40, 30}, {25, 1, 33},
                                              {30, 41, 1},  {2, 3, 90},  {70, 66, 2}};
  const std::vector<std::pair<double, double>> densities = {{0.002, 0.0}, {0.05, 0.2}, {0.4, 0.1}};
  for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
    // Clamps of 1, 2, 7, 20 and kMaxWindowCapCells voxels at 0.1 m, then one beyond.
    for (const double max_m : {0.1, 0.25, 0.7, 2.0, 4.8, 4.95}) {
      EsdfMap windowed(config(max_m, policy));
      EsdfMap envelope(config(max_m, policy));
      envelope.setEnvelopeOnly(true);
      for (const Eigen::Vector3i& size : sizes) {
        for (const auto& [p_occ, p_unk] : densities) {
          const OccupancyBox box = randomBox({-5, 3, -9}, size, 0.1, p_occ, p_unk, &rng);
          ASSERT_TRUE(windowed.compute(box));
          ASSERT_TRUE(envelope.compute(box));
          EXPECT_FALSE(envelope.windowedPasses());
          // Beyond 4.8 m the clamp (49 voxels) exceeds the windowed passes' unless the box's
          // diagonal is shorter (that is then the clamp: cap_sq = diagonal^2 + 1).
          const bool long_diagonal = (size - Eigen::Vector3i::Ones()).squaredNorm() + 1 >= 49 * 49;
          EXPECT_EQ(windowed.windowedPasses(), max_m < 4.9 || !long_diagonal) << max_m;
          const std::string what = std::string(toString(policy)) + ", max " +
                                   std::to_string(max_m) + " m, size " + std::to_string(size.x()) +
                                   "x" + std::to_string(size.y()) + "x" + std::to_string(size.z()) +
                                   ", occupied " + std::to_string(p_occ);
          ASSERT_EQ(windowed.distances().size(), box.states.size()) << what;
          EXPECT_EQ(std::memcmp(windowed.distances().data(), envelope.distances().data(),
                                box.states.size() * sizeof(float)),
                    0)
              << what;
        }
      }
    }
  }
}

TEST(Esdf, RecomputingReusesBuffersWithoutStaleValues) {
  std::mt19937 rng(5);
  const OccupancyBox big = randomBox({-5, -5, -5}, {30, 30, 30}, 0.2, 0.1, 0.1, &rng);
  const OccupancyBox small = randomBox({2, 3, 4}, {7, 5, 9}, 0.3, 0.2, 0.1, &rng);
  EsdfMap reused(config(1.0, UnknownAs::kOccupied, 2));
  ASSERT_TRUE(reused.compute(big));
  const std::size_t bytes = reused.memoryBytes();
  EXPECT_GE(bytes, big.states.size() * 8);
  ASSERT_TRUE(reused.compute(small));
  EXPECT_EQ(reused.memoryBytes(), bytes);  // no reallocation for a smaller box
  EsdfMap fresh(config(1.0, UnknownAs::kOccupied, 2));
  ASSERT_TRUE(fresh.compute(small));
  ASSERT_EQ(reused.distances().size(), small.states.size());
  EXPECT_EQ(std::memcmp(reused.distances().data(), fresh.distances().data(),
                        small.states.size() * sizeof(float)),
            0);
  EXPECT_EQ(reused.size(), small.size);
  EXPECT_EQ(reused.minIndex(), small.min_index);
  EXPECT_EQ(reused.maxIndex(), small.min_index + small.size);
  EXPECT_DOUBLE_EQ(reused.resolution_m(), 0.3);
}

TEST(Esdf, TrilinearValueEqualsCellValueAtCentres) {
  std::mt19937 rng(2);
  const OccupancyBox box = randomBox({-4, 6, -2}, {12, 9, 7}, 0.15, 0.15, 0.1, &rng);
  EsdfMap map(config(0.6, UnknownAs::kOccupied));
  ASSERT_TRUE(map.compute(box));
  for (int x = 0; x < box.size.x(); ++x) {
    for (int y = 0; y < box.size.y(); ++y) {
      for (int z = 0; z < box.size.z(); ++z) {
        const VoxelIndex g = box.min_index + VoxelIndex(x, y, z);
        const EsdfMap::Query q = map.query(voxelCenter(g, box.resolution_m));
        EXPECT_NEAR(q.distance_m, map.distanceAt(g), 1e-9) << g.transpose();
      }
    }
  }
}

// Central differences of query() at random points away from the kinks of the interpolation
// (cell-centre planes, where the stencil changes) and from the box faces.
TEST(Esdf, GradientMatchesFiniteDifferences) {
  std::mt19937 rng(9);
  const OccupancyBox box = randomBox({-6, -3, 2}, {14, 11, 9}, 0.2, 0.08, 0.05, &rng);
  EsdfMap map(config(1.0, UnknownAs::kOccupied));
  ASSERT_TRUE(map.compute(box));
  const double res = box.resolution_m;
  const double h = 1e-4 * res;
  std::uniform_real_distribution<double> frac(0.05, 0.95);
  int checked = 0;
  int nonzero = 0;
  for (int i = 0; i < 2000; ++i) {
    // Cell-centre coordinate u in [-0.45, n - 0.55] with frac(u) in [0.05, 0.95].
    Eigen::Vector3d p;
    for (int a = 0; a < 3; ++a) {
      std::uniform_int_distribution<int> cell(-1, box.size[a] - 1);
      const int whole = cell(rng);
      const double u = whole + frac(rng);
      if (u < -0.45 || u > box.size[a] - 0.55) {
        p[a] = std::numeric_limits<double>::quiet_NaN();
        continue;
      }
      p[a] = (box.min_index[a] + 0.5 + u) * res;
    }
    if (!p.allFinite()) continue;
    const EsdfMap::Query q = map.query(p);
    ASSERT_TRUE(map.contains(voxelIndexOf(p, res)));
    for (int a = 0; a < 3; ++a) {
      Eigen::Vector3d step = Eigen::Vector3d::Zero();
      step[a] = h;
      const double fd = (map.query(p + step).distance_m - map.query(p - step).distance_m) / (2 * h);
      EXPECT_NEAR(q.gradient[a], fd, 1e-6) << "axis " << a << " at " << p.transpose();
      if (std::abs(q.gradient[a]) > 1e-3) ++nonzero;
    }
    ++checked;
  }
  EXPECT_GT(checked, 500);
  EXPECT_GT(nonzero, 300);
}

// Within half a voxel of a box face the stencil is clamped: the value is that at the border
// cell-centre plane and the gradient has no component along the face normal.
// queryBatch() returns query()'s results bit for bit: points inside, on and beyond the box's
// faces, far away and NaN, in batches shorter and longer than its prefetch distance.
TEST(Esdf, BatchedQueriesEqualSingleQueries) {
  std::mt19937 rng(31);
  const OccupancyBox box = randomBox({-12, 5, -3}, {29, 17, 11}, 0.1, 0.05, 0.2, &rng);
  EsdfMap map(config(0.7, UnknownAs::kOccupied));
  ASSERT_TRUE(map.compute(box));
  const Eigen::Vector3d lo = map.minCorner_W();
  const Eigen::Vector3d extent = map.maxCorner_W() - lo;
  std::uniform_real_distribution<double> u(-0.1, 1.1);  // a tenth beyond each face
  std::vector<Eigen::Vector3d> points;
  points.reserve(5004);
  for (int i = 0; i < 5000; ++i) {
    points.emplace_back(lo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(extent));
  }
  points.push_back(lo);
  points.push_back(map.maxCorner_W());
  points.emplace_back(std::nan(""), 0.0, 0.0);
  points.emplace_back(1e300, -1e300, 0.0);
  for (const std::size_t count : {std::size_t{0}, std::size_t{1}, std::size_t{5}, points.size()}) {
    std::vector<EsdfMap::Query> batch(count);
    map.queryBatch(points.data() + (points.size() - count), count, batch.data());
    for (std::size_t i = 0; i < count; ++i) {
      const Eigen::Vector3d& p = points[points.size() - count + i];
      const EsdfMap::Query single = map.query(p);
      ASSERT_EQ(batch[i].valid, single.valid) << p.transpose();
      ASSERT_EQ(batch[i].distance_m, single.distance_m) << p.transpose();
      ASSERT_EQ(batch[i].gradient, single.gradient) << p.transpose();
    }
  }
}

TEST(Esdf, BorderHalfCellsHoldTheBorderValue) {
  std::mt19937 rng(4);
  const OccupancyBox box = randomBox({-3, 5, -8}, {9, 7, 6}, 0.25, 0.15, 0.1, &rng);
  EsdfMap map(config(0.8, UnknownAs::kOccupied));
  ASSERT_TRUE(map.compute(box));
  const Eigen::Vector3d lo = map.minCorner_W();
  const Eigen::Vector3d hi = map.maxCorner_W();
  const double res = box.resolution_m;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_real_distribution<double> half(0.01, 0.49);
  for (int i = 0; i < 300; ++i) {
    const int axis = i % 3;
    const bool upper = (i / 3) % 2 == 1;
    Eigen::Vector3d p = lo + test::draw3(u, rng).cwiseProduct(hi - lo);
    p[axis] = upper ? hi[axis] - half(rng) * res : lo[axis] + half(rng) * res;
    Eigen::Vector3d on_plane = p;
    on_plane[axis] = upper ? hi[axis] - 0.5 * res : lo[axis] + 0.5 * res;
    const EsdfMap::Query q = map.query(p);
    const EsdfMap::Query r = map.query(on_plane);
    EXPECT_NEAR(q.distance_m, r.distance_m, 1e-9) << p.transpose();
    EXPECT_EQ(q.gradient[axis], 0.0) << p.transpose();
  }
}

TEST(Esdf, WallGivesUnitGradientAwayFromIt) {
  OccupancyBox box;
  box.reset({-10, -5, -5}, {30, 10, 10}, 0.1, Occupancy::kFree);
  fill(&box, {0, -100, -100}, {0, 100, 100}, Occupancy::kOccupied);  // wall x in [0, 0.1)
  EsdfMap map(config(1.0, UnknownAs::kOccupied));
  ASSERT_TRUE(map.compute(box));
  for (const double x : {0.33, 0.52, 0.87}) {
    const EsdfMap::Query q = map.query({x, 0.013, -0.21});
    ASSERT_TRUE(q.valid);
    EXPECT_NEAR(q.distance_m, x - 0.05, 1e-6);
    EXPECT_NEAR(q.gradient.x(), 1.0, 1e-5);
    EXPECT_NEAR(q.gradient.y(), 0.0, 1e-9);
    EXPECT_NEAR(q.gradient.z(), 0.0, 1e-9);
  }
  const EsdfMap::Query behind = map.query({-0.47, 0.2, 0.3});
  EXPECT_NEAR(behind.distance_m, 0.52, 1e-6);
  EXPECT_NEAR(behind.gradient.x(), -1.0, 1e-5);
  const EsdfMap::Query clamped = map.query({0.92 + 0.5, 0.0, 0.0});
  EXPECT_NEAR(clamped.distance_m, 1.0, 1e-6);
  EXPECT_NEAR(clamped.gradient.norm(), 0.0, 1e-9);
}

TEST(Esdf, ValidOnlyInsideTheBoxAndInKnownVoxels) {
  OccupancyBox box;
  box.reset({-3, 2, -1}, {6, 5, 4}, 0.5, Occupancy::kFree);
  box.at({-3, 2, -1}) = Occupancy::kOccupied;
  box.at({1, 4, 1}) = Occupancy::kUnknown;
  box.at({2, 6, 2}) = Occupancy::kOccupied;
  EsdfMap map(config(2.0, UnknownAs::kOccupied));
  EXPECT_TRUE(map.empty());
  EXPECT_FALSE(map.query({0.1, 1.1, 0.1}).valid);  // nothing computed yet
  ASSERT_TRUE(map.compute(box));
  EXPECT_FALSE(map.empty());
  for (int x = -3; x < 3; ++x) {
    for (int y = 2; y < 7; ++y) {
      for (int z = -1; z < 3; ++z) {
        const VoxelIndex g(x, y, z);
        const Eigen::Vector3d c = voxelCenter(g, 0.5);
        const bool unknown = box.at(g) == Occupancy::kUnknown;
        EXPECT_EQ(map.query(c).valid, !unknown) << g.transpose();
        // Corners of the voxel (the lower one belongs to it).
        EXPECT_EQ(map.query(g.cast<double>() * 0.5).valid, !unknown) << g.transpose();
      }
    }
  }
  const EsdfMap::Query in_unknown = map.query(voxelCenter({1, 4, 1}, 0.5));
  EXPECT_FALSE(in_unknown.valid);
  EXPECT_FLOAT_EQ(static_cast<float>(in_unknown.distance_m), -0.5f);  // still filled in
  const Eigen::Vector3d lo = map.minCorner_W();
  const Eigen::Vector3d hi = map.maxCorner_W();
  EXPECT_TRUE(lo.isApprox(Eigen::Vector3d(-1.5, 1.0, -0.5)));
  EXPECT_TRUE(hi.isApprox(Eigen::Vector3d(1.5, 3.5, 1.5)));
  EXPECT_TRUE(map.query(lo).valid);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(hi), Eigen::Vector3d(hi.x() - 1e-3, hi.y() - 1e-3, hi.z()),
        Eigen::Vector3d(lo.x() - 1e-9, 2.0, 0.0), Eigen::Vector3d(0.0, 3.6, 0.0),
        Eigen::Vector3d(0.0, 2.0, -0.51), Eigen::Vector3d(nan, 2.0, 0.0),
        Eigen::Vector3d(0.0, std::numeric_limits<double>::infinity(), 0.0),
        Eigen::Vector3d(1e300, 2.0, 0.0)}) {
    const EsdfMap::Query q = map.query(p);
    EXPECT_FALSE(q.valid) << p.transpose();
    EXPECT_EQ(q.distance_m, 0.0);
    EXPECT_EQ(q.gradient, Eigen::Vector3d::Zero());
  }
}

TEST(Esdf, MalformedBoxIsRejectedAndLeavesTheMapEmpty) {
  EsdfMap map(config(1.0, UnknownAs::kOccupied));
  OccupancyBox box;
  box.reset({0, 0, 0}, {4, 4, 4}, 0.2, Occupancy::kFree);
  ASSERT_TRUE(map.compute(box));
  OccupancyBox bad = box;
  bad.states.pop_back();
  EXPECT_FALSE(map.compute(bad));
  EXPECT_TRUE(map.empty());
  EXPECT_FALSE(map.query({0.3, 0.3, 0.3}).valid);
  EXPECT_TRUE(std::isnan(map.distanceAt({1, 1, 1})));
  bad = box;
  bad.resolution_m = 0.0;
  EXPECT_FALSE(map.compute(bad));
  bad.resolution_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(map.compute(bad));
  bad.reset({0, 0, 0}, {4, 0, 4}, 0.2);
  EXPECT_FALSE(map.compute(bad));
  bad.reset({0, 0, 0}, {4, -2, 4}, 0.2);
  EXPECT_FALSE(map.compute(bad));
  bad.reset({0, 0, 0}, {EsdfMap::kMaxCellsPerAxis + 1, 1, 1}, 0.2);
  EXPECT_FALSE(map.compute(bad));
  bad.reset({2147483600, 0, 0}, {4, 4, 4}, 0.2);
  EXPECT_FALSE(map.compute(bad));
  EXPECT_TRUE(map.compute(box));
  EXPECT_TRUE(map.query({0.3, 0.3, 0.3}).valid);
}

/// A world of states larger than the box, changed step by step: blobs of occupied voxels appear
/// and disappear, unknown voxels become known, a box-shaped "person" walks across it, and single
/// voxels flip between all three states.
class ChangingWorld {
 public:
  ChangingWorld(const Eigen::Vector3i& size, std::uint32_t seed) : size_(size), rng_(seed) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    states_.resize(static_cast<std::size_t>(size.prod()));
    for (Occupancy& s : states_) {
      const double r = u(rng_);
      s = r < 0.03 ? Occupancy::kOccupied : (r < 0.4 ? Occupancy::kUnknown : Occupancy::kFree);
    }
  }
  /// One step of changes.
  void step() {
    std::uniform_int_distribution<int> pick(0, 1 << 20);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    // A blob appears or disappears (obstacles appearing and disappearing).
    const VoxelIndex c(pick(rng_) % size_.x(), pick(rng_) % size_.y(), pick(rng_) % size_.z());
    const int radius = 1 + pick(rng_) % 3;
    const Occupancy blob = u(rng_) < 0.5 ? Occupancy::kOccupied : Occupancy::kFree;
    fill(c - VoxelIndex::Constant(radius), c + VoxelIndex::Constant(radius), blob);
    // Unknown space seen: a slab of unknown voxels becomes free with a few occupied.
    const VoxelIndex s(pick(rng_) % size_.x(), pick(rng_) % size_.y(), pick(rng_) % size_.z());
    for (int x = s.x(); x < std::min(size_.x(), s.x() + 4); ++x) {
      for (int y = s.y(); y < std::min(size_.y(), s.y() + 6); ++y) {
        for (int z = s.z(); z < std::min(size_.z(), s.z() + 3); ++z) {
          Occupancy& v = at({x, y, z});
          if (v == Occupancy::kUnknown) v = u(rng_) < 0.1 ? Occupancy::kOccupied : Occupancy::kFree;
        }
      }
    }
    // The person: a 2 x 2 x 5 box moving one voxel along y per step, leaving free space.
    fill(person_, person_ + VoxelIndex(1, 1, 4), Occupancy::kFree);
    person_.y() = (person_.y() + 1) % size_.y();
    fill(person_, person_ + VoxelIndex(1, 1, 4), Occupancy::kOccupied);
    // Single flips, any state to any state.
    for (int i = 0; i < 20; ++i) {
      at({pick(rng_) % size_.x(), pick(rng_) % size_.y(), pick(rng_) % size_.z()}) =
          static_cast<Occupancy>(pick(rng_) % 3);
    }
  }
  /// The box of `box_size` voxels at world index `min_index` (inside the world).
  [[nodiscard]] OccupancyBox box(const VoxelIndex& min_index, const Eigen::Vector3i& box_size,
                                 double res) const {
    OccupancyBox b;
    b.reset(min_index, box_size, res);
    for (int x = 0; x < box_size.x(); ++x) {
      for (int y = 0; y < box_size.y(); ++y) {
        for (int z = 0; z < box_size.z(); ++z) {
          b.at(min_index + VoxelIndex(x, y, z)) = at(min_index + VoxelIndex(x, y, z));
        }
      }
    }
    return b;
  }

 private:
  [[nodiscard]] std::size_t offset(const VoxelIndex& v) const {
    return (static_cast<std::size_t>(v.x()) * static_cast<std::size_t>(size_.y()) +
            static_cast<std::size_t>(v.y())) *
               static_cast<std::size_t>(size_.z()) +
           static_cast<std::size_t>(v.z());
  }
  [[nodiscard]] Occupancy at(const VoxelIndex& v) const { return states_[offset(v)]; }
  Occupancy& at(const VoxelIndex& v) { return states_[offset(v)]; }
  void fill(const VoxelIndex& lo, const VoxelIndex& hi, Occupancy state) {
    for (int x = std::max(0, lo.x()); x <= std::min(size_.x() - 1, hi.x()); ++x) {
      for (int y = std::max(0, lo.y()); y <= std::min(size_.y() - 1, hi.y()); ++y) {
        for (int z = std::max(0, lo.z()); z <= std::min(size_.z() - 1, hi.z()); ++z) {
          at({x, y, z}) = state;
        }
      }
    }
  }

  Eigen::Vector3i size_;
  std::mt19937 rng_;
  std::vector<Occupancy> states_;
  VoxelIndex person_ = VoxelIndex(3, 0, 0);
};

/// Every cell value and unknown bit of `actual` equals those of `expected` (exactly).
void expectSameField(const EsdfMap& actual, const EsdfMap& expected, const std::string& what) {
  ASSERT_EQ(actual.minIndex(), expected.minIndex()) << what;
  ASSERT_EQ(actual.size(), expected.size()) << what;
  const std::vector<float>& a = actual.distances();
  const std::vector<float>& e = expected.distances();
  ASSERT_EQ(a.size(), e.size()) << what;
  int failures = 0;
  for (std::size_t i = 0; i < e.size(); ++i) {
    if (a[i] != e[i] && ++failures <= 5) {  // (never NaN)
      ADD_FAILURE() << what << ": cell " << i << ": " << a[i] << ", full recompute " << e[i];
    }
  }
  const Eigen::Vector3i& n = expected.size();
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      for (int z = 0; z < n.z(); ++z) {
        const VoxelIndex g = expected.minIndex() + VoxelIndex(x, y, z);
        if (actual.isUnknown(g) != expected.isUnknown(g) && ++failures <= 5) {
          ADD_FAILURE() << what << ": unknown bit of (" << x << ", " << y << ", " << z << ")";
        }
      }
    }
  }
  EXPECT_EQ(failures, 0) << what;
}

// update() after every step of a changing world, with the box sliding by small and large steps
// (and once by more than its size), equals a full compute() bit for bit; so does a copy kept up
// to date with copyCells(changedCells()). Both unknown policies, a clamp reached and one not,
// 32- and 64-bit envelope keys, a box one voxel thick.
TEST(Esdf, IncrementalUpdatesEqualAFullRecomputeAfterEveryStep) {
  struct Case {
    Eigen::Vector3i box_size;
    double max_m;
    bool envelope_only;  ///< setEnvelopeOnly() on both maps (the windowed passes otherwise)
  };
  const Case cases[] = {{{31, 27, 17}, 0.65, false}, {{24, 33, 12}, 100.0, false},
                        {{40, 37, 1}, 0.9, false},   {{47, 45, 26}, 2.0, false},
                        {{31, 27, 17}, 0.65, true},  {{24, 33, 12}, 100.0, true}};
  std::mt19937 rng(5);
  for (const Case& c : cases) {
    for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
      std::ostringstream what_case;
      what_case << "box " << c.box_size.transpose() << ", max " << c.max_m << " m, "
                << toString(policy) << (c.envelope_only ? ", envelope code" : "");
      SCOPED_TRACE(what_case.str());
      const Eigen::Vector3i world_size = c.box_size * 2 + Eigen::Vector3i::Ones();
      ChangingWorld world(world_size, static_cast<std::uint32_t>(rng()));
      EsdfMap incremental(config(c.max_m, policy));
      EsdfMap full(config(c.max_m, policy));
      incremental.setEnvelopeOnly(c.envelope_only);
      full.setEnvelopeOnly(c.envelope_only);
      EsdfMap copy(config(c.max_m, policy));
      VoxelIndex min_index = VoxelIndex::Zero();
      std::uniform_int_distribution<int> pick(0, 99);
      std::size_t incremental_steps = 0;
      std::size_t shifted_steps = 0;
      std::size_t moved_steps = 0;
      VoxelIndex previous_min = min_index;
      for (int step = 0; step < 60; ++step) {
        world.step();
        const int kind = pick(rng);
        VoxelIndex delta = VoxelIndex::Zero();
        if (kind < 25) {  // slide by a few voxels on one or more axes
          for (int a = 0; a < 3; ++a) delta[a] = pick(rng) % 7 - 3;
        } else if (kind < 30) {  // slide by most of the box
          delta.x() = c.box_size.x() - 1;
        }
        if (step == 40) delta.y() = c.box_size.y();  // beyond the box: computed whole
        for (int a = 0; a < 3; ++a) {
          min_index[a] = std::clamp(min_index[a] + delta[a], 0, world_size[a] - c.box_size[a]);
        }
        const OccupancyBox box = world.box(min_index, c.box_size, 0.1);
        ASSERT_TRUE(incremental.update(box));
        ASSERT_TRUE(full.compute(box));
        const EsdfMap::UpdateStats& u = incremental.lastUpdate();
        incremental_steps += u.full ? 0 : 1;
        shifted_steps += u.shifted ? 1 : 0;
        // A move within the box is shifted with the envelope code; with the windowed passes it
        // is moved along x and y (moveWindowed()) and computed whole along z.
        const bool moved = box.min_index != previous_min && step > 0 && step != 40;
        if (moved) {
          ++moved_steps;
          if (!incremental.windowedPasses()) {
            EXPECT_TRUE(u.shifted) << "step " << step;
          } else if (box.min_index.z() != previous_min.z()) {
            EXPECT_TRUE(u.full) << "step " << step;
          } else {
            EXPECT_TRUE(u.shifted || u.full) << "step " << step;
          }
        }
        previous_min = box.min_index;
        if (step == 0) {
          EXPECT_TRUE(u.full);
        }
        if (u.full || u.shifted) {
          copy.copyFrom(incremental);
        } else {
          // Only cells that changed are listed (the copy below checks that all of them are).
          std::size_t unchanged_listed = 0;
          const auto ny = static_cast<std::uint32_t>(box.size.y());
          const auto nz = static_cast<std::uint32_t>(box.size.z());
          for (const std::uint32_t cell : incremental.changedCells()) {
            const auto x = static_cast<int>(cell / (ny * nz));
            const auto y = static_cast<int>(cell / nz % ny);
            const auto z = static_cast<int>(cell % nz);
            const bool same = copy.distances()[cell] == incremental.distances()[cell] &&
                              copy.isUnknownCell(x, y, z) == incremental.isUnknownCell(x, y, z);
            unchanged_listed += same ? 1 : 0;
          }
          EXPECT_EQ(unchanged_listed, 0u) << "step " << step;
          ASSERT_TRUE(copy.copyCells(incremental, incremental.changedCells()));
        }
        const std::string what = "step " + std::to_string(step);
        expectSameField(incremental, full, what);
        expectSameField(copy, full, what + " (copy)");
        if (HasFailure()) return;
      }
      EXPECT_GT(incremental_steps, 30u);
      EXPECT_GT(moved_steps, 2u);
      if (c.envelope_only) {
        EXPECT_GT(shifted_steps, 2u);
      }
    }
  }
}

// update() told where the states may have changed (as the map engine tells it: the submaps it
// refilled) compares the box with the kept one only there, and still equals a full compute()
// bit for bit: blocks of 5^3 voxels holding a change, one of them listed twice, plus unchanged
// ones. When the box moved the hint speaks of the old place and is ignored: given an empty
// list then, the update must still find every change.
TEST(Esdf, UpdatesToldWhereStatesChangedEqualAFullRecompute) {
  const Eigen::Vector3i size(31, 27, 17);
  std::mt19937 rng(11);
  for (const bool envelope_only : {false, true}) {
    for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
      SCOPED_TRACE(std::string(toString(policy)) + (envelope_only ? ", envelope code" : ""));
      const Eigen::Vector3i world_size = size * 2 + Eigen::Vector3i::Ones();
      ChangingWorld world(world_size, static_cast<std::uint32_t>(rng()));
      EsdfMap incremental(config(0.65, policy));
      EsdfMap full(config(0.65, policy));
      incremental.setEnvelopeOnly(envelope_only);
      full.setEnvelopeOnly(envelope_only);
      VoxelIndex min_index = VoxelIndex::Zero();
      OccupancyBox before = world.box(min_index, size, 0.1);
      ASSERT_TRUE(incremental.compute(before));
      std::size_t hinted = 0;
      std::size_t moved = 0;
      for (int step = 0; step < 40; ++step) {
        world.step();
        if (step % 5 == 4) {  // slide by a voxel or two along x and y
          min_index += VoxelIndex(1 + step % 2, step % 3 == 0 ? 1 : -1, 0);
          min_index = min_index.cwiseMax(0).cwiseMin(world_size - size);
        }
        const OccupancyBox box = world.box(min_index, size, 0.1);
        std::vector<EsdfMap::Region> regions;
        if (box.min_index == before.min_index) {
          constexpr int kBlock = 5;
          std::vector<EsdfMap::Region> holding_changes;
          for (int x = 0; x < size.x(); x += kBlock)
            for (int y = 0; y < size.y(); y += kBlock)
              for (int z = 0; z < size.z(); z += kBlock) {
                const Eigen::Vector3i lo(x, y, z);
                const Eigen::Vector3i hi = lo + Eigen::Vector3i::Constant(kBlock);  // clipped
                bool changed = false;
                for (int i = x; i < std::min(hi.x(), size.x()) && !changed; ++i)
                  for (int j = y; j < std::min(hi.y(), size.y()) && !changed; ++j)
                    for (int k = z; k < std::min(hi.z(), size.z()) && !changed; ++k) {
                      const VoxelIndex g = box.min_index + VoxelIndex(i, j, k);
                      changed = box.at(g) != before.at(g);
                    }
                if (changed) holding_changes.push_back({lo, hi});
                if (changed || (x + y + z) % 3 == 0) regions.push_back({lo, hi});  // some unchanged
              }
          // Overlapping: a block listed twice, and blocks holding changes listed again shifted
          // along x and y (a voxel in two regions of different extents).
          if (!regions.empty()) regions.push_back(regions.front());
          for (const EsdfMap::Region& r : holding_changes) {
            const Eigen::Vector3i shift(2, 3, 0);
            regions.push_back({r.lo - shift, r.hi - shift});
          }
          ++hinted;
        } else {
          ++moved;
        }
        ASSERT_TRUE(incremental.update(box, regions));
        ASSERT_TRUE(full.compute(box));
        expectSameField(incremental, full, "step " + std::to_string(step));
        if (box.min_index == before.min_index && !incremental.lastUpdate().full) {
          std::size_t differing = 0;  // each changed voxel counted once, overlaps or not
          for (std::size_t i = 0; i < box.states.size(); ++i) {
            differing += box.states[i] != before.states[i] ? 1 : 0;
          }
          EXPECT_EQ(incremental.lastUpdate().changed_states, differing) << "step " << step;
        }
        before = box;
      }
      EXPECT_GT(hinted, 20u);
      EXPECT_GT(moved, 3u);
    }
  }
}

// A box moving along x and y, by less than the clamp and by more, while the world changes
// under it: with the windowed passes the move goes through moveWindowed() (shifted, not
// computed whole), and the field and unknown bits equal a full compute() after every step,
// on boxes larger than the clamp bands (so that kept slabs and rows are reused) and smaller.
TEST(Esdf, WindowedMovesAlongXAndYEqualAFullRecompute) {
  struct Case {
    Eigen::Vector3i box_size;
    double max_m;
  };
  const Case cases[] = {{{60, 52, 9}, 0.3}, {{47, 45, 26}, 0.5}, {{20, 18, 7}, 0.9}};
  std::mt19937 rng(11);
  for (const Case& c : cases) {
    for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
      std::ostringstream what_case;
      what_case << "box " << c.box_size.transpose() << ", max " << c.max_m << " m, "
                << toString(policy);
      SCOPED_TRACE(what_case.str());
      const Eigen::Vector3i world_size(c.box_size.x() * 3, c.box_size.y() * 3, c.box_size.z());
      ChangingWorld world(world_size, static_cast<std::uint32_t>(rng()));
      EsdfMap incremental(config(c.max_m, policy));
      EsdfMap full(config(c.max_m, policy));
      VoxelIndex min_index(c.box_size.x(), c.box_size.y(), 0);
      std::uniform_int_distribution<int> pick(0, 99);
      std::size_t moved_steps = 0;
      for (int step = 0; step < 40; ++step) {
        world.step();
        VoxelIndex delta = VoxelIndex::Zero();
        const int kind = pick(rng);
        if (kind < 30) {  // a few voxels
          delta.x() = pick(rng) % 7 - 3;
          delta.y() = pick(rng) % 7 - 3;
        } else if (kind < 60) {  // a fifth of the box (the local map's window), one axis or both
          delta.x() = (kind % 3 != 2 ? 1 : 0) * (kind % 2 == 0 ? 1 : -1) * (c.box_size.x() / 5);
          delta.y() = (kind % 3 != 1 ? 1 : 0) * (kind % 4 < 2 ? 1 : -1) * (c.box_size.y() / 5);
        }
        const VoxelIndex before = min_index;
        for (int a = 0; a < 2; ++a) {
          min_index[a] = std::clamp(min_index[a] + delta[a], 0, world_size[a] - c.box_size[a]);
        }
        const OccupancyBox box = world.box(min_index, c.box_size, 0.1);
        ASSERT_TRUE(incremental.update(box));
        ASSERT_TRUE(full.compute(box));
        ASSERT_TRUE(incremental.windowedPasses());
        const EsdfMap::UpdateStats& u = incremental.lastUpdate();
        if (step > 0 && min_index != before) {
          ++moved_steps;
          EXPECT_TRUE(u.shifted) << "step " << step;
          EXPECT_FALSE(u.full) << "step " << step;
        }
        expectSameField(incremental, full, "step " + std::to_string(step));
        if (HasFailure()) return;
      }
      EXPECT_GT(moved_steps, 15u);
    }
  }
}

// The incremental path touches only what a change can reach: one voxel turned occupied in a
// free box far from everything re-sweeps one row and re-transforms only lines within the clamp;
// an update with nothing changed, also right after a window move, transforms nothing (the line
// marks are left clear). Both the windowed passes and the envelope code.
TEST(Esdf, OneChangedVoxelTouchesOnlyLinesWithinTheClamp) {
  for (const bool envelope_only : {false, true}) {
    SCOPED_TRACE(envelope_only ? "envelope code" : "windowed passes");
    OccupancyBox box;
    box.reset({0, 0, 0}, {60, 50, 40}, 0.1, Occupancy::kFree);
    EsdfMap map(config(0.5, UnknownAs::kOccupied));  // 5 voxels
    map.setEnvelopeOnly(envelope_only);
    ASSERT_TRUE(map.update(box));
    ASSERT_EQ(map.windowedPasses(), !envelope_only);
    box.at({30, 25, 20}) = Occupancy::kOccupied;
    ASSERT_TRUE(map.update(box));
    const EsdfMap::UpdateStats& u = map.lastUpdate();
    EXPECT_FALSE(u.full);
    EXPECT_EQ(u.changed_states, 1u);
    EXPECT_EQ(u.rows_swept, 1u);
    EXPECT_LE(u.y_lines, 11u);        // x within +-5 of the voxel, z = 20
    EXPECT_LE(u.z_lines, 11u * 11u);  // x and y within +-5
    EXPECT_GT(u.changed_cells, 100u);
    EsdfMap full(config(0.5, UnknownAs::kOccupied));
    ASSERT_TRUE(full.compute(box));
    expectSameField(map, full, "one voxel");
    // Nothing changed: nothing is done.
    ASSERT_TRUE(map.update(box));
    EXPECT_EQ(map.lastUpdate().rows_swept, 0u);
    EXPECT_EQ(map.lastUpdate().y_lines, 0u);
    EXPECT_EQ(map.lastUpdate().z_lines, 0u);
    EXPECT_EQ(map.lastUpdate().changed_cells, 0u);
    // The box moved along x and y (the obstacle stays where it is in the world), then the same
    // box again: the second update has nothing to do.
    OccupancyBox moved;
    moved.reset({4, -3, 0}, box.size, 0.1, Occupancy::kFree);
    moved.at({30, 25, 20}) = Occupancy::kOccupied;
    ASSERT_TRUE(map.update(moved));
    EXPECT_FALSE(map.lastUpdate().full);
    EXPECT_TRUE(map.lastUpdate().shifted);
    ASSERT_TRUE(map.update(moved));
    EXPECT_EQ(map.lastUpdate().rows_swept, 0u);
    EXPECT_EQ(map.lastUpdate().y_lines, 0u);
    EXPECT_EQ(map.lastUpdate().z_lines, 0u);
    ASSERT_TRUE(full.compute(moved));
    expectSameField(map, full, "moved, then unchanged");
    // A malformed box empties the map and the next update computes whole.
    OccupancyBox bad = moved;
    bad.states.pop_back();
    EXPECT_FALSE(map.update(bad));
    EXPECT_TRUE(map.empty());
    ASSERT_TRUE(map.update(moved));
    EXPECT_TRUE(map.lastUpdate().full);
    expectSameField(map, full, "after a malformed box");
  }
}

// A change that keeps a voxel's kind (obstacle or not, all the x pass reads) sweeps no row and
// transforms no line: with unknown as free, unknown seen free only flips unknown bits; with
// unknown as occupied, the same voxel becoming free is a real change. Either way the field
// equals a full compute.
TEST(Esdf, AChangeThatKeepsTheKindSweepsNoRow) {
  for (const UnknownAs policy : {UnknownAs::kFree, UnknownAs::kOccupied}) {
    SCOPED_TRACE(toString(policy));
    OccupancyBox box;
    box.reset({0, 0, 0}, {40, 30, 20}, 0.1, Occupancy::kFree);
    for (int x = 10; x < 30; ++x) box.at({x, 15, 10}) = Occupancy::kOccupied;
    for (int y = 0; y < 30; ++y) box.at({35, y, 5}) = Occupancy::kUnknown;
    EsdfMap map(config(0.5, policy));
    ASSERT_TRUE(map.update(box));
    for (int y = 0; y < 30; ++y) box.at({35, y, 5}) = Occupancy::kFree;  // seen free
    ASSERT_TRUE(map.update(box));
    const EsdfMap::UpdateStats& u = map.lastUpdate();
    EXPECT_FALSE(u.full);
    EXPECT_EQ(u.changed_states, 30u);
    if (policy == UnknownAs::kFree) {
      EXPECT_EQ(u.rows_swept, 0u);
      EXPECT_EQ(u.y_lines, 0u);
      EXPECT_EQ(u.z_lines, 0u);
      EXPECT_EQ(u.changed_cells, 30u);  // the unknown bits
    } else {
      EXPECT_EQ(u.rows_swept, 30u);
      EXPECT_GT(u.z_lines, 0u);
    }
    EsdfMap full(config(0.5, policy));
    ASSERT_TRUE(full.compute(box));
    expectSameField(map, full, "unknown seen free");
  }
}

// The hint is taken at its word where the box stayed: a change outside the regions named is not
// looked for (that is the saving), and is found once a region names it.
TEST(Esdf, AnUnmovedUpdateComparesOnlyTheRegionsNamed) {
  OccupancyBox box;
  box.reset({0, 0, 0}, {30, 20, 10}, 0.1, Occupancy::kFree);
  EsdfMap map(config(0.5, UnknownAs::kOccupied));
  ASSERT_TRUE(map.update(box));
  box.at({20, 10, 5}) = Occupancy::kOccupied;
  ASSERT_TRUE(map.update(box, {{{0, 0, 0}, {10, 20, 10}}}));  // names another part only
  EXPECT_EQ(map.lastUpdate().changed_states, 0u);
  ASSERT_TRUE(map.update(box, {{{15, 5, 0}, {25, 15, 10}}}));
  EXPECT_EQ(map.lastUpdate().changed_states, 1u);
  EsdfMap full(config(0.5, UnknownAs::kOccupied));
  ASSERT_TRUE(full.compute(box));
  expectSameField(map, full, "after the region named it");
}

/// Points for comparing queries: uniform over the box and a tenth beyond each face, the box's
/// corners, cell centres, points within half a voxel of the faces, and points that are no
/// points (NaN, huge).
std::vector<Eigen::Vector3d> queryPoints(const EsdfMap& map, int count, std::mt19937* rng) {
  const Eigen::Vector3d lo = map.minCorner_W();
  const Eigen::Vector3d extent = map.maxCorner_W() - lo;
  std::uniform_real_distribution<double> u(-0.1, 1.1);
  std::uniform_real_distribution<double> inside(0.0, 1.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    points.emplace_back(lo + Eigen::Vector3d(u(*rng), u(*rng), u(*rng)).cwiseProduct(extent));
    Eigen::Vector3d near_face = lo + test::draw3(inside, *rng).cwiseProduct(extent);
    const int axis = i % 3;
    near_face[axis] = (i / 3) % 2 == 0 ? lo[axis] + 0.3 * map.resolution_m()
                                       : lo[axis] + extent[axis] - 0.3 * map.resolution_m();
    points.push_back(near_face);
  }
  std::uniform_int_distribution<int> cell(0, 1 << 20);
  for (int i = 0; i < count / 4; ++i) {
    const VoxelIndex g =
        map.minIndex() + VoxelIndex(cell(*rng) % map.size().x(), cell(*rng) % map.size().y(),
                                    cell(*rng) % map.size().z());
    points.push_back(voxelCenter(g, map.resolution_m()));
  }
  points.push_back(lo);
  points.push_back(map.maxCorner_W());
  points.emplace_back(std::nan(""), 0.0, 0.0);
  points.emplace_back(1e300, -1e300, 0.0);
  points.emplace_back(0.0, std::numeric_limits<double>::infinity(), 0.0);
  return points;
}

/// EsdfQueryGrid::query() equals EsdfMap::query() within the grid's error bounds (validity
/// exactly), and queryBatch() equals query() bit for bit.
void expectQueriesWithinBounds(const EsdfQueryGrid& grid, const EsdfMap& map,
                               const std::vector<Eigen::Vector3d>& points,
                               const std::string& what) {
  const double distance_bound = grid.distanceErrorBound_m() + 1e-9;
  const double gradient_bound = grid.gradientErrorBound() + 1e-9;
  std::vector<EsdfMap::Query> batch(points.size());
  grid.queryBatch(points.data(), points.size(), batch.data());
  int failures = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& p = points[i];
    const EsdfMap::Query exact = map.query(p);
    const EsdfMap::Query fast = grid.query(p);
    // On a plane through cell centres the trilinear gradient jumps: either side's holds there.
    bool gradient_ok = true;
    for (int a = 0; a < 3; ++a) {
      const double u = p[a] / map.resolution_m() - 0.5;
      const bool on_centre_plane = std::abs(u - std::round(u)) < 1e-6;
      gradient_ok =
          gradient_ok &&
          (on_centre_plane || std::abs(fast.gradient[a] - exact.gradient[a]) <= gradient_bound);
    }
    const bool ok = fast.valid == exact.valid &&
                    std::abs(fast.distance_m - exact.distance_m) <= distance_bound && gradient_ok &&
                    batch[i].valid == fast.valid && batch[i].distance_m == fast.distance_m &&
                    batch[i].gradient == fast.gradient;
    if (!ok && ++failures <= 5) {
      ADD_FAILURE() << what << ": at " << p.transpose() << ": grid " << fast.distance_m << " ["
                    << fast.gradient.transpose() << "] valid " << fast.valid << ", exact "
                    << exact.distance_m << " [" << exact.gradient.transpose() << "] valid "
                    << exact.valid << ", batch " << batch[i].distance_m;
    }
  }
  EXPECT_EQ(failures, 0) << what;
}

// The quantised query grid against the exact query on random scenes: boxes one voxel thick
// along each axis, both policies, clamps of several sizes (one never reached).
TEST(EsdfQueryGrid, QueriesMatchTheExactQueryWithinTheBound) {
  struct Shape {
    VoxelIndex min_index;
    Eigen::Vector3i size;
    double res;
    double max_m;
  };
  const Shape shapes[] = {
      {{-12, 5, -3}, {29, 17, 11}, 0.1, 0.7}, {{3, -8, 100}, {40, 33, 21}, 0.2, 2.0},
      {{0, 0, 0}, {1, 9, 13}, 0.15, 1.0},     {{-5, 2, 7}, {11, 1, 6}, 0.1, 0.5},
      {{4, 4, -4}, {7, 8, 1}, 0.25, 50.0},    {{0, 0, 0}, {1, 1, 1}, 0.1, 2.0}};
  std::mt19937 rng(77);
  for (const Shape& shape : shapes) {
    for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
      const OccupancyBox box = randomBox(shape.min_index, shape.size, shape.res, 0.06, 0.2, &rng);
      EsdfMap map(config(shape.max_m, policy));
      ASSERT_TRUE(map.compute(box));
      EsdfQueryGrid grid;
      EXPECT_TRUE(grid.empty());
      EXPECT_FALSE(grid.query(map.minCorner_W()).valid);
      grid.build(map);
      EXPECT_FALSE(grid.empty());
      EXPECT_NEAR(grid.distanceErrorBound_m(), 0.5 * shape.max_m / EsdfQueryGrid::kMaxLevel, 1e-15);
      std::ostringstream what;
      what << "box " << shape.size.transpose() << ", max " << shape.max_m << " m, "
           << toString(policy);
      expectQueriesWithinBounds(grid, map, queryPoints(map, 3000, &rng), what.str());
      // At cell centres away from the faces the distance is the cell's value, quantised.
      for (int i = 0; i < 50; ++i) {
        const VoxelIndex g = box.min_index + VoxelIndex(static_cast<int>(rng() % shape.size.x()),
                                                        static_cast<int>(rng() % shape.size.y()),
                                                        static_cast<int>(rng() % shape.size.z()));
        const EsdfMap::Query q = grid.query(voxelCenter(g, shape.res));
        EXPECT_NEAR(q.distance_m, map.distanceAt(g), grid.distanceErrorBound_m() + 1e-9);
        EXPECT_EQ(q.valid, !map.isUnknown(g));
      }
    }
  }
  // An empty map gives an empty grid.
  EsdfMap empty_map(config(1.0, UnknownAs::kFree));
  EsdfQueryGrid grid;
  grid.build(empty_map);
  EXPECT_TRUE(grid.empty());
  EXPECT_FALSE(grid.query(Eigen::Vector3d::Zero()).valid);
}

// A grid kept up to date by sync() after every update() of a changing, sliding world answers
// bit for bit as a grid built from a full compute(), and copies only the changed cells on the
// incremental steps (cells on the box's faces included: their padding follows).
TEST(EsdfQueryGrid, SyncAfterIncrementalUpdatesEqualsAFreshBuild) {
  const Eigen::Vector3i box_size(31, 27, 17);
  std::mt19937 rng(9);
  for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
    for (const bool envelope_only : {false, true}) {
      SCOPED_TRACE(std::string(toString(policy)) + (envelope_only ? ", envelope code" : ""));
      const Eigen::Vector3i world_size = box_size * 2 + Eigen::Vector3i::Ones();
      ChangingWorld world(world_size, static_cast<std::uint32_t>(rng()));
      EsdfMap incremental(config(0.65, policy));
      incremental.setEnvelopeOnly(envelope_only);
      EsdfMap full(config(0.65, policy));
      EsdfQueryGrid synced;
      EsdfQueryGrid fresh;
      VoxelIndex min_index = VoxelIndex::Zero();
      std::size_t copied_steps = 0;
      for (int step = 0; step < 40; ++step) {
        world.step();
        if (step % 7 == 3) {
          for (int a = 0; a < 3; ++a) {
            min_index[a] = std::clamp(min_index[a] + static_cast<int>(rng() % 5) - 2, 0,
                                      world_size[a] - box_size[a]);
          }
        }
        const OccupancyBox box = world.box(min_index, box_size, 0.1);
        ASSERT_TRUE(incremental.update(box));
        ASSERT_TRUE(full.compute(box));
        const bool copied = synced.sync(incremental);
        EXPECT_EQ(copied, !incremental.lastUpdate().full && !incremental.lastUpdate().shifted);
        copied_steps += copied ? 1 : 0;
        fresh.build(full);
        const std::vector<Eigen::Vector3d> points = queryPoints(full, 400, &rng);
        int failures = 0;
        for (const Eigen::Vector3d& p : points) {
          const EsdfMap::Query a = synced.query(p);
          const EsdfMap::Query e = fresh.query(p);
          if ((a.valid != e.valid || a.distance_m != e.distance_m || a.gradient != e.gradient) &&
              ++failures <= 5) {
            ADD_FAILURE() << "step " << step << " at " << p.transpose() << ": synced "
                          << a.distance_m << " valid " << a.valid << ", fresh " << e.distance_m
                          << " valid " << e.valid;
          }
        }
        // The face cells (and so the padding) at every cell centre of the faces.
        for (int y = 0; y < box_size.y(); ++y) {
          for (int z = 0; z < box_size.z(); ++z) {
            for (const int x : {0, box_size.x() - 1}) {
              const Eigen::Vector3d p = voxelCenter(box.min_index + VoxelIndex(x, y, z), 0.1) +
                                        Eigen::Vector3d(x == 0 ? -0.04 : 0.04, 0.0, 0.0);
              if (synced.query(p).distance_m != fresh.query(p).distance_m && ++failures <= 5) {
                ADD_FAILURE() << "step " << step << ": face cell " << x << " " << y << " " << z;
              }
            }
          }
        }
        ASSERT_EQ(failures, 0) << "step " << step;
        expectQueriesWithinBounds(synced, full, points, "step " + std::to_string(step));
      }
      EXPECT_GT(copied_steps, 20u);
    }
  }
}

TEST(EsdfConfig, DefaultsAreValid) {
  std::vector<std::string> errors;
  EsdfConfig{}.validate(&errors);
  EXPECT_TRUE(errors.empty());
  EXPECT_EQ(EsdfConfig{}.unknown_as, UnknownAs::kOccupied);
}

TEST(EsdfConfig, BadValuesNameTheKey) {
  const auto problems = [](const EsdfConfig& c) {
    std::vector<std::string> errors;
    c.validate(&errors);
    return errors;
  };
  for (const double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::infinity()}) {
    EsdfConfig c;
    c.max_distance_m = bad;
    const std::vector<std::string> errors = problems(c);
    ASSERT_EQ(errors.size(), 1u) << bad;
    EXPECT_EQ(errors[0].rfind("esdf.max_distance_m: ", 0), 0u) << errors[0];
    EXPECT_NE(errors[0].find("(got "), std::string::npos) << errors[0];
  }
  for (const int bad : {0, -3, 65}) {
    EsdfConfig c;
    c.num_threads = bad;
    const std::vector<std::string> errors = problems(c);
    ASSERT_EQ(errors.size(), 1u) << bad;
    EXPECT_EQ(errors[0].rfind("esdf.num_threads: ", 0), 0u) << errors[0];
    EXPECT_NE(errors[0].find("(got " + std::to_string(bad) + ")"), std::string::npos) << errors[0];
  }
  EsdfConfig c;
  c.unknown_as = static_cast<UnknownAs>(7);
  c.max_distance_m = -2.0;
  c.num_threads = 0;
  const std::vector<std::string> errors = problems(c);
  ASSERT_EQ(errors.size(), 3u);
  EXPECT_EQ(errors[1].rfind("esdf.unknown_as: ", 0), 0u) << errors[1];
  try {
    EsdfMap map(c);
    ADD_FAILURE() << "an invalid config must throw";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("esdf.max_distance_m"), std::string::npos) << what;
    EXPECT_NE(what.find("esdf.num_threads"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace mlmap
