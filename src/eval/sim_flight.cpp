#include "mlmap/eval/sim_flight.h"

#include "mlmap/core/stopwatch.h"
#include "mlmap/datasets/frame_source.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace mlmap::eval {

bool overlapsSolid(const sim::World& world, const VoxelIndex& v, double resolution_m) {
  const Eigen::Vector3d inset = Eigen::Vector3d::Constant(1e-4 * resolution_m);
  const Eigen::Vector3d lo = v.cast<double>() * resolution_m;
  return world.intersectsBox(lo + inset, lo + Eigen::Vector3d::Constant(resolution_m) - inset, 0.0);
}

bool touchesSolid(const sim::World& world, const VoxelIndex& v, double resolution_m) {
  const Eigen::Vector3d lo = v.cast<double>() * resolution_m;
  return world.intersectsBox(lo, lo + Eigen::Vector3d::Constant(resolution_m), 1e-6);
}

int frameCount(const datasets::Scenario& scenario) {
  return datasets::SimulatedFlightSource::frameCount(scenario);
}

double frameTime(const datasets::Scenario& scenario, int i) { return i / scenario.frame_rate_hz; }

void ObservedTruth::observe(const DepthFrame& frame, const sim::World& world,
                            const MapConfig& config) {
  // Voxels of measured points whose interior overlaps a static solid. A voxel that only touches a
  // surface with a face (a floor at z = 0 under the voxel layer [0, res)) is empty inside: it is
  // not required, and accepted if mapped.
  const double res = config.local_map.resolution_m;
  const double max_range_m = config.awareness.max_range_m;
  const Transform T_W_S = frame.T_W_B * frame.T_B_S;
  backProject(frame, &points_S_);
  const double range = max_range_m + 1.0;
  const VoxelIndex origin = voxelIndexOf(T_W_S.translation(), res) -
                            VoxelIndex::Constant(static_cast<int>(range / res) + 1);
  seen_.reset(origin, Eigen::Vector3i::Constant(2 * (static_cast<int>(range / res) + 1) + 1));
  for (const Eigen::Vector3f& p_S : points_S_) {
    const Eigen::Vector3d p_W = T_W_S * p_S.cast<double>();
    if ((p_W - T_W_S.translation()).norm() > max_range_m) continue;
    const VoxelIndex v = voxelIndexOf(p_W, res);
    const VoxelIndex r = v - origin;
    if (!seen_.contains(r.x(), r.y(), r.z()) || seen_.testAndSet(r.x(), r.y(), r.z())) continue;
    if (voxels_.count(v)) continue;
    if (overlapsSolid(world, v, res)) voxels_.insert(v);
  }
}

FlightResult flyScenario(const datasets::Scenario& scenario, MapEngine& engine,
                         const FlightOptions& options) {
  FlightResult result;
  datasets::SimulatedTiming timing;
  timing.start_time_s = options.start_time_s;
  const datasets::SimulatedFlightSource source(scenario, engine.config().sensor.T_B_S(), timing);
  const int planned = static_cast<int>(std::min<std::size_t>(
      source.size(), static_cast<std::size_t>(std::max(options.max_frames, 0))));
  std::vector<double> render_ms;
  ObservedTruth truth;
  for (int i = 0; i < planned; ++i) {
    const auto start = SteadyClock::now();
    DepthFrame frame = std::get<DepthFrame>(source.read(static_cast<std::size_t>(i)));
    render_ms.push_back(msSince(start));
    truth.observe(frame, scenario.world, engine.config());
    result.trajectory_W.push_back(frame.T_W_B.translation());
    if (options.before_submit) options.before_submit(result.frames);
    engine.submit(std::move(frame));
    ++result.frames;
    if (options.progress) options.progress(result.frames, planned);
  }
  engine.flush();
  result.observed_truth = truth.voxels();
  if (!render_ms.empty()) {
    std::nth_element(render_ms.begin(), render_ms.begin() + render_ms.size() / 2, render_ms.end());
    result.render_ms_median = render_ms[render_ms.size() / 2];
  }
  return result;
}

Accuracy scoreOccupancy(const std::vector<VoxelIndex>& mapped, const VoxelSet& observed_truth,
                        const sim::World& world, double resolution_m) {
  Accuracy a;
  a.mapped = mapped.size();
  a.observed_truth = observed_truth.size();
  for (const VoxelIndex& v : mapped) {
    if (touchesSolid(world, v, resolution_m)) ++a.true_positives;
    if (observed_truth.count(v)) ++a.recalled;
  }
  a.precision =
      a.mapped ? static_cast<double>(a.true_positives) / static_cast<double>(a.mapped) : 0.0;
  a.recall = a.observed_truth
                 ? static_cast<double>(a.recalled) / static_cast<double>(a.observed_truth)
                 : 0.0;
  a.f1 = (a.precision + a.recall) > 0.0 ? 2.0 * a.precision * a.recall / (a.precision + a.recall)
                                        : 0.0;
  return a;
}

}  // namespace mlmap::eval
