// The awareness stage's threads (also run under ThreadSanitizer by tools/test.sh): TaskThreads
// runs every job of a run() exactly once, whoever claims it, and hands exceptions back; the
// stage's two halves (collect(), carve()) on two threads at once fill the batches process()
// fills.
#include "../../src/awareness/task_threads.h"
#include "mlmap/awareness/awareness_stage.h"

#include "../support/random_draws.h"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

namespace mlmap {
namespace {

// Points all around the sensor, some beyond the range (6 m).
PointCloudFrame randomCloud(std::mt19937& rng, int n, double max_r) {
  PointCloudFrame f;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> r(0.2, max_r);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d d = test::draw3(u, rng);
    if (d.norm() < 1e-3) continue;
    f.points_S.push_back((d.normalized() * r(rng)).cast<float>());
  }
  f.T_W_B.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  f.T_B_S = SensorConfig{}.T_B_S();
  return f;
}

MapConfig testConfig(double resolution) {
  MapConfig c;
  c.local_map.resolution_m = resolution;
  c.awareness.max_range_m = 6.0;
  c.awareness.rho_cells = 70;
  return c;
}

TEST(TaskThreads, RunsEveryJobExactlyOnceBeforeReturning) {
  for (int threads : {1, 2, 3}) {
    TaskThreads pool(threads);
    EXPECT_EQ(pool.size(), threads);
    for (int round = 0; round < 300; ++round) {
      const int n = round % 9;  // 0 .. 8 jobs: fewer, as many and more than threads
      std::vector<std::atomic<int>> calls(static_cast<std::size_t>(n));
      pool.run(n, [&](int i) { calls[static_cast<std::size_t>(i)].fetch_add(1); });
      for (int i = 0; i < n; ++i) {
        ASSERT_EQ(calls[static_cast<std::size_t>(i)].load(), 1)
            << threads << " threads, " << n << " jobs, job " << i;
      }
    }
  }
}

TEST(TaskThreads, JobZeroRunsOnTheCaller) {
  TaskThreads pool(2);
  for (int round = 0; round < 50; ++round) {
    std::thread::id first;
    pool.run(2, [&](int i) {
      if (i == 0) first = std::this_thread::get_id();
    });
    ASSERT_EQ(first, std::this_thread::get_id());
  }
}

TEST(TaskThreads, AJobMayWaitForALaterOneWhileAnotherThreadIsFree) {
  // Job 1 waits until job 2 has run. Whichever thread holds job 1, the other one claims job 2:
  // no job is tied to a thread, so this never hangs.
  TaskThreads pool(2);
  for (int round = 0; round < 100; ++round) {
    std::atomic<bool> second_done{false};
    pool.run(3, [&](int i) {
      if (i == 1) {
        while (!second_done.load()) std::this_thread::yield();
      } else if (i == 2) {
        second_done.store(true);
      }
    });
    ASSERT_TRUE(second_done.load());
  }
}

TEST(TaskThreads, ACallWhileAnotherRunsDoesItsJobsItself) {
  // The threaded engine's two halves of the awareness stage share the kept threads: a run()
  // called while another one holds them runs its jobs on its caller, and both get every job
  // done once.
  TaskThreads pool(2);
  for (int round = 0; round < 50; ++round) {
    std::atomic<bool> second_done{false};
    std::vector<std::atomic<int>> first(2);
    std::vector<std::atomic<int>> second(3);
    std::thread other;
    pool.run(2, [&](int i) {
      if (i == 0) {  // the first run() is under way: a second caller now
        other = std::thread([&] {
          pool.run(3, [&](int j) { second[static_cast<std::size_t>(j)].fetch_add(1); });
          second_done.store(true);
        });
        while (!second_done.load()) std::this_thread::yield();
      }
      first[static_cast<std::size_t>(i)].fetch_add(1);
    });
    other.join();
    for (const std::atomic<int>& c : first) ASSERT_EQ(c.load(), 1) << "round " << round;
    for (const std::atomic<int>& c : second) ASSERT_EQ(c.load(), 1) << "round " << round;
  }
}

TEST(TaskThreads, RethrowsAJobsExceptionAfterAllReturned) {
  TaskThreads pool(2);
  for (int thrower : {0, 1, 2}) {
    std::atomic<int> ran{0};
    EXPECT_THROW(pool.run(3,
                          [&](int i) {
                            ran.fetch_add(1);
                            if (i == thrower) throw std::runtime_error("job failed");
                          }),
                 std::runtime_error);
    EXPECT_EQ(ran.load(), 3);
    std::atomic<int> after{0};
    pool.run(2, [&](int) { after.fetch_add(1); });  // still works
    EXPECT_EQ(after.load(), 2);
  }
}

// collect() and carve() as the threaded engine runs them: frame k's carving on one thread
// while frame k + 1 is collected on another, in a ring of batches (with two threads both halves
// ask the one kept thread for help), the awareness map updated by collect(), by carve(), or by
// either in turn (a frame whose map goes back to collect() waits for the carving of the one
// before, or, past the wait's bound, leaves it to carve() too), and the cone listing done by
// carve(), its bin entry or all of it by collect(), or each in turn (collect() listing frame
// k + 1's while carve() lists frame k's). Each batch is then what process() makes of its frame, bit
// for bit, and so is the awareness map; carve() hands the map to its observer exactly for the
// frames whose map collect() left to it.
TEST(AwarenessStage, HalvesOnTwoThreadsCarveWhatProcessCarves) {
  enum class Place { kCollect, kCarve, kAlternate };
  using Step = AwarenessStage::ConeListingStep;
  // Threads, the awareness map's half, how far collect() takes the cone listing (0: nowhere,
  // 1: the bin entry, 2: all of it; -1: frame by frame 0, 1, 2, 0, 2, 1, 0, every change).
  using Case = std::tuple<int, Place, int>;
  for (const auto& [threads, place, listing] :
       {Case{1, Place::kCollect, 0}, Case{2, Place::kCollect, 0}, Case{1, Place::kCarve, 0},
        Case{2, Place::kCarve, 0}, Case{1, Place::kAlternate, 0}, Case{2, Place::kAlternate, 0},
        Case{1, Place::kCollect, 1}, Case{2, Place::kCarve, 1}, Case{1, Place::kCarve, 2},
        Case{2, Place::kCollect, 2}, Case{1, Place::kAlternate, -1},
        Case{2, Place::kAlternate, -1}}) {
    const auto inCarve = [place = place](std::size_t k) {
      return place == Place::kCarve || (place == Place::kAlternate && k % 3 != 0);
    };
    const auto listedInCollect = [listing = listing](std::size_t k) {
      constexpr std::array<int, 7> kTurns{0, 1, 2, 0, 2, 1, 0};
      return static_cast<Step>(listing >= 0 ? listing : kTurns[k % kTurns.size()]);
    };
    MapConfig config = testConfig(0.1);
    AwarenessStage reference(config);
    config.awareness.num_threads = threads;
    AwarenessStage split(config);
    std::mt19937 rng(90 + static_cast<std::uint32_t>(threads));
    std::vector<PointCloudFrame> frames;
    for (int k = 0; k < 7; ++k) {
      frames.push_back(randomCloud(rng, 4000 + 1000 * k, 8.0));  // each frame its own ends
      frames.back().T_W_B.translation() = Eigen::Vector3d(0.37 * k, -0.21 * k, 0.05 * k);
      frames.back().stamp_s = 0.1 * (k + 1);
    }
    std::array<MeasurementBatch, 3> ring;
    std::array<PointCounters, 3> counters;
    std::vector<bool> map_in_carve(frames.size(), false);  // what collect() did
    split.placeAwarenessMap(inCarve(0));
    // Each step timed on the half that did it, and only there.
    const auto expectSteps = [](AwarenessStage::ListingMs ms, Step from, Step to) {
      EXPECT_EQ(ms.bins > 0.0, from < Step::kBinsEntered && to >= Step::kBinsEntered);
      EXPECT_EQ(ms.cones > 0.0, from < Step::kConesListed && to >= Step::kConesListed);
    };
    split.placeConeListing(listedInCollect(0));
    split.collect(frames[0], &ring[0], &counters[0]);
    expectSteps(split.lastCollectListingMs(), Step::kNothing, listedInCollect(0));
    map_in_carve[0] = !split.lastCollectUpdatedMap();
    EXPECT_EQ(map_in_carve[0], inCarve(0));  // nothing to wait for
    for (std::size_t k = 0; k < frames.size(); ++k) {
      MeasurementBatch& b = ring[k % 3];
      int maps_observed = 0;
      double map_ms = -1.0;
      AwarenessStage::ListingMs carve_listing_ms;
      std::thread carver([&] {
        map_ms = split.carve(&b, &counters[k % 3], [&](const AwarenessMap&) { ++maps_observed; });
        carve_listing_ms = split.lastCarveListingMs();
      });
      if (k + 1 < frames.size()) {
        counters[(k + 1) % 3] = PointCounters{};
        split.placeAwarenessMap(inCarve(k + 1));
        split.placeConeListing(listedInCollect(k + 1));
        split.collect(frames[k + 1], &ring[(k + 1) % 3], &counters[(k + 1) % 3]);
        SCOPED_TRACE("frame " + std::to_string(k + 1));
        expectSteps(split.lastCollectListingMs(), Step::kNothing, listedInCollect(k + 1));
        map_in_carve[k + 1] = !split.lastCollectUpdatedMap();
        // Left to carve() when asked; the other way, only while an earlier frame's map waited.
        if (inCarve(k + 1) || !map_in_carve[k]) {
          EXPECT_EQ(map_in_carve[k + 1], inCarve(k + 1));
        }
      }
      carver.join();
      expectSteps(carve_listing_ms, listedInCollect(k), Step::kConesListed);
      EXPECT_EQ(maps_observed, map_in_carve[k] ? 1 : 0) << "frame " << k;
      EXPECT_EQ(map_ms > 0.0, map_in_carve[k]) << "frame " << k;
      MeasurementBatch a;
      PointCounters ca;
      reference.process(frames[k], &a, &ca);
      const PointCounters& cb = counters[k % 3];
      ASSERT_EQ(a.free.origin(), b.free.origin());
      ASSERT_EQ(a.free.dims(), b.free.dims());
      const std::size_t words = static_cast<std::size_t>(a.free.dims().x()) *
                                static_cast<std::size_t>(a.free.dims().y()) * a.free.wordsPerRow();
      std::size_t differing = 0;
      for (std::size_t w = 0; w < words; ++w)
        differing += a.free.data()[w] != b.free.data()[w] ? 1 : 0;
      EXPECT_EQ(differing, 0u) << threads << " threads, frame " << k
                               << ", listed by collect() to step "
                               << static_cast<int>(listedInCollect(k));
      EXPECT_EQ(a.free_count, b.free_count);
      EXPECT_GT(a.free_count, 10000u);
      EXPECT_EQ(a.stamp_s, b.stamp_s);
      ASSERT_EQ(a.hits.size(), b.hits.size());
      for (std::size_t i = 0; i < a.hits.size(); ++i) {
        EXPECT_EQ(a.hits[i].index, b.hits[i].index);
        EXPECT_EQ(a.hits[i].p_W, b.hits[i].p_W);
      }
      EXPECT_EQ(a.far_hits, b.far_hits);
      EXPECT_EQ(ca.free_voxels, cb.free_voxels);
      EXPECT_EQ(ca.hit_voxels, cb.hit_voxels);
      EXPECT_EQ(ca.points_in, cb.points_in);
      EXPECT_EQ(ca.beyond_max_range, cb.beyond_max_range);
      // The map is one frame ahead in `split` where collect() updated it for frame k + 1:
      // compare it where it is frame k's, and after the last.
      if (k + 1 == frames.size() || map_in_carve[k + 1]) {
        EXPECT_EQ(reference.map().occupiedPoints(), split.map().occupiedPoints());
        EXPECT_EQ(reference.map().count(Occupancy::kFree), split.map().count(Occupancy::kFree));
      }
    }
  }
}

}  // namespace
}  // namespace mlmap
