#include "mlmap/pipeline/map_engine.h"

#include "mlmap/eval/sim_flight.h"
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/planning/planning_layers.h"

#include "../support/small_flight.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <limits>
#include <mutex>
#include <stdexcept>

namespace mlmap {
namespace {

MapConfig configAt(double resolution_m) {
  MapConfig c;
  c.local_map.resolution_m = resolution_m;
  const int xy = static_cast<int>(std::lround(19.0 / resolution_m / 5.0)) * 5;
  const int z = static_cast<int>(std::lround(7.0 / resolution_m / 5.0)) * 5;
  c.local_map.size_cells = {xy, xy, z};
  return c;
}

PointCloudFrame cloudAt(double t, const Eigen::Vector3d& body) {
  PointCloudFrame f;
  f.stamp_s = t;
  f.T_W_B.translation() = body;
  for (int i = -10; i <= 10; ++i)
    for (int j = -10; j <= 10; ++j) {
      f.points_S.emplace_back(4.0f, 0.1f * static_cast<float>(i), 0.1f * static_cast<float>(j));
    }
  return f;
}

TEST(TimingSummary, NearestRankOnTheSortedValuesWhateverTheirOrder) {
  std::vector<double> values(100);
  for (int i = 0; i < 100; ++i)
    values[static_cast<std::size_t>(i)] = (i * 37) % 100 + 1;  // 1..100, shuffled
  const TimingSummary s = summarizeTimings(values);
  EXPECT_EQ(s.samples, 100u);
  EXPECT_DOUBLE_EQ(s.median_ms, 51.0);  // rank round(0.5 * 99) = 50 (0-based)
  EXPECT_DOUBLE_EQ(s.p99_ms, 99.0);     // rank round(0.99 * 99) = 98
  EXPECT_DOUBLE_EQ(s.max_ms, 100.0);
  EXPECT_DOUBLE_EQ(s.mean_ms, 50.5);
  EXPECT_DOUBLE_EQ(sortedQuantile({7.0}, 0.99), 7.0);
  EXPECT_EQ(summarizeTimings({}).samples, 0u);
  EXPECT_DOUBLE_EQ(summarizeTimings({}).median_ms, 0.0);
}

TEST(MapEngine, NoiseFreeSimulatedFlightReachesF1OfAtLeast095At10cm) {
  const datasets::Scenario scenario = datasets::defaultScenario();
  MapEngine engine(configAt(0.1));
  eval::FlightOptions options;
  options.max_frames = 120;  // the first 12 s of the default flight
  const eval::FlightResult flight = eval::flyScenario(scenario, engine, options);
  const eval::Accuracy a =
      eval::scoreOccupancy(engine.occupiedVoxels(), flight.observed_truth, scenario.world, 0.1);
  std::printf(
      "noise-free flight, %d frames at 0.1 m: %zu mapped, %zu observed true voxels, "
      "precision %.4f recall %.4f F1 %.4f\n",
      flight.frames, a.mapped, a.observed_truth, a.precision, a.recall, a.f1);
  EXPECT_EQ(flight.frames, 120);
  EXPECT_GT(a.observed_truth, 5000u);
  EXPECT_GE(a.f1, 0.95);
  const EngineStats s = engine.stats();
  EXPECT_EQ(s.frames_mapped, 120u);
  EXPECT_EQ(s.rejected_invalid_pose + s.rejected_out_of_order + s.rejected_empty, 0u);
  EXPECT_GT(s.local.shifts, 0u) << "the flight should slide the local map";
}

// The estimate made from the configuration before anything is allocated against what the
// engine accounts once it maps: the layers it covers within 15 % each, with the ESDF over the
// whole window, over a box, and off (the awareness grid, whose point buffers vary with the
// frames, within 30 %).
TEST(MapEngine, MemoryEstimateMatchesTheEngineAccounting) {
  const datasets::Scenario scenario = datasets::defaultScenario();
  for (int variant = 0; variant < 3; ++variant) {
    MapConfig c = configAt(0.1);
    if (variant == 1) c.esdf.box_size_m = Eigen::Vector3d(8.0, 8.0, 4.0);
    if (variant == 2) c.esdf.enabled = false;
    const MemoryEstimate estimate = estimateMemory(c);
    MapEngine engine(c);
    eval::FlightOptions options;
    options.max_frames = 30;
    (void)eval::flyScenario(scenario, engine, options);
    const MemoryUsage used = engine.stats().memory;
    const auto mb = [](std::size_t bytes) { return static_cast<double>(bytes) / 1e6; };
    const double planning_mb = mb(estimate.snapshot_bytes) + mb(estimate.esdf_bytes);
    std::printf(
        "variant %d: estimate %s; engine: local %.1f MB, planning %.1f MB, awareness %.1f MB\n",
        variant, describeMemory(estimate).c_str(), mb(used.local_bytes), mb(used.planning_bytes),
        mb(used.awareness_bytes));
    EXPECT_NEAR(mb(estimate.local_bytes), mb(used.local_bytes), 0.15 * mb(used.local_bytes));
    EXPECT_NEAR(planning_mb, mb(used.planning_bytes), 0.15 * mb(used.planning_bytes));
    EXPECT_NEAR(mb(estimate.awareness_bytes), mb(used.awareness_bytes),
                0.3 * mb(used.awareness_bytes));
  }
}

TEST(MapEngine, MovingObstacleLeavesNoTraceWithinTenFramesOfLeaving) {
  // A camera hovering in front of a wall; a person-sized box walks across the view.
  datasets::Scenario scenario;
  scenario.world.addBox({{6.0, -6.0, -0.2}, {6.3, 6.0, 3.0}});   // wall 6 m ahead
  scenario.world.addBox({{-1.0, -6.0, -0.2}, {6.0, 6.0, 0.0}});  // floor
  sim::MovingBox person;
  person.size_m = {0.5, 0.5, 1.8};
  person.start_center_W = {3.0, -4.0, 0.9};
  person.velocity_mps = {0.0, 1.0, 0.0};
  person.t_start_s = 0.0;
  person.t_end_s = 8.0;  // from y = -4 to y = +4: out of the view (|y| < 2.6 at x = 3) at t ~ 6.9
  scenario.world.addMovingBox(person);
  std::vector<sim::Waypoint> waypoints = {{{0.0, 0.0, 1.2}, 0.0, true},
                                          {{0.05, 0.0, 1.2}, 0.0, true}};
  scenario.trajectory = sim::Trajectory(waypoints, 0.0025);  // 20 s of near-hover
  scenario.frame_rate_hz = 10.0;
  MapEngine engine(configAt(0.1));
  const double leave_s = (2.6 + 0.25 + 4.0) / 1.0;  // person fully out of the view
  int saw_person_frames = 0;
  int trace_after_leaving = -1;
  eval::FlightOptions options;
  options.max_frames = 1;
  for (int i = 0; i < 110; ++i) {
    options.start_time_s = eval::frameTime(scenario, i);
    eval::flyScenario(scenario, engine, options);
    const double t = eval::frameTime(scenario, i);
    std::size_t trace = 0;
    for (const VoxelIndex& v : engine.occupiedVoxels()) {
      const Eigen::Vector3d c = voxelCenter(v, 0.1);
      if (c.x() > 2.6 && c.x() < 3.4 && c.z() > 0.1 && c.z() < 1.9) ++trace;  // only the person
    }
    if (t < leave_s && trace > 0) ++saw_person_frames;
    if (t >= leave_s + 1.0 - 1e-9 && trace_after_leaving < 0)
      trace_after_leaving = static_cast<int>(trace);
  }
  EXPECT_GT(saw_person_frames, 20) << "the person should have been mapped while in view";
  EXPECT_EQ(trace_after_leaving, 0) << "occupied voxels of the person 10 frames after it left";
}

TEST(MapEngine, BadFramesAreRejectedWithCountersAndMappingGoesOn) {
  MapEngine engine(configAt(0.2));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(engine.submit(cloudAt(1.0, {0, 0, 1})), FrameStatus::kAccepted);
  PointCloudFrame bad = cloudAt(2.0, {0, 0, 1});
  bad.T_W_B.translation().x() = nan;
  EXPECT_EQ(engine.submit(bad), FrameStatus::kInvalidPose);
  bad = cloudAt(2.0, {0, 0, 1});
  bad.T_W_B.linear() *= 1.1;  // not a rotation (e.g. a non-unit quaternion used as is)
  EXPECT_EQ(engine.submit(bad), FrameStatus::kInvalidPose);
  bad = cloudAt(2.0, {1e9, 0, 1});  // absurd position
  EXPECT_EQ(engine.submit(bad), FrameStatus::kInvalidPose);
  Transform T;
  EXPECT_FALSE(makePose({0, 0, 0}, Eigen::Quaterniond(0, 0, 0, 0), &T));
  EXPECT_FALSE(makePose({0, 0, 0}, Eigen::Quaterniond(2, 0, 0, 0), &T));
  EXPECT_FALSE(makePose({0, 0, 0}, Eigen::Quaterniond(nan, 0, 0, 1), &T));
  EXPECT_TRUE(makePose({0, 0, 0}, Eigen::Quaterniond(1.0000001, 0, 0, 0), &T));
  EXPECT_EQ(engine.submit(cloudAt(0.5, {0, 0, 1})), FrameStatus::kOutOfOrder);
  EXPECT_EQ(engine.submit(cloudAt(nan, {0, 0, 1})), FrameStatus::kOutOfOrder);
  PointCloudFrame empty = cloudAt(3.0, {0, 0, 1});
  empty.points_S.clear();
  EXPECT_EQ(engine.submit(empty), FrameStatus::kEmpty);
  PointCloudFrame garbage = cloudAt(4.0, {0, 0, 1});
  for (auto& p : garbage.points_S) p = Eigen::Vector3f(std::nanf(""), 1e38f, -1e38f);
  EXPECT_EQ(engine.submit(garbage), FrameStatus::kAccepted);
  DepthFrame image;
  image.stamp_s = 5.0;
  image.intrinsics = {100, 100, 5, 5, 10, 10};
  image.depth_m.resize(99);  // one pixel short
  EXPECT_EQ(engine.submit(image), FrameStatus::kBadImage);
  EXPECT_EQ(engine.submit(cloudAt(6.0, {0.1, 0, 1})), FrameStatus::kAccepted);
  const EngineStats s = engine.stats();
  EXPECT_EQ(s.frames_in, 10u);
  EXPECT_EQ(s.rejected_invalid_pose, 3u);
  EXPECT_EQ(s.rejected_out_of_order, 2u);
  EXPECT_EQ(s.rejected_empty, 1u);
  EXPECT_EQ(s.rejected_bad_image, 1u);
  EXPECT_EQ(s.frames_mapped, 3u);
  EXPECT_EQ(s.points.rejected_non_finite, 441u);
  EXPECT_GT(engine.occupiedVoxels().size(), 50u);
}

TEST(MapEngine, LogsRejectionsRateLimited) {
  std::vector<std::string> lines;
  MapEngine engine(configAt(0.2), [&](LogLevel, const std::string& m) { lines.push_back(m); });
  PointCloudFrame bad = cloudAt(1.0, {0, 0, 1});
  bad.T_W_B.linear() *= 2.0;
  for (int i = 0; i < 100; ++i) engine.submit(bad);
  ASSERT_EQ(lines.size(), 1u);  // one line per reason and second
  EXPECT_NE(lines[0].find("invalid pose"), std::string::npos);
  EXPECT_EQ(engine.stats().rejected_invalid_pose, 100u);
}

TEST(MapEngine, InvalidConfigurationIsAClearError) {
  MapConfig c;
  c.local_map.size_cells = {96, 95, 35};
  c.awareness.phi_cells = 0;
  try {
    MapEngine engine(c);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("local_map.size_cells.x"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("awareness.phi_cells"), std::string::npos);
  }
}

// Threaded, the carving of a frame runs on the local-global thread beside the next frame's point
// loop (AwarenessStage::collect() / carve()); with awareness.num_threads 2 the point loop is
// split as well. The awareness map goes to whichever thread is less busy (either half may update
// it). The window's log-odds, the global map, the awareness map and the counters are those of the
// synchronous engine, bit for bit, and the awareness observer sees every frame once, in order.
TEST(MapEngine, ThreadedModeBuildsTheSameMapAsTheSynchronousMode) {
  const datasets::Scenario scenario = datasets::defaultScenario();
  MapConfig sync_config = configAt(0.2);
  MapEngine sync_engine(sync_config);
  eval::FlightOptions options;
  options.max_frames = 60;
  eval::flyScenario(scenario, sync_engine, options);
  const MapState a = sync_engine.exportState();
  for (const int awareness_threads : {1, 2}) {
    MapConfig threaded_config = sync_config;
    threaded_config.pipeline.threaded = true;
    threaded_config.pipeline.input_queue_capacity = 1000;  // nothing dropped
    threaded_config.awareness.num_threads = awareness_threads;
    std::vector<double> observed_stamps;  // the awareness observer's, on either thread
    std::mutex observed_mutex;
    EngineObservers observers;
    observers.awareness = [&](const AwarenessMap&, double stamp_s, const Transform&) {
      std::lock_guard<std::mutex> lock(observed_mutex);
      observed_stamps.push_back(stamp_s);
    };
    MapEngine threaded_engine(threaded_config, {}, observers);
    eval::flyScenario(scenario, threaded_engine, options);
    threaded_engine.flush();
    EXPECT_EQ(sync_engine.awareness().occupiedPoints(),
              threaded_engine.awareness().occupiedPoints());
    EXPECT_EQ(sync_engine.awareness().count(Occupancy::kFree),
              threaded_engine.awareness().count(Occupancy::kFree));
    EXPECT_GT(sync_engine.awareness().count(Occupancy::kFree), 100u);
    {
      std::lock_guard<std::mutex> lock(observed_mutex);
      ASSERT_EQ(observed_stamps.size(), 60u);
      EXPECT_TRUE(std::is_sorted(observed_stamps.begin(), observed_stamps.end()));
      EXPECT_EQ(std::adjacent_find(observed_stamps.begin(), observed_stamps.end()),
                observed_stamps.end());
    }
    const MapState b = threaded_engine.exportState();
    EXPECT_EQ(a.window.min_index, b.window.min_index);
    EXPECT_GT(a.window.log_odds.size(), 1000u);
    EXPECT_TRUE(a.window.log_odds == b.window.log_odds) << awareness_threads << " threads";
    ASSERT_EQ(a.global_submaps.size(), b.global_submaps.size());
    for (std::size_t i = 0; i < a.global_submaps.size(); ++i) {
      EXPECT_EQ(a.global_submaps[i].first, b.global_submaps[i].first);
      const auto& ra = a.global_submaps[i].second;
      const auto& rb = b.global_submaps[i].second;
      ASSERT_EQ(ra.size(), rb.size());
      for (std::size_t j = 0; j < ra.size(); ++j) {
        EXPECT_EQ(ra[j].offset, rb[j].offset);
        EXPECT_EQ(ra[j].log_odds, rb[j].log_odds);
      }
    }
    EXPECT_GT(sync_engine.occupiedVoxels().size(), 1000u);
    const EngineStats s = sync_engine.stats();
    const EngineStats t = threaded_engine.stats();
    EXPECT_EQ(t.frames_mapped, 60u);
    EXPECT_EQ(t.frames_dropped, 0u);
    EXPECT_EQ(s.points.free_voxels, t.points.free_voxels);
    EXPECT_EQ(s.points.hit_voxels, t.points.hit_voxels);
    EXPECT_EQ(s.points.points_in, t.points.points_in);
    EXPECT_EQ(t.awareness.samples, 60u);
  }
}

TEST(MapEngine, WithoutPlanningLayersTheMapIsTheSameAndNoSnapshotIsMade) {
  // Fly 30 m along x, so that submaps retire into the global map on the way.
  const MapConfig with = configAt(0.2);
  MapConfig without = with;
  without.pipeline.planning_layers = false;
  std::size_t snapshots_announced = 0;
  EngineObservers observers;
  observers.snapshot = [&](std::uint64_t, double) { ++snapshots_announced; };
  MapEngine a(with);
  MapEngine b(without, {}, observers);
  for (int i = 0; i < 60; ++i) {
    ASSERT_EQ(a.submit(cloudAt(1.0 + i, {0.5 * i, 0.0, 1.0})), FrameStatus::kAccepted);
    ASSERT_EQ(b.submit(cloudAt(1.0 + i, {0.5 * i, 0.0, 1.0})), FrameStatus::kAccepted);
  }
  ASSERT_GT(a.stats().local.submaps_retired, 0u);
  const auto sorted = [](const MapEngine& e) {
    std::vector<VoxelIndex> v = e.occupiedVoxels();
    std::sort(v.begin(), v.end(), [](const VoxelIndex& x, const VoxelIndex& y) {
      return std::lexicographical_compare(x.data(), x.data() + 3, y.data(), y.data() + 3);
    });
    return v;
  };
  EXPECT_GT(a.occupiedVoxels().size(), 100u);
  EXPECT_TRUE(sorted(a) == sorted(b));
  EXPECT_EQ(a.stats().planning.snapshots, 60u);
  const EngineStats s = b.stats();
  EXPECT_EQ(s.frames_mapped, 60u);
  EXPECT_EQ(s.planning.snapshots, 0u);
  EXPECT_EQ(s.planning.esdf_updates, 0u);
  EXPECT_EQ(s.memory.planning_bytes, 0u);
  EXPECT_EQ(snapshots_announced, 0u);
  EXPECT_EQ(b.snapshot()->frame(), 0u);
  // A restored state publishes no snapshot either.
  MapEngine c(without);
  c.restoreState(a.exportState());
  EXPECT_EQ(c.snapshot()->frame(), 0u);
  EXPECT_TRUE(sorted(c) == sorted(a));
}

TEST(MapEngine, ObserversSeeEveryAwarenessFrameEverySnapshotAndEveryGlobalChange) {
  // Threaded, so the observers run on the engine's threads as they would under a publisher.
  MapConfig c = configAt(0.2);
  c.pipeline.threaded = true;
  c.pipeline.input_queue_capacity = 1000;
  std::vector<double> awareness_stamps;
  std::size_t last_awareness_points = 0;
  std::size_t global_changes = 0;
  std::size_t last_global_voxels = 0;
  EngineObservers observers;
  observers.awareness = [&](const AwarenessMap& map, double stamp_s, const Transform& T_W_B) {
    awareness_stamps.push_back(stamp_s);
    last_awareness_points = map.occupiedPoints().size();
    EXPECT_TRUE(map.origin_W().isApprox(T_W_B.translation()));
  };
  std::uint64_t last_version = 0;
  observers.global = [&](const GlobalMap& map, double, std::uint64_t version) {
    if (version != last_version) ++global_changes;
    EXPECT_GE(version, last_version);
    last_version = version;
    last_global_voxels = map.voxelCount();
  };
  // Every mapped frame announces its snapshot once it is published: snapshot() already returns
  // it inside the call (the planning thread may republish it with a new ESDF, same frame).
  std::vector<std::uint64_t> snapshot_frames;
  std::vector<double> snapshot_stamps;
  MapEngine* engine_seen = nullptr;
  observers.snapshot = [&](std::uint64_t frame, double stamp_s) {
    snapshot_frames.push_back(frame);
    snapshot_stamps.push_back(stamp_s);
    ASSERT_NE(engine_seen, nullptr);
    const std::shared_ptr<const MapSnapshot> snap = engine_seen->snapshot();
    EXPECT_EQ(snap->frame(), frame);
    EXPECT_EQ(snap->stamp_s(), stamp_s);
  };
  MapEngine engine(c, {}, observers);
  engine_seen = &engine;
  // Fly 30 m along x: submaps retire into the global map on the way.
  const int frames = 60;
  for (int i = 0; i < frames; ++i) engine.submit(cloudAt(1.0 + i, {0.5 * i, 0.0, 1.0}));
  engine.flush();
  ASSERT_EQ(snapshot_frames.size(), static_cast<std::size_t>(frames));
  for (int i = 0; i < frames; ++i) {
    EXPECT_EQ(snapshot_frames[i], static_cast<std::uint64_t>(i + 1));
    EXPECT_EQ(snapshot_stamps[i], 1.0 + i);
  }
  EXPECT_EQ(engine.snapshot()->frame(), static_cast<std::uint64_t>(frames));
  ASSERT_EQ(awareness_stamps.size(), static_cast<std::size_t>(frames));
  for (int i = 0; i < frames; ++i) EXPECT_EQ(awareness_stamps[i], 1.0 + i);
  EXPECT_EQ(last_awareness_points, engine.awareness().occupiedPoints().size());
  EXPECT_GT(last_awareness_points, 0u);
  const EngineStats s = engine.stats();
  ASSERT_GT(s.local.submaps_retired, 0u);
  EXPECT_GT(global_changes, 1u);
  EXPECT_LT(global_changes, static_cast<std::size_t>(frames));  // only frames that moved submaps
  EXPECT_EQ(last_version, s.local.submaps_retired + s.local.submaps_restored);
  EXPECT_EQ(last_global_voxels, engine.globalMap().voxelCount());
  EXPECT_GT(last_global_voxels, 0u);
}

TEST(MapEngine, FullInputQueueDropsTheOldestFrameAndCountsIt) {
  MapConfig c = configAt(0.1);
  c.pipeline.threaded = true;
  c.pipeline.input_queue_capacity = 1;
  MapEngine engine(c);
  for (int i = 0; i < 40; ++i) {
    PointCloudFrame f = cloudAt(1.0 + i, {0.01 * i, 0, 1});
    // Heavy frames so the awareness thread is busy while we submit.
    for (int k = 0; k < 30; ++k)
      f.points_S.insert(f.points_S.end(), f.points_S.begin(), f.points_S.begin() + 441);
    engine.submit(std::move(f));
  }
  engine.flush();
  const EngineStats s = engine.stats();
  EXPECT_GT(s.frames_dropped, 0u);
  EXPECT_EQ(s.frames_mapped + s.frames_dropped, 40u);
}

TEST(MapEngine, MapsTheSharedRealDepthFrames) {
  const datasets::FrameDirectory frames(MLMAP_SHARED_DATA_DIR "/realsense_tabletop");
  ASSERT_EQ(frames.size(), 50u);
  MapConfig c = configAt(0.2);
  c.local_map.resolution_m = 0.02;
  c.local_map.size_cells = {200, 200, 200};
  c.sensor.translation_B_m.setZero();  // the poses are the camera's
  c.sensor.rotation_rpy_deg.setZero();
  c.log_odds.hit = 0.6;  // Table 1, low-precision sensor
  MapEngine engine(c);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    ASSERT_EQ(engine.submit(frames.read(i)), FrameStatus::kAccepted) << frames.frameName(i);
  }
  const EngineStats s = engine.stats();
  EXPECT_EQ(s.frames_mapped, 50u);
  const std::vector<VoxelIndex> occupied = engine.occupiedVoxels();
  // Reference straight from the data: in how many frames does each voxel receive a point?
  std::unordered_map<VoxelIndex, int, eval::VoxelHash> frames_with_points;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const DepthFrame f = frames.read(i);
    std::vector<Eigen::Vector3f> points;
    ASSERT_TRUE(backProject(f, &points));
    eval::VoxelSet seen;
    for (const Eigen::Vector3f& p : points) {
      if (p.norm() > c.awareness.min_range_m)
        seen.insert(voxelIndexOf(f.T_W_B * p.cast<double>(), 0.02));
    }
    for (const VoxelIndex& v : seen) ++frames_with_points[v];
  }
  std::size_t steady = 0;
  std::size_t steady_mapped = 0;
  const eval::VoxelSet occupied_set(occupied.begin(), occupied.end());
  for (const auto& [v, n] : frames_with_points) {
    if (n < 25) continue;  // measured in most frames
    ++steady;
    steady_mapped += occupied_set.count(v);
  }
  std::size_t with_points = 0;
  for (const VoxelIndex& v : occupied) with_points += frames_with_points.count(v);
  std::printf(
      "real frames at 0.02 m: %zu occupied voxels (%zu hold points); %zu of %zu voxels with "
      "points in >= 25 frames are occupied; awareness %.2f ms, local %.2f ms\n",
      occupied.size(), with_points, steady_mapped, steady, s.awareness.median_ms,
      s.local_global.median_ms);
  EXPECT_GT(steady, 500u);
  // Surfaces seen again and again are in the map; the map holds nothing that was never measured.
  EXPECT_GT(static_cast<double>(steady_mapped) / static_cast<double>(steady), 0.85);
  EXPECT_EQ(with_points, occupied.size());
}

}  // namespace
}  // namespace mlmap

namespace mlmap {
namespace {

// The snapshot after a synchronous flight holds exactly the engine's window, the grid of that
// window, and (with no rate limit) the ESDF of that window.
TEST(MapEngine, SnapshotHoldsTheWindowItsGridAndItsEsdf) {
  const datasets::Scenario scenario = datasets::defaultScenario();
  MapConfig config;
  config.esdf.max_rate_hz = 0.0;
  MapEngine engine(config);
  eval::FlightOptions options;
  options.max_frames = 30;
  eval::flyScenario(scenario, engine, options);

  const auto snap = engine.snapshot();
  ASSERT_EQ(snap->frame(), 30u);
  const LocalMap& local = engine.localMap();
  const LocalWindow& window = snap->window();
  ASSERT_EQ(window.min_index, local.minIndex());
  ASSERT_EQ(window.size, local.config().size_cells);
  std::size_t occupied = 0;
  for (int x = 0; x < window.size.x(); ++x) {
    for (int y = 0; y < window.size.y(); ++y) {
      for (int z = 0; z < window.size.z(); ++z) {
        const VoxelIndex g = window.min_index + VoxelIndex(x, y, z);
        ASSERT_EQ(window.state(g), local.state(g));
        occupied += window.state(g) == Occupancy::kOccupied;
      }
    }
  }
  EXPECT_GT(occupied, 1000u);

  ProjectedGrid grid;
  projectToGrid(window, &engine.globalMap(), config.projected_grid, snap->T_W_B().translation().z(),
                &grid);
  EXPECT_EQ(snap->grid().cells, grid.cells);
  EXPECT_EQ(snap->grid().origin_W, grid.origin_W);

  ASSERT_NE(snap->esdf(), nullptr);
  ASSERT_EQ(snap->esdfFrame(), snap->frame());
  OccupancyBox box;
  box.reset(window.min_index, window.size, window.resolution_m);
  for (std::size_t i = 0; i < box.states.size(); ++i) {
    box.states[i] = window.model.state(window.log_odds[i]);
  }
  EsdfMap reference(config.esdf);
  ASSERT_TRUE(reference.compute(box));
  EXPECT_EQ(snap->esdf()->distances(), reference.distances());
}

// The 2D grid is rebuilt whole only when the window or the band moves and otherwise updated in
// the columns of the changed submaps; after every frame it equals a direct projection of the
// snapshot's window: state and probability values (a hit on an occupied voxel changes only the
// latter), relative and absolute bands, and the global map's voxels above and below the window.
TEST(MapEngine, IncrementalGridEqualsADirectProjectionAfterEveryFrame) {
  struct Case {
    const char* name;
    bool probability_values;
    bool relative_band;
    bool include_global;
    double band_min_m;
    double band_max_m;
  };
  const Case cases[] = {
      {"state values, relative band", false, true, false, -0.3, 0.3},
      {"probability values, relative band", true, true, false, -0.3, 0.3},
      {"state values, absolute band", false, false, true, 0.3, 1.1},
      {"probability values, band beyond the window", true, false, true, -2.0, 6.0}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    MapConfig config = test::smallWindowConfig();
    config.esdf.enabled = false;
    config.projected_grid.probability_values = c.probability_values;
    config.projected_grid.relative_band = c.relative_band;
    config.projected_grid.include_global = c.include_global;
    config.projected_grid.band_min_m = c.band_min_m;
    config.projected_grid.band_max_m = c.band_max_m;
    MapEngine engine(config);
    const datasets::Scenario scenario = test::cheapScenario();
    eval::FlightOptions options;
    options.max_frames = 60;
    std::size_t known_cells = 0;
    options.progress = [&](int done, int) {
      const auto snap = engine.snapshot();
      ASSERT_EQ(snap->frame(), static_cast<std::uint64_t>(done));
      ProjectedGrid direct;
      projectToGrid(snap->window(), &engine.globalMap(), config.projected_grid,
                    snap->T_W_B().translation().z(), &direct);
      const ProjectedGrid& grid = snap->grid();
      ASSERT_EQ(grid.origin_W, direct.origin_W) << "frame " << done;
      ASSERT_EQ(grid.width, direct.width) << "frame " << done;
      ASSERT_EQ(grid.height, direct.height) << "frame " << done;
      for (std::size_t i = 0; i < direct.cells.size(); ++i) {
        ASSERT_EQ(grid.cells[i], direct.cells[i]) << "frame " << done << ", cell " << i;
        known_cells += direct.cells[i] != ProjectedGrid::kUnknown;
      }
    };
    ASSERT_EQ(eval::flyScenario(scenario, engine, options).frames, 60);
    const PlanningStats stats = engine.stats().planning;
    EXPECT_GT(known_cells, 10000u);
    EXPECT_GT(stats.grid_rebuilds, 5u);  // the window slides
    if (!c.include_global) {
      EXPECT_GT(stats.grid_updates, stats.grid_rebuilds + 10) << "updated in part";
    } else if (engine.stats().hits_to_global > 0) {
      // Hits beyond the window change the global map in most frames: the grid is rebuilt.
      EXPECT_GE(stats.grid_updates, stats.grid_rebuilds);
    } else if (c.band_max_m < 6.0) {
      EXPECT_GT(stats.grid_updates, stats.grid_rebuilds + 10) << "updated in part";
    } else {
      EXPECT_EQ(stats.grid_updates, stats.grid_rebuilds) << "depends on the global map";
    }
    if (!c.include_global) continue;
    // A loaded map whose window lies where the current one does, with another global map: the
    // grid follows the new global map too.
    MapState state = engine.exportState();
    ASSERT_GT(state.globalVoxelCount(), 0u);
    state.global_submaps.clear();
    engine.restoreState(state);
    options.progress(60, 60);
  }
}

// With a box smaller than the window, the ESDF is recomputed when a voxel state inside its box
// changed, and not for changes elsewhere in the window or for log-odds changes that keep states.
TEST(PlanningLayers, EsdfIsRecomputedOnlyWhenAStateInsideItsBoxChanged) {
  MapConfig config;
  config.local_map.resolution_m = 0.2;
  config.local_map.size_cells = {25, 25, 15};  // 5 x 5 x 3 m
  config.esdf.box_size_m = {1.0, 1.0, 1.0};    // 5 x 5 x 5 voxels around the body
  config.esdf.max_rate_hz = 0.0;
  config.projected_grid.enabled = false;
  LocalMap local(config.local_map, config.log_odds);
  GlobalMap global(config.local_map.submap_cells(), config.local_map.resolution_m);
  PlanningLayers layers(config, /*own_thread=*/false);
  Transform T_W_B = Transform::Identity();
  T_W_B.translation() = Eigen::Vector3d(0.1, 0.1, 0.1);
  local.recenter(T_W_B.translation(), &global);
  std::uint64_t frame = 0;
  auto apply = [&](const std::vector<VoxelIndex>& hits, const std::vector<VoxelIndex>& frees) {
    MeasurementBatch batch;
    batch.free.reset(local.minIndex(), config.local_map.size_cells);
    for (const VoxelIndex& h : hits) batch.hits.push_back({h, h.cast<double>() * 0.2});
    for (const VoxelIndex& f : frees) {
      const VoxelIndex r = f - local.minIndex();
      batch.free.testAndSet(r.x(), r.y(), r.z());
      ++batch.free_count;
    }
    local.integrate(batch);
    ++frame;
    layers.update(local, global, frame, 0.1 * static_cast<double>(frame), T_W_B);
    return layers.stats();
  };
  const VoxelIndex inside(1, 0, 0);   // in the 5^3 box around the body's voxel (0, 0, 0)
  const VoxelIndex outside(9, 9, 0);  // in the window, far from the box
  PlanningStats s = apply({inside}, {});
  EXPECT_EQ(s.esdf_updates, 1u);
  s = apply({}, {outside});  // unknown -> free, outside the box
  EXPECT_EQ(s.esdf_updates, 1u);
  EXPECT_EQ(s.esdf_unchanged, 1u);
  s = apply({inside}, {});  // occupied stays occupied, higher log-odds
  EXPECT_EQ(s.esdf_updates, 1u);
  EXPECT_EQ(s.esdf_unchanged, 2u);
  s = apply({}, {inside + VoxelIndex(0, 1, 0)});  // unknown -> free, inside
  EXPECT_EQ(s.esdf_updates, 2u);
  ASSERT_NE(layers.snapshot()->esdf(), nullptr);
  EXPECT_EQ(layers.snapshot()->esdfFrame(), frame);
  EXPECT_EQ(layers.snapshot()->esdf()->size(), Eigen::Vector3i(5, 5, 5));
}

/// The ESDF of the snapshot's window computed whole, as the engine's box (the whole window).
EsdfMap fullEsdfOf(const MapSnapshot& snap, const EsdfConfig& config) {
  const LocalWindow& window = snap.window();
  OccupancyBox box;
  box.reset(window.min_index, window.size, window.resolution_m);
  for (std::size_t i = 0; i < box.states.size(); ++i) {
    box.states[i] = window.model.state(window.log_odds[i]);
  }
  EsdfMap reference(config);
  EXPECT_TRUE(reference.compute(box));
  return reference;
}

// The ESDF is updated incrementally (only what changed voxels reach; a moved window computed
// whole) and published as copies brought up to date cell by cell; after every frame
// of a long sliding flight (the moving person, both unknown policies), across window shifts and
// after loading an older map, the snapshot's field equals a full recompute bit for bit.
TEST(MapEngine, IncrementalEsdfEqualsAFullRecomputeAfterEveryFrame) {
  const datasets::Scenario scenario = test::cheapScenario();
  const int frames = eval::frameCount(scenario);
  ASSERT_GE(frames, 80);
  for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
    SCOPED_TRACE(toString(policy));
    MapConfig config = test::smallWindowConfig();
    config.esdf.max_rate_hz = 0.0;
    config.esdf.unknown_as = policy;
    config.projected_grid.enabled = false;
    MapEngine engine(config);
    VoxelIndex last_min = VoxelIndex::Zero();
    int window_moves = 0;
    int checked = 0;
    const auto check = [&](int done) {
      const auto snap = engine.snapshot();
      ASSERT_NE(snap->esdf(), nullptr) << "frame " << done;
      // (A frame that changed no state in the box leaves the field of an earlier frame.)
      const EsdfMap reference = fullEsdfOf(*snap, config.esdf);
      ASSERT_EQ(snap->esdf()->minIndex(), reference.minIndex()) << "frame " << done;
      ASSERT_TRUE(snap->esdf()->distances() == reference.distances()) << "frame " << done;
      const Eigen::Vector3i& n = reference.size();
      for (int x = 0; x < n.x(); ++x) {
        for (int y = 0; y < n.y(); ++y) {
          for (int z = 0; z < n.z(); ++z) {
            const VoxelIndex g = reference.minIndex() + VoxelIndex(x, y, z);
            ASSERT_EQ(snap->esdf()->isUnknown(g), reference.isUnknown(g)) << "frame " << done;
          }
        }
      }
      window_moves += snap->window().min_index != last_min ? 1 : 0;
      last_min = snap->window().min_index;
      ++checked;
    };
    eval::FlightOptions options;
    options.progress = [&](int done, int) { check(done); };
    const int half = frames / 2;
    options.max_frames = half;
    ASSERT_EQ(eval::flyScenario(scenario, engine, options).frames, half);
    const MapState early = engine.exportState();  // the map at the middle of the flight
    options.start_time_s = eval::frameTime(scenario, half);
    options.max_frames = frames - half;
    ASSERT_EQ(eval::flyScenario(scenario, engine, options).frames, frames - half);
    // A map load (the middle's map, elsewhere than the window now), then flying on from there.
    engine.restoreState(early);
    check(frames);
    options.max_frames = 20;
    ASSERT_EQ(eval::flyScenario(scenario, engine, options).frames, 20);

    const PlanningStats p = engine.stats().planning;
    EXPECT_EQ(checked, frames + 21);
    EXPECT_GT(window_moves, 10) << "the window slides";
    EXPECT_GT(p.esdf_updates, static_cast<std::uint64_t>(frames));
    // Where the window stayed, the update is incremental, and so is a move along x or y; a
    // window moved along z is computed whole (EsdfMap::update() with the windowed passes), as
    // are the first frame and the load.
    EXPECT_LE(p.esdf_full, static_cast<std::uint64_t>(window_moves) + 2)
        << "the updates of frames where the window stayed are incremental";
    EXPECT_GT(p.esdf_updates - p.esdf_full, static_cast<std::uint64_t>(frames / 4));
  }
}

// With esdf.query_grid, every snapshot carries a query copy of its field, pooled and brought up
// to date cell by cell (across several updates while planners held other copies, across window
// moves): after every frame of a sliding flight it answers exactly as a copy freshly built from
// the snapshot's field, at every cell centre and between them. Without the key there is none.
TEST(MapEngine, SnapshotQueryGridEqualsAFreshBuildAfterEveryFrame) {
  const datasets::Scenario scenario = test::cheapScenario();
  MapConfig config = test::smallWindowConfig();
  config.esdf.max_rate_hz = 0.0;
  config.esdf.query_grid = true;
  config.projected_grid.enabled = false;
  MapEngine engine(config);
  std::vector<std::shared_ptr<const MapSnapshot>> held;  // planners holding older snapshots
  int checked = 0;
  int failures = 0;
  const auto check = [&](int done) {
    const auto snap = engine.snapshot();
    ASSERT_NE(snap->esdf(), nullptr) << "frame " << done;
    ASSERT_NE(snap->esdfGrid(), nullptr) << "frame " << done;
    EsdfQueryGrid fresh;
    fresh.build(*snap->esdf());
    const EsdfMap& field = *snap->esdf();
    const Eigen::Vector3i& n = field.size();
    const double res = field.resolution_m();
    for (int x = 0; x < n.x(); ++x) {
      for (int y = 0; y < n.y(); ++y) {
        for (int z = 0; z < n.z(); ++z) {
          // A cell centre and a point between it and its upper neighbours.
          const Eigen::Vector3d c = voxelCenter(field.minIndex() + VoxelIndex(x, y, z), res);
          for (const Eigen::Vector3d& p :
               {c, Eigen::Vector3d(c + Eigen::Vector3d(0.3, 0.6, 0.45) * res)}) {
            const EsdfMap::Query a = snap->esdfGrid()->query(p);
            const EsdfMap::Query e = fresh.query(p);
            if ((a.valid != e.valid || a.distance_m != e.distance_m || a.gradient != e.gradient) &&
                ++failures <= 5) {
              ADD_FAILURE() << "frame " << done << " at " << p.transpose() << ": pooled "
                            << a.distance_m << ", fresh " << e.distance_m;
            }
          }
        }
      }
    }
    if (done % 3 == 0) held.push_back(snap);  // keeps this copy out of the pool for a while
    if (held.size() > 4) held.erase(held.begin());
    ++checked;
  };
  eval::FlightOptions options;
  options.max_frames = 60;
  options.progress = [&](int done, int) { check(done); };
  ASSERT_EQ(eval::flyScenario(scenario, engine, options).frames, 60);
  EXPECT_EQ(checked, 60);
  EXPECT_EQ(failures, 0);

  config.esdf.query_grid = false;
  MapEngine without(config);
  options.max_frames = 3;
  options.progress = nullptr;
  eval::flyScenario(scenario, without, options);
  ASSERT_NE(without.snapshot()->esdf(), nullptr);
  EXPECT_EQ(without.snapshot()->esdfGrid(), nullptr);
}

// The ESDF is updated at most at its rate (frame stamps) and the skips are counted.
TEST(MapEngine, EsdfIsRateLimitedByFrameStamps) {
  const datasets::Scenario scenario = datasets::defaultScenario();
  MapConfig config;
  config.esdf.max_rate_hz = 2.0;
  MapEngine engine(config);
  eval::FlightOptions options;
  options.max_frames = 40;
  eval::flyScenario(scenario, engine, options);
  const PlanningStats p = engine.stats().planning;
  const double span_s = eval::frameTime(scenario, 39) - eval::frameTime(scenario, 0);
  EXPECT_EQ(p.snapshots, 40u);
  EXPECT_GE(p.grid_updates, 1u);
  EXPECT_LE(p.grid_updates, 40u);
  EXPECT_GE(p.esdf_updates, 1u);
  EXPECT_LE(static_cast<double>(p.esdf_updates), span_s * 2.0 + 1.0);
  EXPECT_EQ(p.esdf_updates + p.esdf_rate_limited + p.esdf_unchanged, 40u);
  EXPECT_GT(p.esdf_rate_limited, 0u);
}

}  // namespace
}  // namespace mlmap

namespace mlmap {
namespace {

/// Frames that fly along x, 1 m per frame (30 frames go far enough to retire submaps to the
/// global map), from `t0_s`.
std::vector<PointCloudFrame> flightAlongX(double t0_s, int frames) {
  std::vector<PointCloudFrame> out;
  out.reserve(static_cast<std::size_t>(frames));
  for (int i = 0; i < frames; ++i) {
    out.push_back(cloudAt(t0_s + 0.1 * i, Eigen::Vector3d(1.0 * i, 0.0, 1.0)));
  }
  return out;
}

/// clear() empties both layers (and the snapshot), keeps the stamp order, and the next frames
/// map as in a new engine: the reference is a fresh engine given only those frames.
void checkClearEmptiesAndMapsAgain(bool threaded) {
  MapConfig config = configAt(0.2);
  config.pipeline.threaded = threaded;
  config.pipeline.input_queue_capacity = 1000;  // nothing dropped
  std::uint64_t last_version = 0;
  std::size_t last_global_voxels = 0;
  EngineObservers observers;
  observers.global = [&](const GlobalMap& map, double, std::uint64_t version) {
    last_version = version;
    last_global_voxels = map.voxelCount();
  };
  MapEngine engine(config, {}, observers);
  for (PointCloudFrame& f : flightAlongX(0.0, 30)) {
    ASSERT_EQ(engine.submit(std::move(f)), FrameStatus::kAccepted);
  }
  engine.flush();
  ASSERT_FALSE(engine.occupiedVoxels().empty());
  ASSERT_GT(engine.globalMap().voxelCount(), 0u) << "the flight must retire submaps";
  const std::uint64_t version_before = last_version;

  engine.clear();
  EXPECT_TRUE(engine.occupiedVoxels().empty());
  EXPECT_EQ(engine.globalMap().voxelCount(), 0u);
  EXPECT_EQ(engine.stats().global_voxels, 0u);
  const MapState state = engine.exportState();
  EXPECT_TRUE(state.global_submaps.empty());
  EXPECT_EQ(state.window.size.prod(), 0) << "the window is unplaced";
  // cppcheck-suppress knownConditionTrueFalse ; the engine's global observer sets last_version
  EXPECT_NE(last_version, version_before) << "the global observer hears of the change";
  EXPECT_EQ(last_global_voxels, 0u);
  const std::shared_ptr<const MapSnapshot> snap = engine.snapshot();
  ASSERT_NE(snap, nullptr);
  EXPECT_EQ(snap->window().size.prod(), 0);
  // The stamp order holds: a frame older than the last one mapped is still refused.
  EXPECT_EQ(engine.submit(cloudAt(1.0, Eigen::Vector3d(0, 0, 1))), FrameStatus::kOutOfOrder);

  MapConfig fresh_config = config;
  MapEngine fresh(fresh_config);
  for (PointCloudFrame& f : flightAlongX(10.0, 10)) {
    PointCloudFrame copy = f;
    ASSERT_EQ(engine.submit(std::move(f)), FrameStatus::kAccepted);
    ASSERT_EQ(fresh.submit(std::move(copy)), FrameStatus::kAccepted);
  }
  engine.flush();
  fresh.flush();
  const std::vector<VoxelIndex> after = engine.occupiedVoxels();
  EXPECT_FALSE(after.empty()) << "the next frames map again";
  EXPECT_EQ(after, fresh.occupiedVoxels());
}

TEST(MapEngine, ClearEmptiesTheMapAndTheNextFramesMapAgainSynchronous) {
  checkClearEmptiesAndMapsAgain(false);
}

TEST(MapEngine, ClearEmptiesTheMapAndTheNextFramesMapAgainThreaded) {
  checkClearEmptiesAndMapsAgain(true);
}

}  // namespace
}  // namespace mlmap
