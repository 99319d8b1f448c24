/// @file
/// Fuzz target: the fleet merger's accept path (mlmap_fleet), FleetIntake::take() over a stream
/// of mlmap_msgs/Submap samples from up to four writers: the trust checks (topic, grid, vehicles,
/// sequence numbers, memory budgets), decoding and fusion. Checks what docs/fleet.md#trust
/// promises: the map never holds more than the fleet's budget nor a vehicle more than its own,
/// a closed fleet never holds another vehicle, an open one never more than kMaxVehicles and
/// never one that sent nothing but empty samples, and every sample is applied or counted once.
///
/// Input: one mode byte (bit 0: a closed fleet of uav1 and uav2, else an open domain), then
/// records of [writer byte (0..3, modulo; bit 7: on uav1's topic, else on the topic of the
/// name it carries)][uint16 little-endian n][n bytes of Submap CDR as it arrives,
/// cdr_payload.h].

#include "cdr_payload.h"
#include "fuzz_support.h"

#include "mlmap/dds/fleet/fleet_intake.h"

#include "mlmap_msgs/msg/Submap_PubSubTypes.h"

#include <map>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using mlmap::fuzz::requireThat;
  namespace dds = mlmap::dds;
  if (size < 1) return 0;
  dds::FleetTrustConfig trust;
  trust.resolution_m = 0.1;  // make_seeds.cpp's grid
  trust.submap_cells = {16, 16, 6};
  const bool closed = (data[0] & 1u) != 0;
  if (closed) trust.vehicles = {"uav1", "uav2"};
  trust.vehicle_budget_bytes = 24 * 1024;  // ~3,000 voxels
  trust.fleet_budget_bytes = 64 * 1024;
  dds::FleetIntake intake(trust, {});
  constexpr std::uint64_t kClock_us = std::uint64_t{1'800'000'000} * 1'000'000;
  std::uint64_t taken = 0, applied = 0;
  std::map<std::string, std::uint64_t> applied_by_name;
  std::size_t pos = 1;
  while (pos + 3 <= size) {
    dds::SubmapWriterId writer{};
    writer[0] = static_cast<std::uint8_t>(data[pos] % 4);
    const bool on_uav1s_topic = (data[pos] & 0x80) != 0;  // else on the topic of its own name
    const std::size_t n = data[pos + 1] | (static_cast<std::size_t>(data[pos + 2]) << 8);
    pos += 3;
    if (n > size - pos) break;
    ::mlmap_msgs::msg::dds_::Submap_ msg;
    const bool decoded =
        mlmap::fuzz::deserializeAsNodeDoes<::mlmap_msgs::msg::dds_::Submap_PubSubType>(data + pos,
                                                                                       n, &msg);
    pos += n;
    ++taken;
    if (!decoded) {
      intake.countUndecodable();
      continue;
    }
    const std::string topic_vehicle = on_uav1s_topic ? std::string("uav1") : msg.vehicle_();
    const dds::SubmapIntake r =
        intake.take(msg, topic_vehicle, writer, static_cast<double>(taken), kClock_us);
    if (r.applied) {
      requireThat(msg.vehicle_() == topic_vehicle, "FleetIntake: a sample named for another topic");
      ++applied;
      ++applied_by_name[msg.vehicle_()];
    } else {
      requireThat(!r.why.empty(), "FleetIntake: a refusal without a reason");
    }
    const mlmap::fleet::FleetMap& map = intake.map();
    requireThat(map.memoryBytes() <= trust.fleet_budget_bytes,
                "FleetIntake: over the fleet's budget");
    requireThat(map.vehicles().size() <= mlmap::fleet::FleetMap::kMaxVehicles,
                "FleetIntake: more vehicles than places");
    std::size_t vehicle_bytes = 0;
    for (const mlmap::fleet::FleetVehicle& v : map.vehicles()) {
      requireThat(v.memory_bytes <= trust.vehicle_budget_bytes,
                  "FleetIntake: over a vehicle's budget");
      requireThat(!closed || v.name == "uav1" || v.name == "uav2",
                  "FleetIntake: a closed fleet holds a vehicle not listed");
      requireThat(closed || applied_by_name.count(v.name) > 0,
                  "FleetIntake: a vehicle holds a place without an applied sample");
      vehicle_bytes += v.memory_bytes;
    }
    requireThat(vehicle_bytes <= map.memoryBytes(), "FleetIntake: vehicles hold more than the map");
    std::size_t occupied = 0;
    map.forEachOccupied([&](const mlmap::VoxelIndex&, mlmap::LogOddsQ q, std::uint64_t) {
      requireThat(map.model().isOccupied(q), "FleetIntake: a fused voxel that is not occupied");
      ++occupied;
    });
    requireThat(occupied == map.voxelCount(), "FleetIntake: voxel count");
    requireThat(applied + intake.refusedTotal() == taken, "FleetIntake: a sample not counted once");
  }
  return 0;
}
