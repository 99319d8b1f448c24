// The sending side: the global map's per-submap stamps, and SubmapShare sending exactly what
// changed, so that a receiver applying every update holds the vehicle's whole map, and a
// hovering vehicle sends nothing.
#include "fleet_test_support.h"

#include "mlmap/fleet/submap_codec.h"
#include "mlmap/fleet/submap_share.h"

#include <gtest/gtest.h>

#include <unordered_map>

namespace mlmap::fleet {
namespace {

using test_support::VoxelValues;

TEST(GlobalMapStamps, EachChangeStampsItsSubmapAndRemovalsAreReported) {
  GlobalMap map({4, 4, 4}, 0.1);
  EXPECT_EQ(map.submapModifiedAt({0, 0, 0}), 0u);
  map.store({0, 0, 0}, {{1, 100}});
  map.store({1, 0, 0}, {{2, 100}});
  const std::uint64_t v1 = map.modifications();
  map.store({5, 0, 0}, {});  // nothing held, nothing stored: no stamp
  EXPECT_EQ(map.submapModifiedAt({5, 0, 0}), 0u);
  std::vector<VoxelRecord> taken;
  ASSERT_TRUE(map.take({0, 0, 0}, &taken));
  std::vector<VoxelIndex> hits = {VoxelIndex(-1, 0, 0)};
  std::uint64_t lost = 0;
  map.addHits(&hits, LogOddsModel(LogOddsConfig{}), &lost);
  std::map<std::tuple<int, int, int>, bool> seen;  // submap -> holds records
  map.forEachSubmapModifiedAfter(v1, [&](const SubmapIndex& m, const std::vector<VoxelRecord>* r) {
    seen[{m.x(), m.y(), m.z()}] = r != nullptr;
  });
  const std::map<std::tuple<int, int, int>, bool> expected = {{{0, 0, 0}, false},
                                                              {{-1, 0, 0}, true}};
  EXPECT_EQ(seen, expected);
  EXPECT_GT(map.submapModifiedAt({0, 0, 0}), v1);
  EXPECT_EQ(map.submapModifiedAt({1, 0, 0}), v1);
  // Stored again: a stored submap, stamped anew.
  map.store({0, 0, 0}, std::move(taken));
  EXPECT_EQ(map.submapModifiedAt({0, 0, 0}), map.modifications());
  map.clear();
  EXPECT_EQ(map.lastClearedAt(), map.modifications());
  EXPECT_EQ(map.submapModifiedAt({0, 0, 0}), 0u);
  const GlobalMapDelta delta = collectGlobalDelta(map, v1);
  EXPECT_TRUE(delta.cleared);
  EXPECT_TRUE(delta.changed.empty());
}

/// A receiver of SubmapUpdates: the latest content of each submap, through the wire form.
class Receiver {
 public:
  explicit Receiver(const Eigen::Vector3i& cells) : cells_(cells) {}
  void apply(const std::vector<SubmapUpdate>& updates) {
    for (const SubmapUpdate& u : updates) {
      const SubmapPayload p = encodeSubmapVoxels(u.records);
      std::vector<VoxelRecord> records;
      ASSERT_EQ(decodeSubmapVoxels(p.voxel_count, static_cast<std::uint8_t>(p.encoding), p.raw_size,
                                   p.data.data(), p.data.size(),
                                   static_cast<std::uint64_t>(cells_.prod()), &records),
                SubmapDecodeError::kNone);
      if (records.empty()) {
        submaps_.erase(packSubmap(u.index));
      } else {
        submaps_[packSubmap(u.index)] = std::move(records);
      }
    }
  }
  [[nodiscard]] VoxelValues content() const {
    VoxelValues out;
    const int plane = cells_.y() * cells_.z();
    for (const auto& [key, records] : submaps_) {
      const VoxelIndex base = unpackSubmap(key).cwiseProduct(cells_);
      for (const VoxelRecord& r : records) {
        const int o = static_cast<int>(r.offset);
        out[base + VoxelIndex(o / plane, (o % plane) / cells_.z(), o % cells_.z())] = r.log_odds;
      }
    }
    return out;
  }

 private:
  Eigen::Vector3i cells_;
  std::unordered_map<std::uint64_t, std::vector<VoxelRecord>> submaps_;
};

/// Collects on the engine's side as the node does (global delta since the last collection and
/// the window of the same frame) and returns the updates to send.
std::vector<SubmapUpdate> collect(const MapEngine& engine, SubmapShare* share,
                                  std::uint64_t* version) {
  GlobalMapDelta delta = collectGlobalDelta(engine.globalMap(), *version);
  *version = delta.version;
  const std::shared_ptr<const MapSnapshot> snap = engine.snapshot();
  return share->changes(std::move(delta), snap ? &snap->window() : nullptr);
}

TEST(SubmapShare, AReceiverOfEveryUpdateHoldsTheVehiclesWholeMapAndAHoverSendsNothing) {
  const MapConfig config = test_support::fleetMapConfig();
  MapEngine engine(config);
  const std::vector<PointCloudFrame> frames = test_support::roomFlight(120);
  SubmapShare share(config.local_map.submap_cells());
  Receiver receiver(config.local_map.submap_cells());
  std::uint64_t version = 0;
  std::size_t sent = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    ASSERT_EQ(engine.submit(frames[i]), FrameStatus::kAccepted);
    if (i % 7 == 6) {
      const std::vector<SubmapUpdate> updates = collect(engine, &share, &version);
      sent += updates.size();
      receiver.apply(updates);
      ASSERT_EQ(receiver.content(), test_support::engineContent(engine)) << "after frame " << i;
    }
  }
  receiver.apply(collect(engine, &share, &version));
  const VoxelValues whole = test_support::engineContent(engine);
  EXPECT_EQ(receiver.content(), whole);
  EXPECT_GT(whole.size(), 2000u);
  EXPECT_GT(engine.stats().local.submaps_retired, 0u) << "the flight should leave submaps behind";
  EXPECT_EQ(
      share.submapsHeld(),
      engine.globalMap().submapCount() + [&] {  // the window's submaps holding occupied voxels
        std::size_t n = 0;
        for (const auto& s :
             windowSubmaps(engine.snapshot()->window(), config.local_map.submap_cells())) {
          n += s.second.empty() ? 0 : 1;
        }
        return n;
      }());

  // Hovering at the last pose: once the repeated scans saturated, nothing changes.
  PointCloudFrame hover = frames.back();
  for (int i = 0; i < 12; ++i) {
    hover.stamp_s += 0.1;
    ASSERT_EQ(engine.submit(hover), FrameStatus::kAccepted);
  }
  receiver.apply(collect(engine, &share, &version));
  for (int i = 0; i < 10; ++i) {
    hover.stamp_s += 0.1;
    ASSERT_EQ(engine.submit(hover), FrameStatus::kAccepted);
  }
  EXPECT_TRUE(collect(engine, &share, &version).empty());
  EXPECT_EQ(receiver.content(), test_support::engineContent(engine));
  std::printf("%zu submap updates over the flight, %zu submaps held\n", sent, share.submapsHeld());
}

TEST(SubmapShare, ClearingTheMapSendsEverySubmapEmpty) {
  const MapConfig config = test_support::fleetMapConfig();
  MapEngine engine(config);
  const std::vector<PointCloudFrame> frames = test_support::roomFlight(40);
  SubmapShare share(config.local_map.submap_cells());
  Receiver receiver(config.local_map.submap_cells());
  std::uint64_t version = 0;
  for (const PointCloudFrame& f : frames) ASSERT_EQ(engine.submit(f), FrameStatus::kAccepted);
  receiver.apply(collect(engine, &share, &version));
  ASSERT_FALSE(receiver.content().empty());
  engine.clear();
  receiver.apply(collect(engine, &share, &version));
  EXPECT_TRUE(receiver.content().empty());
  EXPECT_EQ(share.submapsHeld(), 0u);
}

}  // namespace
}  // namespace mlmap::fleet
