#include "mlmap/nav/nav_flight.h"

#include "mlmap/pipeline/map_engine.h"

#include <chrono>
#include <cmath>
#include <limits>

namespace mlmap::nav {

MapConfig navMapConfig(double resolution_m) {
  MapConfig c;
  c.local_map.resolution_m = resolution_m;
  const auto cells = [resolution_m](double metres) {
    const int n = static_cast<int>(std::lround(metres / resolution_m));
    return (n + LocalMapConfig::kSubmapsPerAxis - 1) / LocalMapConfig::kSubmapsPerAxis *
           LocalMapConfig::kSubmapsPerAxis;
  };
  c.local_map.size_cells = Eigen::Vector3i(cells(19.0), cells(19.0), cells(7.0));
  c.esdf.unknown_as = UnknownAs::kFree;
  c.esdf.max_rate_hz = 0.0;
  c.projected_grid.band_min_m = -0.5;
  c.projected_grid.band_max_m = 0.5;
  c.pipeline.threaded = false;
  return c;
}

NavFlightOptions::NavFlightOptions() : map(navMapConfig(0.2)) {
  camera.intrinsics = {96.25, 96.25, 79.5, 59.5, 160, 120};
}

NavFlightResult flyToGoal(const NavWorld& world, const NavFlightOptions& options) {
  NavFlightResult result;
  result.name = world.name;
  result.shortest_route_W = shortestRoute(world, options.planner.inflation_m, 0.1);
  result.shortest_path_m = polylineLength(result.shortest_route_W);

  // The latest frame's measured points near the vehicle's height (see recentObstacles()).
  std::vector<Eigen::Vector3f> points_S;
  const double flight_z = world.goal_W.z();
  MapEngine engine(options.map);
  Navigator navigator(options.planner);
  navigator.setGoal(world.goal_W);
  sim::VehicleState initial;
  initial.position_W = world.start_W;
  initial.yaw_rad = world.start_yaw_rad;
  sim::Vehicle vehicle(initial, options.vehicle);
  const sim::DepthCamera camera(options.camera);
  const Transform T_B_S = options.map.sensor.T_B_S();

  std::shared_ptr<const MapSnapshot> map = engine.snapshot();
  const double frame_period_s = 1.0 / options.camera_rate_hz;
  double next_frame_s = 0.0;
  bool in_collision = false;
  result.min_clearance_m = std::numeric_limits<double>::infinity();
  const auto steps = static_cast<long>(std::ceil(options.timeout_s / options.control_dt_s));
  for (long k = 0; k <= steps; ++k) {
    const double t = static_cast<double>(k) * options.control_dt_s;
    const sim::VehicleState& state = vehicle.state();
    if (navigator.reached(state.position_W)) {
      result.reached = true;
      result.time_s = t;
      break;
    }
    result.time_s = t;
    bool fresh_frame = false;
    std::chrono::steady_clock::time_point submitted;
    if (t >= next_frame_s - 1e-9) {
      next_frame_s += frame_period_s;
      const double cpu0 = threadCpu_s();
      DepthFrame frame;
      camera.render(world.world, state.T_W_B() * T_B_S, t, &frame);
      frame.T_W_B = state.T_W_B();
      frame.T_B_S = T_B_S;
      backProject(frame, &points_S);
      navigator.setRecentObstacles(recentObstacles(points_S, frame.T_W_B * T_B_S, flight_z,
                                                   options.map.local_map.resolution_m));
      const double cpu1 = threadCpu_s();
      submitted = std::chrono::steady_clock::now();
      if (engine.submit(std::move(frame)) == FrameStatus::kAccepted) ++result.frames;
      map = engine.snapshot();
      result.cpu_render_s += cpu1 - cpu0;
      result.cpu_mapping_s += threadCpu_s() - cpu1;
      fresh_frame = true;
    }
    const PlanReason reason = navigator.update(*map, state.position_W, t);
    if (reason != PlanReason::kNone) {
      result.cpu_global_s += 1e-3 * navigator.lastGlobalCpu_ms();
      result.cpu_local_s += 1e-3 * navigator.lastLocalCpu_ms();
      if (fresh_frame) {
        result.map_to_plan_ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - submitted)
                .count());
      }
      if (reason == PlanReason::kBlocked) result.replan_points_W.push_back(state.position_W);
    }
    const double cpu2 = threadCpu_s();
    const Setpoint sp = navigator.setpoint(state.position_W, state.yaw_rad);
    const Eigen::Vector3d before = vehicle.state().position_W;
    vehicle.step(sp.position_W, sp.velocity_W, sp.yaw_rad, options.control_dt_s);
    result.cpu_control_s += threadCpu_s() - cpu2;
    const Eigen::Vector3d& after = vehicle.state().position_W;
    result.path_length_m += (after - before).norm();
    result.trajectory_W.push_back(after);
    const double gap = clearance(world.world, after, t + options.control_dt_s);
    result.min_clearance_m = std::min(result.min_clearance_m, gap);
    const bool touching = gap < options.vehicle_radius_m;
    if (touching && !in_collision) ++result.collisions;
    in_collision = touching;
  }
  result.plans = navigator.plans();
  result.blocked_replans = navigator.blockedReplans();
  result.route_failures = navigator.routeFailures();
  result.grid = navigator.grid();
  return result;
}

}  // namespace mlmap::nav
