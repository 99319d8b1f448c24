// exportState() from another thread while the threaded engine maps (mlmap_node's periodic map
// saving): every exported state must be a consistent map that an engine accepts. Also run under
// ThreadSanitizer by tools/test.sh.

#include "../support/small_flight.h"

#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>

namespace mlmap {
namespace {

TEST(ExportConcurrency, StatesExportedWhileMappingAreConsistent) {
  MapConfig config = test::smallWindowConfig();
  config.pipeline.threaded = true;
  config.pipeline.input_queue_capacity = 1000;  // nothing dropped
  MapEngine engine(config);
  std::atomic<bool> done{false};
  int exported = 0;
  std::uint64_t last_frames = 0;
  bool monotonic = true;
  std::string refused;
  std::thread saver([&] {
    MapConfig sync = test::smallWindowConfig();
    while (!done.load()) {
      const MapState state = engine.exportState();
      MapEngine check(sync);
      try {
        check.restoreState(state);
      } catch (const std::exception& e) {
        refused = e.what();
        break;
      }
      monotonic = monotonic && state.frames_mapped >= last_frames;
      last_frames = state.frames_mapped;
      ++exported;
    }
  });
  test::flyCheap(engine, 0, 30);
  engine.flush();
  done = true;
  saver.join();
  EXPECT_EQ(refused, "");
  EXPECT_GT(exported, 1);
  EXPECT_TRUE(monotonic);
  EXPECT_EQ(engine.exportState().frames_mapped, 30u);
  EXPECT_GT(engine.exportState().global_submaps.size(), 0u);
}

}  // namespace
}  // namespace mlmap
