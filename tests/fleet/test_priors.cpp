// Sharing back: another vehicle's submaps taken as prior knowledge (MapEngine::addPrior), so a
// vehicle entering an area mapped only by another has those obstacles in its local map before
// its own sensor sees them.
#include "fleet_test_support.h"

#include "mlmap/fleet/submap_share.h"

#include <gtest/gtest.h>

namespace mlmap::fleet {
namespace {

/// Share of `a`'s occupied voxels inside `b`'s window that `b`'s snapshot holds occupied, and
/// how many there are.
std::pair<double, std::size_t> heldInWindow(const test_support::VoxelValues& a,
                                            const MapEngine& b) {
  const std::shared_ptr<const MapSnapshot> snap = b.snapshot();
  std::size_t inside = 0, held = 0;
  for (const auto& [g, l] : a) {
    if (!snap->window().contains(g)) continue;
    ++inside;
    held += snap->window().state(g) == Occupancy::kOccupied ? 1 : 0;
  }
  return {inside == 0 ? 0.0 : static_cast<double>(held) / static_cast<double>(inside), inside};
}

TEST(FleetPriors, AVehicleEnteringAnAreaMappedOnlyByAnotherHasItsObstaclesBeforeItsSensorSeesThem) {
  const MapConfig config = test_support::fleetMapConfig();
  const std::vector<PointCloudFrame> frames = test_support::roomFlight(120);
  MapEngine a(config);
  for (const PointCloudFrame& f : frames) ASSERT_EQ(a.submit(f), FrameStatus::kAccepted);
  const test_support::VoxelValues mapped_by_a = test_support::engineContent(a);

  // Vehicle b receives everything a shares (as mlmap_node would on rt/a/mlmap/submaps).
  SubmapShare share(config.local_map.submap_cells());
  MapEngine b(config);
  std::size_t sent = 0;
  for (SubmapUpdate& u :
       share.changes(collectGlobalDelta(a.globalMap(), 0), &a.snapshot()->window())) {
    sent += u.records.size();
    b.addPrior(u.index, std::move(u.records));
  }
  ASSERT_EQ(sent, mapped_by_a.size());

  // b's sensor sees almost nothing: one return 1 m below the body (the floor's voxel column).
  auto blindFrame = [](double stamp_s, const Transform& T_W_B) {
    PointCloudFrame f;
    f.stamp_s = stamp_s;
    f.T_W_B = T_W_B;
    f.points_S = {Eigen::Vector3f(0.0f, 0.0f, -1.0f)};
    return f;
  };
  // Entering the east room (mid-flight pose of a), then jumping to the north-west one.
  ASSERT_EQ(b.submit(blindFrame(1.0, frames[40].T_W_B)), FrameStatus::kAccepted);
  EXPECT_EQ(b.stats().prior_voxels_added, mapped_by_a.size());
  const auto [east, east_count] = heldInWindow(mapped_by_a, b);
  EXPECT_GT(east_count, 1000u);
  EXPECT_GE(east, 0.995) << "a's obstacles in b's window on entry";
  ASSERT_EQ(b.submit(blindFrame(2.0, frames[100].T_W_B)), FrameStatus::kAccepted);
  const auto [west, west_count] = heldInWindow(mapped_by_a, b);
  EXPECT_GT(west_count, 1000u);
  EXPECT_GE(west, 0.995);

  // The priors are marked for planners: every one in the window, none of b's own voxels.
  {
    const std::shared_ptr<const MapSnapshot> snap = b.snapshot();
    const std::shared_ptr<const PriorVoxels> priors = b.priors();
    EXPECT_EQ(priors->size(), mapped_by_a.size());
    std::size_t marked = 0;
    for (const auto& [g, l] : mapped_by_a) marked += priors->isPrior(g, snap->window()) ? 1 : 0;
    EXPECT_EQ(marked, west_count);
  }
  // Its own measurements then update them as usual: a's scans from b's pose give the same map.
  for (int i = 0; i < 5; ++i) {
    PointCloudFrame f = frames[100];
    f.stamp_s = 3.0 + i;
    ASSERT_EQ(b.submit(f), FrameStatus::kAccepted);
  }
  EXPECT_GT(b.stats().local.hits_applied, 0u);
  {
    // Measured now: the voxels whose value the own scans changed are no longer priors.
    const std::shared_ptr<const MapSnapshot> snap = b.snapshot();
    std::size_t still = 0, inside = 0;
    for (const auto& [g, l] : mapped_by_a) {
      if (!snap->window().contains(g)) continue;
      ++inside;
      still += b.priors()->isPrior(g, snap->window()) ? 1 : 0;
    }
    EXPECT_LT(still, inside);
    std::printf("after 5 own scans: %zu of %zu prior voxels in the window still unconfirmed\n",
                still, inside);
  }
  std::printf(
      "prior voxels: %zu sent, in b's window on entry %.4f of %zu (east), %.4f of %zu "
      "(north-west)\n",
      sent, east, east_count, west, west_count);
}

TEST(FleetPriors, OwnEvidenceWinsAndPriorsForTheWindowWaitUntilItLeaves) {
  GlobalMap global({4, 4, 4}, 0.1);
  global.store({0, 0, 0}, {{1, 500}, {5, 900}});
  EXPECT_EQ(global.addPrior({0, 0, 0}, {{1, 3500}, {2, 3500}, {5, 3500}, {9, 3500}}), 2u);
  const std::vector<VoxelRecord>* r = global.find({0, 0, 0});
  ASSERT_NE(r, nullptr);
  ASSERT_EQ(r->size(), 4u);
  EXPECT_EQ((*r)[0].log_odds, 500);  // own value kept
  EXPECT_EQ((*r)[1].offset, 2u);
  EXPECT_EQ((*r)[3].offset, 9u);
  EXPECT_EQ(global.voxelCount(), 4u);
  EXPECT_EQ(global.addPrior({0, 0, 0}, {{2, 100}}), 0u);  // nothing new: unchanged, unstamped

  const MapConfig config = test_support::fleetMapConfig();
  MapEngine engine(config);
  PointCloudFrame f;
  f.stamp_s = 1.0;
  f.T_W_B.translation() = Eigen::Vector3d(1.0, 1.0, 1.0);
  f.points_S = {Eigen::Vector3f(0.0f, 0.0f, -0.5f)};
  ASSERT_EQ(engine.submit(f), FrameStatus::kAccepted);
  // A prior for the submap the body is in: it waits while the window holds that submap.
  const SubmapIndex here = engine.localMap().centerSubmap();
  engine.addPrior(here, {{0, 3000}});
  f.stamp_s = 2.0;
  ASSERT_EQ(engine.submit(f), FrameStatus::kAccepted);
  EXPECT_EQ(engine.stats().prior_submaps_waiting, 1u);
  EXPECT_EQ(engine.stats().prior_voxels_added, 0u);
  // Far away, the window retires it: the prior is added to the global map.
  f.stamp_s = 3.0;
  f.T_W_B.translation() = Eigen::Vector3d(100.0, 1.0, 1.0);
  ASSERT_EQ(engine.submit(f), FrameStatus::kAccepted);
  f.stamp_s = 4.0;
  ASSERT_EQ(engine.submit(f), FrameStatus::kAccepted);
  EXPECT_EQ(engine.stats().prior_submaps_waiting, 0u);
  EXPECT_EQ(engine.stats().prior_voxels_added, 1u);
}

}  // namespace
}  // namespace mlmap::fleet
