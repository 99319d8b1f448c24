#pragma once
/// @file
/// The reference planner as a whole: the global route on mlmap's projected grid (accumulated on a
/// fixed origin, inflated, searched with A*), the local plan on the ESDF and the local map, when
/// each is computed again, and the setpoints that fly the committed segment.
///
/// Policies, stated once:
/// - global route: unknown cells are free (optimistic), cells within inflation_m of an occupied
///   cell are not entered; replanned with every new map snapshot and at least every
///   replan_period_s;
/// - committed segment: never enters unknown space nor comes nearer than
///   local.commit_clearance_m to a known obstacle (local_planner.h); checked against every new
///   snapshot, and planned again at once when the snapshot blocks it (a reactive replan);
/// - speed: the vehicle can always stop before the end of the committed segment (braking at
///   max_accel_mps2, stop_margin_m short of it).
/// Frames: world frame W, metres, seconds, radians (yaw about W +z, 0 facing +x).

#include "mlmap/nav/grid_search.h"
#include "mlmap/nav/local_planner.h"
#include "mlmap/nav/moving_obstacles.h"
#include "mlmap/planning/fixed_origin_grid.h"
#include "mlmap/planning/map_snapshot.h"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace mlmap::nav {

/// Parameters of the navigator.
struct NavigatorConfig {
  double inflation_m = 0.6;        ///< the global route keeps this far from occupied cells [m]
  double replan_period_s = 0.1;    ///< longest time between two plans [s]
  double goal_tolerance_m = 0.3;   ///< horizontal distance at which the goal counts as reached [m]
  double max_speed_mps = 1.5;      ///< speed the setpoints never exceed [m/s]
  double max_accel_mps2 = 2.0;     ///< braking the setpoints assume [m/s^2]
  double stop_margin_m = 0.2;      ///< the vehicle stops this short of the committed end [m]
  double carrot_m = 0.5;           ///< the setpoint's direction looks this far ahead [m]
  double planning_margin_m = 4.0;  ///< the route may leave the start-goal box by this much [m]
  /// A recent obstacle (setRecentObstacles()) in open space the map knows free, two voxels or
  /// more from any mapped obstacle (something that moved there), nearer than this makes the
  /// vehicle back away from it, into known-free space, whatever the plan: a person walking into
  /// the vehicle [m].
  double evade_radius_m = 1.2;
  /// Such an obstacle (something that moved) nearer than this caps the speed at
  /// caution_speed_mps, so that what it does next leaves time to stop [m].
  double caution_radius_m = 4.0;
  double caution_speed_mps = 0.5;  ///< [m/s]
  /// When the vehicle has not moved stuck_move_m for stuck_s, it turns on the spot until it
  /// moves again: a forward camera looks round, and what it sees (a door a walking person left
  /// occupied in the map, a way round) may open a route [m], [s].
  double stuck_move_m = 0.3;
  double stuck_s = 3.0;
  /// An occupied cell of the accumulated grid that it knew free before (something moved in: a
  /// walking person's trail, which the map keeps until the camera looks there again) and that no
  /// frame's point (setRecentObstacles()) has hit for this long counts as unknown for the route:
  /// the route may cross it, the committed segment never enters it until the map sees it free,
  /// and the vehicle stopped before it faces it, so that the camera sees whether it was left [s].
  /// 0: such cells stay occupied for the route. A cell hit by more than stale_max_hits frames
  /// since the map last knew it free is not stale: something that stayed in view (a wall whose
  /// edge cell the map once saw free), not a person passing by, who covers a cell for a few
  /// frames; otherwise the route would turn to it and away from it again and again. When there
  /// is no route, the search is made again with the occupied cells the map never knew free
  /// under the same rules (a trail first seen from afar, before the map saw free space there).
  double stale_obstacle_s = 2.0;
  int stale_max_hits = 15;
  /// Follow what moved (moving_obstacles.h): a frame's point stands where something moved when
  /// it lies in open space the map knows free (as for evade_radius_m) or when the cell of the
  /// accumulated grid 0.75 cell behind it (seen from the vehicle) was known free within
  /// moved_free_within_s and at most stale_max_hits frames have hit it since (the map takes a
  /// walking person in within a second, and they stay a person). The
  /// committed segment then keeps local.commit_clearance_m from where the moving ones will be
  /// over moving.horizon_s too, the vehicle is cautious near them and backs away from where
  /// they will be within evade_lookahead_s, also once they left the camera's view. false: only
  /// the latest frame's points count.
  bool follow_moving = true;
  double evade_lookahead_s = 0.5;    ///< [s]
  double moved_free_within_s = 1.5;  ///< see follow_moving [s]
  MovingObstacleConfig moving;       ///< the tracker
  LocalPlannerConfig local;          ///< the local planner
};

/// What the vehicle is asked to do: be at position_W moving at velocity_W, heading yaw_rad.
struct Setpoint {
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Vector3d velocity_W = Eigen::Vector3d::Zero();  ///< [m/s]
  double yaw_rad = 0.0;                                  ///< [rad]
};

/// Why a plan was made (Navigator::update()).
enum class PlanReason : std::uint8_t {
  kNone,      ///< no plan this time
  kNewMap,    ///< a new snapshot arrived, the committed segment still clear
  kPeriodic,  ///< replan_period_s elapsed without a new snapshot
  kBlocked,   ///< the new snapshot blocks the committed segment: planned again at once
};

/// Global route, local plan and setpoints for one vehicle and goal.
class Navigator {
 public:
  /// A navigator without a goal (it hovers).
  explicit Navigator(const NavigatorConfig& config = {});

  /// Sets the goal; the route is planned at the next update().
  void setGoal(const Eigen::Vector3d& goal_W);

  /// The obstacles of the latest frame (its measured points near the flight height, in W), which
  /// the committed segment keeps local.commit_clearance_m from; the next update() checks the
  /// committed segment against them as against a new snapshot.
  void setRecentObstacles(std::vector<Eigen::Vector3d> points_W);

  /// Brings the plan up to date with `map` for a vehicle at `p_W` at `time_s`: a snapshot not seen
  /// before is absorbed into the accumulated grid, the committed segment is checked against it
  /// (and the recent obstacles, when new ones were set), and global route and local plan are
  /// computed again when it is blocked, when the snapshot is new, or when replan_period_s has
  /// elapsed. Returns why it planned (kNone: it did not).
  PlanReason update(const MapSnapshot& map, const Eigen::Vector3d& p_W, double time_s);

  /// The setpoint for a vehicle at `p_W` heading `yaw_rad` (cheap: call it at the control rate):
  /// along the committed segment, or away from a recent obstacle within evade_radius_m.
  [[nodiscard]] Setpoint setpoint(const Eigen::Vector3d& p_W, double yaw_rad) const;

  /// True when `p_W` lies within goal_tolerance_m of the goal, horizontally.
  [[nodiscard]] bool reached(const Eigen::Vector3d& p_W) const;

  /// The current global route (shortened, start at the vehicle, goal last; empty before a plan or
  /// when none was found), at the goal's height.
  [[nodiscard]] const std::vector<Eigen::Vector3d>& route_W() const { return route_W_; }
  /// The current local plan.
  [[nodiscard]] const LocalPlan& localPlan() const { return plan_; }
  /// The accumulated 2D grid the route is planned on.
  [[nodiscard]] const ProjectedGrid& grid() const { return accumulated_.grid(); }
  /// The obstacles followed (follow_moving).
  [[nodiscard]] const MovingObstacleTracker& movingObstacles() const { return tracker_; }
  /// True when the last update() found a recent obstacle within evade_radius_m.
  [[nodiscard]] bool evading() const { return evade_W_.squaredNorm() > 0.0; }
  /// True when the last update() found one within caution_radius_m.
  [[nodiscard]] bool cautious() const { return cautious_; }
  /// True while the vehicle turns on the spot to look round (see stuck_s).
  [[nodiscard]] bool lookingRound() const { return looking_round_; }
  /// Plans made, those made at once because a snapshot blocked the committed segment, and
  /// global plans that found no route, the second search included (the previous route is kept).
  [[nodiscard]] std::uint64_t plans() const { return plans_; }
  [[nodiscard]] std::uint64_t blockedReplans() const { return blocked_replans_; }
  [[nodiscard]] std::uint64_t routeFailures() const { return route_failures_; }
  /// Thread CPU time of the last plan's global and local parts [ms].
  [[nodiscard]] double lastGlobalCpu_ms() const { return last_global_cpu_ms_; }
  [[nodiscard]] double lastLocalCpu_ms() const { return last_local_cpu_ms_; }

 private:
  void planRoute(const Eigen::Vector3d& p_W, double time_s);
  /// Keeps last_free_s_ and last_hit_s_ on the accumulated grid's layout after it grew.
  void followGridLayout();
  /// Index of the accumulated grid's cell holding p_W, or -1 outside.
  [[nodiscard]] std::ptrdiff_t cellIndex(const Eigen::Vector2d& p_W) const;
  /// The nearest recent obstacle in open known-free space (see evade_radius_m) within
  /// `radius_m` of p_W, or nullptr.
  [[nodiscard]] const Eigen::Vector3d* nearestMoved(const MapSnapshot& map,
                                                    const Eigen::Vector3d& p_W,
                                                    double radius_m) const;
  /// True when the frame's point q_W, seen from a vehicle at p_W, stands where something moved
  /// (see follow_moving).
  [[nodiscard]] bool standsWhereSomethingMoved(const MapSnapshot& map, const Eigen::Vector3d& p_W,
                                               const Eigen::Vector3d& q_W) const;
  /// The velocity away from the nearest moved obstacle within evade_radius_m, the followed ones
  /// where they will be within evade_lookahead_s included (zero when there is none, or when no
  /// step away, straight or turned by up to 90 degrees, is into known-free space with
  /// clearance); sets evade_from_W_.
  [[nodiscard]] Eigen::Vector3d evadeVelocity(const MapSnapshot& map, const Eigen::Vector3d& p_W,
                                              double time_s);

  NavigatorConfig config_;
  bool has_goal_ = false;
  Eigen::Vector3d goal_W_ = Eigen::Vector3d::Zero();
  FixedOriginGrid accumulated_;
  /// Per cell of the accumulated grid: when a snapshot last knew it free, and when a frame's
  /// point last fell in it (-infinity: never) [s]; double, since a stamp over DDS is a ROS
  /// epoch time (1.8e9 s), which a float holds only to 128 s; laid out as layout_.
  std::vector<double> last_free_s_;
  std::vector<double> last_hit_s_;
  std::vector<std::uint16_t> hits_since_free_;  ///< frames that hit the cell since it was free
  ProjectedGrid layout_;  ///< origin and size of the three above (cells unused)
  std::uint64_t last_frame_ = 0;
  std::vector<Eigen::Vector3d> recent_obstacles_W_;
  /// recent_obstacles_W_ and where the followed moving obstacles will be: what the committed
  /// segment keeps clear of.
  std::vector<Eigen::Vector3d> avoid_W_;
  MovingObstacleTracker tracker_;
  double last_frame_time_s_ = 0.0;  ///< when the latest frame's points were set [s]
  Eigen::Vector3d evade_from_W_ = Eigen::Vector3d::Zero();  ///< what the vehicle backs away from
  bool recent_obstacles_new_ = false;
  bool planned_once_ = false;
  double last_plan_time_s_ = 0.0;
  std::vector<Eigen::Vector3d> route_W_;
  LocalPlan plan_;
  Eigen::Vector3d evade_W_ = Eigen::Vector3d::Zero();
  bool cautious_ = false;
  bool looking_round_ = false;
  Eigen::Vector3d anchor_W_ = Eigen::Vector3d::Constant(1e300);  ///< where it last moved from
  double anchor_time_s_ = 0.0;                                   ///< and when
  std::uint64_t plans_ = 0;
  std::uint64_t blocked_replans_ = 0;
  std::uint64_t route_failures_ = 0;
  double last_global_cpu_ms_ = 0.0;
  double last_local_cpu_ms_ = 0.0;
};

/// Thread CPU time of the calling thread [s] (CLOCK_THREAD_CPUTIME_ID).
[[nodiscard]] double threadCpu_s();

/// A grid covering `grid` and the box of `points_W` grown by margin_m, on the lattice of `grid`
/// (or of resolution_m from the origin when `grid` is empty), the new cells unknown.
[[nodiscard]] ProjectedGrid coverPoints(const ProjectedGrid& grid,
                                        const std::vector<Eigen::Vector2d>& points_W,
                                        double margin_m, double resolution_m);

}  // namespace mlmap::nav
