#include "mlmap/nav/nav_worlds.h"

#include "mlmap/nav/grid_search.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace mlmap::nav {

namespace {

constexpr double kWallHeight_m = 3.0;
constexpr double kWallThickness_m = 0.2;
constexpr double kFlightHeight_m = 1.0;
/// Every generated world has a route keeping this clearance (the benchmark's inflation).
constexpr double kRouteClearance_m = 0.6;
constexpr int kMaxAttempts = 50;

/// Floor slab (top at z = 0) and four walls around [min, max].
void addFloorAndWalls(sim::World* world, const Eigen::Vector2d& min, const Eigen::Vector2d& max) {
  const double t = kWallThickness_m;
  world->addBox({Eigen::Vector3d(min.x() - t, min.y() - t, -0.2),
                 Eigen::Vector3d(max.x() + t, max.y() + t, 0.0)});
  world->addBox({Eigen::Vector3d(min.x() - t, min.y() - t, 0.0),
                 Eigen::Vector3d(max.x() + t, min.y(), kWallHeight_m)});
  world->addBox({Eigen::Vector3d(min.x() - t, max.y(), 0.0),
                 Eigen::Vector3d(max.x() + t, max.y() + t, kWallHeight_m)});
  world->addBox({Eigen::Vector3d(min.x() - t, min.y(), 0.0),
                 Eigen::Vector3d(min.x(), max.y(), kWallHeight_m)});
  world->addBox({Eigen::Vector3d(max.x(), min.y(), 0.0),
                 Eigen::Vector3d(max.x() + t, max.y(), kWallHeight_m)});
}

/// True when the world is a fair task: a route exists and the start does not see the goal.
bool isFair(const NavWorld& w) {
  return !seesPoint(w.world, w.start_W, w.goal_W) &&
         !shortestRoute(w, kRouteClearance_m, 0.1).empty();
}

double headingTo(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  return std::atan2(to.y() - from.y(), to.x() - from.x());
}

/// Adds two pieces of furniture (boxes 0.6-1.4 m across, 0.8-2.2 m tall) to the room whose
/// lower corner is `corner_W` and size `size_m`, kept 1.6 m from its walls, 2 m from `doors` and
/// 1.2 m from the world's start and goal (200 tries at most).
void addFurniture(NavWorld* w, const std::vector<Eigen::Vector2d>& doors,
                  const Eigen::Vector2d& corner_W, const Eigen::Vector2d& size_m,
                  std::mt19937* rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int added = 0;
  for (int tries = 0; tries < 200 && added < 2; ++tries) {
    const Eigen::Vector2d half(0.3 + 0.4 * unit(*rng), 0.3 + 0.4 * unit(*rng));
    const Eigen::Vector2d c(
        corner_W.x() + 1.6 + half.x() + unit(*rng) * (size_m.x() - 3.2 - 2 * half.x()),
        corner_W.y() + 1.6 + half.y() + unit(*rng) * (size_m.y() - 3.2 - 2 * half.y()));
    const double reach = half.norm();
    bool ok = true;
    for (const Eigen::Vector2d& d : doors) ok = ok && (d - c).norm() - reach > 2.0;
    for (const Eigen::Vector3d& q : {w->start_W, w->goal_W})
      ok = ok && (q.head<2>() - c).norm() - reach > 1.2;
    if (!ok) continue;
    const double height = 0.8 + 1.4 * unit(*rng);
    w->world.addBox({Eigen::Vector3d(c.x() - half.x(), c.y() - half.y(), 0.0),
                     Eigen::Vector3d(c.x() + half.x(), c.y() + half.y(), height)});
    ++added;
  }
}

}  // namespace

double clearance(const sim::World& world, const Eigen::Vector3d& p_W, double time_s) {
  double best = world.distance(p_W);
  for (const sim::MovingBox& box : world.movingBoxes()) {
    if (!box.isActiveAt(time_s)) continue;
    const Eigen::Vector3d c = box.centerAt(time_s);
    const Eigen::Vector3d half = 0.5 * box.size_m;
    best = std::min(best, ((p_W - c).cwiseAbs() - half).cwiseMax(0.0).norm());
  }
  return best;
}

bool seesPoint(const sim::World& world, const Eigen::Vector3d& a_W, const Eigen::Vector3d& b_W) {
  const Eigen::Vector3d d = b_W - a_W;
  const double length = d.norm();
  if (length <= 0.0) return true;
  double t_hit = 0.0;
  // A time before any moving box exists: only the static solids count.
  return !world.raycast(a_W, d / length, length, -1e9, &t_hit);
}

std::vector<Eigen::Vector2d> shortestRoute(const NavWorld& world, double inflation_m,
                                           double resolution_m) {
  PlanningGrid grid;
  grid.resolution_m = resolution_m;
  grid.origin_W = world.min_xy_W;
  const Eigen::Vector2d size = world.max_xy_W - world.min_xy_W;
  grid.width = static_cast<int>(std::ceil(size.x() / resolution_m));
  grid.height = static_cast<int>(std::ceil(size.y() / resolution_m));
  grid.blocked.assign(static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height),
                      0);
  const double z = world.start_W.z();
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const Eigen::Vector2d c = grid.cellCenter_W({x, y});
      if (world.world.distance(Eigen::Vector3d(c.x(), c.y(), z)) < inflation_m) {
        grid.blocked[static_cast<std::size_t>(y) * static_cast<std::size_t>(grid.width) +
                     static_cast<std::size_t>(x)] = 1;
      }
    }
  }
  const GridPath path =
      searchGrid(grid, grid.cellOf(world.start_W.head<2>()), grid.cellOf(world.goal_W.head<2>()));
  if (!path.found || grid.isBlocked(path.cells.front().x(), path.cells.front().y())) return {};
  std::vector<Eigen::Vector2d> route = shortenPath(grid, path.cells);
  route.front() = world.start_W.head<2>();
  route.back() = world.goal_W.head<2>();
  return route;
}

NavWorld forestWorld(std::uint32_t seed, double trees_per_m2, const Eigen::Vector2d& size_m) {
  for (int attempt = 0;; ++attempt) {
    std::mt19937 rng(seed * 7919u + static_cast<std::uint32_t>(attempt));
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    NavWorld w;
    char name[96];
    std::snprintf(name, sizeof(name), "forest_%.0fx%.0f_d%.2f_s%u", size_m.x(), size_m.y(),
                  trees_per_m2, seed);
    w.name = name;
    w.min_xy_W = Eigen::Vector2d::Zero();
    w.max_xy_W = size_m;
    addFloorAndWalls(&w.world, w.min_xy_W, w.max_xy_W);
    w.start_W = {1.5, 1.5 + unit(rng) * (size_m.y() - 3.0), kFlightHeight_m};
    w.goal_W = {size_m.x() - 1.5, 1.5 + unit(rng) * (size_m.y() - 3.0), kFlightHeight_m};
    w.start_yaw_rad = headingTo(w.start_W, w.goal_W);
    const int trees = static_cast<int>(std::lround(trees_per_m2 * size_m.x() * size_m.y()));
    std::vector<sim::Cylinder> placed;
    // The first tree stands on the line from start to goal, so the start cannot see the goal.
    for (int tries = 0; tries < trees * 60 && static_cast<int>(placed.size()) < trees + 1;
         ++tries) {
      sim::Cylinder c;
      c.radius_m = 0.15 + 0.3 * unit(rng);
      if (placed.empty()) {
        const double s = 0.35 + 0.3 * unit(rng);
        c.center_xy_W = (w.start_W + s * (w.goal_W - w.start_W)).head<2>();
        c.radius_m = 0.45;
      } else {
        c.center_xy_W = {1.0 + unit(rng) * (size_m.x() - 2.0),
                         1.0 + unit(rng) * (size_m.y() - 2.0)};
      }
      c.z_min_m = 0.0;
      c.z_max_m = kWallHeight_m;
      bool ok = true;
      const Eigen::Vector2d& p = c.center_xy_W;
      const double wall_gap =
          std::min({p.x(), p.y(), size_m.x() - p.x(), size_m.y() - p.y()}) - c.radius_m;
      if (wall_gap < 1.5 && !placed.empty()) ok = false;
      for (const Eigen::Vector3d& q : {w.start_W, w.goal_W}) {
        if ((q.head<2>() - p).norm() - c.radius_m < 1.2) ok = false;
      }
      for (const sim::Cylinder& o : placed) {
        if ((o.center_xy_W - p).norm() - o.radius_m - c.radius_m < 1.5) ok = false;
      }
      if (!ok) continue;
      placed.push_back(c);
      w.world.addCylinder(c);
    }
    if (isFair(w) || attempt >= kMaxAttempts) return w;
  }
}

NavWorld roomsWorld(std::uint32_t seed, int rooms) {
  rooms = std::max(rooms, 2);
  const double room_x = 8.0;
  const double room_y = 10.0;
  for (int attempt = 0;; ++attempt) {
    std::mt19937 rng(seed * 104729u + static_cast<std::uint32_t>(attempt));
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    NavWorld w;
    w.name = "rooms" + std::to_string(rooms) + "_s" + std::to_string(seed);
    w.min_xy_W = Eigen::Vector2d::Zero();
    w.max_xy_W = {room_x * rooms, room_y};
    addFloorAndWalls(&w.world, w.min_xy_W, w.max_xy_W);
    const double half_t = 0.5 * kWallThickness_m;
    std::vector<Eigen::Vector2d> doors;
    for (int k = 1; k < rooms; ++k) {
      const double x = room_x * k;
      const double door_lo = 1.0 + unit(rng) * (room_y - 4.0);
      const double door_hi = door_lo + 2.0;
      w.world.addBox({Eigen::Vector3d(x - half_t, 0.0, 0.0),
                      Eigen::Vector3d(x + half_t, door_lo, kWallHeight_m)});
      w.world.addBox({Eigen::Vector3d(x - half_t, door_hi, 0.0),
                      Eigen::Vector3d(x + half_t, room_y, kWallHeight_m)});
      doors.emplace_back(x, 0.5 * (door_lo + door_hi));
    }
    w.start_W = {1.5, 1.5 + unit(rng) * (room_y - 3.0), kFlightHeight_m};
    w.goal_W = {room_x * rooms - 1.5, 1.5 + unit(rng) * (room_y - 3.0), kFlightHeight_m};
    w.start_yaw_rad = headingTo(w.start_W, w.goal_W);
    // Furniture: two boxes a room, away from the walls, the doors, start and goal.
    for (int k = 0; k < rooms; ++k) {
      addFurniture(&w, doors, {room_x * k, 0.0}, {room_x, room_y}, &rng);
    }
    if (isFair(w) || attempt >= kMaxAttempts) return w;
  }
}

NavWorld buildingFloorWorld(std::uint32_t seed) {
  const Eigen::Vector2d size(40.0, 16.0);
  const double room_x = 10.0;
  const double corridor_lo = 6.4;  // the corridor's south wall [m]
  const double corridor_hi = 9.6;  // its north wall [m]
  const double half_t = 0.5 * kWallThickness_m;
  for (int attempt = 0;; ++attempt) {
    std::mt19937 rng(seed * 7919u + static_cast<std::uint32_t>(attempt));
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    NavWorld w;
    w.name = "building_s" + std::to_string(seed);
    w.min_xy_W = Eigen::Vector2d::Zero();
    w.max_xy_W = size;
    addFloorAndWalls(&w.world, w.min_xy_W, w.max_xy_W);
    // The walls between rooms, on both sides of the corridor.
    for (int k = 1; k < 4; ++k) {
      const double x = room_x * k;
      w.world.addBox({Eigen::Vector3d(x - half_t, 0.0, 0.0),
                      Eigen::Vector3d(x + half_t, corridor_lo, kWallHeight_m)});
      w.world.addBox({Eigen::Vector3d(x - half_t, corridor_hi, 0.0),
                      Eigen::Vector3d(x + half_t, size.y(), kWallHeight_m)});
    }
    // The corridor's walls, one 2 m door into each room at a random place.
    std::vector<Eigen::Vector2d> doors;
    for (const double y : {corridor_lo, corridor_hi}) {
      double wall_from = 0.0;
      for (int k = 0; k < 4; ++k) {
        const double door_lo = room_x * k + 1.0 + unit(rng) * (room_x - 4.0);
        w.world.addBox({Eigen::Vector3d(wall_from, y - half_t, 0.0),
                        Eigen::Vector3d(door_lo, y + half_t, kWallHeight_m)});
        wall_from = door_lo + 2.0;
        doors.emplace_back(door_lo + 1.0, y);
      }
      w.world.addBox({Eigen::Vector3d(wall_from, y - half_t, 0.0),
                      Eigen::Vector3d(size.x(), y + half_t, kWallHeight_m)});
    }
    // Start in a south room, goal in a north room at the other end of the corridor.
    const int start_room = static_cast<int>(unit(rng) * 4.0) % 4;
    const int goal_room = (start_room < 2 ? 2 : 0) + static_cast<int>(unit(rng) * 2.0) % 2;
    w.start_W = {room_x * start_room + 2.0 + unit(rng) * (room_x - 4.0),
                 1.5 + unit(rng) * (corridor_lo - 3.0), kFlightHeight_m};
    w.goal_W = {room_x * goal_room + 2.0 + unit(rng) * (room_x - 4.0),
                size.y() - 1.5 - unit(rng) * (size.y() - corridor_hi - 3.0), kFlightHeight_m};
    w.start_yaw_rad = headingTo(w.start_W, w.goal_W);
    // Furniture: two boxes a room, away from the walls, the doors, start and goal.
    for (int k = 0; k < 8; ++k) {
      const double y0 = k < 4 ? 0.0 : corridor_hi;
      const double depth = k < 4 ? corridor_lo : size.y() - corridor_hi;
      addFurniture(&w, doors, {room_x * (k % 4), y0}, {room_x, depth}, &rng);
    }
    if (isFair(w) || attempt >= kMaxAttempts) return w;
  }
}

NavWorld paperRoomWorld(std::uint32_t seed) {
  const sim::World room = sim::World::defaultRoom();
  std::mt19937 rng(static_cast<std::mt19937::result_type>(seed * 15485863u));
  std::uniform_real_distribution<double> jitter(-0.8, 0.8);
  NavWorld w;
  w.name = "paper_room_s" + std::to_string(seed);
  for (const sim::Box& b : room.boxes()) w.world.addBox(b);
  for (const sim::Cylinder& c : room.cylinders()) w.world.addCylinder(c);
  for (const sim::Sphere& s : room.spheres()) w.world.addSphere(s);
  w.min_xy_W = {0.2, 0.2};
  w.max_xy_W = {29.8, 19.8};
  w.start_W = {4.0 + jitter(rng), 4.5 + jitter(rng), 1.5};
  w.goal_W = {25.0 + jitter(rng), 15.5 + jitter(rng), 1.5};
  w.start_yaw_rad = headingTo(w.start_W, w.goal_W);
  return w;
}

void addCrossingPerson(NavWorld* world, const std::vector<Eigen::Vector2d>& route_W,
                       double speed_mps, double lead_m) {
  const double length = polylineLength(route_W);
  if (route_W.size() < 2 || length <= 0.0) return;
  // The point halfway along the route and the route's direction there.
  double walked = 0.0;
  Eigen::Vector2d at = route_W.front();
  Eigen::Vector2d dir(1.0, 0.0);
  for (std::size_t i = 0; i + 1 < route_W.size(); ++i) {
    const double seg = (route_W[i + 1] - route_W[i]).norm();
    if (walked + seg >= 0.5 * length && seg > 0.0) {
      dir = (route_W[i + 1] - route_W[i]) / seg;
      at = route_W[i] + dir * (0.5 * length - walked);
      break;
    }
    walked += seg;
  }
  const Eigen::Vector2d across(-dir.y(), dir.x());
  const double walk_mps = 1.0;
  const double half_walk_m = 3.0;
  const double t_cross = std::max(0.5 * length - lead_m, 0.0) / speed_mps;
  sim::MovingBox person;
  person.size_m = {0.5, 0.5, 1.8};
  const Eigen::Vector2d from = at - across * half_walk_m;
  person.start_center_W = {from.x(), from.y(), 0.9};
  person.velocity_mps = {across.x() * walk_mps, across.y() * walk_mps, 0.0};
  person.t_start_s = std::max(t_cross - half_walk_m / walk_mps, 0.0);
  person.t_end_s = person.t_start_s + 2.0 * half_walk_m / walk_mps;
  if (t_cross < half_walk_m / walk_mps) {  // too early to walk the first half: start nearer
    const double late = half_walk_m / walk_mps - t_cross;
    person.start_center_W += person.velocity_mps * late;
    person.t_end_s -= late;
  }
  world->world.addMovingBox(person);
  world->moving_obstacle = true;
  world->name += "_person";
}

std::vector<NavWorld> benchmarkWorlds(int count, std::uint32_t seed, double inflation_m,
                                      double speed_mps) {
  std::vector<NavWorld> worlds;
  const double densities[3] = {0.03, 0.06, 0.09};
  for (int i = 0; i < count; ++i) {
    const auto s = seed + static_cast<std::uint32_t>(i);
    NavWorld w;
    switch (i % 5) {
      case 0:
      case 1:
      case 2:
        w = forestWorld(s, densities[(i % 5 + i / 5) % 3], Eigen::Vector2d(24.0, 12.0));
        break;
      case 3:
        w = roomsWorld(s, 2 + (i / 5) % 2);
        break;
      default:
        w = (i / 5) % 2 == 0 ? paperRoomWorld(s) : buildingFloorWorld(s);
        break;
    }
    if (i % 3 == 2) addCrossingPerson(&w, shortestRoute(w, inflation_m, 0.1), speed_mps, 3.0);
    worlds.push_back(std::move(w));
  }
  return worlds;
}

}  // namespace mlmap::nav
