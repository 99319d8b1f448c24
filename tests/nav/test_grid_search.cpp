// The global search against brute force on small random grids: inflation against a check of
// every cell pair, A* against Dijkstra over all cells (same step rules), shortening against
// dense sampling of its segments.
#include "mlmap/nav/grid_search.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace mlmap::nav {
namespace {

ProjectedGrid randomGrid(std::mt19937& rng, int width, int height, double occupied_fraction,
                         double unknown_fraction) {
  ProjectedGrid g;
  g.origin_W = Eigen::Vector2d(-1.3, 0.7);
  g.resolution_m = 0.2;
  g.width = width;
  g.height = height;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < width * height; ++i) {
    const double r = u(rng);
    g.cells.push_back(r < occupied_fraction                      ? ProjectedGrid::kOccupied
                      : r < occupied_fraction + unknown_fraction ? ProjectedGrid::kUnknown
                                                                 : ProjectedGrid::kFree);
  }
  return g;
}

// Blocked by definition: some occupied (or, pessimistically, unknown) cell's centre within the
// radius of this cell's centre, cells outside the grid being unknown.
bool bruteBlocked(const ProjectedGrid& g, int margin, int x, int y, double radius_m,
                  UnknownAs unknown) {
  for (int sy = -margin; sy < g.height + margin; ++sy) {
    for (int sx = -margin; sx < g.width + margin; ++sx) {
      const bool in = sx >= 0 && sy >= 0 && sx < g.width && sy < g.height;
      const int v = in ? g.at(sx, sy) : -1;
      const bool source = v < 0 ? unknown == UnknownAs::kOccupied : v > 50;
      if (!source) continue;
      const double d = std::hypot(sx + margin - x, sy + margin - y) * g.resolution_m;
      if (d <= radius_m + 1e-9) return true;
    }
  }
  return false;
}

// Dijkstra over every cell, picking the nearest open cell by a linear scan: the same steps and
// costs as searchGrid(), with nothing in common with its code.
double bruteShortest(const PlanningGrid& g, const Eigen::Vector2i& s, const Eigen::Vector2i& t) {
  const int n = g.width * g.height;
  std::vector<double> dist(static_cast<std::size_t>(n), std::numeric_limits<double>::infinity());
  std::vector<bool> done(static_cast<std::size_t>(n), false);
  dist[static_cast<std::size_t>(s.y() * g.width + s.x())] = 0.0;
  for (;;) {
    int best = -1;
    for (int i = 0; i < n; ++i) {
      if (!done[static_cast<std::size_t>(i)] && std::isfinite(dist[static_cast<std::size_t>(i)]) &&
          (best < 0 || dist[static_cast<std::size_t>(i)] < dist[static_cast<std::size_t>(best)])) {
        best = i;
      }
    }
    if (best < 0) break;
    done[static_cast<std::size_t>(best)] = true;
    const int x = best % g.width;
    const int y = best / g.width;
    const bool from_blocked = g.isBlocked(x, y);
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const int nx = x + dx;
        const int ny = y + dy;
        if (!g.inside(nx, ny)) continue;
        if (g.isBlocked(nx, ny) && !from_blocked) continue;
        if (dx != 0 && dy != 0 && !from_blocked && (g.isBlocked(nx, y) || g.isBlocked(x, ny)))
          continue;
        if (g.isSolid(nx, ny)) continue;  // never into an obstacle's own cell, even escaping
        if (dx != 0 && dy != 0 && (g.isSolid(nx, y) || g.isSolid(x, ny))) continue;
        const double step = (dx != 0 && dy != 0 ? std::sqrt(2.0) : 1.0) * g.resolution_m *
                            (from_blocked ? kEscapeCostFactor : 1.0);
        double& d = dist[static_cast<std::size_t>(ny * g.width + nx)];
        d = std::min(d, dist[static_cast<std::size_t>(best)] + step);
      }
    }
  }
  return dist[static_cast<std::size_t>(t.y() * g.width + t.x())];
}

// True when some point of the segment, sampled every 1/200 of a cell, lies in a blocked cell.
bool sampledHitsBlocked(const PlanningGrid& g, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const int samples = std::max(1, static_cast<int>((b - a).norm() / g.resolution_m * 200.0));
  for (int i = 0; i <= samples; ++i) {
    const Eigen::Vector2i c = g.cellOf(a + (b - a) * (static_cast<double>(i) / samples));
    if (!g.inside(c.x(), c.y()) || g.isBlocked(c.x(), c.y())) return true;
  }
  return false;
}

TEST(GridSearch, InflationMarksExactlyTheCellsWithinTheRadiusOfAnObstacle) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 40; ++trial) {
    const ProjectedGrid g = randomGrid(rng, 9 + trial % 5, 7 + trial % 4, 0.08, 0.15);
    const double radius = 0.1 * (trial % 7);
    const UnknownAs unknown = trial % 2 ? UnknownAs::kFree : UnknownAs::kOccupied;
    const int margin = trial % 3;
    const PlanningGrid p = inflateGrid(g, radius, unknown, margin);
    ASSERT_EQ(p.width, g.width + 2 * margin);
    ASSERT_EQ(p.height, g.height + 2 * margin);
    for (int y = 0; y < p.height; ++y) {
      for (int x = 0; x < p.width; ++x) {
        ASSERT_EQ(p.isBlocked(x, y), bruteBlocked(g, margin, x, y, radius, unknown))
            << "trial " << trial << " cell " << x << "," << y;
      }
    }
  }
}

TEST(GridSearch, AStarFindsTheBruteForceShortestLengthAndNeverEntersABlockedCell) {
  std::mt19937 rng(5);
  int found = 0;
  int unreachable = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const ProjectedGrid g = randomGrid(rng, 10 + trial % 9, 8 + trial % 7, 0.06, 0.2);
    const PlanningGrid p = inflateGrid(g, 0.2 * (trial % 3), UnknownAs::kFree);
    std::vector<Eigen::Vector2i> free;
    for (int y = 0; y < p.height; ++y) {
      for (int x = 0; x < p.width; ++x) {
        if (!p.isBlocked(x, y)) free.emplace_back(x, y);
      }
    }
    if (free.size() < 2) continue;
    std::uniform_int_distribution<std::size_t> pick(0, free.size() - 1);
    const Eigen::Vector2i s = free[pick(rng)];
    const Eigen::Vector2i t = free[pick(rng)];
    const GridPath path = searchGrid(p, s, t);
    const double reference = bruteShortest(p, s, t);
    ASSERT_EQ(path.found, std::isfinite(reference)) << "trial " << trial;
    if (!path.found) {
      ++unreachable;
      continue;
    }
    ++found;
    EXPECT_NEAR(path.length_m, reference, 1e-9) << "trial " << trial;
    ASSERT_EQ(path.cells.front(), s);
    ASSERT_EQ(path.cells.back(), t);
    double walked = 0.0;
    for (std::size_t i = 0; i < path.cells.size(); ++i) {
      const Eigen::Vector2i& c = path.cells[i];
      ASSERT_FALSE(p.isBlocked(c.x(), c.y())) << "trial " << trial << " enters a blocked cell";
      if (i == 0) continue;
      const Eigen::Vector2i d = c - path.cells[i - 1];
      ASSERT_LE(d.cwiseAbs().maxCoeff(), 1);
      walked += (d.cast<double>() * p.resolution_m).norm();
      if (d.x() != 0 && d.y() != 0) {  // no corner of a blocked cell cut
        ASSERT_FALSE(p.isBlocked(c.x(), path.cells[i - 1].y()));
        ASSERT_FALSE(p.isBlocked(path.cells[i - 1].x(), c.y()));
      }
    }
    EXPECT_NEAR(walked, path.length_m, 1e-9);
    // The shortened path: from s to t, no longer, every segment clear of blocked cells.
    const std::vector<Eigen::Vector2d> short_path = shortenPath(p, path.cells);
    ASSERT_GE(short_path.size(), 1u);
    EXPECT_TRUE(short_path.front().isApprox(p.cellCenter_W(s)));
    EXPECT_TRUE(short_path.back().isApprox(p.cellCenter_W(t)));
    EXPECT_LE(polylineLength(short_path), path.length_m + 1e-9);
    for (std::size_t i = 1; i < short_path.size(); ++i) {
      ASSERT_FALSE(sampledHitsBlocked(p, short_path[i - 1], short_path[i])) << "trial " << trial;
    }
  }
  EXPECT_GT(found, 150);
  EXPECT_GT(unreachable, 0);  // the random grids include walls that cannot be passed
}

TEST(GridSearch, AStarLeavesAnInflatedZoneByTheShortestWayThenStaysOut) {
  std::mt19937 rng(9);
  for (int trial = 0; trial < 100; ++trial) {
    const ProjectedGrid g = randomGrid(rng, 12, 10, 0.04, 0.0);
    const PlanningGrid p = inflateGrid(g, 0.4, UnknownAs::kFree);
    std::vector<Eigen::Vector2i> blocked;
    std::vector<Eigen::Vector2i> free;
    for (int y = 0; y < p.height; ++y) {
      for (int x = 0; x < p.width; ++x) {
        if (p.isBlocked(x, y)) {
          blocked.emplace_back(x, y);
        } else {
          free.emplace_back(x, y);
        }
      }
    }
    if (blocked.empty() || free.empty()) continue;
    const Eigen::Vector2i s =
        blocked[std::uniform_int_distribution<std::size_t>(0, blocked.size() - 1)(rng)];
    const Eigen::Vector2i t =
        free[std::uniform_int_distribution<std::size_t>(0, free.size() - 1)(rng)];
    const GridPath path = searchGrid(p, s, t);
    const double reference = bruteShortest(p, s, t);
    ASSERT_EQ(path.found, std::isfinite(reference));
    if (!path.found) continue;
    EXPECT_NEAR(path.length_m, reference, 1e-9);
    // Once out of the inflated zone, the path never enters it again; it never enters an
    // occupied cell (the start excepted), nor cuts the corner of one.
    bool out = false;
    for (std::size_t i = 0; i < path.cells.size(); ++i) {
      const Eigen::Vector2i& c = path.cells[i];
      if (!p.isBlocked(c.x(), c.y())) out = true;
      if (out) {
        ASSERT_FALSE(p.isBlocked(c.x(), c.y())) << "trial " << trial;
      }
      if (i == 0) continue;
      ASSERT_NE(g.at(c.x(), c.y()), ProjectedGrid::kOccupied) << "trial " << trial;
      const Eigen::Vector2i& b = path.cells[i - 1];
      if (b.x() == c.x() || b.y() == c.y()) continue;
      ASSERT_NE(g.at(c.x(), b.y()), ProjectedGrid::kOccupied) << "trial " << trial;
      ASSERT_NE(g.at(b.x(), c.y()), ProjectedGrid::kOccupied) << "trial " << trial;
    }
  }
}

TEST(GridSearch, AnEscapeFromBesideAWallGoesRoundByTheDoorNotThroughTheWall) {
  // A room's east wall (one cell thick, x = 20) with a door at its north end; the start is in
  // the inflated zone beside the wall, the goal just behind it. Through the wall: 1.4 m of
  // escape steps (5.6 m at 4x); round by the door: about 12 m. building_s20 hovered at the wall
  // for 150 s on such a route, which the local planner could never commit to.
  ProjectedGrid g;
  g.resolution_m = 0.2;
  g.width = 40;
  g.height = 40;
  g.cells.assign(1600, ProjectedGrid::kFree);
  for (int y = 0; y < 30; ++y)
    g.cells[static_cast<std::size_t>(y * 40 + 20)] = ProjectedGrid::kOccupied;
  const PlanningGrid p = inflateGrid(g, 0.6, UnknownAs::kFree);
  const Eigen::Vector2i start(18, 10);  // 0.4 m from the wall's cell
  const Eigen::Vector2i goal(24, 10);
  ASSERT_TRUE(p.isBlocked(start.x(), start.y()));
  const GridPath path = searchGrid(p, start, goal);
  ASSERT_TRUE(path.found);
  for (const Eigen::Vector2i& c : path.cells)
    ASSERT_NE(g.at(c.x(), c.y()), ProjectedGrid::kOccupied);
  EXPECT_GT(path.length_m, 8.0);
  EXPECT_NEAR(path.length_m, bruteShortest(p, start, goal), 1e-9);
  // Without the door the goal cannot be reached (before: through the wall).
  for (int y = 30; y < 40; ++y)
    g.cells[static_cast<std::size_t>(y * 40 + 20)] = ProjectedGrid::kOccupied;
  EXPECT_FALSE(searchGrid(inflateGrid(g, 0.6, UnknownAs::kFree), start, goal).found);
}

TEST(GridSearch, LineFreeAgreesWithDenseSampling) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int free_lines = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const ProjectedGrid g = randomGrid(rng, 10, 10, 0.03, 0.0);
    const PlanningGrid p = inflateGrid(g, 0.0, UnknownAs::kFree);
    // Cell centres, as shortenPath() uses them (general points: a line through a corner of a
    // blocked cell counts as blocked for isLineFree(), which sampling can miss).
    const Eigen::Vector2i a(static_cast<int>(u(rng) * 10), static_cast<int>(u(rng) * 10));
    const Eigen::Vector2i b(static_cast<int>(u(rng) * 10), static_cast<int>(u(rng) * 10));
    const bool line_free = isLineFree(p, p.cellCenter_W(a), p.cellCenter_W(b));
    const bool sampled_free = !sampledHitsBlocked(p, p.cellCenter_W(a), p.cellCenter_W(b));
    if (line_free) {
      ++free_lines;
      ASSERT_TRUE(sampled_free) << "trial " << trial;  // never optimistic
    }
  }
  EXPECT_GT(free_lines, 300);
}

TEST(GridSearch, NoPathWhenTheGoalIsWalledOffOrOutsideTheGrid) {
  ProjectedGrid g;
  g.resolution_m = 0.2;
  g.width = 10;
  g.height = 6;
  g.cells.assign(60, ProjectedGrid::kFree);
  for (int y = 0; y < 6; ++y)
    g.cells[static_cast<std::size_t>(y * 10 + 5)] = ProjectedGrid::kOccupied;
  const PlanningGrid p = inflateGrid(g, 0.0, UnknownAs::kFree);
  EXPECT_FALSE(searchGrid(p, {1, 1}, {8, 1}).found);
  EXPECT_FALSE(searchGrid(p, {1, 1}, {10, 1}).found);
  EXPECT_TRUE(searchGrid(p, {1, 1}, {4, 5}).found);
  // Unknown cells: passable when optimistic, not when pessimistic.
  g.cells[static_cast<std::size_t>(3 * 10 + 5)] = ProjectedGrid::kUnknown;
  EXPECT_TRUE(searchGrid(inflateGrid(g, 0.0, UnknownAs::kFree), {1, 1}, {8, 1}).found);
  EXPECT_FALSE(searchGrid(inflateGrid(g, 0.0, UnknownAs::kOccupied), {1, 1}, {8, 1}).found);
}

}  // namespace
}  // namespace mlmap::nav
