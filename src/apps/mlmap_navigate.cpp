// mlmap_navigate: the reference planner (mlmap_nav) flies a few seeded unknown worlds on
// mlmap's maps in the simulator, in one process, and writes for each world a picture (the
// planner's map, the ground truth, the path flown, the goal, where a new frame made it plan at
// once) and summary.json (docs/planners.md, "Flying on mlmap"). `bash tools/demo.sh --navigate`.

#include "mlmap/eval/json_output.h"
#include "mlmap/nav/nav_flight.h"
#include "mlmap/pictures/map_image.h"
#include "mlmap/pipeline/map_engine.h"

#include <CLI/CLI.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace {

using namespace mlmap;

/// The vehicle's mean speed along a route as a share of its top speed (measured: 0.95-0.97 in
/// the forests), to time the crossing persons.
constexpr double kMeanSpeedShare = 0.95;

/// The command line of mlmap_navigate.
struct Options {
  std::string out_dir = "nav_output";  ///< --out
  int worlds = 10;                     ///< --worlds: the first N of the benchmark's worlds
  unsigned seed = 1;                   ///< --seed
  double resolution_m = 0.2;           ///< --resolution
};

/// Where the picture puts the world: pixels per metre and the world corner at the top left.
struct View {
  double px_per_m = 25.0;
  Eigen::Vector2d min_W = Eigen::Vector2d::Zero();
  Eigen::Vector2d max_W = Eigen::Vector2d::Zero();
  int top_px = 60;  ///< room for the title
  [[nodiscard]] cv::Point toPixel(const Eigen::Vector2d& p_W) const {
    return {static_cast<int>(std::lround((p_W.x() - min_W.x()) * px_per_m)),
            top_px + static_cast<int>(std::lround((max_W.y() - p_W.y()) * px_per_m))};
  }
};

void drawPolyline(cv::Mat* image, const View& view, const std::vector<Eigen::Vector2d>& points_W,
                  const cv::Scalar& bgr, int thickness) {
  std::vector<cv::Point> pixels;
  pixels.reserve(points_W.size());
  for (const Eigen::Vector2d& p : points_W) pixels.push_back(view.toPixel(p));
  if (pixels.size() >= 2) cv::polylines(*image, pixels, false, bgr, thickness, cv::LINE_AA);
}

/// The picture of one flight.
cv::Mat renderFlight(const nav::NavWorld& world, const nav::NavFlightResult& r) {
  View view;
  view.min_W = world.min_xy_W - Eigen::Vector2d::Constant(1.0);
  view.max_W = world.max_xy_W + Eigen::Vector2d::Constant(1.0);
  const Eigen::Vector2d size = view.max_W - view.min_W;
  const int legend_px = 80;
  cv::Mat image(view.top_px + static_cast<int>(size.y() * view.px_per_m) + legend_px,
                std::max(static_cast<int>(size.x() * view.px_per_m), 760), CV_8UC3,
                cv::Scalar(255, 255, 255));
  // The planner's map: known free light grey, occupied dark grey, unknown left white.
  const ProjectedGrid& grid = r.grid;
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const std::int8_t v = grid.at(x, y);
      if (v == ProjectedGrid::kUnknown) continue;
      const Eigen::Vector2d lo = grid.origin_W + Eigen::Vector2d(x, y) * grid.resolution_m;
      const cv::Point a = view.toPixel(lo);
      const cv::Point b = view.toPixel(lo + Eigen::Vector2d::Constant(grid.resolution_m));
      const cv::Scalar colour = v > 50 ? cv::Scalar(80, 80, 80) : cv::Scalar(228, 228, 228);
      cv::rectangle(image, cv::Rect(cv::Point(a.x, b.y), cv::Point(b.x, a.y)), colour, cv::FILLED);
    }
  }
  // The ground truth at the flight height: outlines of the solids it cuts.
  const double z = world.start_W.z();
  const cv::Scalar truth(40, 140, 40);
  for (const sim::Box& box : world.world.boxes()) {
    if (box.min_W.z() > z + 0.5 || box.max_W.z() < z - 0.5) continue;
    const cv::Point a = view.toPixel(box.min_W.head<2>());
    const cv::Point b = view.toPixel(box.max_W.head<2>());
    cv::rectangle(image, cv::Rect(cv::Point(a.x, b.y), cv::Point(b.x, a.y)), truth, 1, cv::LINE_AA);
  }
  for (const sim::Cylinder& c : world.world.cylinders()) {
    if (c.z_min_m > z + 0.5 || c.z_max_m < z - 0.5) continue;
    cv::circle(image, view.toPixel(c.center_xy_W),
               std::max(1, static_cast<int>(std::lround(c.radius_m * view.px_per_m))), truth, 1,
               cv::LINE_AA);
  }
  for (const sim::Sphere& s : world.world.spheres()) {
    const double dz = std::abs(s.center_W.z() - z);
    if (dz > s.radius_m) continue;
    const double r_cut = std::sqrt(s.radius_m * s.radius_m - dz * dz);
    cv::circle(image, view.toPixel(s.center_W.head<2>()),
               std::max(1, static_cast<int>(std::lround(r_cut * view.px_per_m))), truth, 1,
               cv::LINE_AA);
  }
  for (const sim::MovingBox& m : world.world.movingBoxes()) {  // the person's walk
    const Eigen::Vector3d from = m.centerAt(m.t_start_s);
    const Eigen::Vector3d to = m.centerAt(m.t_end_s);
    cv::arrowedLine(image, view.toPixel(from.head<2>()), view.toPixel(to.head<2>()),
                    cv::Scalar(200, 60, 200), 2, cv::LINE_AA, 0, 0.05);
  }
  // Ground-truth shortest route, path flown, replan points, start and goal.
  drawPolyline(&image, view, r.shortest_route_W, cv::Scalar(60, 200, 60), 1);
  std::vector<Eigen::Vector2d> flown;
  flown.reserve(r.trajectory_W.size());
  for (const Eigen::Vector3d& p : r.trajectory_W) flown.push_back(p.head<2>());
  drawPolyline(&image, view, flown, cv::Scalar(200, 90, 20), 2);
  for (const Eigen::Vector3d& p : r.replan_points_W) {
    cv::circle(image, view.toPixel(p.head<2>()), 5, cv::Scalar(0, 140, 255), 2, cv::LINE_AA);
  }
  cv::circle(image, view.toPixel(world.start_W.head<2>()), 6, cv::Scalar(200, 90, 20), cv::FILLED,
             cv::LINE_AA);
  cv::drawMarker(image, view.toPixel(world.goal_W.head<2>()), cv::Scalar(30, 30, 220),
                 cv::MARKER_TILTED_CROSS, 16, 3, cv::LINE_AA);
  char title[256];
  std::snprintf(title, sizeof(title), "%s: %s, %d collisions, clearance >= %.2f m",
                world.name.c_str(), r.reached ? "reached" : "NOT reached", r.collisions,
                r.min_clearance_m);
  cv::putText(image, title, {8, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  std::snprintf(
      title, sizeof(title), "flown %.1f m (shortest %.1f m) in %.1f s, %llu plans, %llu at once",
      r.path_length_m, r.shortest_path_m, r.time_s, static_cast<unsigned long long>(r.plans),
      static_cast<unsigned long long>(r.blocked_replans));
  cv::putText(image, title, {8, 48}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  const int y0 = image.rows - legend_px + 22;
  const auto legend = [&image](int x, int y, const cv::Scalar& colour, const char* text) {
    cv::rectangle(image, cv::Rect(x, y - 9, 14, 10), colour, cv::FILLED);
    cv::putText(image, text, {x + 20, y}, cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
  };
  legend(8, y0, cv::Scalar(80, 80, 80), "mapped occupied");
  legend(180, y0, cv::Scalar(228, 228, 228), "mapped free (white: unknown)");
  legend(450, y0, cv::Scalar(40, 140, 40), "ground truth at flight height");
  legend(8, y0 + 24, cv::Scalar(200, 90, 20), "path flown (dot: start)");
  legend(205, y0 + 24, cv::Scalar(60, 200, 60), "shortest route");
  legend(350, y0 + 24, cv::Scalar(30, 30, 220), "goal");
  legend(420, y0 + 24, cv::Scalar(0, 140, 255), "planned at once");
  legend(590, y0 + 24, cv::Scalar(200, 60, 200), "person's walk");
  return image;
}

double p99(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return sortedQuantile(values, 0.99);
}

int run(const Options& o) {
  std::filesystem::create_directories(o.out_dir);
  nav::NavFlightOptions options;
  options.map = nav::navMapConfig(o.resolution_m);
  const std::vector<nav::NavWorld> worlds =
      nav::benchmarkWorlds(o.worlds, o.seed, options.planner.inflation_m,
                           kMeanSpeedShare * options.vehicle.max_speed_mps);
  eval::Json json_worlds = eval::Json::array();
  int reached = 0;
  int collisions = 0;
  for (const nav::NavWorld& world : worlds) {
    const nav::NavFlightResult r = nav::flyToGoal(world, options);
    reached += r.reached ? 1 : 0;
    collisions += r.collisions;
    pictures::writePng(o.out_dir + "/" + world.name + ".png", renderFlight(world, r));
    json_worlds.push_back({{"name", world.name},
                           {"reached", r.reached},
                           {"collisions", r.collisions},
                           {"min_clearance_m", r.min_clearance_m},
                           {"path_length_m", r.path_length_m},
                           {"shortest_path_m", r.shortest_path_m},
                           {"time_s", r.time_s},
                           {"replans", r.blocked_replans},
                           {"map_to_plan_ms_p99", p99(r.map_to_plan_ms)}});
    std::printf(
        "%-32s %s  collisions %d  min clearance %.2f m  flown %.1f m / shortest %.1f m  %.1f s\n",
        world.name.c_str(), r.reached ? "reached" : "NOT reached", r.collisions, r.min_clearance_m,
        r.path_length_m, r.shortest_path_m, r.time_s);
  }
  eval::Json summary;
  summary["worlds"] = json_worlds;
  summary["totals"] = {
      {"reached_fraction",
       worlds.empty() ? 0.0 : static_cast<double>(reached) / static_cast<double>(worlds.size())},
      {"collisions", collisions}};
  eval::writeJsonFile(o.out_dir + "/summary.json", summary, 2);
  std::printf("reached %d of %zu goals, %d collisions; wrote %s/{<world>.png, summary.json}\n",
              reached, worlds.size(), collisions, o.out_dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Flies the reference planner on mlmap's maps through seeded unknown worlds and "
      "writes a picture per world and summary.json"};
  Options o;
  app.add_option("--out", o.out_dir, "output folder")->capture_default_str();
  app.add_option("--worlds", o.worlds, "how many of the benchmark's worlds to fly")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--seed", o.seed, "first seed")->capture_default_str();
  app.add_option("--resolution", o.resolution_m, "voxel size [m]")
      ->check(CLI::Range(0.05, 0.5))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_default_logger(spdlog::stderr_color_mt("mlmap"));
  try {
    return run(o);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
