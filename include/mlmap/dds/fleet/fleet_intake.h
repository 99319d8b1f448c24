#pragma once
/// @file
/// The fleet's trust model (docs/fleet.md#trust): what mlmap_fleet accepts from a Submap sample
/// and what it refuses, before anything is allocated for it. No DDS entities: FleetMerger hands
/// every sample with the vehicle whose topic it came on and the GUID of the writer that
/// published it; the fuzz target and the unit tests call it directly.
///
/// In order, a sample is refused (and counted by reason) when:
/// 1. its header is malformed (submapHeaderProblem());
/// 2. its vehicle name is not the one of its topic (vehicleSubmapTopic()): under DDS Security a
///    vehicle's permissions let it publish its own topic only, so the name is its identity;
/// 3. its grid (voxel edge, voxels per submap) is not the configured one: the fleet's grid is
///    configuration, never taken from a sample;
/// 4. its vehicle is not in the configured list (a closed fleet), or, on an open domain (no
///    list), it is new and the sample is empty (a name that holds nothing never takes one of the
///    kMaxVehicles places) or every place is taken by a vehicle that sent voxels;
/// 5. its sequence number is more than kMaxClockLead_us ahead of the wall clock (SubmapWriter
///    starts at its clock's microseconds and adds one per sample) and more than
///    kMaxSequenceLead ahead of the highest one accepted from the same writer;
/// 6. it would take its vehicle over vehicle_budget_bytes or the map over fleet_budget_bytes
///    (from the declared voxel count; a sample that shrinks what is held always passes);
/// 7. its payload does not decode (decodeSubmapMessage());
/// 8. it is outdated: not newer than the content held from the same writer.
/// A vehicle's samples from another writer than its last one mark a restart (a new epoch of
/// fleet::FleetMap::apply()): each replaces what the old writer sent for its submap, whatever
/// the sequence numbers, so no sample can lock a vehicle out of its own submaps. Submaps the new
/// writer does not send again keep the old writer's content (and count against the budget).

#include "mlmap/core/config.h"
#include "mlmap/core/log_odds.h"
#include "mlmap/fleet/fleet_map.h"

#include "mlmap_msgs/msg/Submap_.h"

#include <array>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace mlmap::dds {

/// Why a Submap sample was refused or dropped.
enum class SubmapRefusal : std::uint8_t {
  kMalformed = 0,    ///< failed to deserialise, a bad header or payload (decodeSubmapMessage())
  kWrongGrid,        ///< another voxel edge or submap size than the configured grid
  kUnknownVehicle,   ///< a name not in the configured list
  kEmptyNewVehicle,  ///< open domain: an empty sample from a name that holds nothing
  kFleetFull,        ///< open domain: a new name while kMaxVehicles vehicles hold places
  kSequenceAhead,    ///< a sequence number too far ahead (FleetIntake::kMaxSequenceLead)
  kVehicleBudget,    ///< it would take its vehicle over vehicle_budget_bytes
  kFleetBudget,      ///< it would take the merged map over fleet_budget_bytes
  kOutdated,         ///< not newer than the content held from the same writer: ignored
  kNotItsTopic,      ///< a vehicle name other than the one of the topic it came on
};
/// Number of SubmapRefusal values.
inline constexpr std::size_t kSubmapRefusals = 10;
/// Short name of a reason as the status line prints it ("malformed", "grid", ...).
const char* toString(SubmapRefusal reason);
/// Refused and dropped samples by reason (index: the SubmapRefusal value).
using SubmapRefusalCounts = std::array<std::uint64_t, kSubmapRefusals>;

/// The writer that published a sample: its DDS GUID (SampleInfo::publication_handle).
using SubmapWriterId = std::array<std::uint8_t, 16>;

/// What the fleet trusts.
struct FleetTrustConfig {
  /// The fleet's grid: voxel edge [m] and voxels per submap and axis (the vehicles'
  /// local_map.resolution_m and local_map.submap_cells()); samples of another are refused.
  double resolution_m = LocalMapConfig{}.resolution_m;
  Eigen::Vector3i submap_cells = LocalMapConfig{}.submap_cells();
  /// The fleet's vehicles, by the name in their samples (dds.fleet.vehicle), in the order of
  /// their provenance bits and colours. Empty: an open domain, any name may join.
  std::vector<std::string> vehicles;
  /// Bytes one vehicle's contributions may hold (fleet::FleetVehicle::memory_bytes): 256 MiB,
  /// ~33 M voxels.
  std::size_t vehicle_budget_bytes = std::size_t{256} << 20;
  /// Bytes the whole merged map may hold (FleetMap::memoryBytes()): 1 GiB.
  std::size_t fleet_budget_bytes = std::size_t{1} << 30;

  /// What is wrong with it (empty: nothing): a grid not > 0, budgets of 0, more than
  /// fleet::FleetMap::kMaxVehicles names, an empty, overlong or repeated name.
  [[nodiscard]] std::vector<std::string> validate() const;
};

/// What FleetIntake::take() did with a sample.
struct SubmapIntake {
  bool applied = false;                               ///< it changed the vehicle's contribution
  SubmapRefusal refusal = SubmapRefusal::kMalformed;  ///< why not, when !applied
  std::string why;                                    ///< the refusal in words ("" when applied)
  bool joined = false;     ///< its vehicle was registered by it (open domain)
  bool restarted = false;  ///< it came from another writer than its vehicle's last one
};

/// The merged map behind the trust checks. Not thread-safe.
class FleetIntake {
 public:
  /// How far past the highest sequence number accepted from a writer its next may be when it is
  /// beyond the clock bound [samples]: samples overwritten in its history (KEEP_LAST 1) are
  /// never delivered, so gaps are normal, but not of 16.7 M samples.
  static constexpr std::uint64_t kMaxSequenceLead = std::uint64_t{1} << 24;
  /// How far ahead of the merger's wall clock a sequence number may be [us] (SubmapWriter's are
  /// its clock's microseconds at start plus one per sample): one hour of clock difference.
  static constexpr std::uint64_t kMaxClockLead_us = std::uint64_t{3600} * 1000000;

  /// Throws std::invalid_argument when `trust` is not valid (FleetTrustConfig::validate()).
  FleetIntake(const FleetTrustConfig& trust, const LogOddsConfig& log_odds);

  /// Checks `msg` (published by `writer` on the topic of vehicle `topic_vehicle`) in the order
  /// of this file's comment, and applies it to the map when it passes. `now_s`: the caller's
  /// clock for FleetVehicle::last_seen_s; `wall_clock_us`: microseconds since the epoch (the
  /// first-sequence bound).
  SubmapIntake take(const ::mlmap_msgs::msg::dds_::Submap_& msg, const std::string& topic_vehicle,
                    const SubmapWriterId& writer, double now_s, std::uint64_t wall_clock_us);
  /// Counts a sample that failed to deserialise (kMalformed).
  void countUndecodable() { ++refused_[static_cast<std::size_t>(SubmapRefusal::kMalformed)]; }

  [[nodiscard]] const fleet::FleetMap& map() const { return map_; }
  [[nodiscard]] const FleetTrustConfig& trust() const { return trust_; }
  /// Refused and dropped samples by reason.
  [[nodiscard]] const SubmapRefusalCounts& refused() const { return refused_; }
  /// Their sum.
  [[nodiscard]] std::uint64_t refusedTotal() const;

 private:
  /// The writer a vehicle's samples come from, and its highest accepted sequence number.
  struct Source {
    bool known = false;
    SubmapWriterId writer{};
    std::uint64_t highest_sequence = 0;
    std::uint32_t epoch = 0;
  };
  SubmapIntake refuse(SubmapRefusal reason, std::string why);

  FleetTrustConfig trust_;
  fleet::FleetMap map_;
  std::vector<Source> sources_;  // by vehicle index
  SubmapRefusalCounts refused_{};
};

}  // namespace mlmap::dds
