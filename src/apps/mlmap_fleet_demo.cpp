// mlmap_fleet_demo: flies several simulated vehicles at once (one scenario each, e.g.
// config/worlds/fleet/uav1..3.yaml), each with its own engine sharing its changed submaps once a
// second as mlmap_node does (fleet::SubmapShare, its own evidence), the others taking them as
// priors (sharing back), all merged in a fleet::FleetMap as mlmap_fleet merges them. In one
// process, without DDS (the DDS side is tested in mlmap_fleet_dds_tests). Writes the merged map's
// top view coloured by vehicle, each vehicle's own map, and summary.json with the merged map's
// accuracy against ground truth and its agreement with one engine fed every vehicle's frames.

#include "mlmap/eval/json_output.h"
#include "mlmap/eval/run_outputs.h"
#include "mlmap/fleet/fleet_map.h"
#include "mlmap/fleet/submap_codec.h"
#include "mlmap/fleet/submap_share.h"
#include "mlmap/eval/voxel_agreement.h"
#include "mlmap/datasets/frame_source.h"
#include "mlmap/pictures/map_image.h"

#include <CLI/CLI.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <tuple>

namespace {

using namespace mlmap;

/// The command line of mlmap_fleet_demo.
struct Options {
  std::vector<std::string>
      scenario_paths;                    ///< --scenario, one per vehicle (its file stem names it)
  std::string out_dir = "fleet_output";  ///< --out
  double resolution_m = 0.1;             ///< --resolution
  double share_hz = 1.0;                 ///< --share-hz: sharing rounds per second of flight
  double noise = 0.0;                    ///< --noise: depth noise coefficient [1/m]
  int max_frames = 0;                    ///< --max-frames per vehicle (0: all)
  bool share_back = true;                ///< --no-share-back clears it
  double view_min_z_m = 0.2;             ///< --view-min-z: the pictures' height band, bottom
  double view_max_z_m = 2.0;             ///< --view-max-z: top (floor and ceiling left out)
};

void addOptions(CLI::App& app, Options& o) {
  app.add_option("--scenario", o.scenario_paths,
                 "a vehicle's scenario YAML (repeat per vehicle; "
                 "its file name without .yaml names the vehicle)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--out", o.out_dir, "output folder")->capture_default_str();
  app.add_option("--resolution", o.resolution_m, "voxel size [m]")
      ->check(CLI::Range(0.05, 1.0))
      ->capture_default_str();
  app.add_option("--share-hz", o.share_hz,
                 "sharing rounds per second of flight (dds.fleet.rate_hz)")
      ->check(CLI::Range(0.1, 100.0))
      ->capture_default_str();
  app.add_option("--noise", o.noise, "depth noise: sigma = K * z^2 [1/m] (0: noise-free)")
      ->check(CLI::Range(0.0, 0.1))
      ->capture_default_str();
  app.add_option("--max-frames", o.max_frames, "stop each vehicle after N frames (0: all)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--view-min-z", o.view_min_z_m, "pictures: voxels whose centre is above [m]")
      ->capture_default_str();
  app.add_option("--view-max-z", o.view_max_z_m, "pictures: ... and below [m] (walls, obstacles)")
      ->capture_default_str();
  app.add_flag("!--no-share-back", o.share_back,
               "vehicles do not take the others' submaps as priors (only occupied voxels travel)");
}

/// One simulated vehicle: its frames, its engine and what it shared.
struct Vehicle {
  Vehicle(std::string vehicle_name, datasets::Scenario flight, const MapConfig& config)
      : name(std::move(vehicle_name)),
        scenario(std::move(flight)),
        source(scenario, config.sensor.T_B_S()),
        engine(config),
        share(config.local_map.submap_cells()) {}

  std::string name;
  datasets::Scenario scenario;
  datasets::SimulatedFlightSource source;
  MapEngine engine;
  fleet::SubmapShare share;
  std::vector<Eigen::Vector3d> trajectory_W;
  int frames_planned = 0;
  int frames_mapped = 0;
  std::uint64_t version = 0;   ///< the global map's version at the last share
  std::uint64_t sequence = 0;  ///< of the last sample
  std::size_t bytes_sent = 0;  ///< encoded voxel payloads (mlmap_msgs/Submap's `data`)
  std::size_t submaps_sent = 0;
};

/// One sharing round of `v`, as mlmap_node's fleet output: its changed submaps (its own
/// evidence) into `fleet`, and as priors into every other vehicle when `share_back`.
void shareRound(Vehicle& v, std::vector<std::unique_ptr<Vehicle>>& all, fleet::FleetMap* fleet,
                bool share_back) {
  fleet::GlobalMapDelta delta = fleet::collectGlobalDelta(v.engine.globalMap(), v.version);
  v.version = delta.version;
  const std::shared_ptr<const MapSnapshot> snap = v.engine.snapshot();
  const std::shared_ptr<const PriorVoxels> priors = v.engine.priors();
  std::vector<fleet::SubmapUpdate> updates =
      v.share.changes(std::move(delta), snap ? &snap->window() : nullptr, priors.get());
  for (fleet::SubmapUpdate& u : updates) {
    v.bytes_sent += fleet::encodeSubmapVoxels(u.records).data.size();
    ++v.submaps_sent;
    if (share_back) {
      for (auto& other : all) {
        if (other.get() != &v) other->engine.addPrior(u.index, u.records);
      }
    }
    fleet->apply(v.name, u.index, ++v.sequence, std::move(u.records));
  }
}

/// BGR of vehicle `index`'s colour, `shade` in (0, 1] darkening it.
cv::Scalar vehicleBgr(int index, double shade = 1.0) {
  const std::uint32_t rgb = fleet::vehicleColourRgb(index);
  return {shade * (rgb & 0xff), shade * ((rgb >> 8) & 0xff), shade * ((rgb >> 16) & 0xff)};
}

/// `v` with one decimal.
std::string fixed(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", v);
  return text;
}

/// True when voxel `g`'s centre lies in the pictures' height band.
bool inView(const Options& o, const VoxelIndex& g, double resolution_m) {
  const double z_m = (g.z() + 0.5) * resolution_m;
  return z_m >= o.view_min_z_m && z_m <= o.view_max_z_m;
}

/// The merged map from above (the height band of `o`): each column in the colour of the first
/// vehicle holding its highest voxel, each vehicle's path in its own colour (darker), a legend.
cv::Mat renderMergedByVehicle(const Options& o, const fleet::FleetMap& fleet,
                              const std::vector<std::unique_ptr<Vehicle>>& vehicles) {
  const double res = fleet.resolution_m();
  // Per column: the highest voxel's height and vehicle bits.
  std::map<std::pair<int, int>, std::pair<int, std::uint64_t>> columns;
  pictures::VoxelList voxels;
  voxels.resolution_m = res;
  fleet.forEachOccupied([&](const VoxelIndex& g, LogOddsQ, std::uint64_t bits) {
    if (!inView(o, g, res)) return;
    voxels.centers_W.push_back((g.cast<double>() + Eigen::Vector3d::Constant(0.5)) * res);
    auto [it, inserted] = columns.try_emplace({g.x(), g.y()}, g.z(), bits);
    if (!inserted && g.z() > it->second.first) it->second = {g.z(), bits};
  });
  pictures::MapImageOptions options;
  options.title = "fleet map: " + std::to_string(vehicles.size()) + " vehicles, " +
                  std::to_string(fleet.voxelCount()) + " occupied voxels, coloured by vehicle (" +
                  fixed(o.view_min_z_m) + " .. " + fixed(o.view_max_z_m) + " m high)";
  options.legend = false;
  pictures::MapImageGeometry geometry;
  cv::Mat image = pictures::renderTopDown(voxels, options, &geometry);
  if (voxels.centers_W.empty()) return image;
  const int px = std::max(1, geometry.pixels_per_voxel);
  for (const auto& [xy, top] : columns) {
    const std::uint64_t bits = top.second;
    const int first = bits == 0 ? 0 : __builtin_ctzll(bits);
    const cv::Point c = geometry.toPixel((xy.first + 0.5) * res, (xy.second + 0.5) * res);
    cv::rectangle(image, cv::Rect(c.x - px / 2, c.y - px / 2, px, px), vehicleBgr(first),
                  cv::FILLED);
  }
  for (std::size_t k = 0; k < vehicles.size(); ++k) {
    const auto& path = vehicles[k]->trajectory_W;
    const int index = static_cast<int>(k);
    for (std::size_t i = 1; i < path.size(); ++i) {
      cv::line(image, geometry.toPixel(path[i - 1].x(), path[i - 1].y()),
               geometry.toPixel(path[i].x(), path[i].y()), vehicleBgr(index, 0.55), 2, cv::LINE_AA);
    }
    // Legend, top left inside the map area.
    const cv::Point at(geometry.map_area_px.x + 8, geometry.map_area_px.y + 18 + 20 * index);
    cv::rectangle(image, cv::Rect(at.x, at.y - 12, 14, 14), vehicleBgr(index), cv::FILLED);
    cv::putText(image, vehicles[k]->name, at + cv::Point(20, 0), cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  return image;
}

/// The fleet's flight: every vehicle's frame i in turn (they fly at once), a sharing round every
/// 1 / share_hz seconds of flight and one at the end.
void flyFleet(const Options& o, std::vector<std::unique_ptr<Vehicle>>& vehicles,
              fleet::FleetMap* fleet, eval::ObservedTruth* truth, const MapConfig& config) {
  int longest = 0;
  for (const auto& v : vehicles) longest = std::max(longest, v->frames_planned);
  const double rate_hz = vehicles.front()->scenario.frame_rate_hz;
  const int share_every = std::max(1, static_cast<int>(std::lround(rate_hz / o.share_hz)));
  eval::ProgressBar bar("flying ");
  for (int i = 0; i < longest; ++i) {
    for (auto& v : vehicles) {
      if (i >= v->frames_planned) continue;
      DepthFrame frame = std::get<DepthFrame>(v->source.read(static_cast<std::size_t>(i)));
      truth->observe(frame, v->scenario.world, config);
      v->trajectory_W.push_back(frame.T_W_B.translation());
      if (v->engine.submit(std::move(frame)) == FrameStatus::kAccepted) ++v->frames_mapped;
    }
    if ((i + 1) % share_every == 0) {
      for (const auto& v : vehicles) shareRound(*v, vehicles, fleet, o.share_back);
    }
    bar.update(i + 1, longest);
  }
  for (const auto& v : vehicles) shareRound(*v, vehicles, fleet, o.share_back);
}

/// One engine fed every vehicle's frames, one flight after the other (each flight's stamps
/// moved after the previous one's: an engine maps frames in stamp order): its occupied voxels.
std::vector<VoxelIndex> singleEngineVoxels(const std::vector<std::unique_ptr<Vehicle>>& vehicles,
                                           const MapConfig& config) {
  MapEngine single(config);
  double stamp_offset_s = 0.0;
  for (const auto& v : vehicles) {
    double last_s = 0.0;
    for (int i = 0; i < v->frames_planned; ++i) {
      DepthFrame frame = std::get<DepthFrame>(v->source.read(static_cast<std::size_t>(i)));
      last_s = frame.stamp_s;
      frame.stamp_s += stamp_offset_s;
      if (single.submit(std::move(frame)) != FrameStatus::kAccepted) {
        throw std::runtime_error("the single engine refused frame " + std::to_string(i) + " of " +
                                 v->name);
      }
    }
    stamp_offset_s += last_s + 1.0;
  }
  return single.occupiedVoxels();
}

/// Writes <out>/<vehicle>_top.png: what vehicle `index` brought to the merged map (the voxels
/// its own evidence raised, in the height band) and its path. Returns how many it raised.
std::size_t writeOwnVoxelsPicture(const Options& o, const fleet::FleetMap& fleet, const Vehicle& v,
                                  int index, double resolution_m) {
  pictures::VoxelList own;
  own.resolution_m = resolution_m;
  std::size_t own_count = 0;
  const std::uint64_t bit = std::uint64_t{1} << index;
  fleet.forEachOccupied([&](const VoxelIndex& g, LogOddsQ, std::uint64_t bits) {
    if ((bits & bit) == 0) return;
    ++own_count;
    if (inView(o, g, resolution_m)) {
      own.centers_W.push_back((g.cast<double>() + Eigen::Vector3d::Constant(0.5)) * resolution_m);
    }
  });
  pictures::MapImageOptions options;
  options.trajectory_W = v.trajectory_W;
  options.title = v.name + ": the " + std::to_string(own_count) +
                  " merged voxels its own evidence raised (" + fixed(o.view_min_z_m) + " .. " +
                  fixed(o.view_max_z_m) + " m high)";
  pictures::writePng(o.out_dir + "/" + v.name + "_top.png", pictures::renderTopDown(own, options));
  return own_count;
}

/// Flies the fleet and one engine fed every vehicle's frames, writes the pictures and
/// summary.json.
void run(const Options& o) {
  const auto started = std::chrono::steady_clock::now();
  MapConfig config = eval::runConfig("", eval::DataKind::kSimulator, o.resolution_m);
  const std::vector<std::string> problems = config.validate();
  if (!problems.empty()) throw std::runtime_error("configuration: " + problems.front());
  std::filesystem::create_directories(o.out_dir);
  std::vector<std::unique_ptr<Vehicle>> vehicles;
  for (const std::string& path : o.scenario_paths) {
    datasets::Scenario scenario = datasets::loadScenarioYaml(path);
    scenario.camera.noise_coeff_per_m = o.noise;
    auto v = std::make_unique<Vehicle>(std::filesystem::path(path).stem().string(),
                                       std::move(scenario), config);
    v->frames_planned = static_cast<int>(v->source.size());
    if (o.max_frames > 0) v->frames_planned = std::min(v->frames_planned, o.max_frames);
    vehicles.push_back(std::move(v));
  }
  fleet::FleetMap fleet(config.log_odds);
  fleet.acceptGeometry(config.local_map.resolution_m, config.local_map.submap_cells());
  for (const auto& v : vehicles) fleet.vehicleIndex(v->name);  // colours in the command's order
  eval::ObservedTruth truth;
  spdlog::info("flying {} vehicles at {} m, sharing at {} Hz{}", vehicles.size(), o.resolution_m,
               o.share_hz, o.share_back ? ", each taking the others' submaps as priors" : "");
  flyFleet(o, vehicles, &fleet, &truth, config);

  const std::vector<VoxelIndex> single_voxels = singleEngineVoxels(vehicles, config);
  std::vector<VoxelIndex> merged;
  fleet.forEachOccupied([&](const VoxelIndex& g, LogOddsQ, std::uint64_t) { merged.push_back(g); });
  const sim::World& world = vehicles.front()->scenario.world;
  const double res = config.local_map.resolution_m;
  const eval::Accuracy accuracy = eval::scoreOccupancy(merged, truth.voxels(), world, res);
  const eval::Accuracy single_accuracy =
      eval::scoreOccupancy(single_voxels, truth.voxels(), world, res);
  const double iou = eval::compareVoxels(merged, single_voxels).iou;

  pictures::writePng(o.out_dir + "/fleet_top.png", renderMergedByVehicle(o, fleet, vehicles));
  eval::Json json_vehicles = eval::Json::array();
  double seconds = 0.0;
  for (std::size_t k = 0; k < vehicles.size(); ++k) {
    const Vehicle& v = *vehicles[k];
    const double flight_s = v.frames_planned / v.scenario.frame_rate_hz;
    seconds = std::max(seconds, flight_s);
    const std::size_t own_count = writeOwnVoxelsPicture(o, fleet, v, static_cast<int>(k), res);
    json_vehicles.push_back(
        {{"name", v.name},
         {"frames_mapped", v.frames_mapped},
         {"frames_planned", v.frames_planned},
         {"bytes_sent", v.bytes_sent},
         {"bytes_per_s", flight_s > 0.0 ? static_cast<double>(v.bytes_sent) / flight_s : 0.0},
         {"submaps_sent", v.submaps_sent},
         {"merged_voxels_raised", own_count},
         {"flight_s", flight_s},
         {"colour_rgb", fleet::vehicleColourRgb(static_cast<int>(k))}});
  }
  eval::Json summary;
  summary["vehicles"] = json_vehicles;
  summary["merged"] = {{"occupied_voxels", merged.size()},
                       {"f1", accuracy.f1},
                       {"precision", accuracy.precision},
                       {"recall", accuracy.recall},
                       {"iou_vs_single_engine", iou}};
  summary["single_engine"] = {{"occupied_voxels", single_voxels.size()},
                              {"f1", single_accuracy.f1},
                              {"precision", single_accuracy.precision},
                              {"recall", single_accuracy.recall}};
  summary["seconds"] = seconds;
  summary["wall_seconds"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  summary["resolution_m"] = res;
  summary["share_hz"] = o.share_hz;
  summary["share_back"] = o.share_back;
  summary["noise_coeff_per_m"] = o.noise;
  summary["transport"] = "in-process fleet core (fleet::SubmapShare -> fleet::FleetMap), no DDS";
  eval::writeJsonFile(o.out_dir + "/summary.json", summary, 2);

  std::printf("\nfleet of %zu over %.1f s of flight, %.1f m voxels, sharing at %.1f Hz%s\n",
              vehicles.size(), seconds, res, o.share_hz, o.share_back ? ", sharing back" : "");
  for (const auto& v : vehicles) {
    std::printf("  %-8s %5d frames mapped, %8zu B sent (%.0f B/s) in %zu submaps\n",
                v->name.c_str(), v->frames_mapped, v->bytes_sent,
                static_cast<double>(v->bytes_sent) /
                    std::max(1e-9, v->frames_planned / v->scenario.frame_rate_hz),
                v->submaps_sent);
  }
  std::printf(
      "  merged: %zu occupied voxels, F1 %.4f (precision %.4f, recall %.4f), IoU vs one "
      "engine %.4f (its F1 %.4f)\n  wrote %s/{fleet_top.png, <vehicle>_top.png, summary.json}\n",
      merged.size(), accuracy.f1, accuracy.precision, accuracy.recall, iou, single_accuracy.f1,
      o.out_dir.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mlmap fleet demo: several simulated vehicles map at once, share their submaps as\n"
      "mlmap_node does and are merged as mlmap_fleet merges them (in one process, no DDS)."};
  Options options;
  addOptions(app, options);
  CLI11_PARSE(app, argc, argv);
  spdlog::set_default_logger(spdlog::stderr_color_mt("mlmap"));  // stdout carries the results
  try {
    run(options);
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
