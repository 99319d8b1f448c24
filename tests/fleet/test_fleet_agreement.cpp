// The merged map against one engine fed every vehicle's frames and against the ground truth:
// two vehicles fly the two halves of a LiDAR flight through the simulated room, the second
// taking the first one's shared submaps as priors (sharing back); each shares its own evidence
// (fleet::ownEvidence) through the wire form into a FleetMap, as mlmap_node and mlmap_fleet do
// over DDS.
#include "fleet_test_support.h"

#include "mlmap/fleet/fleet_map.h"
#include "mlmap/fleet/submap_codec.h"
#include "mlmap/fleet/submap_share.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <set>
#include <tuple>

namespace mlmap::fleet {
namespace {

using test_support::iou;
using test_support::Key3;
using test_support::keys;

/// Agreement of the merged map with one engine and with the room.
struct Agreement {
  double iou_vs_single = 0.0;  ///< merged against one engine fed every frame
  double precision = 0.0;      ///< merged voxels touching a solid of the room
  double recall = 0.0;         ///< voxels holding a LiDAR return that the merged map holds
  double f1 = 0.0;
  double single_f1 = 0.0;  ///< the one engine's, against the room
  std::size_t merged = 0;
  std::size_t single = 0;
  std::size_t only_merged = 0;    ///< voxels the merged map holds and the one engine does not
  std::size_t only_single = 0;    ///< and the other way round
  std::size_t bytes[2] = {0, 0};  ///< each vehicle's serialized voxel payloads
};

/// How the second vehicle takes part.
enum class SecondVehicle {
  kSendsOwnEvidence,  ///< takes the first one's submaps as priors, sends its own evidence
  kSendsWholeMap,     ///< takes them as priors, sends its map as it holds it (no free evidence)
  kTakesNoPriors,     ///< maps alone (only occupied voxels travel)
};

/// A vehicle: its engine and its share, as mlmap_node's fleet output runs them.
struct Vehicle {
  explicit Vehicle(const MapConfig& config)
      : engine(config), share(config.local_map.submap_cells()) {}
  /// One round of sharing into `fleet` as `name` (through the wire form); every update also
  /// goes to `receiver` as priors when not null. Returns the payload bytes.
  std::size_t shareRound(const std::string& name, bool own_evidence, FleetMap* fleet,
                         MapEngine* receiver) {
    GlobalMapDelta delta = collectGlobalDelta(engine.globalMap(), version);
    version = delta.version;
    const std::shared_ptr<const MapSnapshot> snap = engine.snapshot();
    const std::shared_ptr<const PriorVoxels> priors = engine.priors();
    std::size_t bytes = 0;
    std::vector<SubmapUpdate> updates = share.changes(
        std::move(delta), snap ? &snap->window() : nullptr, own_evidence ? priors.get() : nullptr);
    for (SubmapUpdate& u : updates) {
      const SubmapPayload p = encodeSubmapVoxels(u.records);
      bytes += p.data.size();
      std::vector<VoxelRecord> records;
      EXPECT_EQ(decodeSubmapVoxels(
                    p.voxel_count, static_cast<std::uint8_t>(p.encoding), p.raw_size, p.data.data(),
                    p.data.size(),
                    static_cast<std::uint64_t>(engine.config().local_map.submap_cells().prod()),
                    &records),
                SubmapDecodeError::kNone);
      if (receiver != nullptr) receiver->addPrior(u.index, records);
      EXPECT_EQ(fleet->apply(name, u.index, ++sequence, std::move(records)), SubmapApply::kApplied);
    }
    return bytes;
  }
  MapEngine engine;
  SubmapShare share;
  std::uint64_t version = 0;
  std::uint64_t sequence = 0;
};

/// The voxels holding a LiDAR return of `frames` (noise-free: points on the room's surfaces):
/// the ground truth of what the vehicles saw.
std::set<Key3> returnVoxels(const std::vector<PointCloudFrame>& frames, double resolution_m) {
  std::set<Key3> out;
  for (const PointCloudFrame& f : frames) {
    const Transform T_W_S = f.T_W_B * f.T_B_S;
    for (const Eigen::Vector3f& p_S : f.points_S) {
      const Eigen::Vector3d p_W = T_W_S * p_S.cast<double>();
      const Eigen::Vector3d i = (p_W / resolution_m).array().floor();
      out.insert({static_cast<int>(i.x()), static_cast<int>(i.y()), static_cast<int>(i.z())});
    }
  }
  return out;
}

/// Vehicle uav1 maps the first half of `frames`, uav2 the second; each shares once every six
/// frames (1 Hz at the flight's 6 Hz) and at its end; one engine maps every frame.
Agreement flyTwoHalves(const MapConfig& config, const std::vector<PointCloudFrame>& frames,
                       const Eigen::Vector3d& map_from_simulator_m, SecondVehicle second) {
  FleetMap fleet(config.log_odds);
  EXPECT_TRUE(fleet.acceptGeometry(config.local_map.resolution_m, config.local_map.submap_cells()));
  Vehicle uav1(config), uav2(config);
  MapEngine single(config);
  MapEngine* receiver = second == SecondVehicle::kTakesNoPriors ? nullptr : &uav2.engine;
  const bool own_evidence = second == SecondVehicle::kSendsOwnEvidence;
  Agreement out;
  const std::size_t half = frames.size() / 2;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(single.submit(frames[i]), FrameStatus::kAccepted);
    Vehicle& v = i < half ? uav1 : uav2;
    EXPECT_EQ(v.engine.submit(frames[i]), FrameStatus::kAccepted);
    if (i % 6 != 5) continue;
    if (i < half) {
      out.bytes[0] += uav1.shareRound("uav1", own_evidence, &fleet, receiver);
    } else {
      out.bytes[1] += uav2.shareRound("uav2", own_evidence, &fleet, nullptr);
    }
    if (i + 1 == half) out.bytes[0] += uav1.shareRound("uav1", own_evidence, &fleet, receiver);
  }
  out.bytes[0] += uav1.shareRound("uav1", own_evidence, &fleet, receiver);
  out.bytes[1] += uav2.shareRound("uav2", own_evidence, &fleet, nullptr);

  std::set<Key3> merged;
  fleet.forEachOccupied([&](const VoxelIndex& g, LogOddsQ, std::uint64_t) {
    merged.insert({g.x(), g.y(), g.z()});
  });
  const std::set<Key3> reference = keys(single.occupiedVoxels());
  const sim::World world = sim::World::defaultRoom();
  const double r = config.local_map.resolution_m;
  const std::set<Key3> seen = returnVoxels(frames, r);
  // Precision: voxels touching a solid; recall: voxels holding a return that are mapped.
  auto score = [&](const std::set<Key3>& voxels, double* precision, double* recall) {
    std::size_t right = 0;
    for (const auto& [x, y, z] : voxels) {
      right += test_support::touchesRoomSolid(world, VoxelIndex(x, y, z), r, map_from_simulator_m)
                   ? 1
                   : 0;
    }
    std::size_t found = 0;
    for (const Key3& k : seen) found += voxels.count(k);
    *precision =
        voxels.empty() ? 0.0 : static_cast<double>(right) / static_cast<double>(voxels.size());
    *recall = seen.empty() ? 0.0 : static_cast<double>(found) / static_cast<double>(seen.size());
    return *precision + *recall > 0.0 ? 2.0 * *precision * *recall / (*precision + *recall) : 0.0;
  };
  out.iou_vs_single = iou(merged, reference);
  out.f1 = score(merged, &out.precision, &out.recall);
  double single_precision = 0.0, single_recall = 0.0;
  out.single_f1 = score(reference, &single_precision, &single_recall);
  out.merged = merged.size();
  out.single = reference.size();
  for (const Key3& k : merged) out.only_merged += reference.count(k) == 0 ? 1 : 0;
  for (const Key3& k : reference) out.only_single += merged.count(k) == 0 ? 1 : 0;
  return out;
}

void print(const char* what, double resolution_m, const Agreement& a) {
  std::printf(
      "%.1f m, %s: IoU vs one engine %.4f (%zu vs %zu voxels, %zu only merged, %zu only "
      "in the engine), against the room: "
      "precision %.4f recall %.4f F1 %.4f (one engine's F1 %.4f); bytes %zu + %zu\n",
      resolution_m, what, a.iou_vs_single, a.merged, a.single, a.only_merged, a.only_single,
      a.precision, a.recall, a.f1, a.single_f1, a.bytes[0], a.bytes[1]);
}

TEST(FleetAgreement, OwnEvidenceIsTheChangeToPriorsAndFreeEvidenceCancelsTheClaim) {
  // uav1 sent voxels 3, 5, 9 (3499 each: a prior is kept below clamp_max); uav2 took them as
  // priors and holds: 2 (its own, 850), 3 untouched, 5 confirmed (3500), 9 lowered to -400 by
  // its rays (below occupancy, so only its window or `value_of` knows it).
  const std::vector<VoxelRecord> priors = {{3, 3499}, {5, 3499}, {9, 3499}};
  const std::vector<VoxelRecord> occupied = {{2, 850}, {3, 3499}, {5, 3500}};
  std::vector<std::uint32_t> asked;
  const std::vector<VoxelRecord> own = ownEvidence(occupied, &priors, [&](std::uint32_t offset) {
    asked.push_back(offset);
    return -400;
  });
  const std::vector<VoxelRecord> expected = {{2, 850}, {5, 1}, {9, -3899}};
  ASSERT_EQ(own.size(), expected.size());
  for (std::size_t i = 0; i < own.size(); ++i) {
    EXPECT_EQ(own[i].offset, expected[i].offset);
    EXPECT_EQ(own[i].log_odds, expected[i].log_odds);
  }
  EXPECT_EQ(asked, std::vector<std::uint32_t>{9});
  EXPECT_EQ(ownEvidence(occupied, nullptr, [](std::uint32_t) { return 0; }).size(), 3u);

  // Fused: uav2's value where it saw through uav1's claim, no provenance for free evidence.
  FleetMap map;
  ASSERT_TRUE(map.acceptGeometry(0.1, {4, 4, 4}));
  const SubmapIndex m(0, 0, 0);
  ASSERT_EQ(map.apply("uav1", m, 1, {{3, 3499}, {5, 3499}, {9, 3499}}), SubmapApply::kApplied);
  ASSERT_EQ(map.apply("uav2", m, 1, std::vector<VoxelRecord>(own)), SubmapApply::kApplied);
  std::map<std::uint32_t, std::pair<LogOddsQ, std::uint64_t>> got;
  map.forEachOccupied([&](const VoxelIndex& g, LogOddsQ l, std::uint64_t bits) {
    got[static_cast<std::uint32_t>(g.x() * 16 + g.y() * 4 + g.z())] = {l, bits};
  });
  const std::map<std::uint32_t, std::pair<LogOddsQ, std::uint64_t>> fused = {
      {2, {850, 2u}}, {3, {3499, 1u}}, {5, {3500, 3u}}};
  EXPECT_EQ(got, fused);  // voxel 9: 3499 - 3899 = -400, not occupied, not in the map
  EXPECT_EQ(map.voxelCount(), 3u);
}

/// The flight's config at `resolution_m`: the test config's 16 x 16 x 6 m window.
MapConfig configAt(double resolution_m) {
  MapConfig config = test_support::fleetMapConfig();
  config.local_map.resolution_m = resolution_m;
  const int per_02 = static_cast<int>(std::lround(0.2 / resolution_m));
  config.local_map.size_cells = Eigen::Vector3i(80, 80, 30) * per_02;
  return config;
}

TEST(FleetAgreement, FreeEvidenceOnOtherVehiclesPriorsBringsTheMergedMapToOneEngines) {
  // 0.1 m (the figure), and 0.2 m with the two ways without free evidence next to it.
  for (const double resolution_m : {0.1, 0.2}) {
    const MapConfig config = configAt(resolution_m);
    // Half a voxel: the room's faces cut their voxels in the middle, not on a border.
    const Eigen::Vector3d shift = Eigen::Vector3d::Constant(resolution_m / 2.0);
    const std::vector<PointCloudFrame> frames = test_support::roomFlight(400, 8.0, shift);
    const Agreement own = flyTwoHalves(config, frames, shift, SecondVehicle::kSendsOwnEvidence);
    print("uav2 takes uav1's submaps as priors, sends its own evidence", resolution_m, own);
    // The target against one engine fed every frame, noise-free.
    EXPECT_GE(own.iou_vs_single, 0.97) << resolution_m;
    // Against the room, as good as one engine (its F1 is the LiDAR's: grazing rays clear
    // surface voxels other rays hit, in one engine as in the fleet).
    EXPECT_GE(own.precision, 0.99) << resolution_m;
    EXPECT_GE(own.f1, own.single_f1 - 0.005) << resolution_m;
    if (resolution_m < 0.15) continue;
    const Agreement whole = flyTwoHalves(config, frames, shift, SecondVehicle::kSendsWholeMap);
    const Agreement alone = flyTwoHalves(config, frames, shift, SecondVehicle::kTakesNoPriors);
    print("uav2 takes them as priors, sends its map as it holds it", resolution_m, whole);
    print("uav2 takes no priors", resolution_m, alone);
    // Without the free evidence the merged map keeps what uav2 saw through: below the target
    // (and sending the priors back counts uav1's evidence twice).
    EXPECT_LT(whole.iou_vs_single, 0.95) << resolution_m;
    EXPECT_LT(alone.iou_vs_single, 0.96) << resolution_m;
    EXPECT_GT(own.iou_vs_single, alone.iou_vs_single + 0.02) << resolution_m;
  }
}

}  // namespace
}  // namespace mlmap::fleet
