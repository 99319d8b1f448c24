// The one frame-source interface against the readers and the renderer it wraps: every frame the
// same, bit for bit, as read or rendered directly.
#include "mlmap/datasets/frame_source.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#ifndef MLMAP_SHARED_DATA_DIR
#error "MLMAP_SHARED_DATA_DIR must name the shared data folder (e.g. /work/shared/data)"
#endif

namespace mlmap::datasets {
namespace {

const std::string kTabletopDir = std::string(MLMAP_SHARED_DATA_DIR) + "/realsense_tabletop";

bool sameDepth(const DepthFrame& a, const DepthFrame& b) {
  // Bit for bit (NaN pixels included); no memcmp of empty vectors' null data.
  const bool same_metres =
      a.depth_m.size() == b.depth_m.size() &&
      (a.depth_m.empty() ||
       std::memcmp(a.depth_m.data(), b.depth_m.data(), a.depth_m.size() * sizeof(float)) == 0);
  return a.depth_mm == b.depth_mm && same_metres && a.intrinsics.width == b.intrinsics.width &&
         a.intrinsics.height == b.intrinsics.height && a.intrinsics.fx == b.intrinsics.fx &&
         a.intrinsics.cy == b.intrinsics.cy && a.T_W_B.matrix() == b.T_W_B.matrix() &&
         a.T_B_S.matrix() == b.T_B_S.matrix() && a.stamp_s == b.stamp_s;
}

TEST(FrameDirectorySource, EveryFrameIsTheDirectorysFrameWithItsNameAndPixels) {
  const FrameDirectory direct(kTabletopDir);
  const FrameDirectorySource source(kTabletopDir);
  ASSERT_EQ(source.size(), direct.size());
  EXPECT_NE(source.describe().find(kTabletopDir), std::string::npos) << source.describe();
  for (std::size_t i = 0; i < source.size(); i += 7) {
    SourceFrameInfo info;
    const SourceFrame frame = source.read(i, &info);
    ASSERT_TRUE(std::holds_alternative<DepthFrame>(frame));
    const DepthFrame expected = direct.read(i);
    EXPECT_TRUE(sameDepth(std::get<DepthFrame>(frame), expected)) << "frame " << i;
    EXPECT_EQ(info.name, direct.frameName(i));
    EXPECT_EQ(info.points_in_file, expected.depth_mm.size() + expected.depth_m.size());
    EXPECT_EQ(stampOf(frame), expected.stamp_s);
    EXPECT_EQ(bodyPoseOf(frame).matrix(), expected.T_W_B.matrix());
  }
  EXPECT_THROW((void)source.read(source.size()), std::out_of_range);
}

/// A frame of `scenario` rendered directly, as the simulator's flights always did.
DepthFrame renderDirectly(const Scenario& scenario, const Transform& T_B_S, double t) {
  const sim::DepthCamera camera(scenario.camera);
  DepthFrame frame;
  frame.T_W_B = scenario.trajectory.poseAt(t);
  frame.T_B_S = T_B_S;
  camera.render(scenario.world, frame.T_W_B * T_B_S, t, &frame);
  frame.stamp_s = t;
  return frame;
}

TEST(SimulatedFlightSource, FramesAreTheRenderersAtTheScenariosTimes) {
  Scenario scenario = defaultScenario();
  scenario.camera.intrinsics.width = 80;  // small frames: this is about which frame, not pixels
  scenario.camera.intrinsics.height = 60;
  scenario.camera.intrinsics.fx = scenario.camera.intrinsics.fy = 60.0;
  scenario.camera.intrinsics.cx = 40.0;
  scenario.camera.intrinsics.cy = 30.0;
  Transform T_B_S = Transform::Identity();
  T_B_S.translation() = Eigen::Vector3d(0.1, 0.0, 0.0);
  const SimulatedFlightSource source(scenario, T_B_S);
  const auto total = static_cast<std::size_t>(
      std::floor(scenario.trajectory.duration_s() * scenario.frame_rate_hz) + 1);
  ASSERT_EQ(source.size(), total);
  EXPECT_EQ(static_cast<int>(total), SimulatedFlightSource::frameCount(scenario));
  for (std::size_t i : {std::size_t{0}, std::size_t{1}, total / 2, total - 1}) {
    SourceFrameInfo info;
    const SourceFrame frame = source.read(i, &info);
    const double t = static_cast<double>(i) / scenario.frame_rate_hz;
    EXPECT_EQ(source.frameTime(i), t);
    EXPECT_TRUE(sameDepth(std::get<DepthFrame>(frame), renderDirectly(scenario, T_B_S, t)))
        << "frame " << i;
    EXPECT_EQ(info.name, "sim-" + std::to_string(i));
    EXPECT_EQ(info.points_in_file, 80u * 60u);
  }
  EXPECT_THROW((void)source.read(total), std::out_of_range);

  // Later start, another rate, a faster flight: frame i shows speed x (first + i) / rate.
  SimulatedTiming timing;
  timing.rate_hz = 4.0;
  timing.speed = 2.5;
  timing.start_time_s = 3.1;  // frame time: the first frame is frame ceil(3.1 x 4) = 13
  const SimulatedFlightSource later(scenario, T_B_S, timing);
  const auto all = static_cast<std::size_t>(std::floor(scenario.trajectory.duration_s() * 4.0) + 1);
  ASSERT_EQ(later.size(), all - 13);
  const double t5 = 2.5 * 18.0 / 4.0;
  EXPECT_EQ(later.frameTime(5), t5);
  EXPECT_TRUE(sameDepth(std::get<DepthFrame>(later.read(5)), renderDirectly(scenario, T_B_S, t5)));

  timing.rate_hz = -1.0;
  EXPECT_THROW(SimulatedFlightSource(scenario, T_B_S, timing), std::invalid_argument);
  timing.rate_hz = 10.0;
  timing.speed = 0.0;
  EXPECT_THROW(SimulatedFlightSource(scenario, T_B_S, timing), std::invalid_argument);
  timing.speed = 1.0;
  timing.start_time_s = 1e9;  // beyond the trajectory: no frame
  EXPECT_EQ(SimulatedFlightSource(scenario, T_B_S, timing).size(), 0u);
}

}  // namespace
}  // namespace mlmap::datasets
