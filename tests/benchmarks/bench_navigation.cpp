// mlmap_bench_navigation: the reference planner (mlmap_nav) flying on mlmap's maps in the
// simulator, in one process, over seeded unknown worlds (forests at three densities, rooms
// joined by doors, the paper's room; a person crossing the route in every third). Per world and
// in total: goals reached, collisions (ground-truth clearance below the vehicle radius), the
// smallest clearance, the length flown against the ground-truth shortest route (same
// inflation), time to goal, map-to-plan latency (a frame's submission to the plan made from its
// snapshot, wall clock), plans per simulated second, and the CPU of each part against the
// simulated time. Figures, not pass / fail.

#include "mlmap/nav/nav_flight.h"
#include "mlmap/pipeline/map_engine.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

namespace {

using namespace mlmap;

/// The vehicle's mean speed along a route as a share of its top speed (measured: 0.95-0.97 in
/// the forests), to time the crossing persons.
constexpr double kMeanSpeedShare = 0.95;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return sortedQuantile(v, 0.5);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Closed-loop flights of the reference planner on mlmap's maps (figures, not pass / fail)"};
  int count = 100;
  unsigned seed = 1;
  double resolution_m = 0.2;
  bool per_world = false;
  std::string only;
  app.add_option("--worlds", count, "number of seeded worlds")->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "first seed");
  app.add_option("--resolution", resolution_m, "voxel edge [m]")->check(CLI::Range(0.05, 0.5));
  app.add_flag("--per-world", per_world, "a line per world");
  app.add_option("--only", only, "fly only the worlds whose name contains this");
  nav::NavFlightOptions options;
  app.add_option("--evade-radius", options.planner.evade_radius_m,
                 "back away from something that moved within this [m]")
      ->capture_default_str();
  app.add_option("--caution-radius", options.planner.caution_radius_m,
                 "slow down when something that moved is within this [m]")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  options.map = nav::navMapConfig(resolution_m);
  const std::vector<nav::NavWorld> worlds = nav::benchmarkWorlds(
      count, seed, options.planner.inflation_m, kMeanSpeedShare * options.vehicle.max_speed_mps);
  std::printf(
      "mlmap_bench_navigation: %d worlds from seed %u, %.2f m voxels, camera %dx%d at %.0f Hz, "
      "vehicle radius %.2f m, inflation %.2f m, %.1f m/s, %.1f m/s^2\n",
      count, seed, resolution_m, options.camera.intrinsics.width, options.camera.intrinsics.height,
      options.camera_rate_hz, options.vehicle_radius_m, options.planner.inflation_m,
      options.vehicle.max_speed_mps, options.vehicle.max_accel_mps2);
  int flown = 0;
  int reached = 0;
  int collisions = 0;
  int worlds_with_collision = 0;
  double min_clearance = 1e9;
  std::vector<double> latency_ms;
  std::vector<double> ratios_forest;
  std::vector<double> ratios_all;
  std::vector<double> times_s;
  double sim_s = 0.0;
  double render_s = 0.0, mapping_s = 0.0, global_s = 0.0, local_s = 0.0, control_s = 0.0;
  std::uint64_t plans = 0;
  std::uint64_t blocked = 0;
  for (const nav::NavWorld& world : worlds) {
    if (!only.empty() && world.name.find(only) == std::string::npos) continue;
    const nav::NavFlightResult r = nav::flyToGoal(world, options);
    ++flown;
    reached += r.reached ? 1 : 0;
    collisions += r.collisions;
    worlds_with_collision += r.collisions > 0 ? 1 : 0;
    min_clearance = std::min(min_clearance, r.min_clearance_m);
    latency_ms.insert(latency_ms.end(), r.map_to_plan_ms.begin(), r.map_to_plan_ms.end());
    const double ratio = r.shortest_path_m > 0.0 ? r.path_length_m / r.shortest_path_m : 0.0;
    if (r.reached) {
      ratios_all.push_back(ratio);
      if (r.name.rfind("forest", 0) == 0) ratios_forest.push_back(ratio);
      times_s.push_back(r.time_s);
    }
    sim_s += r.time_s;
    render_s += r.cpu_render_s;
    mapping_s += r.cpu_mapping_s;
    global_s += r.cpu_global_s;
    local_s += r.cpu_local_s;
    control_s += r.cpu_control_s;
    plans += r.plans;
    blocked += r.blocked_replans;
    if (per_world || !r.reached || r.collisions > 0) {
      std::vector<double> l = r.map_to_plan_ms;
      std::sort(l.begin(), l.end());
      std::printf(
          "  %-34s %s collisions %d  min clearance %.2f m  path %.1f m / shortest %.1f m (x%.3f)  "
          "%.1f s  plans %llu (blocked %llu, no route %llu)  map-to-plan p99 %.1f ms\n",
          r.name.c_str(), r.reached ? "reached" : "FAILED ", r.collisions, r.min_clearance_m,
          r.path_length_m, r.shortest_path_m, ratio, r.time_s,
          static_cast<unsigned long long>(r.plans),
          static_cast<unsigned long long>(r.blocked_replans),
          static_cast<unsigned long long>(r.route_failures),
          l.empty() ? 0.0 : sortedQuantile(l, 0.99));
    }
  }
  std::sort(latency_ms.begin(), latency_ms.end());
  std::sort(ratios_forest.begin(), ratios_forest.end());
  std::sort(ratios_all.begin(), ratios_all.end());
  std::printf("worlds flown              %d\n", flown);
  std::printf("goals reached             %d (%.1f %%)\n", reached,
              flown ? 100.0 * reached / flown : 0.0);
  std::printf("collisions                %d (in %d worlds)\n", collisions, worlds_with_collision);
  std::printf("min clearance             %.3f m (vehicle radius %.2f m)\n", min_clearance,
              options.vehicle_radius_m);
  if (!ratios_forest.empty()) {
    std::printf("path / shortest, forests  median %.3f  p90 %.3f  max %.3f (%zu flights)\n",
                sortedQuantile(ratios_forest, 0.5), sortedQuantile(ratios_forest, 0.9),
                ratios_forest.back(), ratios_forest.size());
  }
  if (!ratios_all.empty()) {
    std::printf("path / shortest, all      median %.3f  p90 %.3f  max %.3f\n",
                sortedQuantile(ratios_all, 0.5), sortedQuantile(ratios_all, 0.9),
                ratios_all.back());
  }
  std::printf("time to goal              median %.1f s\n", median(times_s));
  if (!latency_ms.empty()) {
    std::printf("map-to-plan (in process)  median %.2f ms  p99 %.2f ms  max %.2f ms (%zu frames)\n",
                sortedQuantile(latency_ms, 0.5), sortedQuantile(latency_ms, 0.99),
                latency_ms.back(), latency_ms.size());
  }
  std::printf(
      "plans                     %.1f per simulated second (%llu made at once on a blocked "
      "segment)\n",
      sim_s > 0 ? static_cast<double>(plans) / sim_s : 0.0,
      static_cast<unsigned long long>(blocked));
  const auto share = [sim_s](double cpu_s) { return sim_s > 0 ? 100.0 * cpu_s / sim_s : 0.0; };
  std::printf(
      "CPU, %% of one core over simulated time: mapping %.1f  global plan %.1f  local plan %.1f  "
      "control %.2f  (mapping + planning %.1f)  simulator's camera %.1f\n",
      share(mapping_s), share(global_s), share(local_s), share(control_s),
      share(mapping_s + global_s + local_s + control_s), share(render_s));
  return 0;
}
