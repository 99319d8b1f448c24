#include "mlmap/nav/navigator.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <limits>

namespace mlmap::nav {

double threadCpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

ProjectedGrid coverPoints(const ProjectedGrid& grid, const std::vector<Eigen::Vector2d>& points_W,
                          double margin_m, double resolution_m) {
  const double res = grid.width > 0 ? grid.resolution_m : resolution_m;
  const Eigen::Vector2d lattice = grid.width > 0 ? grid.origin_W : Eigen::Vector2d::Zero();
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300);
  Eigen::Vector2d hi = Eigen::Vector2d::Constant(-1e300);
  for (const Eigen::Vector2d& p : points_W) {
    lo = lo.cwiseMin(p - Eigen::Vector2d::Constant(margin_m));
    hi = hi.cwiseMax(p + Eigen::Vector2d::Constant(margin_m));
  }
  if (grid.width > 0) {
    lo = lo.cwiseMin(grid.origin_W);
    hi = hi.cwiseMax(grid.origin_W + Eigen::Vector2d(grid.width, grid.height) * res);
  }
  ProjectedGrid out;
  out.resolution_m = res;
  out.band_min_z_m = grid.band_min_z_m;
  out.band_max_z_m = grid.band_max_z_m;
  if (points_W.empty() && grid.width == 0) return out;
  // Whole cells of the lattice; the offset of `grid` inside is then a whole number of cells.
  const Eigen::Vector2d first = ((lo - lattice) / res).array().floor();
  const Eigen::Vector2d last = ((hi - lattice) / res).array().ceil();
  out.origin_W = lattice + first * res;
  out.width = static_cast<int>(last.x() - first.x());
  out.height = static_cast<int>(last.y() - first.y());
  out.cells.assign(static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height),
                   ProjectedGrid::kUnknown);
  if (grid.width > 0) {
    const int ox = static_cast<int>(std::lround((grid.origin_W.x() - out.origin_W.x()) / res));
    const int oy = static_cast<int>(std::lround((grid.origin_W.y() - out.origin_W.y()) / res));
    for (int y = 0; y < grid.height; ++y) {
      std::copy_n(grid.cells.begin() + static_cast<std::ptrdiff_t>(y) * grid.width, grid.width,
                  out.cells.begin() + static_cast<std::ptrdiff_t>(y + oy) * out.width + ox);
    }
  }
  return out;
}

Navigator::Navigator(const NavigatorConfig& config) : config_(config), tracker_(config.moving) {}

void Navigator::setGoal(const Eigen::Vector3d& goal_W) {
  goal_W_ = goal_W;
  has_goal_ = true;
  route_W_.clear();
  plan_ = LocalPlan{};
  planned_once_ = false;
}

bool Navigator::reached(const Eigen::Vector3d& p_W) const {
  return has_goal_ && (p_W.head<2>() - goal_W_.head<2>()).norm() <= config_.goal_tolerance_m;
}

void Navigator::followGridLayout() {
  const ProjectedGrid& g = accumulated_.grid();
  if (g.width == layout_.width && g.height == layout_.height && g.origin_W == layout_.origin_W)
    return;
  constexpr double kNever = -std::numeric_limits<double>::infinity();
  const std::size_t n = static_cast<std::size_t>(g.width) * static_cast<std::size_t>(g.height);
  std::vector<double> free_s(n, kNever);
  std::vector<double> hit_s(n, kNever);
  std::vector<std::uint16_t> hits(n, 0);
  if (layout_.width > 0) {
    const int ox =
        static_cast<int>(std::lround((layout_.origin_W.x() - g.origin_W.x()) / g.resolution_m));
    const int oy =
        static_cast<int>(std::lround((layout_.origin_W.y() - g.origin_W.y()) / g.resolution_m));
    for (int y = 0; y < layout_.height; ++y) {
      for (int x = 0; x < layout_.width; ++x) {
        const int nx = x + ox;
        const int ny = y + oy;
        if (nx < 0 || ny < 0 || nx >= g.width || ny >= g.height) continue;
        const std::size_t from = static_cast<std::size_t>(y) * layout_.width + x;
        const std::size_t to = static_cast<std::size_t>(ny) * g.width + nx;
        free_s[to] = last_free_s_[from];
        hit_s[to] = last_hit_s_[from];
        hits[to] = hits_since_free_[from];
      }
    }
  }
  last_free_s_ = std::move(free_s);
  last_hit_s_ = std::move(hit_s);
  hits_since_free_ = std::move(hits);
  layout_.origin_W = g.origin_W;
  layout_.resolution_m = g.resolution_m;
  layout_.width = g.width;
  layout_.height = g.height;
}

std::ptrdiff_t Navigator::cellIndex(const Eigen::Vector2d& p_W) const {
  if (layout_.width == 0) return -1;
  const Eigen::Vector2d u = (p_W - layout_.origin_W) / layout_.resolution_m;
  const int x = static_cast<int>(std::floor(u.x()));
  const int y = static_cast<int>(std::floor(u.y()));
  if (x < 0 || y < 0 || x >= layout_.width || y >= layout_.height) return -1;
  return static_cast<std::ptrdiff_t>(y) * layout_.width + x;
}

void Navigator::planRoute(const Eigen::Vector3d& p_W, double time_s) {
  const ProjectedGrid& accumulated = accumulated_.grid();
  // `never_free_too`: also the occupied cells the map never knew free (seen only from afar).
  const auto search = [&](bool never_free_too, PlanningGrid* grid) {
    ProjectedGrid canvas =
        coverPoints(accumulated, {p_W.head<2>(), goal_W_.head<2>()}, config_.planning_margin_m,
                    accumulated.width > 0 ? accumulated.resolution_m : 0.2);
    if (config_.stale_obstacle_s > 0.0 && accumulated.width > 0) {
      // Occupied cells that were free before and that no frame has hit lately: unknown.
      const int ox = static_cast<int>(
          std::lround((accumulated.origin_W.x() - canvas.origin_W.x()) / canvas.resolution_m));
      const int oy = static_cast<int>(
          std::lround((accumulated.origin_W.y() - canvas.origin_W.y()) / canvas.resolution_m));
      const auto stale = time_s - config_.stale_obstacle_s;
      for (int y = 0; y < accumulated.height; ++y) {
        for (int x = 0; x < accumulated.width; ++x) {
          if (accumulated.at(x, y) <= 50) continue;
          const std::size_t i = static_cast<std::size_t>(y) * accumulated.width + x;
          if (last_free_s_[i] <= stale && last_hit_s_[i] <= stale &&
              hits_since_free_[i] <= config_.stale_max_hits &&
              (never_free_too || last_free_s_[i] > -std::numeric_limits<double>::infinity())) {
            canvas.cells[static_cast<std::size_t>(y + oy) * canvas.width + (x + ox)] =
                ProjectedGrid::kUnknown;
          }
        }
      }
    }
    *grid = inflateGrid(canvas, config_.inflation_m, UnknownAs::kFree);
    return searchGrid(*grid, grid->cellOf(p_W.head<2>()), grid->cellOf(goal_W_.head<2>()));
  };
  PlanningGrid grid;
  GridPath path = search(false, &grid);
  if (!path.found && config_.stale_obstacle_s > 0.0) {
    // No route: also the occupied cells that no frame has hit from near (a person's trail first
    // seen from afar, where the map had not seen free space yet); the vehicle goes to look.
    path = search(true, &grid);
  }
  if (!path.found) {
    ++route_failures_;
    return;
  }
  std::vector<Eigen::Vector2d> points = shortenPath(grid, path.cells);
  points.front() = p_W.head<2>();
  if (points.size() == 1) points.push_back(goal_W_.head<2>());
  points.back() = goal_W_.head<2>();
  route_W_.clear();
  for (const Eigen::Vector2d& p : points) route_W_.emplace_back(p.x(), p.y(), goal_W_.z());
}

void Navigator::setRecentObstacles(std::vector<Eigen::Vector3d> points_W) {
  recent_obstacles_W_ = std::move(points_W);
  recent_obstacles_new_ = true;
}

PlanReason Navigator::update(const MapSnapshot& map, const Eigen::Vector3d& p_W, double time_s) {
  if (!has_goal_) return PlanReason::kNone;
  const double cpu0 = threadCpu_s();
  const bool recent_obstacles_new_now = recent_obstacles_new_;
  const bool new_map = map.frame() != last_frame_ || recent_obstacles_new_;
  recent_obstacles_new_ = false;
  PlanReason reason = PlanReason::kNone;
  if (new_map) {
    if (map.frame() != last_frame_) {
      accumulated_.absorb(map.grid());
      followGridLayout();
      const ProjectedGrid& rolling = map.grid();
      for (int y = 0; y < rolling.height; ++y) {
        for (int x = 0; x < rolling.width; ++x) {
          const int v = rolling.at(x, y);
          if (v < 0 || v > 50) continue;
          const std::ptrdiff_t i = cellIndex(
              rolling.origin_W +
              (Eigen::Vector2d(x, y) + Eigen::Vector2d::Constant(0.5)) * rolling.resolution_m);
          if (i < 0) continue;
          last_free_s_[static_cast<std::size_t>(i)] = time_s;
          hits_since_free_[static_cast<std::size_t>(i)] = 0;
        }
      }
    }
    if (recent_obstacles_new_now) {
      for (const Eigen::Vector3d& q : recent_obstacles_W_) {
        const std::ptrdiff_t i = cellIndex(q.head<2>());
        if (i < 0) continue;
        const auto k = static_cast<std::size_t>(i);
        if (last_hit_s_[k] != time_s && hits_since_free_[k] < 0xffff)
          ++hits_since_free_[k];  // once a frame
        last_hit_s_[k] = time_s;
      }
      if (config_.follow_moving) {
        last_frame_time_s_ = time_s;
        std::vector<bool> moved;
        moved.reserve(recent_obstacles_W_.size());
        for (const Eigen::Vector3d& q : recent_obstacles_W_)
          moved.push_back(standsWhereSomethingMoved(map, p_W, q));
        tracker_.update(recent_obstacles_W_, moved, time_s);
      }
    }
    last_frame_ = map.frame();
    avoid_W_ = recent_obstacles_W_;
    if (config_.follow_moving) {
      const std::vector<Eigen::Vector3d> ahead = tracker_.predictedPoints(time_s);
      avoid_W_.insert(avoid_W_.end(), ahead.begin(), ahead.end());
    }
    // The rest of the committed segment, from the vehicle on, under the new map.
    const std::vector<Eigen::Vector3d> committed = plan_.committedPoints();
    if (committed.size() > 1) {
      std::vector<Eigen::Vector3d> rest =
          routeAhead(committed, p_W, polylineLength(committed), config_.local.sample_step_m);
      if (committablePrefix(map, config_.local, rest, &avoid_W_) < rest.size()) {
        reason = PlanReason::kBlocked;
        ++blocked_replans_;
      }
    }
    if (reason == PlanReason::kNone) reason = PlanReason::kNewMap;
  } else if (!planned_once_ || time_s - last_plan_time_s_ >= config_.replan_period_s - 1e-9) {
    reason = PlanReason::kPeriodic;
  }
  if (reason == PlanReason::kNone) return reason;
  planRoute(p_W, time_s);
  const double cpu1 = threadCpu_s();
  plan_ = planLocal(map, config_.local, route_W_, p_W, &avoid_W_);
  evade_W_ = evadeVelocity(map, p_W, time_s);
  cautious_ =
      nearestMoved(map, p_W, config_.caution_radius_m) != nullptr ||
      (config_.follow_moving &&
       tracker_.nearestMoving(p_W, time_s, config_.caution_radius_m, 0.0, nullptr) != nullptr);
  if ((p_W - anchor_W_).norm() >= config_.stuck_move_m) {
    anchor_W_ = p_W;
    anchor_time_s_ = time_s;
    looking_round_ = false;
  } else if (time_s - anchor_time_s_ >= config_.stuck_s) {
    looking_round_ = true;
  }
  const double cpu2 = threadCpu_s();
  last_global_cpu_ms_ = 1e3 * (cpu1 - cpu0);
  last_local_cpu_ms_ = 1e3 * (cpu2 - cpu1);
  planned_once_ = true;
  last_plan_time_s_ = time_s;
  ++plans_;
  return reason;
}

const Eigen::Vector3d* Navigator::nearestMoved(const MapSnapshot& map, const Eigen::Vector3d& p_W,
                                               double radius_m) const {
  // Only what stands in open space the map knows free, two voxels from any mapped obstacle:
  // something that moved there. A static obstacle is in the map (its measured surface points
  // lie in or next to its occupied voxels), and the plan keeps its clearance from it.
  const double open_m = 2.0 * map.window().resolution_m;
  const Eigen::Vector3d* nearest = nullptr;
  double best = radius_m;
  for (const Eigen::Vector3d& q : recent_obstacles_W_) {
    const double d = (q - p_W).norm();
    if (d >= best) continue;
    const EsdfMap::Query at = map.distance(q);
    if (map.state(q) == Occupancy::kFree && at.valid && at.distance_m >= open_m) {
      best = d;
      nearest = &q;
    }
  }
  return nearest;
}

bool Navigator::standsWhereSomethingMoved(const MapSnapshot& map, const Eigen::Vector3d& p_W,
                                          const Eigen::Vector3d& q_W) const {
  const EsdfMap::Query at = map.distance(q_W);
  if (map.state(q_W) == Occupancy::kFree && at.valid &&
      at.distance_m >= 2.0 * map.window().resolution_m) {
    return true;  // in open space the map knows free
  }
  // The cell behind the measured surface, 0.75 cell further from the vehicle: a surface point on
  // or near a cell's border (a wall along a cell row) lies in the mixed or free cell before it.
  Eigen::Vector2d ray = q_W.head<2>() - p_W.head<2>();
  if (ray.norm() < 1e-6) return false;
  ray *= 0.75 * layout_.resolution_m / ray.norm();
  const std::ptrdiff_t i = cellIndex(q_W.head<2>() + ray);
  if (i < 0) return false;
  const auto k = static_cast<std::size_t>(i);
  return last_free_s_[k] >= last_frame_time_s_ - config_.moved_free_within_s &&
         hits_since_free_[k] <= config_.stale_max_hits;
}

Eigen::Vector3d Navigator::evadeVelocity(const MapSnapshot& map, const Eigen::Vector3d& p_W,
                                         double time_s) {
  evade_from_W_.setZero();
  const Eigen::Vector3d* moved = nearestMoved(map, p_W, config_.evade_radius_m);
  Eigen::Vector3d from = moved != nullptr ? *moved : Eigen::Vector3d::Zero();
  double gap = moved != nullptr ? (*moved - p_W).norm() : config_.evade_radius_m;
  Eigen::Vector3d ahead_W;
  if (config_.follow_moving &&
      tracker_.nearestMoving(p_W, time_s, gap, config_.evade_lookahead_s, &ahead_W) != nullptr) {
    from = ahead_W;
    gap = (ahead_W - p_W).norm();
    moved = &from;
  }
  if (moved == nullptr) return Eigen::Vector3d::Zero();
  Eigen::Vector3d away = p_W - from;
  away.z() = 0.0;
  if (away.norm() < 1e-6) return Eigen::Vector3d::Zero();
  away.normalize();
  evade_from_W_ = from;
  const double urgency =
      std::min(1.0, 2.0 * (config_.evade_radius_m - gap) / config_.evade_radius_m);
  // Straight away, else turned by 45 then 90 degrees either way: the first step into known-free
  // space with clearance.
  constexpr double kTurns_rad[] = {0.0, 0.785398163, -0.785398163, 1.570796327, -1.570796327};
  for (const double turn : kTurns_rad) {
    const Eigen::Vector3d dir(std::cos(turn) * away.x() - std::sin(turn) * away.y(),
                              std::sin(turn) * away.x() + std::cos(turn) * away.y(), 0.0);
    const Eigen::Vector3d to = p_W + dir * config_.local.own_radius_m * 2.0;
    const EsdfMap::Query q = map.distance(to);
    if (map.isSegmentFree(p_W + dir * config_.local.own_radius_m, to, UnknownAs::kOccupied) &&
        q.valid && q.distance_m >= config_.local.commit_clearance_m) {
      return dir * (config_.max_speed_mps * urgency);
    }
  }
  return Eigen::Vector3d::Zero();
}

Setpoint Navigator::setpoint(const Eigen::Vector3d& p_W, double yaw_rad) const {
  Setpoint sp;
  sp.position_W = p_W;
  sp.yaw_rad = yaw_rad;
  if (evading()) {
    // Backing away, it faces what it backs away from, so that the camera keeps seeing it.
    sp.velocity_W = evade_W_;
    const Eigen::Vector3d look = evade_from_W_ - p_W;
    if (look.head<2>().norm() > 1e-3) sp.yaw_rad = std::atan2(look.y(), look.x());
    return sp;
  }
  const std::vector<Eigen::Vector3d> committed = plan_.committedPoints();
  // Where the vehicle is along the committed segment, and what is left of it.
  double along = 0.0;
  double best = 1e300;
  double total = 0.0;
  Eigen::Vector3d nearest = p_W;
  for (std::size_t i = 0; i + 1 < committed.size(); ++i) {
    const Eigen::Vector3d ab = committed[i + 1] - committed[i];
    const double len = ab.norm();
    const double t =
        len > 0.0 ? std::clamp((p_W - committed[i]).dot(ab) / (len * len), 0.0, 1.0) : 0.0;
    const Eigen::Vector3d q = committed[i] + t * ab;
    const double d = (q - p_W).squaredNorm();
    if (d < best) {
      best = d;
      along = total + t * len;
      nearest = q;
    }
    total += len;
  }
  const double left = total - along;
  // The point carrot_m further on (or the end).
  auto pointAt = [&committed](double s) {
    double walked = 0.0;
    for (std::size_t i = 0; i + 1 < committed.size(); ++i) {
      const double len = (committed[i + 1] - committed[i]).norm();
      if (walked + len >= s && len > 0.0) {
        return Eigen::Vector3d(committed[i] +
                               (committed[i + 1] - committed[i]) * ((s - walked) / len));
      }
      walked += len;
    }
    return committed.back();
  };
  const double speed = std::min(
      cautious_ ? std::min(config_.caution_speed_mps, config_.max_speed_mps)
                : config_.max_speed_mps,
      std::sqrt(2.0 * config_.max_accel_mps2 * std::max(0.0, left - config_.stop_margin_m)));
  if (committed.size() > 1) {
    sp.position_W = nearest;
    Eigen::Vector3d dir = pointAt(std::min(total, along + config_.carrot_m)) - p_W;
    dir.z() = 0.0;
    if (dir.norm() > 1e-3 && speed > 0.0) {
      sp.velocity_W = dir.normalized() * speed;
      sp.velocity_W.z() = 0.0;
    }
  }
  // Heading: the direction of travel; when (nearly) stopped, towards where the plan goes next,
  // so that a forward camera looks at the space the vehicle waits to see, or round when stuck.
  if (sp.velocity_W.norm() > 0.1) {
    sp.yaw_rad = std::atan2(sp.velocity_W.y(), sp.velocity_W.x());
  } else if (looking_round_) {
    sp.yaw_rad = yaw_rad + 1.0;  // keep turning, as fast as the vehicle turns
  } else {
    const std::vector<Eigen::Vector3d>& ahead = plan_.points_W;
    for (const Eigen::Vector3d& q : ahead) {
      const Eigen::Vector2d d = q.head<2>() - p_W.head<2>();
      if (d.norm() > 0.5) {
        sp.yaw_rad = std::atan2(d.y(), d.x());
        break;
      }
    }
  }
  return sp;
}

}  // namespace mlmap::nav
