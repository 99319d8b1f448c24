// adaptReplayConfig(): how an offline replay fits the engine to its range, threads and outputs.
#include "mlmap/eval/run_outputs.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace mlmap::eval {
namespace {

TEST(ReplayConfig, TheWindowGrowsToHoldEveryHitInRange) {
  MapConfig config;
  const Eigen::Vector3i before = config.local_map.size_cells;
  ReplayEngineOptions options;
  options.max_range_m = 30.0;
  const ConfigNotes notes = adaptReplayConfig(options, &config);
  const int needed = config.local_map.horizontalCellsForRange(30.0);
  // The smallest window (in whole submaps) whose reach, 0.4 x its width, holds the range.
  EXPECT_EQ(needed % 5, 0);
  EXPECT_GE(0.4 * needed * config.local_map.resolution_m, 30.0 - 1e-9);
  EXPECT_LT(0.4 * (needed - 5) * config.local_map.resolution_m, 30.0);
  EXPECT_EQ(config.local_map.size_cells.x(), needed);
  EXPECT_EQ(config.local_map.size_cells.y(), needed);
  EXPECT_EQ(config.local_map.size_cells.z(), before.z());
  EXPECT_GE(config.local_map.horizontalReach_m(), 30.0);
  EXPECT_DOUBLE_EQ(config.awareness.max_range_m, 30.0);
  EXPECT_GE(config.awareness.radius_m(), 30.0);
  ASSERT_EQ(notes.info.size(), 1u);
  EXPECT_NE(notes.info[0].find(std::to_string(needed) + " x " + std::to_string(needed)),
            std::string::npos)
      << notes.info[0];
  EXPECT_TRUE(notes.warnings.empty());
  EXPECT_TRUE(config.validate().empty());
}

TEST(ReplayConfig, AWindowTheLimitsRefuseIsKeptAndSaid) {
  MapConfig config;
  config.local_map.resolution_m = 0.02;
  const Eigen::Vector3i before = config.local_map.size_cells;
  ReplayEngineOptions options;
  options.max_range_m = 30.0;  // 3750 voxels across at 0.02 m: far over the window's limit
  const ConfigNotes notes = adaptReplayConfig(options, &config);
  EXPECT_EQ(config.local_map.size_cells, before);
  EXPECT_TRUE(notes.info.empty());
  ASSERT_EQ(notes.warnings.size(), 1u);
  EXPECT_NE(notes.warnings[0].find("global map as hits only"), std::string::npos);
}

TEST(ReplayConfig, ARangeTheWindowAlreadyHoldsChangesNothingButTheRange) {
  MapConfig config;
  const Eigen::Vector3i before = config.local_map.size_cells;
  ReplayEngineOptions options;
  options.max_range_m = 2.0;
  const ConfigNotes notes = adaptReplayConfig(options, &config);
  EXPECT_EQ(config.local_map.size_cells, before);
  EXPECT_DOUBLE_EQ(config.awareness.max_range_m, 2.0);
  EXPECT_TRUE(notes.info.empty());
  EXPECT_TRUE(notes.warnings.empty());
}

TEST(ReplayConfig, SynchronousWithThePlanningLayersTheOutputsNeed) {
  MapConfig config;
  config.pipeline.threaded = true;
  config.pipeline.planning_layers = true;
  config.esdf.enabled = true;
  ReplayEngineOptions options;
  ConfigNotes notes = adaptReplayConfig(options, &config);
  EXPECT_FALSE(config.pipeline.threaded);
  ASSERT_EQ(notes.warnings.size(), 1u);
  EXPECT_NE(notes.warnings[0].find("synchronously"), std::string::npos);
  EXPECT_FALSE(config.pipeline.planning_layers);
  EXPECT_FALSE(config.esdf.enabled);

  options.grid_out = true;
  notes = adaptReplayConfig(options, &config);
  EXPECT_TRUE(notes.warnings.empty());
  EXPECT_TRUE(config.pipeline.planning_layers);
  EXPECT_TRUE(config.projected_grid.enabled);
  EXPECT_FALSE(config.esdf.enabled);
}

TEST(ReplayConfig, AwarenessThreadsAsGivenElseTheFilesElseTheDefault) {
  ReplayEngineOptions options;
  options.default_awareness_threads = 2;
  MapConfig config;
  config.awareness.num_threads = 1;
  (void)adaptReplayConfig(options, &config);
  EXPECT_EQ(config.awareness.num_threads, 2);  // no file: the replay's default

  config.awareness.num_threads = 1;
  options.config_file = true;
  (void)adaptReplayConfig(options, &config);
  EXPECT_EQ(config.awareness.num_threads, 1);  // the file's

  options.awareness_threads = 3;
  (void)adaptReplayConfig(options, &config);
  EXPECT_EQ(config.awareness.num_threads, 3);  // as given
}

}  // namespace
}  // namespace mlmap::eval
