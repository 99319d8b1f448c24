#include "mlmap/nav/local_planner.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mlmap::nav {

double polylineLength(const std::vector<Eigen::Vector3d>& points_W) {
  double length = 0.0;
  for (std::size_t i = 1; i < points_W.size(); ++i)
    length += (points_W[i] - points_W[i - 1]).norm();
  return length;
}

std::vector<Eigen::Vector3d> routeAhead(const std::vector<Eigen::Vector3d>& route_W,
                                        const Eigen::Vector3d& p_W, double length_m,
                                        double step_m) {
  std::vector<Eigen::Vector3d> out;
  if (route_W.empty()) {
    out.push_back(p_W);
    return out;
  }
  // The nearest point of the route (horizontally).
  std::size_t seg = 0;
  double seg_t = 0.0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < route_W.size(); ++i) {
    const Eigen::Vector2d a = route_W[i].head<2>();
    const Eigen::Vector2d ab = route_W[i + 1].head<2>() - a;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0.0 ? std::clamp((p_W.head<2>() - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const double d = (a + t * ab - p_W.head<2>()).squaredNorm();
    if (d < best) {
      best = d;
      seg = i;
      seg_t = t;
    }
  }
  // Walk the route from there, the vehicle's own point first.
  std::vector<Eigen::Vector3d> rest;
  if (route_W.size() == 1) {
    rest.push_back(route_W[0]);
  } else {
    rest.push_back(route_W[seg] + seg_t * (route_W[seg + 1] - route_W[seg]));
    for (std::size_t i = seg + 1; i < route_W.size(); ++i) rest.push_back(route_W[i]);
  }
  const double z = route_W.front().z();
  Eigen::Vector3d cursor(p_W.x(), p_W.y(), z);
  out.push_back(cursor);
  double walked = 0.0;
  for (const Eigen::Vector3d& target : rest) {
    Eigen::Vector3d to = target - cursor;
    to.z() = 0.0;
    double left = to.norm();
    while (left > 1e-9 && walked < length_m) {
      const double step = std::min({step_m, left, length_m - walked});
      cursor += to / to.norm() * step;
      cursor.z() = z;
      walked += step;
      left -= step;
      out.push_back(cursor);
      to = target - cursor;
      to.z() = 0.0;
    }
    if (walked >= length_m) break;
  }
  return out;
}

void pushAwayFromObstacles(const MapSnapshot& map, const LocalPlannerConfig& config,
                           std::vector<Eigen::Vector3d>* points_W) {
  if (map.esdf() == nullptr) return;
  for (std::size_t i = 1; i < points_W->size(); ++i) {
    Eigen::Vector3d& p = (*points_W)[i];
    const Eigen::Vector3d original = p;
    for (int k = 0; k < config.push_iterations; ++k) {
      const EsdfMap::Query q = map.distance(p);
      if (!q.valid || q.distance_m >= config.push_clearance_m) break;
      Eigen::Vector3d g(q.gradient.x(), q.gradient.y(), 0.0);
      if (g.norm() < 1e-6) break;
      const double step = std::min(0.5 * (config.push_clearance_m - q.distance_m), 0.1);
      Eigen::Vector3d moved = p + g.normalized() * step;
      const Eigen::Vector3d offset = moved - original;
      if (offset.norm() > config.max_push_m)
        moved = original + offset.normalized() * config.max_push_m;
      p = moved;
    }
  }
}

double nearestPointDistance(const std::vector<Eigen::Vector3d>& points_W,
                            const Eigen::Vector3d& p_W) {
  double best = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& q : points_W) best = std::min(best, (q - p_W).squaredNorm());
  return std::sqrt(best);
}

std::size_t committablePrefix(const MapSnapshot& map, const LocalPlannerConfig& config,
                              const std::vector<Eigen::Vector3d>& points_W,
                              const std::vector<Eigen::Vector3d>* recent_obstacles_W) {
  if (map.esdf() == nullptr || points_W.empty()) return 0;
  const Eigen::Vector3d& p0 = points_W.front();
  const EsdfMap::Query here = map.distance(p0);
  const double required =
      here.valid ? std::min(config.commit_clearance_m, here.distance_m) : config.commit_clearance_m;
  const bool recent = recent_obstacles_W != nullptr && !recent_obstacles_W->empty();
  const double required_recent =
      recent ? std::min(config.commit_clearance_m, nearestPointDistance(*recent_obstacles_W, p0))
             : 0.0;
  std::size_t n = 1;
  for (std::size_t i = 1; i < points_W.size(); ++i) {
    Eigen::Vector3d a = points_W[i - 1];
    const Eigen::Vector3d& b = points_W[i];
    // The part near the vehicle's own position is not checked (see own_radius_m).
    if ((a - p0).norm() < config.own_radius_m) {
      const double db = (b - p0).norm();
      if (db > config.own_radius_m) {
        a = p0 + (b - p0) * (config.own_radius_m / db);
      } else {
        a = b;
      }
    }
    if (a != b && !map.isSegmentFree(a, b, UnknownAs::kOccupied)) break;
    const EsdfMap::Query q = map.distance(b);
    if (!q.valid || q.distance_m < required) break;
    if (recent && nearestPointDistance(*recent_obstacles_W, b) < required_recent) break;
    n = i + 1;
  }
  return n;
}

LocalPlan planLocal(const MapSnapshot& map, const LocalPlannerConfig& config,
                    const std::vector<Eigen::Vector3d>& route_W, const Eigen::Vector3d& p_W,
                    const std::vector<Eigen::Vector3d>* recent_obstacles_W) {
  LocalPlan plan;
  plan.points_W = routeAhead(route_W, p_W, config.horizon_m, config.sample_step_m);
  pushAwayFromObstacles(map, config, &plan.points_W);
  plan.committed = committablePrefix(map, config, plan.points_W, recent_obstacles_W);
  plan.committed_length_m = polylineLength(plan.committedPoints());
  return plan;
}

}  // namespace mlmap::nav
