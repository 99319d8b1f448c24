// The generated worlds: reproducible, fair (a route exists, the start cannot see the goal) and
// scored by a ground truth that agrees with the world's own queries.
#include "mlmap/nav/nav_worlds.h"

#include "mlmap/nav/grid_search.h"

#include <gtest/gtest.h>

namespace mlmap::nav {
namespace {

std::vector<NavWorld> someWorlds() {
  return {forestWorld(1, 0.03, {16.0, 10.0}),
          forestWorld(2, 0.09, {24.0, 12.0}),
          roomsWorld(3, 2),
          roomsWorld(4, 3),
          paperRoomWorld(5),
          buildingFloorWorld(6),
          buildingFloorWorld(7)};
}

TEST(NavWorlds, EachHasARouteWithClearanceAndAGoalTheStartCannotSee) {
  for (const NavWorld& w : someWorlds()) {
    SCOPED_TRACE(w.name);
    EXPECT_FALSE(seesPoint(w.world, w.start_W, w.goal_W));
    const std::vector<Eigen::Vector2d> route = shortestRoute(w, 0.6, 0.1);
    ASSERT_GE(route.size(), 2u);
    EXPECT_GT(polylineLength(route), (w.goal_W - w.start_W).head<2>().norm());
    // Every point of the route keeps the clearance (sampled; cell centres kept 0.6 m, a line
    // between them may pass a corner by less than half a cell).
    for (std::size_t i = 1; i < route.size(); ++i) {
      for (int k = 0; k <= 50; ++k) {
        const Eigen::Vector2d p = route[i - 1] + (route[i] - route[i - 1]) * (k / 50.0);
        ASSERT_GT(w.world.distance({p.x(), p.y(), w.start_W.z()}), 0.6 - 0.08);
      }
    }
  }
}

TEST(NavWorlds, TheSameSeedGivesTheSameWorld) {
  const NavWorld a = forestWorld(7, 0.06, {24.0, 12.0});
  const NavWorld b = forestWorld(7, 0.06, {24.0, 12.0});
  const NavWorld c = forestWorld(8, 0.06, {24.0, 12.0});
  ASSERT_EQ(a.world.cylinders().size(), b.world.cylinders().size());
  for (std::size_t i = 0; i < a.world.cylinders().size(); ++i) {
    EXPECT_EQ(a.world.cylinders()[i].center_xy_W, b.world.cylinders()[i].center_xy_W);
  }
  EXPECT_EQ(a.start_W, b.start_W);
  EXPECT_NE(a.start_W, c.start_W);
  EXPECT_GT(a.world.cylinders().size(), 5u);
}

TEST(NavWorlds, ThePersonCrossesTheRouteAndClearanceSeesIt) {
  NavWorld w = forestWorld(4, 0.03, {20.0, 10.0});
  const std::vector<Eigen::Vector2d> route = shortestRoute(w, 0.6, 0.1);
  addCrossingPerson(&w, route, 1.5);
  ASSERT_EQ(w.world.movingBoxes().size(), 1u);
  const sim::MovingBox& person = w.world.movingBoxes().front();
  // Halfway along the route, at some time the person stands on it.
  double walked = 0.0;
  Eigen::Vector2d half = route.front();
  const double length = polylineLength(route);
  for (std::size_t i = 1; i < route.size(); ++i) {
    const double seg = (route[i] - route[i - 1]).norm();
    if (walked + seg >= 0.5 * length) {
      half = route[i - 1] + (route[i] - route[i - 1]) * ((0.5 * length - walked) / seg);
      break;
    }
    walked += seg;
  }
  const Eigen::Vector3d p(half.x(), half.y(), 1.0);
  double min_gap = 1e9;
  for (double t = person.t_start_s; t <= person.t_end_s; t += 0.01) {
    min_gap = std::min(min_gap, clearance(w.world, p, t));
  }
  EXPECT_EQ(min_gap, 0.0);
  EXPECT_GT(clearance(w.world, p, person.t_end_s + 1.0), 0.5);  // gone, the static world alone
  EXPECT_DOUBLE_EQ(clearance(w.world, p, person.t_end_s + 1.0), w.world.distance(p));
}

}  // namespace
}  // namespace mlmap::nav
