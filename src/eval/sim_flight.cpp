#include "mlmap/eval/sim_flight.h"

#include "mlmap/core/voxel_bitset.h"

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

int frameCount(const io::Scenario& scenario) {
  return static_cast<int>(std::floor(scenario.trajectory.duration_s() * scenario.frame_rate_hz)) + 1;
}

double frameTime(const io::Scenario& scenario, int i) { return i / scenario.frame_rate_hz; }

FlightResult flyScenario(const io::Scenario& scenario, MapEngine& engine,
                         const FlightOptions& options) {
  FlightResult result;
  const sim::DepthCamera camera(scenario.camera);
  const Transform T_B_S = engine.config().sensor.T_B_S();
  const double res = engine.config().local_map.resolution_m;
  const int first = static_cast<int>(std::ceil(options.start_time_s * scenario.frame_rate_hz));
  const int last = std::min(frameCount(scenario), first + std::max(options.max_frames, 0));
  const int planned = std::max(last - first, 0);
  std::vector<double> render_ms;
  std::vector<Eigen::Vector3f> points_S;
  VoxelBitset seen;
  for (int i = first; i < last; ++i) {
    const double t = frameTime(scenario, i);
    DepthFrame frame;
    frame.T_W_B = scenario.trajectory.poseAt(t);
    frame.T_B_S = T_B_S;
    const Transform T_W_S = frame.T_W_B * T_B_S;
    const auto start = std::chrono::steady_clock::now();
    camera.render(scenario.world, T_W_S, t, &frame);
    render_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    frame.stamp_s = t;

    // Ground truth actually observed: voxels of measured points whose interior overlaps a static
    // solid. A voxel that only touches a surface with a face (a floor at z = 0 under the voxel
    // layer [0, res)) is empty inside: it is not required, and accepted if mapped.
    backProject(frame, &points_S);
    const double range = engine.config().awareness.max_range_m + 1.0;
    const VoxelIndex origin = voxelIndexOf(T_W_S.translation(), res) -
                              VoxelIndex::Constant(static_cast<int>(range / res) + 1);
    seen.reset(origin, Eigen::Vector3i::Constant(2 * (static_cast<int>(range / res) + 1) + 1));
    for (const Eigen::Vector3f& p_S : points_S) {
      const Eigen::Vector3d p_W = T_W_S * p_S.cast<double>();
      if ((p_W - T_W_S.translation()).norm() > engine.config().awareness.max_range_m) continue;
      const VoxelIndex v = voxelIndexOf(p_W, res);
      const VoxelIndex r = v - origin;
      if (!seen.contains(r.x(), r.y(), r.z()) || seen.testAndSet(r.x(), r.y(), r.z())) continue;
      if (result.observed_truth.count(v)) continue;
      if (overlapsSolid(scenario.world, v, res)) result.observed_truth.insert(v);
    }
    result.trajectory_W.push_back(frame.T_W_B.translation());
    if (options.before_submit) options.before_submit(result.frames);
    engine.submit(std::move(frame));
    ++result.frames;
    if (options.progress) options.progress(result.frames, planned);
  }
  engine.flush();
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
  a.precision = a.mapped ? static_cast<double>(a.true_positives) / static_cast<double>(a.mapped) : 0.0;
  a.recall = a.observed_truth
                 ? static_cast<double>(a.recalled) / static_cast<double>(a.observed_truth)
                 : 0.0;
  a.f1 = (a.precision + a.recall) > 0.0 ? 2.0 * a.precision * a.recall / (a.precision + a.recall)
                                        : 0.0;
  return a;
}

}  // namespace mlmap::eval
