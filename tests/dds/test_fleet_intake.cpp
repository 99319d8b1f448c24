// FleetIntake, the fleet's trust checks without DDS (docs/fleet.md#trust): the configured grid
// and vehicle list, sequence numbers bounded ahead, restarts, memory budgets checked from the
// declared sizes before anything is allocated, every refusal counted by reason.
#include "mlmap/dds/fleet/fleet_intake.h"
#include "mlmap/dds/fleet/submap_messages.h"

#include <gtest/gtest.h>

#include <limits>

namespace mlmap::dds {
namespace {

using Submap = ::mlmap_msgs::msg::dds_::Submap_;

constexpr std::uint64_t kNow_us = std::uint64_t{1'800'000'000} * 1'000'000;  // 2027
const SubmapGeometry kGrid{0.2, {16, 16, 6}};
const SubmapWriterId kWriterA{1};
const SubmapWriterId kWriterB{2};

FleetTrustConfig trust() {
  FleetTrustConfig t;
  t.resolution_m = kGrid.resolution_m;
  t.submap_cells = kGrid.cells;
  return t;
}

Submap sample(const std::string& vehicle, std::uint64_t sequence, const SubmapIndex& m,
              std::vector<VoxelRecord> records, const SubmapGeometry& grid = kGrid) {
  return toSubmapMessage({m, std::move(records)}, grid, vehicle, sequence, 1.0, "map");
}

/// `msg` as it arrives on the topic of the vehicle it names.
SubmapIntake takeOwn(FleetIntake& intake, const Submap& msg, const SubmapWriterId& writer,
                     double now_s, std::uint64_t wall_clock_us) {
  return intake.take(msg, msg.vehicle_(), writer, now_s, wall_clock_us);
}

std::uint64_t count(const FleetIntake& intake, SubmapRefusal r) {
  return intake.refused()[static_cast<std::size_t>(r)];
}

/// Every offset of a submap of `voxels` voxels, occupied.
std::vector<VoxelRecord> full(std::uint32_t voxels) {
  std::vector<VoxelRecord> out(voxels);
  for (std::uint32_t i = 0; i < voxels; ++i) out[i] = {i, 2000};
  return out;
}

TEST(FleetIntake, AVehicleSpeaksOnlyForItselfOnItsOwnTopic) {
  FleetIntake intake(trust(), {});
  // uav2 (its topic) names itself uav1: refused before anything else is looked at, nothing
  // registered under either name.
  const SubmapIntake r =
      intake.take(sample("uav1", 1, {0, 0, 0}, {{3, 2000}}), "uav2", kWriterA, 0.0, kNow_us);
  EXPECT_FALSE(r.applied);
  EXPECT_EQ(r.refusal, SubmapRefusal::kNotItsTopic);
  EXPECT_NE(r.why.find("'uav1' on the topic of vehicle 'uav2'"), std::string::npos) << r.why;
  EXPECT_TRUE(intake.map().vehicles().empty());
  EXPECT_EQ(count(intake, SubmapRefusal::kNotItsTopic), 1u);
  // A prefix of the topic's name is another name.
  EXPECT_EQ(
      intake.take(sample("uav", 1, {0, 0, 0}, {{3, 2000}}), "uav2", kWriterA, 0.0, kNow_us).refusal,
      SubmapRefusal::kNotItsTopic);
  // On its own topic it is taken.
  EXPECT_TRUE(intake.take(sample("uav2", 1, {0, 0, 0}, {{3, 2000}}), "uav2", kWriterA, 0.0, kNow_us)
                  .applied);
  EXPECT_EQ(intake.refusedTotal(), 2u);
}

TEST(FleetIntake, TheGridIsTheConfiguredOneWhateverTheFirstSampleSays) {
  FleetIntake intake(trust(), {});
  const SubmapIntake r =
      takeOwn(intake, sample("x", 1, {0, 0, 0}, {}, {0.123, {16, 16, 6}}), kWriterA, 0.0, kNow_us);
  EXPECT_FALSE(r.applied);
  EXPECT_EQ(r.refusal, SubmapRefusal::kWrongGrid);
  EXPECT_NE(r.why.find("0.123"), std::string::npos) << r.why;
  EXPECT_TRUE(
      takeOwn(intake, sample("uav1", 1, {0, 0, 0}, {{3, 2000}}), kWriterB, 0.0, kNow_us).applied);
  EXPECT_EQ(intake.map().resolution_m(), 0.2);
  EXPECT_EQ(intake.map().voxelCount(), 1u);
  // Another submap size is another grid too.
  EXPECT_EQ(
      takeOwn(intake, sample("uav1", 2, {0, 0, 0}, {}, {0.2, {16, 16, 5}}), kWriterB, 0.0, kNow_us)
          .refusal,
      SubmapRefusal::kWrongGrid);
  EXPECT_EQ(count(intake, SubmapRefusal::kWrongGrid), 2u);
}

TEST(FleetIntake, AClosedFleetTakesItsListedVehiclesOnlyInTheListsOrder) {
  FleetTrustConfig t = trust();
  t.vehicles = {"uav2", "uav1"};
  FleetIntake intake(t, {});
  ASSERT_EQ(intake.map().vehicles().size(), 2u);  // their places held from the start
  EXPECT_EQ(intake.map().vehicles()[0].name, "uav2");
  const SubmapIntake r =
      takeOwn(intake, sample("ghost", 1, {0, 0, 0}, {{3, 2000}}), kWriterA, 0, kNow_us);
  EXPECT_EQ(r.refusal, SubmapRefusal::kUnknownVehicle);
  EXPECT_TRUE(
      takeOwn(intake, sample("uav1", 1, {0, 0, 0}, {{3, 2000}}), kWriterB, 0, kNow_us).applied);
  EXPECT_EQ(intake.map().vehicles().size(), 2u);
  EXPECT_EQ(count(intake, SubmapRefusal::kUnknownVehicle), 1u);
  // A list that cannot be: refused at start.
  t.vehicles = {"uav1", "uav1"};
  EXPECT_THROW(FleetIntake(t, {}), std::invalid_argument);
  t.vehicles.assign(fleet::FleetMap::kMaxVehicles + 1, "");
  for (std::size_t i = 0; i < t.vehicles.size(); ++i) t.vehicles[i] = "v" + std::to_string(i);
  EXPECT_THROW(FleetIntake(t, {}), std::invalid_argument);
}

TEST(FleetIntake, OnAnOpenDomainEmptyNewcomersTakeNoPlaceAndAFullFleetRefusesNewNames) {
  FleetIntake intake(trust(), {});
  for (int i = 0; i < 100; ++i) {
    EXPECT_EQ(
        takeOwn(intake, sample("ghost" + std::to_string(i), 1, {0, 0, 0}, {}), kWriterA, 0, kNow_us)
            .refusal,
        SubmapRefusal::kEmptyNewVehicle);
  }
  EXPECT_TRUE(intake.map().vehicles().empty());
  for (std::size_t i = 0; i < fleet::FleetMap::kMaxVehicles; ++i) {
    const SubmapIntake r = takeOwn(
        intake, sample("v" + std::to_string(i), 1, {0, 0, 0}, {{3, 2000}}), kWriterA, 0, kNow_us);
    ASSERT_TRUE(r.applied);
    EXPECT_TRUE(r.joined);
  }
  EXPECT_EQ(
      takeOwn(intake, sample("late", 1, {0, 0, 0}, {{3, 2000}}), kWriterB, 0, kNow_us).refusal,
      SubmapRefusal::kFleetFull);
  EXPECT_EQ(count(intake, SubmapRefusal::kEmptyNewVehicle), 100u);
  EXPECT_EQ(count(intake, SubmapRefusal::kFleetFull), 1u);
  EXPECT_EQ(intake.refusedTotal(), 101u);
}

TEST(FleetIntake, SequenceNumbersFarAheadAreRefusedAndARestartedVehicleIsTakenAgain) {
  FleetIntake intake(trust(), {});
  const SubmapIndex m(0, 0, 0);
  // At most an hour of microseconds ahead of the clock ...
  const std::uint64_t start = kNow_us + FleetIntake::kMaxClockLead_us;
  EXPECT_EQ(
      takeOwn(intake, sample("uav1", start + 1, m, {{3, 2000}}), kWriterA, 0, kNow_us).refusal,
      SubmapRefusal::kSequenceAhead);
  EXPECT_EQ(
      takeOwn(intake, sample("uav1", std::numeric_limits<std::uint64_t>::max(), m, {{3, 2000}}),
              kWriterA, 0, kNow_us)
          .refusal,
      SubmapRefusal::kSequenceAhead);
  ASSERT_TRUE(takeOwn(intake, sample("uav1", start, m, {{3, 2000}}), kWriterA, 0, kNow_us).applied);
  // ... or at most 2^24 ahead of the same writer's last.
  EXPECT_EQ(takeOwn(intake, sample("uav1", start + FleetIntake::kMaxSequenceLead + 1, m, {}),
                    kWriterA, 0, kNow_us)
                .refusal,
            SubmapRefusal::kSequenceAhead);
  // Another writer gets the clock bound only.
  EXPECT_EQ(takeOwn(intake, sample("uav1", start + 2, m, {}), kWriterB, 0, kNow_us).refusal,
            SubmapRefusal::kSequenceAhead);
  EXPECT_EQ(intake.map().voxelCount(), 1u);
  // Not newer than what is held from the same writer: outdated, counted.
  EXPECT_EQ(takeOwn(intake, sample("uav1", start, m, {}), kWriterA, 0, kNow_us).refusal,
            SubmapRefusal::kOutdated);
  ASSERT_TRUE(
      takeOwn(intake,
              sample("uav1", start + FleetIntake::kMaxSequenceLead, m, {{3, 2000}, {5, 2000}}),
              kWriterA, 0, kNow_us)
          .applied);
  // A restart whose clock went back: lower sequence numbers from a new writer replace the
  // old writer's content.
  const SubmapIntake r = takeOwn(intake, sample("uav1", 5, m, {{9, 2000}}), kWriterB, 0, kNow_us);
  EXPECT_TRUE(r.applied);
  EXPECT_TRUE(r.restarted);
  EXPECT_EQ(intake.map().voxelCount(), 1u);
  EXPECT_EQ(intake.map().vehicles()[0].restarts, 1u);
  EXPECT_EQ(count(intake, SubmapRefusal::kSequenceAhead), 4u);
  EXPECT_EQ(count(intake, SubmapRefusal::kOutdated), 1u);
}

TEST(FleetIntake, BudgetsAreCheckedFromTheDeclaredSizeBeforeDecodingAndShrinkingAlwaysPasses) {
  FleetTrustConfig t = trust();
  const std::uint32_t submap = 16 * 16 * 6;                                 // 1536 voxels
  t.vehicle_budget_bytes = fleet::FleetMap::contributionBytes(submap) * 2;  // two full submaps
  t.fleet_budget_bytes = 5 * submap * (sizeof(VoxelRecord) + sizeof(fleet::FleetVoxel)) / 2 + 4096;
  FleetIntake intake(t, {});
  ASSERT_TRUE(
      takeOwn(intake, sample("uav1", 1, {0, 0, 0}, full(submap)), kWriterA, 0, kNow_us).applied);
  ASSERT_TRUE(
      takeOwn(intake, sample("uav1", 2, {1, 0, 0}, full(submap)), kWriterA, 0, kNow_us).applied);
  // A third full submap is over uav1's budget; so is a lie about the voxel count with a payload
  // that would not even decode: the budget refuses it first, nothing decoded.
  EXPECT_EQ(
      takeOwn(intake, sample("uav1", 3, {2, 0, 0}, full(submap)), kWriterA, 0, kNow_us).refusal,
      SubmapRefusal::kVehicleBudget);
  Submap lie = sample("uav1", 4, {3, 0, 0}, {{1, 2000}});
  lie.voxel_count_(submap);
  EXPECT_EQ(takeOwn(intake, lie, kWriterA, 0, kNow_us).refusal, SubmapRefusal::kVehicleBudget);
  // Replacing a submap by one of the same size, or emptying one, passes.
  EXPECT_TRUE(
      takeOwn(intake, sample("uav1", 5, {1, 0, 0}, full(submap)), kWriterA, 0, kNow_us).applied);
  EXPECT_TRUE(takeOwn(intake, sample("uav1", 6, {1, 0, 0}, {}), kWriterA, 0, kNow_us).applied);
  EXPECT_LE(intake.map().vehicles()[0].memory_bytes, t.vehicle_budget_bytes);
  // The fleet's budget holds across vehicles: uav2 fits one full submap, not two.
  ASSERT_TRUE(
      takeOwn(intake, sample("uav2", 1, {5, 0, 0}, full(submap)), kWriterB, 0, kNow_us).applied);
  EXPECT_EQ(
      takeOwn(intake, sample("uav2", 2, {6, 0, 0}, full(submap)), kWriterB, 0, kNow_us).refusal,
      SubmapRefusal::kFleetBudget);
  EXPECT_LE(intake.map().memoryBytes(), t.fleet_budget_bytes);
  EXPECT_EQ(count(intake, SubmapRefusal::kVehicleBudget), 2u);
  EXPECT_EQ(count(intake, SubmapRefusal::kFleetBudget), 1u);
  EXPECT_EQ(count(intake, SubmapRefusal::kMalformed), 0u);
}

TEST(FleetIntake, SixFullSubmapsUnderSixNamesStopAtTheFleetsBudget) {
  // Issue 43's attack, scaled down: six fully occupied submaps under six names took the merger
  // to 2.4 GB (256^3 submaps). Here 64^3 submaps (2 MiB of contribution and up to 4 MiB of
  // fused voxels each) against a fleet budget of 16 MiB: two are taken, the other four refused
  // from their declared size, and the map stays within the budget.
  FleetTrustConfig t;
  t.resolution_m = 0.2;
  t.submap_cells = {64, 64, 64};
  t.fleet_budget_bytes = std::size_t{16} << 20;
  FleetIntake intake(t, {});
  const SubmapGeometry grid{0.2, {64, 64, 64}};
  const std::vector<VoxelRecord> everything = full(64 * 64 * 64);
  int taken = 0;
  for (int i = 0; i < 6; ++i) {
    const SubmapIntake r =
        takeOwn(intake, sample("v" + std::to_string(i), 1, {i, 0, 0}, everything, grid), kWriterA,
                0, kNow_us);
    if (r.applied) {
      ++taken;
    } else {
      EXPECT_EQ(r.refusal, SubmapRefusal::kFleetBudget) << r.why;
    }
    EXPECT_LE(intake.map().memoryBytes(), t.fleet_budget_bytes);
  }
  EXPECT_EQ(taken, 2);
  EXPECT_EQ(count(intake, SubmapRefusal::kFleetBudget), 4u);
  EXPECT_EQ(intake.map().vehicles().size(), 2u);  // the refused ones took no place
}

TEST(FleetIntake, EveryMalformedSampleIsCountedAsSuch) {
  FleetIntake intake(trust(), {});
  Submap bad = sample("uav1", 1, {0, 0, 0}, {{3, 2000}});
  bad.version_(kSubmapLayoutVersion + 1);
  EXPECT_EQ(takeOwn(intake, bad, kWriterA, 0, kNow_us).refusal, SubmapRefusal::kMalformed);
  bad = sample("uav1", 1, {0, 0, 0}, {{3, 2000}});
  bad.data_().assign(5, 0xff);
  EXPECT_EQ(takeOwn(intake, bad, kWriterA, 0, kNow_us).refusal, SubmapRefusal::kMalformed);
  intake.countUndecodable();
  EXPECT_EQ(count(intake, SubmapRefusal::kMalformed), 3u);
  EXPECT_TRUE(intake.map().vehicles().empty());
}

}  // namespace
}  // namespace mlmap::dds
