// The fleet's trust model on DDS (docs/fleet.md#trust), on loopback only, domains 148, 149,
// 212 and 213: the attacks of issue 43 (a stranger's grid first, 64 empty names, a sample under a
// vehicle's name with sequence 2^64-1) against a running FleetMerger, and a closed fleet that
// reads its listed vehicles' topics only. Each of them, on the
// merger that believed every participant, left the honest vehicle's map empty or cut.
#include "../fleet/fleet_test_support.h"
#include "dds_test_support.h"

#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/fleet/fleet_merger.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/fleet/submap_messages.h"

#include "mlmap_msgs/msg/Submap_PubSubTypes.h"

#include <gtest/gtest.h>

#include <chrono>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
using test_support::localhostConfig;
using test_support::waitFor;

/// The fleet's grid in these tests: the vehicles' (fleet_test_support.h).
SubmapGeometry fleetGrid() {
  const LocalMapConfig local = fleet::test_support::fleetMapConfig().local_map;
  return SubmapGeometry{local.resolution_m, local.submap_cells()};
}

FleetMergerConfig mergerConfig(int domain_id) {
  FleetMergerConfig c;
  c.dds = localhostConfig(domain_id);
  c.publish_hz = 5.0;
  c.trust.resolution_m = fleetGrid().resolution_m;
  c.trust.submap_cells = fleetGrid().cells;
  return c;
}

bool received(const FleetMerger& merger, std::uint64_t samples) {
  return waitFor([&] { return merger.stats().samples_received >= samples; },
                 std::chrono::milliseconds(20000));
}

std::uint64_t refused(const FleetMerger& merger, SubmapRefusal reason) {
  return merger.stats().refused[static_cast<std::size_t>(reason)];
}

/// A raw writer of Submap samples on vehicle `vehicle`'s topic, as a stranger's program would
/// make one (on an open domain, without DDS Security, anyone may).
fdds::DataWriter* strangerWriter(fdds::Publisher* publisher, const std::string& vehicle) {
  return createWriter<::mlmap_msgs::msg::dds_::Submap_PubSubType>(
      publisher, vehicleSubmapTopic(vehicle, "mlmap/submaps"), submapWriterQos());
}

/// A started merger of `config` and, on its domain, a participant's publisher for the tests'
/// writers (deleted before the merger).
struct MergerAndPublisher {
  explicit MergerAndPublisher(const FleetMergerConfig& config)
      : merger(config),
        participant(createParticipant(config.dds, "writers")),
        publisher(participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT)) {
    merger.start();
  }
  FleetMerger merger;
  ParticipantPtr participant;
  fdds::Publisher* publisher;
};

const fleet::SubmapUpdate kTwoVoxels{SubmapIndex(1, 2, 0), {{3, 2000}, {40, 3500}}};

TEST(FleetTrust, AStrangersGridSentFirstDoesNotBecomeTheFleetsAndNothingMergedSavesNothing) {
  constexpr int kDomain = 148;
  MergerAndPublisher rig(mergerConfig(kDomain));
  FleetMerger& merger = rig.merger;
  fdds::Publisher* publisher = rig.publisher;
  fdds::DataWriter* stranger = strangerWriter(publisher, "stranger");
  ASSERT_TRUE(waitFor([&] { return test_support::writerMatched(stranger); }));
  // One empty sample of a made-up grid, before any vehicle.
  auto lie = toSubmapMessage({SubmapIndex(0, 0, 0), {}}, SubmapGeometry{0.123, {16, 16, 6}},
                             "stranger", 1, 1.0, "map");
  ASSERT_TRUE(stranger->write(&lie));
  ASSERT_TRUE(received(merger, 1));
  EXPECT_EQ(refused(merger, SubmapRefusal::kWrongGrid), 1u);
  // Nothing merged: no map to save (mlmap_fleet --save-map exits with 1).
  EXPECT_THROW(static_cast<void>(merger.mapState()), std::runtime_error);

  SubmapWriter uav1(publisher, "mlmap/submaps", "uav1", fleetGrid(), "map");
  ASSERT_TRUE(waitFor([&] { return test_support::writerMatched(uav1.get()); }));
  uav1.write({kTwoVoxels}, 2.0);
  ASSERT_TRUE(received(merger, 2));
  EXPECT_TRUE(waitFor([&] { return merger.stats().merged_voxels == 2u; })) << merger.statusLine();
  EXPECT_EQ(merger.stats().samples_rejected, 1u);
  EXPECT_NE(merger.statusLine().find("grid 1"), std::string::npos) << merger.statusLine();
  EXPECT_EQ(merger.mapState().globalVoxelCount(), 2u);
}

TEST(FleetTrust, SixtyFourEmptySamplesUnderMadeUpNamesTakeNoPlaceOfARealVehicle) {
  constexpr int kDomain = 149;
  MergerAndPublisher rig(mergerConfig(kDomain));
  FleetMerger& merger = rig.merger;
  fdds::Publisher* publisher = rig.publisher;
  // Each made-up name on a topic of its own (the merger reads each one discovery finds).
  constexpr int kNames = 64;
  std::vector<fdds::DataWriter*> ghosts;
  for (int i = 0; i < kNames; ++i) {
    ghosts.push_back(strangerWriter(publisher, "ghost" + std::to_string(i)));
  }
  ASSERT_TRUE(waitFor([&] {
    for (fdds::DataWriter* w : ghosts) {
      if (!test_support::writerMatched(w)) return false;
    }
    return true;
  }));
  for (int i = 0; i < kNames; ++i) {
    auto empty = toSubmapMessage({SubmapIndex(0, 0, i % 8), {}}, fleetGrid(),
                                 "ghost" + std::to_string(i), 1, 1.0, "map");
    ASSERT_TRUE(ghosts[static_cast<std::size_t>(i)]->write(&empty));
  }
  ASSERT_TRUE(received(merger, kNames));
  SubmapWriter uav1(publisher, "mlmap/submaps", "uav1", fleetGrid(), "map");
  ASSERT_TRUE(waitFor([&] { return test_support::writerMatched(uav1.get()); }));
  uav1.write({kTwoVoxels}, 2.0);
  ASSERT_TRUE(received(merger, kNames + 1));
  EXPECT_TRUE(waitFor([&] { return merger.stats().merged_voxels == 2u; })) << merger.statusLine();
  const FleetMergerStats s = merger.stats();
  ASSERT_EQ(s.vehicles.size(), 1u);
  EXPECT_EQ(s.vehicles[0].info.name, "uav1");
  EXPECT_EQ(s.samples_rejected, static_cast<std::uint64_t>(kNames));
  EXPECT_EQ(refused(merger, SubmapRefusal::kEmptyNewVehicle), static_cast<std::uint64_t>(kNames));
}

TEST(FleetTrust, ASampleUnderAVehiclesNameWithTheLastSequenceNumberNeitherErasesNorLocksItOut) {
  constexpr int kDomain = 212;
  MergerAndPublisher rig(mergerConfig(kDomain));
  FleetMerger& merger = rig.merger;
  fdds::Publisher* publisher = rig.publisher;
  auto uav1 =
      std::make_unique<SubmapWriter>(publisher, "mlmap/submaps", "uav1", fleetGrid(), "map");
  fdds::DataWriter* stranger = strangerWriter(publisher, "uav1");
  ASSERT_TRUE(waitFor([&] {
    return test_support::writerMatched(uav1->get()) && test_support::writerMatched(stranger);
  }));
  fleet::SubmapUpdate other{SubmapIndex(0, 0, 0), {{7, 2500}}};
  uav1->write({kTwoVoxels, other}, 1.0);
  ASSERT_TRUE(received(merger, 2));
  ASSERT_TRUE(waitFor([&] { return merger.stats().merged_voxels == 3u; }));

  // An empty sample of each submap under uav1's name, sequence 2^64-1: refused, counted.
  for (const SubmapIndex& m : {kTwoVoxels.index, other.index}) {
    auto erase = toSubmapMessage({m, {}}, fleetGrid(), "uav1",
                                 std::numeric_limits<std::uint64_t>::max(), 2.0, "map");
    ASSERT_TRUE(stranger->write(&erase));
  }
  ASSERT_TRUE(received(merger, 4));
  EXPECT_EQ(merger.stats().merged_voxels, 3u);
  EXPECT_EQ(refused(merger, SubmapRefusal::kSequenceAhead), 2u);

  // uav1 restarts (a new writer, its sequence numbers from its clock again) and flies on: its
  // samples are taken, none "outdated".
  uav1 = std::make_unique<SubmapWriter>(publisher, "mlmap/submaps", "uav1", fleetGrid(), "map");
  ASSERT_TRUE(waitFor([&] { return test_support::writerMatched(uav1->get()); }));
  other.records.push_back({9, 2600});
  uav1->write({other}, 3.0);
  ASSERT_TRUE(received(merger, 5));
  EXPECT_TRUE(waitFor([&] { return merger.stats().merged_voxels == 4u; })) << merger.statusLine();
  FleetMergerStats s = merger.stats();
  EXPECT_EQ(refused(merger, SubmapRefusal::kOutdated), 0u);
  ASSERT_EQ(s.vehicles.size(), 1u);
  EXPECT_EQ(s.vehicles[0].info.restarts, 1u);
  EXPECT_NE(merger.statusLine().find("1 restarts"), std::string::npos) << merger.statusLine();
}

TEST(FleetTrust, AClosedFleetMergesItsListedVehiclesOnlyAndSaysWhoIsNotHeardYet) {
  constexpr int kDomain = 213;
  FleetMergerConfig mc = mergerConfig(kDomain);
  mc.trust.vehicles = {"uav1", "uav2"};
  MergerAndPublisher rig(mc);
  FleetMerger& merger = rig.merger;
  fdds::Publisher* publisher = rig.publisher;
  EXPECT_NE(merger.statusLine().find("uav2 (not heard yet)"), std::string::npos)
      << merger.statusLine();
  SubmapWriter uav1(publisher, "mlmap/submaps", "uav1", fleetGrid(), "map");
  // A vehicle not listed: the merger has no reader on its topic, its samples never arrive.
  SubmapWriter ghost(publisher, "mlmap/submaps", "ghost", fleetGrid(), "map");
  // A stranger on uav1's topic (possible on a domain without DDS Security), under its own name.
  fdds::DataWriter* stranger = strangerWriter(publisher, "uav1");
  ASSERT_TRUE(waitFor([&] {
    return test_support::writerMatched(uav1.get()) && test_support::writerMatched(stranger);
  }));
  ghost.write({{SubmapIndex(0, 0, 0), {{7, 2500}}}}, 1.0);
  auto named_ghost =
      toSubmapMessage({SubmapIndex(0, 0, 1), {{7, 2500}}}, fleetGrid(), "ghost", 1, 1.0, "map");
  ASSERT_TRUE(stranger->write(&named_ghost));
  uav1.write({kTwoVoxels}, 1.0);
  ASSERT_TRUE(received(merger, 2));
  EXPECT_TRUE(waitFor([&] { return merger.stats().merged_voxels == 2u; })) << merger.statusLine();
  const FleetMergerStats s = merger.stats();
  ASSERT_EQ(s.vehicles.size(), 2u);
  EXPECT_EQ(s.vehicles[0].info.name, "uav1");
  EXPECT_EQ(s.vehicles[0].info.voxels, 2u);
  EXPECT_EQ(s.samples_received, 2u);
  EXPECT_FALSE(test_support::writerMatched(ghost.get()));
  EXPECT_EQ(refused(merger, SubmapRefusal::kNotItsTopic), 1u);
  EXPECT_NE(merger.statusLine().find("not its topic 1"), std::string::npos) << merger.statusLine();
}

}  // namespace
}  // namespace mlmap::dds
