// RecordedRun, what mlmap_replay records: every frame with its status, the run's stats.json
// against the engine's own counters.
#include "mlmap/eval/recorded_run.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlmap::eval {
namespace {

/// A wall 2 m ahead, a point every 5 cm.
PointCloudFrame wallFrame(double stamp_s) {
  PointCloudFrame f;
  f.stamp_s = stamp_s;
  for (float y = -1.0f; y <= 1.0f; y += 0.05f) {
    for (float z = -0.5f; z <= 0.5f; z += 0.05f) f.points_S.emplace_back(2.0f, y, z);
  }
  return f;
}

TEST(RecordedRun, RecordsEveryFrameAndItsStatsAreTheEngines) {
  MapConfig config;
  std::vector<std::string> warnings;
  RecordedRun run(config, "unused", [&](LogLevel, const std::string& m) { warnings.push_back(m); });
  FrameRecord first;
  first.name = "a";
  run.submit(wallFrame(1.0), first);
  FrameRecord empty;
  empty.name = "b";
  PointCloudFrame no_points;
  no_points.stamp_s = 2.0;
  run.submit(no_points, empty);  // rejected as empty
  FrameRecord again;
  again.name = "c";
  run.submit(wallFrame(0.5), again);  // older than the first: out of order (said on the log)
  ASSERT_EQ(run.records().size(), 3u);
  EXPECT_EQ(run.records()[0].status, FrameStatus::kAccepted);
  EXPECT_EQ(run.records()[1].status, FrameStatus::kEmpty);
  EXPECT_EQ(run.records()[2].status, FrameStatus::kOutOfOrder);
  EXPECT_EQ(run.outputs().trajectory_W.size(), 3u);
  EXPECT_GT(run.records()[0].engine_bytes, 0u);
  EXPECT_EQ(run.timer().peakEngineBytes(), run.engine().stats().memory.total());

  const std::size_t occupied = run.engine().occupiedVoxels().size();
  ASSERT_GT(occupied, 0u);
  const Json stats = runStatsJson(run, occupied);
  const EngineStats s = run.engine().stats();
  EXPECT_EQ(stats["counters"]["frames"], 3u);
  EXPECT_EQ(stats["counters"]["frames_mapped"], s.frames_mapped);
  EXPECT_EQ(stats["counters"]["rejected_empty"], 1u);
  EXPECT_EQ(stats["counters"]["rejected_out_of_order"], 1u);
  EXPECT_EQ(stats["counters"]["points_in"], s.points.points_in);
  EXPECT_EQ(stats["counters"]["occupied_voxels"], occupied);
  EXPECT_EQ(stats["frames"].size(), 3u);
  EXPECT_EQ(stats["frames"][2]["name"], "c");
  EXPECT_EQ(stats["timing_ms"]["engine"]["frames"], 1u);  // timings over the accepted frames
  EXPECT_FALSE(warnings.empty());
}

TEST(RecordedRun, ReleasingTheEngineKeepsWhatStatsJsonSays) {
  MapConfig config;
  config.local_map.resolution_m = 0.1;
  RecordedRun run(config, "unused", [](LogLevel, const std::string&) {});
  run.submit(wallFrame(1.0), FrameRecord{});
  run.submit(wallFrame(1.1), FrameRecord{});
  const std::size_t occupied = run.engine().occupiedVoxels().size();
  ASSERT_GT(occupied, 0u);
  Json before = runStatsJson(run, occupied);
  const std::uint64_t points_in = run.engine().stats().points.points_in;
  run.releaseEngine();
  EXPECT_THROW((void)run.engine(), std::logic_error);
  EXPECT_EQ(run.stats().points.points_in, points_in);
  EXPECT_EQ(run.stats().frames_mapped, 2u);
  EXPECT_DOUBLE_EQ(run.resolution_m(), 0.1);
  EXPECT_DOUBLE_EQ(run.config().local_map.resolution_m, 0.1);
  Json after = runStatsJson(run, occupied);
  before["memory_bytes"].erase("peak_rss");  // the process's, which may grow in between
  after["memory_bytes"].erase("peak_rss");
  EXPECT_EQ(after, before);
  run.releaseEngine();  // a second release changes nothing
  EXPECT_EQ(run.stats().frames_mapped, 2u);
}

}  // namespace
}  // namespace mlmap::eval
