#pragma once
/// @file
/// What moved, followed from frame to frame: the points of each frame that stand where the map
/// knew free space (something walked in) are grouped, and a group that makes most of itself and
/// the other points touching it (a person, also one passing a tree; not the sliver of a tree's or
/// a wall's edge that falls in cells once seen free) is an obstacle continuing
/// the nearest obstacle of the frames before, whose velocity is measured over the last second
/// and which is predicted at that velocity, also while the camera no longer sees it (a person
/// walking towards the vehicle from its side leaves an 80 degree view before they meet). The
/// planner keeps its committed segment clear of where they will be (see predictedPoints()).
/// World frame W, metres, seconds; the obstacles are followed horizontally (x, y).

#include <Eigen/Core>

#include <deque>
#include <vector>

namespace mlmap::nav {

/// Parameters of the tracker.
struct MovingObstacleConfig {
  double link_m = 0.45;       ///< points nearer than this belong to one obstacle [m]
  double max_radius_m = 0.8;  ///< a group reaching farther from its centre is not followed [m]
  /// A group of fewer points is not followed either: a person near the flight height gives
  /// tens (0.2 m cells), a mixed cell at a tree's or a wall's edge a few.
  int min_points = 8;
  /// A group of what moved is followed only when it makes at least min_moved_share of itself
  /// and the points that did not move within attach_m of it [m].
  double min_moved_share = 0.6;
  double attach_m = 0.3;
  double gate_m = 0.8;             ///< a group continues an obstacle predicted this near [m]
  double keep_s = 2.0;             ///< an obstacle no frame has seen for this long is dropped [s]
  double velocity_window_s = 1.0;  ///< its velocity: the centre's motion over this long [s]
  double min_baseline_s = 0.5;     ///< shorter observed than this: velocity zero [s]
  double max_speed_mps = 2.0;      ///< a measured velocity is capped at this [m/s]
  double moving_speed_mps = 0.5;   ///< slower than this an obstacle counts as standing [m/s]
  double horizon_s = 1.5;          ///< predictedPoints() look this far ahead [s]
  double horizon_step_s = 0.25;    ///< in steps of [s]
};

/// One followed obstacle.
struct MovingObstacle {
  Eigen::Vector2d center_W = Eigen::Vector2d::Zero();    ///< centre of its points when last seen
  Eigen::Vector2d velocity_W = Eigen::Vector2d::Zero();  ///< [m/s]
  double seen_s = 0.0;                                   ///< when a frame last saw it [s]
  /// Its points when last seen, in W (at the flight height).
  std::vector<Eigen::Vector3d> points_W;
  /// Centres and times over the last velocity_window_s, oldest first.
  std::deque<std::pair<double, Eigen::Vector2d>> history;
  /// True when it moves at moving_speed_mps or more.
  [[nodiscard]] bool moving(const MovingObstacleConfig& config) const {
    return velocity_W.norm() >= config.moving_speed_mps;
  }
  /// Where its centre is predicted at `time_s` [m].
  [[nodiscard]] Eigen::Vector2d centerAt(double time_s) const {
    return center_W + velocity_W * (time_s - seen_s);
  }
};

/// Follows what moved from frame to frame (see the file comment).
class MovingObstacleTracker {
 public:
  /// A tracker following nothing yet.
  explicit MovingObstacleTracker(const MovingObstacleConfig& config = {});

  /// Takes the points of the frame at `time_s` (W) and, for each, whether it stands where
  /// something moved (`moved`, as many), groups those that moved, continues the obstacles the
  /// groups belong to, starts new ones and drops those unseen for keep_s.
  void update(const std::vector<Eigen::Vector3d>& points_W, const std::vector<bool>& moved,
              double time_s);

  /// Where the moving obstacles' points will be from `time_s` on: each point moved at its
  /// obstacle's velocity to time_s, time_s + horizon_step_s, ... time_s + horizon_s. Standing
  /// obstacles are left out (the map and the latest frame show them).
  [[nodiscard]] std::vector<Eigen::Vector3d> predictedPoints(double time_s) const;

  /// The moving obstacle predicted nearest `p_W` (horizontally) within `radius_m` at some time in
  /// [time_s, time_s + lookahead_s], and that nearest predicted point, or nullptr.
  [[nodiscard]] const MovingObstacle* nearestMoving(const Eigen::Vector3d& p_W, double time_s,
                                                    double radius_m, double lookahead_s,
                                                    Eigen::Vector3d* nearest_W) const;

  /// The obstacles followed now.
  [[nodiscard]] const std::vector<MovingObstacle>& obstacles() const { return obstacles_; }

 private:
  MovingObstacleConfig config_;
  std::vector<MovingObstacle> obstacles_;
};

/// Groups of `points_W` whose members are linked by chains of points nearer than link_m
/// (horizontally): indices into points_W, a group each.
[[nodiscard]] std::vector<std::vector<std::size_t>> groupPoints(
    const std::vector<Eigen::Vector3d>& points_W, double link_m);

}  // namespace mlmap::nav
