#include "mlmap/nav/moving_obstacles.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mlmap::nav {

std::vector<std::vector<std::size_t>> groupPoints(const std::vector<Eigen::Vector3d>& points_W,
                                                  double link_m) {
  std::vector<std::vector<std::size_t>> groups;
  std::vector<bool> taken(points_W.size(), false);
  const double link2 = link_m * link_m;
  for (std::size_t seed = 0; seed < points_W.size(); ++seed) {
    if (taken[seed]) continue;
    taken[seed] = true;
    std::vector<std::size_t> group{seed};
    // Breadth-first over the links (a frame gives tens of such points: quadratic is cheap).
    for (std::size_t k = 0; k < group.size(); ++k) {
      const Eigen::Vector2d a = points_W[group[k]].head<2>();
      for (std::size_t j = 0; j < points_W.size(); ++j) {
        if (taken[j] || (points_W[j].head<2>() - a).squaredNorm() >= link2) continue;
        taken[j] = true;
        group.push_back(j);
      }
    }
    groups.push_back(std::move(group));
  }
  return groups;
}

MovingObstacleTracker::MovingObstacleTracker(const MovingObstacleConfig& config)
    : config_(config) {}

void MovingObstacleTracker::update(const std::vector<Eigen::Vector3d>& points_W,
                                   const std::vector<bool>& moved, double time_s) {
  std::vector<bool> continued(obstacles_.size(), false);
  std::vector<Eigen::Vector3d> moved_W;
  std::vector<Eigen::Vector3d> stayed_W;
  for (std::size_t i = 0; i < points_W.size(); ++i)
    (i < moved.size() && moved[i] ? moved_W : stayed_W).push_back(points_W[i]);
  const double attach2 = config_.attach_m * config_.attach_m;
  for (const std::vector<std::size_t>& group : groupPoints(moved_W, config_.link_m)) {
    if (static_cast<int>(group.size()) < config_.min_points) continue;
    // The points of what did not move that touch the group: many for the sliver of a tree's or
    // a wall's edge in cells once seen free, none or a few for a person, also beside a tree.
    std::size_t touching = 0;
    for (const Eigen::Vector3d& q : stayed_W) {
      for (const std::size_t i : group) {
        if ((moved_W[i].head<2>() - q.head<2>()).squaredNorm() < attach2) {
          ++touching;
          break;
        }
      }
    }
    if (static_cast<double>(group.size()) <
        config_.min_moved_share * static_cast<double>(group.size() + touching))
      continue;
    Eigen::Vector2d center = Eigen::Vector2d::Zero();
    for (const std::size_t i : group) center += moved_W[i].head<2>();
    center /= static_cast<double>(group.size());
    double reach = 0.0;
    for (const std::size_t i : group)
      reach = std::max(reach, (moved_W[i].head<2>() - center).norm());
    if (reach > config_.max_radius_m) continue;  // a wall's edge, not a person
    // The obstacle predicted nearest, not yet continued by another group of this frame.
    std::size_t best = obstacles_.size();
    double best_d = config_.gate_m;
    for (std::size_t k = 0; k < obstacles_.size(); ++k) {
      const double d = (obstacles_[k].centerAt(time_s) - center).norm();
      if (!continued[k] && d < best_d) {
        best_d = d;
        best = k;
      }
    }
    if (best == obstacles_.size()) {
      obstacles_.emplace_back();
      continued.push_back(false);
    }
    MovingObstacle& o = obstacles_[best];
    continued[best] = true;
    o.center_W = center;
    o.seen_s = time_s;
    o.points_W.clear();
    for (const std::size_t i : group) o.points_W.push_back(moved_W[i]);
    o.history.emplace_back(time_s, center);
    while (o.history.size() > 1 && time_s - o.history.front().first > config_.velocity_window_s)
      o.history.pop_front();
    const double baseline = time_s - o.history.front().first;
    o.velocity_W = Eigen::Vector2d::Zero();
    if (baseline >= config_.min_baseline_s) {
      o.velocity_W = (center - o.history.front().second) / baseline;
      const double speed = o.velocity_W.norm();
      if (speed > config_.max_speed_mps) o.velocity_W *= config_.max_speed_mps / speed;
    }
  }
  obstacles_.erase(
      std::remove_if(obstacles_.begin(), obstacles_.end(),
                     [&](const MovingObstacle& o) { return time_s - o.seen_s > config_.keep_s; }),
      obstacles_.end());
}

std::vector<Eigen::Vector3d> MovingObstacleTracker::predictedPoints(double time_s) const {
  std::vector<Eigen::Vector3d> out;
  for (const MovingObstacle& o : obstacles_) {
    if (!o.moving(config_)) continue;
    for (double tau = 0.0; tau <= config_.horizon_s + 1e-9; tau += config_.horizon_step_s) {
      const Eigen::Vector2d shift = o.velocity_W * (time_s + tau - o.seen_s);
      for (const Eigen::Vector3d& p : o.points_W)
        out.emplace_back(p.x() + shift.x(), p.y() + shift.y(), p.z());
    }
  }
  return out;
}

const MovingObstacle* MovingObstacleTracker::nearestMoving(const Eigen::Vector3d& p_W,
                                                           double time_s, double radius_m,
                                                           double lookahead_s,
                                                           Eigen::Vector3d* nearest_W) const {
  const MovingObstacle* nearest = nullptr;
  double best = radius_m;
  for (const MovingObstacle& o : obstacles_) {
    if (!o.moving(config_)) continue;
    for (double tau = 0.0; tau <= lookahead_s + 1e-9; tau += config_.horizon_step_s) {
      const Eigen::Vector2d shift = o.velocity_W * (time_s + tau - o.seen_s);
      for (const Eigen::Vector3d& p : o.points_W) {
        const Eigen::Vector3d q(p.x() + shift.x(), p.y() + shift.y(), p_W.z());
        const double d = (q - p_W).norm();
        if (d >= best) continue;
        best = d;
        nearest = &o;
        if (nearest_W != nullptr) *nearest_W = q;
      }
    }
  }
  return nearest;
}

}  // namespace mlmap::nav
