// The local planner and the navigator on hand-made snapshots: what is committed keeps clear of
// obstacles and of unknown space (checked against the voxels themselves), pushing moves points
// away, a new obstacle across the committed segment makes a plan at once, and the setpoints stop
// the vehicle before the committed end.
#include "mlmap/nav/navigator.h"
#include "mlmap/sim/vehicle.h"

#include <gtest/gtest.h>

#include <functional>
#include <memory>

namespace mlmap::nav {
namespace {

constexpr double kRes = 0.2;

/// A snapshot of a 10 x 6 x 3 m window (x in [-2, 8], y in [-3, 3], z in [0, 3]) whose voxel
/// states `state` gives, with its 2D grid (band 0.5..1.5 m) and ESDF (unknown as free).
std::shared_ptr<const MapSnapshot> snapshotOf(
    const std::function<Occupancy(const VoxelIndex&)>& state, std::uint64_t frame) {
  auto window = std::make_shared<LocalWindow>();
  window->min_index = VoxelIndex(-10, -15, 0);
  window->size = Eigen::Vector3i(50, 30, 15);
  window->resolution_m = kRes;
  window->log_odds.assign(static_cast<std::size_t>(window->size.prod()), kUnknownLogOdds);
  OccupancyBox box;
  box.reset(window->min_index, window->size, kRes);
  for (int x = 0; x < window->size.x(); ++x) {
    for (int y = 0; y < window->size.y(); ++y) {
      for (int z = 0; z < window->size.z(); ++z) {
        const VoxelIndex g = window->min_index + VoxelIndex(x, y, z);
        const Occupancy s = state(g);
        window->log_odds[boxOffset(window->min_index, window->size, g)] =
            s == Occupancy::kOccupied ? quantizeLogOdds(2.0)
            : s == Occupancy::kFree   ? quantizeLogOdds(-1.0)
                                      : kUnknownLogOdds;
        box.at(g) = s;
      }
    }
  }
  EsdfConfig esdf_config;
  esdf_config.unknown_as = UnknownAs::kFree;
  auto esdf = std::make_shared<EsdfMap>(esdf_config);
  EXPECT_TRUE(esdf->compute(box));
  ProjectedGridConfig grid_config;
  grid_config.relative_band = false;
  grid_config.band_min_m = 0.5;
  grid_config.band_max_m = 1.5;
  auto grid = std::make_shared<ProjectedGrid>();
  projectToGrid(*window, nullptr, grid_config, 1.0, grid.get());
  return std::make_shared<MapSnapshot>(window, grid, esdf, frame, 0.1 * static_cast<double>(frame),
                                       Transform::Identity(), frame);
}

Occupancy freeExcept(const VoxelIndex& g,
                     const std::function<bool(const Eigen::Vector3d&)>& occupied) {
  const Eigen::Vector3d c = (g.cast<double>() + Eigen::Vector3d::Constant(0.5)) * kRes;
  return occupied(c) ? Occupancy::kOccupied : Occupancy::kFree;
}

/// Distance from p to the nearest occupied voxel's centre of `map` (brute force) [m].
double nearestOccupied(const MapSnapshot& map, const Eigen::Vector3d& p) {
  const LocalWindow& w = map.window();
  double best = 1e9;
  for (int x = 0; x < w.size.x(); ++x) {
    for (int y = 0; y < w.size.y(); ++y) {
      for (int z = 0; z < w.size.z(); ++z) {
        const VoxelIndex g = w.min_index + VoxelIndex(x, y, z);
        if (w.state(g) != Occupancy::kOccupied) continue;
        best =
            std::min(best, ((g.cast<double>() + Eigen::Vector3d::Constant(0.5)) * kRes - p).norm());
      }
    }
  }
  return best;
}

const std::vector<Eigen::Vector3d> kRoute = {{0.0, 0.1, 1.1}, {7.0, 0.1, 1.1}};

TEST(LocalPlanner, CommitsUpToTheClearanceBeforeAWallAcrossTheRoute) {
  const auto map = snapshotOf(
      [](const VoxelIndex& g) {
        return freeExcept(g, [](const Eigen::Vector3d& c) { return c.x() > 2.0 && c.x() < 2.2; });
      },
      1);
  LocalPlannerConfig config;
  const LocalPlan plan = planLocal(*map, config, kRoute, kRoute.front());
  ASSERT_GE(plan.committed, 2u);
  for (const Eigen::Vector3d& p : plan.committedPoints()) {
    EXPECT_GE(nearestOccupied(*map, p), config.commit_clearance_m - 1e-6);
  }
  // It goes as far as the clearance lets it: to within a sample step of it.
  EXPECT_GT(plan.committedPoints().back().x(),
            2.1 - config.commit_clearance_m - 2 * config.sample_step_m);
  EXPECT_GT(plan.points_W.size(), plan.committed);  // the rest is planned, not committed
}

TEST(LocalPlanner, NeverCommitsIntoUnknownSpace) {
  const auto map = snapshotOf(
      [](const VoxelIndex& g) {
        const double x = (g.x() + 0.5) * kRes;
        const double y = (g.y() + 0.5) * kRes;
        return x > 1.5 + 0.3 * y ? Occupancy::kUnknown : Occupancy::kFree;  // a slanted frontier
      },
      1);
  LocalPlannerConfig config;
  const LocalPlan plan = planLocal(*map, config, kRoute, kRoute.front());
  ASSERT_GE(plan.committed, 2u);
  const std::vector<Eigen::Vector3d> committed = plan.committedPoints();
  for (std::size_t i = 1; i < committed.size(); ++i) {
    for (int k = 0; k <= 100; ++k) {  // every voxel the committed line passes through is free
      const Eigen::Vector3d p = committed[i - 1] + (committed[i] - committed[i - 1]) * (k / 100.0);
      if ((p - committed.front()).norm() < config.own_radius_m) continue;
      ASSERT_EQ(map->state(p), Occupancy::kFree) << p.transpose();
    }
  }
  EXPECT_GT(plan.committed_length_m, 1.0);
}

TEST(LocalPlanner, PushesTheRouteAwayFromAPillarBesideIt) {
  const auto map = snapshotOf(
      [](const VoxelIndex& g) {
        return freeExcept(g, [](const Eigen::Vector3d& c) {
          return (c.head<2>() - Eigen::Vector2d(2.0, -0.5)).norm() < 0.3;
        });
      },
      1);
  LocalPlannerConfig config;
  config.horizon_m = 4.0;
  const std::vector<Eigen::Vector3d> straight =
      routeAhead(kRoute, kRoute.front(), 4.0, config.sample_step_m);
  std::vector<Eigen::Vector3d> pushed = straight;
  pushAwayFromObstacles(*map, config, &pushed);
  double min_straight = 1e9;
  double min_pushed = 1e9;
  for (std::size_t i = 0; i < straight.size(); ++i) {
    min_straight = std::min(min_straight, nearestOccupied(*map, straight[i]));
    min_pushed = std::min(min_pushed, nearestOccupied(*map, pushed[i]));
    EXPECT_LE((pushed[i] - straight[i]).norm(), config.max_push_m + 1e-9);
    EXPECT_DOUBLE_EQ(pushed[i].z(), straight[i].z());
  }
  EXPECT_LT(min_straight,
            config.commit_clearance_m);  // the straight route would not commit past it
  EXPECT_GT(min_pushed, min_straight + 0.15);
  const LocalPlan plan = planLocal(*map, config, kRoute, kRoute.front());
  EXPECT_GT(plan.committedPoints().back().x(), 3.0);  // pushed, it commits past the pillar
}

TEST(Navigator, ANewObstacleAcrossTheCommittedSegmentMakesAPlanAtOnceThatStopsBeforeIt) {
  const auto clear = snapshotOf(
      [](const VoxelIndex& g) {
        return freeExcept(g, [](const Eigen::Vector3d&) { return false; });
      },
      1);
  const auto person = snapshotOf(
      [](const VoxelIndex& g) {
        return freeExcept(g, [](const Eigen::Vector3d& c) {
          return std::abs(c.x() - 1.6) < 0.25 && std::abs(c.y() - 0.1) < 0.25;
        });
      },
      2);
  NavigatorConfig config;
  Navigator navigator(config);
  const Eigen::Vector3d start(0.0, 0.1, 1.1);
  navigator.setGoal({6.0, 0.1, 1.1});
  ASSERT_EQ(navigator.update(*clear, start, 0.0), PlanReason::kNewMap);
  EXPECT_GT(navigator.localPlan().committed_length_m, 2.5);
  EXPECT_EQ(navigator.update(*clear, start, 0.05), PlanReason::kNone);  // nothing new, not due
  EXPECT_EQ(navigator.update(*clear, start, 0.1), PlanReason::kPeriodic);
  EXPECT_EQ(navigator.update(*person, start, 0.12), PlanReason::kBlocked);
  EXPECT_EQ(navigator.blockedReplans(), 1u);
  for (const Eigen::Vector3d& p : navigator.localPlan().committedPoints()) {
    EXPECT_GE(nearestOccupied(*person, p), config.local.commit_clearance_m - 1e-6);
  }
  // The route goes round the person (it is in the 2D grid).
  bool round = false;
  for (const Eigen::Vector3d& p : navigator.route_W()) round = round || std::abs(p.y() - 0.1) > 0.5;
  EXPECT_TRUE(round);
}

TEST(Navigator, TheLatestFramesPointsBlockTheSegmentBeforeTheMapShowsThem) {
  // The map still has the space free; the frame's points show a person 1.5 m ahead.
  const auto clear = snapshotOf(
      [](const VoxelIndex& g) {
        return freeExcept(g, [](const Eigen::Vector3d&) { return false; });
      },
      1);
  NavigatorConfig config;
  Navigator navigator(config);
  const Eigen::Vector3d start(0.0, 0.1, 1.1);
  navigator.setGoal({6.0, 0.1, 1.1});
  ASSERT_EQ(navigator.update(*clear, start, 0.0), PlanReason::kNewMap);
  ASSERT_GT(navigator.localPlan().committed_length_m, 2.5);
  EXPECT_FALSE(navigator.cautious());
  std::vector<Eigen::Vector3d> person;
  for (double y = -0.15; y <= 0.35; y += 0.1) {
    for (double z = 0.7; z <= 1.5; z += 0.2) person.emplace_back(1.5, y, z);
  }
  navigator.setRecentObstacles(person);
  EXPECT_EQ(navigator.update(*clear, start, 0.02), PlanReason::kBlocked);  // same map, new frame
  for (const Eigen::Vector3d& p : navigator.localPlan().committedPoints()) {
    EXPECT_GE(nearestPointDistance(person, p), config.local.commit_clearance_m - 1e-9);
  }
  // In open space the map knows free: something moved there. Within caution_radius_m the
  // setpoints slow down; within evade_radius_m the vehicle backs away from it.
  EXPECT_TRUE(navigator.cautious());
  EXPECT_FALSE(navigator.evading());
  EXPECT_LE(navigator.setpoint(start, 0.0).velocity_W.norm(), config.caution_speed_mps + 1e-9);
  const Eigen::Vector3d near(0.6, 0.1, 1.1);
  navigator.setRecentObstacles(person);
  navigator.update(*clear, near, 0.04);
  ASSERT_TRUE(navigator.evading());
  const Setpoint away = navigator.setpoint(near, 0.0);
  EXPECT_LT(away.velocity_W.x(), -0.1);  // back, away from the person at x = 1.5
  // The same points on an obstacle the map holds are not something that moved.
  const auto pillar = snapshotOf(
      [](const VoxelIndex& g) {
        return freeExcept(g, [](const Eigen::Vector3d& c) {
          return std::abs(c.x() - 1.7) < 0.25 && std::abs(c.y() - 0.1) < 0.3;
        });
      },
      2);
  navigator.setRecentObstacles(person);
  navigator.update(*pillar, near, 0.06);
  EXPECT_FALSE(navigator.evading());
  EXPECT_FALSE(navigator.cautious());
}

TEST(Navigator, ARouteTriesAgainWhereSomethingMovedInThatNoFrameHasHitLately) {
  // A wall across the whole window at x = 3 m: in the first snapshot already (static), or only
  // from the second on, where the first saw free space (a person's trail left in the map).
  const auto wall = [](std::uint64_t frame) {
    return snapshotOf(
        [](const VoxelIndex& g) {
          return freeExcept(g,
                            [](const Eigen::Vector3d& c) { return std::abs(c.x() - 3.1) < 0.1; });
        },
        frame);
  };
  const auto clear = snapshotOf(
      [](const VoxelIndex& g) {
        return freeExcept(g, [](const Eigen::Vector3d&) { return false; });
      },
      1);
  const Eigen::Vector3d start(0.0, 0.1, 1.1);
  const auto straight = [](const Navigator& n) {
    for (const Eigen::Vector3d& p : n.route_W()) {
      if (std::abs(p.y() - 0.1) > 0.5) return false;
    }
    return !n.route_W().empty();
  };
  // From zero (the simulator) and from a ROS epoch stamp (over DDS: 1.8e9 s, where a float
  // would round the times to 128 s).
  for (const double t0 : {0.0, 1.8e9}) {
    SCOPED_TRACE(t0);
    NavigatorConfig config;
    Navigator moved(config);
    moved.setGoal({6.0, 0.1, 1.1});
    moved.update(*clear, start, t0);
    EXPECT_TRUE(straight(moved));
    moved.update(*wall(2), start, t0 + 0.1);
    EXPECT_FALSE(straight(moved));  // round the wall, outside the window (unknown: free)
    // The frame's points hit the wall: it is there; not tried again while they do.
    std::vector<Eigen::Vector3d> hits;
    for (double y = -1.0; y <= 1.0; y += 0.2) hits.emplace_back(3.05, y + 0.05, 1.1);
    moved.setRecentObstacles(hits);
    moved.update(*wall(3), start, t0 + 1.5);
    EXPECT_FALSE(straight(moved));
    moved.setRecentObstacles({});
    moved.update(*wall(4), start, t0 + 1.5 + 0.9 * config.stale_obstacle_s);
    EXPECT_FALSE(straight(moved));
    // No hit for stale_obstacle_s: the route tries the wall again; the committed segment still
    // stops before it (the map shows it occupied).
    moved.update(*wall(5), start, t0 + 1.5 + 1.1 * config.stale_obstacle_s);
    EXPECT_TRUE(straight(moved));
    ASSERT_GT(moved.localPlan().committed, 1u);
    for (const Eigen::Vector3d& p : moved.localPlan().committedPoints()) {
      EXPECT_GE(nearestOccupied(*wall(5), p), config.local.commit_clearance_m - 1e-6);
    }
    // Hit by more frames than a passing person would be: it stayed, and stays for the route.
    double t = t0 + 1.5 + 1.1 * config.stale_obstacle_s;
    for (int k = 0; k <= config.stale_max_hits; ++k) {
      t += 0.1;
      moved.setRecentObstacles(hits);
      moved.update(*wall(6 + static_cast<std::uint64_t>(k)), start, t);
    }
    moved.setRecentObstacles({});
    moved.update(*wall(100), start, t + 2.0 * config.stale_obstacle_s);
    EXPECT_FALSE(straight(moved));
    // A wall the map never knew free stays for the route.
    Navigator fixed(config);
    fixed.setGoal({6.0, 0.1, 1.1});
    fixed.update(*wall(1), start, t0);
    fixed.update(*wall(2), start, t0 + 10.0);
    EXPECT_FALSE(straight(fixed));
  }
}

TEST(Navigator, TheSetpointsStopTheVehicleBeforeTheEndOfTheCommittedSegment) {
  const auto wall = snapshotOf(
      [](const VoxelIndex& g) {
        return freeExcept(g, [](const Eigen::Vector3d& c) { return c.x() > 3.0 && c.x() < 3.4; });
      },
      1);
  for (const double speed : {0.5, 1.5, 3.0}) {
    NavigatorConfig config;
    config.max_speed_mps = speed;
    config.local.horizon_m = 6.0;
    Navigator navigator(config);
    navigator.setGoal({7.0, 0.1, 1.1});
    sim::VehicleLimits limits;
    limits.max_speed_mps = speed;
    limits.max_accel_mps2 = config.max_accel_mps2;
    sim::VehicleState initial;
    initial.position_W = {0.0, 0.1, 1.1};
    sim::Vehicle vehicle(initial, limits);
    ASSERT_NE(navigator.update(*wall, vehicle.state().position_W, 0.0), PlanReason::kNone);
    const double end_x = navigator.localPlan().committedPoints().back().x();
    double max_x = 0.0;
    double top_speed = 0.0;
    for (int k = 0; k < 1000; ++k) {  // 20 s, the plan kept (no new map)
      const Setpoint sp = navigator.setpoint(vehicle.state().position_W, vehicle.state().yaw_rad);
      vehicle.step(sp.position_W, sp.velocity_W, sp.yaw_rad, 0.02);
      max_x = std::max(max_x, vehicle.state().position_W.x());
      top_speed = std::max(top_speed, vehicle.state().velocity_W.norm());
    }
    EXPECT_LE(max_x, end_x + 1e-6) << "speed " << speed;
    EXPECT_GT(max_x, end_x - config.stop_margin_m - 0.15) << "speed " << speed;
    EXPECT_LE(top_speed, speed * (1.0 + 1e-9));
    EXPECT_GT(top_speed, 0.5 * speed);
    EXPECT_LT(vehicle.state().velocity_W.norm(), 1e-3);
  }
}

}  // namespace
}  // namespace mlmap::nav
