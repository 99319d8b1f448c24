#pragma once
/// @file
/// Seeded unknown worlds to fly the reference planner in: forests of cylinders at several
/// densities, rooms joined by doors, the paper's 30 x 20 m room and a building floor, each walled,
/// with a floor, a start, and a goal the start cannot see; in some a person (a moving box) crosses
/// the route. Also the ground truth a flight is scored against: the shortest route and the
/// clearance. World frame W (z up), metres, seconds.

#include "mlmap/sim/world.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace mlmap::nav {

/// A world with a start and a goal.
struct NavWorld {
  std::string name;                                    ///< kind, parameters and seed
  sim::World world;                                    ///< the ground truth
  Eigen::Vector3d start_W = Eigen::Vector3d::Zero();   ///< where the vehicle starts [m]
  double start_yaw_rad = 0.0;                          ///< its heading at the start [rad]
  Eigen::Vector3d goal_W = Eigen::Vector3d::Zero();    ///< where it must go [m]
  Eigen::Vector2d min_xy_W = Eigen::Vector2d::Zero();  ///< the walled area's lower corner [m]
  Eigen::Vector2d max_xy_W = Eigen::Vector2d::Zero();  ///< its upper corner [m]
  bool moving_obstacle = false;                        ///< a person crosses the route
};

/// Ground-truth clearance at p_W and time_s: the distance to the nearest static solid or moving
/// box active then [m] (0 inside one).
[[nodiscard]] double clearance(const sim::World& world, const Eigen::Vector3d& p_W, double time_s);

/// True when the straight line from a_W to b_W meets no static solid.
[[nodiscard]] bool seesPoint(const sim::World& world, const Eigen::Vector3d& a_W,
                             const Eigen::Vector3d& b_W);

/// The ground-truth shortest route from start to goal at the start's height keeping at least
/// inflation_m from every static solid: A* over cells of resolution_m over the walled area whose
/// centres keep that clearance (8-connected), shortened by line of sight (grid_search.h).
/// Empty when there is none.
[[nodiscard]] std::vector<Eigen::Vector2d> shortestRoute(const NavWorld& world, double inflation_m,
                                                         double resolution_m);

/// A walled forest of size_m (x along the route) with about trees_per_m2 vertical cylinders
/// (radius 0.15-0.45 m, surface gaps >= 1.5 m), start near x = 0, goal near x = size_m.x().
[[nodiscard]] NavWorld forestWorld(std::uint32_t seed, double trees_per_m2,
                                   const Eigen::Vector2d& size_m);

/// `rooms` rooms of 8 x 10 m in a row along x, joined by 2 m doors at random places, with boxes
/// for furniture; start in the first room, goal in the last.
[[nodiscard]] NavWorld roomsWorld(std::uint32_t seed, int rooms);

/// One floor of the building walk (config/worlds/building.yaml's plan): 40 x 16 m, a 3.2 m
/// corridor along x (y 6.4-9.6) with four 10 x 6.4 m rooms on either side, each room's 2 m door
/// into the corridor at a random place (the walk's 1.2 m doors are narrower than the vehicle's
/// inflated width), two pieces of furniture a room; start in a south room, goal in a north room
/// at the other end of the corridor.
[[nodiscard]] NavWorld buildingFloorWorld(std::uint32_t seed);

/// The paper's 30 x 20 m room (sim::World::defaultRoom()'s static solids, its person left out),
/// flown at 1.5 m from near (4, 4.5) in its south-west to near (25, 15.5) in its north-east,
/// behind the interior wall at x = 10 (through one of its doors, and the one at y = 10 or round).
[[nodiscard]] NavWorld paperRoomWorld(std::uint32_t seed);

/// Adds a person (0.5 x 0.5 x 1.8 m box walking at 1 m/s) who crosses `route_W` halfway along it,
/// walking across it from 3 m on one side to 3 m on the other, timed to pass the route when a
/// vehicle flying it at `speed_mps` from t = 0 is still `lead_m` away.
void addCrossingPerson(NavWorld* world, const std::vector<Eigen::Vector2d>& route_W,
                       double speed_mps, double lead_m = 4.0);

/// The benchmark's `count` worlds from `seed`: forests at three densities, rooms (2 or 3), and the
/// paper room or a building floor, in turn, a person in every third crossing the shortest route
/// (planned with inflation_m) 3 m ahead of a vehicle flying it at `speed_mps` on average.
[[nodiscard]] std::vector<NavWorld> benchmarkWorlds(int count, std::uint32_t seed,
                                                    double inflation_m, double speed_mps);

}  // namespace mlmap::nav
