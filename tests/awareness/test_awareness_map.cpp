#include "mlmap/awareness/awareness_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <tuple>
#include <vector>

namespace mlmap {
namespace {

AwarenessConfig smallConfig() {
  AwarenessConfig c;
  c.rho_cell_m = 0.1;
  c.rho_cells = 60;  // 6 m
  c.phi_cells = 90;  // 4 deg
  c.z_cell_m = 0.2;
  c.z_cells = 20;
  c.z_cells_below = 10;
  c.max_range_m = 6.0;
  return c;
}

// The sector as cellOf() computed it with atan2 alone (before the boundary test).
int referencePhiIndex(const AwarenessConfig& c, double dx, double dy) {
  double phi = std::atan2(dy, dx);
  if (phi < 0.0) phi += 2.0 * 3.14159265358979323846;
  int i = static_cast<int>(phi / c.phi_cell_rad());
  if (i >= c.phi_cells) i -= c.phi_cells;
  return i;
}

// cellOf() finds the sector by the side of the sector boundaries a direction lies on (atan2 only
// next to a boundary): the same sector as atan2 for random directions, for directions on the
// boundaries and a hair either side of them, on the axes, and for every sector count.
TEST(AwarenessMap, SectorOfADirectionIsAtan2s) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(-4.0, 4.0);
  std::uniform_real_distribution<double> radius(1e-6, 9.0);
  std::size_t checked = 0;
  for (const int phi_cells : {4, 7, 90, 180, 360, 4096}) {
    AwarenessConfig c = smallConfig();
    c.phi_cells = phi_cells;
    AwarenessMap map(c);  // origin at 0
    auto expectSame = [&](double dx, double dy) {
      AwarenessCell cell;
      if (!map.cellOf(Eigen::Vector3d(dx, dy, 0.05), &cell)) return;
      ASSERT_EQ(cell.phi, referencePhiIndex(c, dx, dy))
          << phi_cells << " sectors, direction (" << dx << ", " << dy << ")";
      ++checked;
    };
    for (int i = 0; i < 20000; ++i) {
      const double a = angle(rng);
      const double r = radius(rng);
      expectSame(r * std::cos(a), r * std::sin(a));
    }
    for (int k = 0; k <= phi_cells; ++k) {
      const double theta = k * c.phi_cell_rad();
      for (const double off : {0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6, -1e-6}) {
        for (const double r : {1e-6, 0.5, 5.9}) {
          expectSame(r * std::cos(theta + off), r * std::sin(theta + off));
        }
      }
    }
    for (const double r : {0.0, 1e-300, 1.0}) {
      for (const double sx : {1.0, -1.0, 0.0}) {
        for (const double sy : {1.0, -1.0, 0.0, -0.0}) expectSame(sx * r, sy * r);
      }
    }
  }
  EXPECT_GT(checked, 150000u);
}

// Slow reference: walk the 3D segment from the origin to the hit in 1 mm steps; every cell a
// sample falls in must be free, except cells hit in this frame.
void expectRayCleared(const AwarenessMap& map, const Eigen::Vector3d& from,
                      const Eigen::Vector3d& to, const std::vector<Eigen::Vector3d>& hits,
                      const std::string& what) {
  std::vector<std::size_t> hit_ids;
  auto same_cell = [&](const AwarenessCell& a, const AwarenessCell& b) {
    return a.rho == b.rho && a.phi == b.phi && a.z == b.z;
  };
  const int steps = static_cast<int>((to - from).norm() / 0.001) + 1;
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector3d p = from + (to - from) * (static_cast<double>(i) / steps);
    // A point on the axis itself belongs to no sector in particular.
    if ((p - map.origin_W()).head<2>().norm() < 1e-9) continue;
    AwarenessCell cell;
    if (!map.cellOf(p, &cell)) continue;
    bool is_hit = false;
    for (const Eigen::Vector3d& h : hits) {
      AwarenessCell hc;
      if (map.cellOf(h, &hc) && same_cell(hc, cell)) is_hit = true;
    }
    if (is_hit) {
      ASSERT_EQ(map.state(cell), Occupancy::kOccupied) << what;
    } else {
      ASSERT_EQ(map.state(cell), Occupancy::kFree)
          << what << ": cell rho " << cell.rho << " phi " << cell.phi << " z " << cell.z << " at "
          << p.transpose() << " (sample " << i << "/" << steps << ") not cleared";
    }
  }
}

TEST(AwarenessMap, RaysClearEveryCellUpToTheHitInEverySectorAndAtTheBorders) {
  const AwarenessConfig config = smallConfig();
  const Eigen::Vector3d body(3.3, -1.7, 1.25);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double top = (config.z_cells - config.z_cells_below) * config.z_cell_m;
  const double bottom = -config.z_cells_below * config.z_cell_m;
  for (int phi = 0; phi < config.phi_cells; ++phi) {
    AwarenessMap map(config);
    map.beginFrame(body);
    // One ray per sector, at a random angle inside it; every fifth ends at a z border, and
    // sector 0 gets one at its very start.
    const double angle = (phi + (phi == 0 ? 0.01 : unit(rng))) * config.phi_cell_rad();
    const double rho = 0.3 + unit(rng) * 5.5;
    double z = bottom + 0.01 + unit(rng) * (top - bottom - 0.02);
    if (phi % 5 == 1) z = top - 0.001;
    if (phi % 5 == 2) z = bottom + 0.001;
    const Eigen::Vector3d hit =
        body + Eigen::Vector3d(rho * std::cos(angle), rho * std::sin(angle), z);
    ASSERT_TRUE(map.markHit(hit));
    map.castRaysToHits();
    map.endFrame();
    expectRayCleared(map, body, hit, {hit}, "sector " + std::to_string(phi));
    AwarenessCell cell;
    ASSERT_TRUE(map.cellOf(hit, &cell));
    EXPECT_EQ(cell.phi, phi);
  }
}

// The other direction: a ray clears nothing it does not reach. Every free cell must be crossed
// by some ray from the origin into the hit cell (dense rays to its corners and interior).
TEST(AwarenessMap, RaysClearNothingBeyondTheirCone) {
  const AwarenessConfig config = smallConfig();
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    AwarenessMap map(config);
    const Eigen::Vector3d body(0.0, 0.0, 0.0);
    map.beginFrame(body);
    const double angle = unit(rng) * 6.283;
    const double rho = 0.2 + unit(rng) * 5.5;
    const double z = -1.9 + unit(rng) * 3.8;
    const Eigen::Vector3d hit(rho * std::cos(angle), rho * std::sin(angle), z);
    ASSERT_TRUE(map.markHit(hit));
    if (trial % 2 == 1) {  // a second, nearer hit in the same sector must not widen the first
      ASSERT_TRUE(map.markHit(0.4 * hit + Eigen::Vector3d(0.0, 0.0, 0.5)));
    }
    map.castRaysToHits();
    map.endFrame();
    // Reference: cells crossed by rays to a 21 x 21 grid over each hit cell's rho-z rectangle.
    std::set<std::tuple<int, int, int>> reached;
    for (const Eigen::Vector3d& h :
         {hit, Eigen::Vector3d(0.4 * hit + Eigen::Vector3d(0, 0, 0.5))}) {
      AwarenessCell hc;
      ASSERT_TRUE(map.cellOf(h, &hc));
      const double phi = std::atan2(h.y(), h.x());
      for (int a = 0; a <= 20; ++a) {
        for (int b = 0; b <= 20; ++b) {
          const double r = (hc.rho + 0.001 + 0.998 * a / 20.0) * config.rho_cell_m;
          const double zz =
              (hc.z - config.z_cells_below + 0.001 + 0.998 * b / 20.0) * config.z_cell_m;
          const Eigen::Vector3d target(r * std::cos(phi), r * std::sin(phi), zz);
          // The ray from the origin to the target, cut where it crosses a rho or z cell border
          // (rho and z grow linearly along it); each piece's midpoint names a reached cell.
          std::vector<double> cuts = {0.0, 1.0};
          for (double border = config.rho_cell_m; border < r; border += config.rho_cell_m) {
            cuts.push_back(border / r);
          }
          for (double border = 0.0; std::abs(border) < std::abs(zz);
               border += std::copysign(config.z_cell_m, zz)) {
            cuts.push_back(border / zz);
          }
          std::sort(cuts.begin(), cuts.end());
          for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
            AwarenessCell c;
            const double t = 0.5 * (cuts[i] + cuts[i + 1]);
            if (cuts[i + 1] - cuts[i] > 1e-9 && map.cellOf(target * t, &c))
              reached.insert({c.rho, c.phi, c.z});
          }
        }
      }
    }
    for (int r = 0; r < config.rho_cells; ++r) {
      for (int p = 0; p < config.phi_cells; ++p) {
        for (int k = 0; k < config.z_cells; ++k) {
          if (map.state({r, p, k}) != Occupancy::kFree) continue;
          EXPECT_EQ(reached.count({r, p, k}), 1u)
              << "trial " << trial << ": cell rho " << r << " phi " << p << " z " << k
              << " cleared though no ray into the hit reaches it";
        }
      }
    }
  }
}

TEST(AwarenessMap, RhoZeroColumnAndSteepRays) {
  const AwarenessConfig config = smallConfig();
  const Eigen::Vector3d body(0.0, 0.0, 0.0);
  AwarenessMap map(config);
  map.beginFrame(body);
  // Almost straight up and down: the rays stay in rho index 0.
  const std::vector<Eigen::Vector3d> hits = {
      {0.03, 0.02, 1.9}, {-0.02, 0.05, -1.95}, {0.5, 0.01, 1.95}};
  for (const auto& h : hits) ASSERT_TRUE(map.markHit(h));
  map.castRaysToHits();
  map.endFrame();
  for (const auto& h : hits) expectRayCleared(map, body, h, hits, "steep ray");
}

TEST(AwarenessMap, HitWinsOverMissInTheSameFrame) {
  AwarenessMap map(smallConfig());
  map.beginFrame(Eigen::Vector3d::Zero());
  const Eigen::Vector3d near(1.05, 0.05, 0.1);
  const Eigen::Vector3d far(3.05, 0.15, 0.3);  // its ray passes through near's cell
  ASSERT_TRUE(map.markHit(near));
  ASSERT_TRUE(map.markHit(far));
  map.castRaysToHits();
  map.endFrame();
  EXPECT_EQ(map.stateAt(near), Occupancy::kOccupied);
  EXPECT_EQ(map.stateAt(far), Occupancy::kOccupied);
  EXPECT_EQ(map.stateAt({2.0, 0.1, 0.2}), Occupancy::kFree);
  EXPECT_EQ(map.stateAt({-2.0, 0.1, 0.2}), Occupancy::kUnknown);
}

TEST(AwarenessMap, RayCutAtMaximumRangeClearsToTheBorderAndIsNoHit) {
  AwarenessMap map(smallConfig());
  map.beginFrame(Eigen::Vector3d::Zero());
  const Eigen::Vector3d end(5.95, 0.2, 0.5);
  map.castRay(end, /*end_is_free=*/true);
  map.endFrame();
  EXPECT_EQ(map.stateAt(end), Occupancy::kFree);
  EXPECT_EQ(map.count(Occupancy::kOccupied), 0u);
  expectRayCleared(map, Eigen::Vector3d::Zero(), end, {}, "cut ray");
  // A ray leaving through the top is cut at the top border.
  map.beginFrame(Eigen::Vector3d::Zero());
  const Eigen::Vector3d up(1.0, 0.0, 10.0);
  map.castRay(up, /*end_is_free=*/true);
  map.endFrame();
  expectRayCleared(map, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.1999, 0.0, 1.999), {}, "top");
}

TEST(AwarenessMap, ObstaclesAreCarriedByThePoseChangeAndClearedByLaterRays) {
  AwarenessMap map(smallConfig());
  const Eigen::Vector3d obstacle(2.0, 1.0, 0.5);
  map.beginFrame({0.0, 0.0, 0.0});
  ASSERT_TRUE(map.markHit(obstacle));
  map.castRaysToHits();
  map.endFrame();
  // The body moves 1.3 m; no ray this frame: the obstacle is still where it was in the world.
  map.beginFrame({-1.3, 0.4, 0.2});
  map.endFrame();
  EXPECT_EQ(map.stateAt(obstacle), Occupancy::kOccupied);
  AwarenessCell cell;
  ASSERT_TRUE(map.cellOf(obstacle, &cell));
  EXPECT_LT((map.cellCenter(cell) - obstacle).norm(), 0.25);
  ASSERT_EQ(map.occupiedPoints().size(), 1u);
  EXPECT_EQ(map.occupiedPoints()[0], obstacle);  // the measured point, not a cell centre
  // Now a ray to something behind it passes through: the obstacle moved away.
  map.beginFrame({-1.3, 0.4, 0.2});
  const Eigen::Vector3d behind =
      Eigen::Vector3d(-1.3, 0.4, 0.2) + 1.6 * (obstacle - Eigen::Vector3d(-1.3, 0.4, 0.2));
  ASSERT_TRUE(map.markHit(behind));
  map.castRaysToHits();
  map.endFrame();
  EXPECT_EQ(map.stateAt(obstacle), Occupancy::kFree);
  // Carried obstacles leaving the grid are dropped.
  map.beginFrame({100.0, 0.0, 0.0});
  map.endFrame();
  EXPECT_EQ(map.count(Occupancy::kOccupied), 0u);
}

}  // namespace
}  // namespace mlmap
