#pragma once
// A cheap simulated flight for the map-file tests: the default room, a quarter-size depth camera
// (160 x 120, same field of view) and 2.5 frames per second (0.4 m per frame), mapped into a
// 5 x 5 x 3 m window at 0.2 m so that a few dozen frames slide the window and fill the global map.

#include "mlmap/eval/sim_flight.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/pipeline/map_engine.h"

#include <gtest/gtest.h>

namespace mlmap::test {

inline MapConfig smallWindowConfig() {
  MapConfig c;
  c.local_map.resolution_m = 0.2;
  c.local_map.size_cells = Eigen::Vector3i(25, 25, 15);
  return c;
}

/// The default camera at a quarter of its size (160 x 120, same field of view), for tests whose
/// subject is not the image (tests/support/small_camera_scenario.sh writes the same for YAML).
inline PinholeIntrinsics quarterCamera() { return {96.25, 96.25, 79.5, 59.5, 160, 120}; }

inline datasets::Scenario cheapScenario() {
  datasets::Scenario s = datasets::defaultScenario();
  s.camera.intrinsics = quarterCamera();
  s.frame_rate_hz = 2.5;
  return s;
}

/// Flies frames [first, first + frames) of cheapScenario() into `engine`.
inline void flyCheap(MapEngine& engine, int first, int frames) {
  const datasets::Scenario scenario = cheapScenario();
  eval::FlightOptions options;
  options.start_time_s = eval::frameTime(scenario, first);
  options.max_frames = frames;
  ASSERT_EQ(eval::flyScenario(scenario, engine, options).frames, frames);
}

}  // namespace mlmap::test
