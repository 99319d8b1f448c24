// FixedOriginGrid against a slow reference: a map from world cell to the latest known value.
#include "mlmap/planning/fixed_origin_grid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <utility>

namespace mlmap {
namespace {

using Cell = std::pair<int, int>;

/// A rolling grid of `w` x `h` cells at world cell `origin`, random values (a third unknown).
ProjectedGrid randomGrid(const Cell& origin, int w, int h, double resolution_m,
                         std::mt19937* random) {
  ProjectedGrid grid;
  grid.resolution_m = resolution_m;
  grid.origin_W = Eigen::Vector2d(origin.first, origin.second) * resolution_m;
  grid.width = w;
  grid.height = h;
  grid.cells.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  std::uniform_int_distribution<int> kind(0, 2);
  for (std::int8_t& c : grid.cells) {
    const int k = kind(*random);
    c = k == 0 ? ProjectedGrid::kUnknown
               : (k == 1 ? ProjectedGrid::kFree : ProjectedGrid::kOccupied);
  }
  return grid;
}

/// The reference: every known cell of every rolling grid, the latest value winning.
void absorbReference(const ProjectedGrid& rolling, const Cell& origin,
                     std::map<Cell, std::int8_t>* ref) {
  for (int y = 0; y < rolling.height; ++y) {
    for (int x = 0; x < rolling.width; ++x) {
      if (rolling.at(x, y) != ProjectedGrid::kUnknown)
        (*ref)[{origin.first + x, origin.second + y}] = rolling.at(x, y);
    }
  }
}

void expectEqualToReference(const FixedOriginGrid& fixed, const std::map<Cell, std::int8_t>& ref,
                            int chunk) {
  const ProjectedGrid& g = fixed.grid();
  const double res = g.resolution_m;
  const int ox = static_cast<int>(std::lround(g.origin_W.x() / res));
  const int oy = static_cast<int>(std::lround(g.origin_W.y() / res));
  ASSERT_EQ(ox % chunk, 0);  // chunk corners on the world lattice
  ASSERT_EQ(oy % chunk, 0);
  ASSERT_EQ(g.width % chunk, 0);
  ASSERT_EQ(g.height % chunk, 0);
  std::size_t known = 0;
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      const auto it = ref.find({ox + x, oy + y});
      const std::int8_t expected = it == ref.end() ? ProjectedGrid::kUnknown : it->second;
      ASSERT_EQ(g.at(x, y), expected) << "cell " << ox + x << ", " << oy + y;
      if (it != ref.end()) ++known;
    }
  }
  EXPECT_EQ(known, ref.size()) << "a known cell lies outside the grid";
}

TEST(FixedOriginGrid, HoldsTheLatestKnownValueOfEveryCellAsTheReferenceDoes) {
  constexpr int kChunk = 16;
  FixedOriginGrid fixed(kChunk);
  std::map<Cell, std::int8_t> ref;
  std::mt19937 random(3);
  std::uniform_int_distribution<int> step(-12, 12);
  Cell origin{-40, 25};
  Eigen::Vector2d first_origin_W;
  for (int frame = 0; frame < 60; ++frame) {
    origin.first += step(random);
    origin.second += step(random);
    const ProjectedGrid rolling = randomGrid(origin, 30, 22, 0.1, &random);
    ASSERT_TRUE(fixed.absorb(rolling));
    absorbReference(rolling, origin, &ref);
    expectEqualToReference(fixed, ref, kChunk);
    if (frame == 0) first_origin_W = fixed.grid().origin_W;
    // The origin only moves towards -x / -y, by whole chunks.
    EXPECT_LE(fixed.grid().origin_W.x(), first_origin_W.x() + 1e-9);
    EXPECT_LE(fixed.grid().origin_W.y(), first_origin_W.y() + 1e-9);
  }
  EXPECT_GT(fixed.growths(), 1u);
  EXPECT_LT(fixed.growths(), 60u);  // steps, not every frame
  EXPECT_EQ(fixed.cellsDropped(), 0u);
}

TEST(FixedOriginGrid, UnknownCellsOfARollingGridChangeNothing) {
  FixedOriginGrid fixed(8);
  ProjectedGrid rolling;
  rolling.resolution_m = 0.2;
  rolling.origin_W = Eigen::Vector2d(0.4, -0.2);
  rolling.width = 3;
  rolling.height = 2;
  rolling.cells = {100, 0, -1, 0, 0, 100};
  ASSERT_TRUE(fixed.absorb(rolling));
  const std::uint64_t changes = fixed.changes();
  rolling.cells.assign(6, ProjectedGrid::kUnknown);
  ASSERT_TRUE(fixed.absorb(rolling));
  EXPECT_EQ(fixed.changes(), changes);
  EXPECT_EQ(fixed.grid().valueAt(Eigen::Vector2d(0.5, -0.1)), 100);
  EXPECT_EQ(fixed.grid().valueAt(Eigen::Vector2d(0.9, 0.1)), 100);
  EXPECT_EQ(fixed.grid().valueAt(Eigen::Vector2d(0.9, -0.1)), ProjectedGrid::kUnknown);
}

TEST(FixedOriginGrid, StopsGrowingAtItsLimitAndCountsWhatFellOutside) {
  constexpr int kChunk = 4;
  FixedOriginGrid fixed(kChunk, 4 * kChunk * kChunk);  // at most 4 chunks
  std::mt19937 random(5);
  ProjectedGrid rolling = randomGrid({0, 0}, 8, 8, 0.1, &random);
  ASSERT_TRUE(fixed.absorb(rolling));
  EXPECT_EQ(fixed.grid().width * fixed.grid().height, 64);
  rolling = randomGrid({100, 0}, 4, 4, 0.1, &random);  // far away: 4 more chunks would be needed
  std::size_t known = 0;
  for (const std::int8_t c : rolling.cells) known += c != ProjectedGrid::kUnknown ? 1 : 0;
  ASSERT_TRUE(fixed.absorb(rolling));
  EXPECT_EQ(fixed.grid().width * fixed.grid().height, 64);
  EXPECT_EQ(fixed.cellsDropped(), known);
}

TEST(FixedOriginGrid, RefusesAnotherResolutionAnOffLatticeOriginAndBadLimits) {
  FixedOriginGrid fixed(8);
  std::mt19937 random(7);
  ASSERT_TRUE(fixed.absorb(randomGrid({0, 0}, 4, 4, 0.1, &random)));
  EXPECT_FALSE(fixed.absorb(randomGrid({0, 0}, 4, 4, 0.2, &random)));
  ProjectedGrid off = randomGrid({0, 0}, 4, 4, 0.1, &random);
  off.origin_W.x() = 0.05;
  EXPECT_FALSE(fixed.absorb(off));
  EXPECT_TRUE(fixed.absorb(ProjectedGrid{}));  // empty: nothing to do
  EXPECT_THROW(FixedOriginGrid(0), std::invalid_argument);
  EXPECT_THROW(FixedOriginGrid(8, 63), std::invalid_argument);
}

}  // namespace
}  // namespace mlmap
