// Planner threads query the engine while the simulator flies and the map slides (the awareness
// stage and the ESDF on threads of their own too). Run under ThreadSanitizer in CI
// (tools/test.sh): any data race between mapping and queries fails it.

#include "mlmap/eval/sim_flight.h"

#include "../support/small_flight.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

namespace mlmap {
namespace {

TEST(PlanningConcurrency, PlannerThreadsQueryWhileTheMapSlides) {
  datasets::Scenario scenario = datasets::defaultScenario();
  // A 160 x 120 camera (same field of view): the races are between mapping and queries, and
  // rendering 640 x 480 frames under ThreadSanitizer would take most of the test's time.
  scenario.camera.intrinsics = test::quarterCamera();
  MapConfig config;
  config.pipeline.threaded = true;
  config.pipeline.input_queue_capacity = 1000;
  config.esdf.max_rate_hz = 0.0;  // every change: as many ESDF swaps as possible
  config.projected_grid.include_global = true;
  config.esdf.num_threads = 2;       // the ESDF's own worker threads too
  config.awareness.num_threads = 2;  // the carving's threads and the awareness map's thread
  MapEngine engine(config);

  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> queries{0};
  std::atomic<std::uint64_t> valid_distances{0};
  std::atomic<int> failures{0};
  auto planner = [&](unsigned seed) {
    std::uint64_t last_frame = 0;
    std::uint64_t n = 0;
    std::uint64_t valid = 0;
    unsigned state = seed;
    auto next = [&]() {  // small LCG: no shared generator
      state = state * 1664525u + 1013904223u;
      return static_cast<double>(state >> 8) / 16777216.0;
    };
    while (!done.load(std::memory_order_relaxed)) {
      const std::shared_ptr<const MapSnapshot> snap = engine.snapshot();
      if (snap->frame() < last_frame) failures.fetch_add(1);  // snapshots never go back
      last_frame = snap->frame();
      const Eigen::Vector3d lo = snap->windowMin_W();
      const Eigen::Vector3d hi = snap->windowMax_W();
      const ProjectedGrid& grid = snap->grid();
      if (grid.cells.size() != static_cast<std::size_t>(grid.width) * grid.height) {
        failures.fetch_add(1);
      }
      for (int i = 0; i < 200; ++i) {
        const Eigen::Vector3d p =
            lo + (hi - lo).cwiseProduct(Eigen::Vector3d(next(), next(), next()));
        const Eigen::Vector3d q =
            lo + (hi - lo).cwiseProduct(Eigen::Vector3d(next(), next(), next()));
        const Occupancy s = snap->state(p);
        double prob = 0.0;
        if (snap->probability(p, &prob) != (s != Occupancy::kUnknown)) failures.fetch_add(1);
        const EsdfMap::Query d = snap->distance(p);
        if (d.valid) {
          ++valid;
          // Inside an occupied voxel the field is negative at its centre (when the ESDF was
          // computed from this snapshot's window: it may be a few frames older).
          const VoxelIndex g = voxelIndexOf(p, snap->window().resolution_m);
          if (snap->esdfFrame() == snap->frame() && s == Occupancy::kOccupied &&
              snap->esdf()->contains(g) && !(snap->esdf()->distanceAt(g) < 0.0f)) {
            failures.fetch_add(1);
          }
        }
        (void)snap->isSegmentFree(p, q);
        (void)snap->isBoxFree(p, p + Eigen::Vector3d::Constant(0.5), UnknownAs::kFree);
        (void)grid.valueAt(p.head<2>());
        n += 6;
      }
    }
    queries.fetch_add(n);
    valid_distances.fetch_add(valid);
  };
  std::vector<std::thread> planners;
  for (unsigned i = 0; i < 3; ++i) planners.emplace_back(planner, 17u + i);

  eval::FlightOptions options;
  options.max_frames = 120;  // long enough to slide the window over several submaps
  eval::flyScenario(scenario, engine, options);
  engine.flush();
  done = true;
  for (std::thread& t : planners) t.join();

  const EngineStats stats = engine.stats();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(stats.frames_mapped, 120u);
  EXPECT_GT(stats.local.shifts, 0u);
  EXPECT_GT(stats.planning.esdf_updates, 0u);
  EXPECT_GT(queries.load(), 1000u);
  EXPECT_GT(valid_distances.load(), 0u);
  // After flush() the snapshot holds the last frame and an ESDF of it.
  const auto last = engine.snapshot();
  EXPECT_EQ(last->frame(), 120u);
  ASSERT_NE(last->esdf(), nullptr);
}

// The esdf observer announces every ESDF the planning thread publishes, after the snapshot holding
// it is published: the snapshot read in the call already has a field at least that new.
TEST(PlanningConcurrency, EsdfObserverAnnouncesEachPublishedField) {
  MapConfig config = test::smallWindowConfig();
  config.pipeline.threaded = true;
  config.pipeline.input_queue_capacity = 1000;
  config.esdf.max_rate_hz = 0.0;
  std::atomic<int> calls{0};
  std::atomic<int> failures{0};
  std::atomic<std::uint64_t> last_frame{0};
  MapEngine* engine_seen = nullptr;
  std::atomic<bool> ready{false};
  EngineObservers observers;
  observers.esdf = [&](std::uint64_t frame, double) {
    calls.fetch_add(1);
    if (frame < last_frame.load()) failures.fetch_add(1);  // announced in order
    last_frame.store(frame);
    if (ready.load()) {
      const std::shared_ptr<const MapSnapshot> snap = engine_seen->snapshot();
      if (snap->esdf() == nullptr || snap->frame() < frame) failures.fetch_add(1);
    }
  };
  MapEngine engine(config, {}, observers);
  engine_seen = &engine;
  ready.store(true);
  test::flyCheap(engine, 0, 12);
  engine.flush();
  EXPECT_GE(calls.load(), 1);
  EXPECT_EQ(failures.load(), 0);
  const PlanningStats planning = engine.stats().planning;
  EXPECT_EQ(static_cast<std::uint64_t>(calls.load()), planning.esdf_updates);  // every one
  EXPECT_GE(last_frame.load(), planning.esdf_frame);                           // the last one too
}

}  // namespace
}  // namespace mlmap
