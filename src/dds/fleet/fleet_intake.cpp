#include "mlmap/dds/fleet/fleet_intake.h"

#include "mlmap/dds/fleet/submap_messages.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <unordered_set>

namespace mlmap::dds {

const char* toString(SubmapRefusal reason) {
  switch (reason) {
    case SubmapRefusal::kMalformed:
      return "malformed";
    case SubmapRefusal::kWrongGrid:
      return "grid";
    case SubmapRefusal::kUnknownVehicle:
      return "unknown vehicle";
    case SubmapRefusal::kEmptyNewVehicle:
      return "empty from a newcomer";
    case SubmapRefusal::kFleetFull:
      return "fleet full";
    case SubmapRefusal::kSequenceAhead:
      return "sequence ahead";
    case SubmapRefusal::kVehicleBudget:
      return "vehicle budget";
    case SubmapRefusal::kFleetBudget:
      return "fleet budget";
    case SubmapRefusal::kOutdated:
      return "outdated";
    case SubmapRefusal::kNotItsTopic:
      return "not its topic";
  }
  return "?";
}

std::vector<std::string> FleetTrustConfig::validate() const {
  std::vector<std::string> problems;
  if (!std::isfinite(resolution_m) || !(resolution_m > 0.0) || (submap_cells.array() < 1).any() ||
      static_cast<std::uint64_t>(submap_cells.x()) * static_cast<std::uint64_t>(submap_cells.y()) *
              static_cast<std::uint64_t>(submap_cells.z()) >
          kMaxSubmapVoxels) {
    problems.push_back("the fleet's grid needs a voxel edge > 0 and 1 .. 2^24 voxels per submap");
  }
  if (vehicle_budget_bytes == 0 || fleet_budget_bytes == 0) {
    problems.push_back("the vehicle and fleet memory budgets must be > 0 bytes");
  }
  if (vehicles.size() > fleet::FleetMap::kMaxVehicles) {
    problems.push_back("more than " + std::to_string(fleet::FleetMap::kMaxVehicles) +
                       " vehicles listed");
  }
  std::unordered_set<std::string> seen;
  for (const std::string& name : vehicles) {
    if (name.empty() || name.size() > kMaxVehicleNameBytes) {
      problems.push_back("a vehicle name is empty or longer than " +
                         std::to_string(kMaxVehicleNameBytes) + " bytes");
    } else if (!seen.insert(name).second) {
      problems.push_back("vehicle '" + name + "' listed twice");
    }
  }
  return problems;
}

FleetIntake::FleetIntake(const FleetTrustConfig& trust, const LogOddsConfig& log_odds)
    : trust_(trust), map_(log_odds) {
  const std::vector<std::string> problems = trust_.validate();
  if (!problems.empty()) throw std::invalid_argument("fleet trust: " + problems.front());
  map_.acceptGeometry(trust_.resolution_m, trust_.submap_cells);
  // Listed vehicles hold their places (and colours) from the start, in the list's order.
  for (const std::string& name : trust_.vehicles) map_.vehicleIndex(name);
  sources_.resize(trust_.vehicles.size());
}

std::uint64_t FleetIntake::refusedTotal() const {
  std::uint64_t total = 0;
  for (const std::uint64_t n : refused_) total += n;
  return total;
}

namespace {
std::uint64_t saturatingAdd(std::uint64_t a, std::uint64_t b) {
  return a > std::numeric_limits<std::uint64_t>::max() - b
             ? std::numeric_limits<std::uint64_t>::max()
             : a + b;
}
}  // namespace

SubmapIntake FleetIntake::refuse(SubmapRefusal reason, std::string why) {
  ++refused_[static_cast<std::size_t>(reason)];
  SubmapIntake out;
  out.refusal = reason;
  out.why = std::move(why);
  return out;
}

SubmapIntake FleetIntake::take(const ::mlmap_msgs::msg::dds_::Submap_& msg,
                               const std::string& topic_vehicle, const SubmapWriterId& writer,
                               double now_s, std::uint64_t wall_clock_us) {
  const std::string name = msg.vehicle_().substr(0, kMaxVehicleNameBytes);
  // 1. The header, without decoding anything.
  const std::string header = submapHeaderProblem(msg);
  if (!header.empty()) return refuse(SubmapRefusal::kMalformed, "from '" + name + "': " + header);
  // 2. A vehicle speaks for itself only: on its own topic.
  if (msg.vehicle_() != topic_vehicle) {
    return refuse(SubmapRefusal::kNotItsTopic,
                  "named '" + name + "' on the topic of vehicle '" + topic_vehicle + "'");
  }
  // 3. The fleet's grid is configuration.
  const Eigen::Vector3i cells(static_cast<int>(msg.size_x_()), static_cast<int>(msg.size_y_()),
                              static_cast<int>(msg.size_z_()));
  if (msg.resolution_() != trust_.resolution_m || cells != trust_.submap_cells) {
    std::ostringstream m;
    m << "from '" << name << "': grid " << msg.resolution_() << " m, " << cells.transpose()
      << " voxels per submap differs from the fleet's " << trust_.resolution_m << " m, "
      << trust_.submap_cells.transpose() << " (the vehicles' local_map, --config)";
    return refuse(SubmapRefusal::kWrongGrid, m.str());
  }
  // 4. Who may speak.
  int index = map_.findVehicle(name);
  if (index < 0) {
    if (!trust_.vehicles.empty()) {
      return refuse(SubmapRefusal::kUnknownVehicle, "from '" + name + "': not a listed vehicle");
    }
    if (msg.voxel_count_() == 0) {
      return refuse(SubmapRefusal::kEmptyNewVehicle,
                    "from '" + name + "': an empty sample from a vehicle that holds nothing");
    }
    if (map_.vehicles().size() >= fleet::FleetMap::kMaxVehicles) {
      return refuse(SubmapRefusal::kFleetFull,
                    "from '" + name + "': " + std::to_string(fleet::FleetMap::kMaxVehicles) +
                        " vehicles already hold voxels");
    }
  }
  // 5. Sequence numbers: bounded ahead of the clock, or of the same writer's last.
  const Source* source = index >= 0 ? &sources_[static_cast<std::size_t>(index)] : nullptr;
  const bool same_writer = source != nullptr && source->known && source->writer == writer;
  const std::uint64_t bound =
      std::max(saturatingAdd(wall_clock_us, kMaxClockLead_us),
               same_writer ? saturatingAdd(source->highest_sequence, kMaxSequenceLead) : 0);
  if (msg.sequence_() > bound) {
    return refuse(SubmapRefusal::kSequenceAhead,
                  "from '" + name + "': sequence " + std::to_string(msg.sequence_()) +
                      " is more than an hour of microseconds ahead of the clock" +
                      (same_writer ? " and more than 2^24 ahead of its writer's last" : ""));
  }
  // 6. Budgets, from the declared size: nothing is allocated for a sample refused here.
  const SubmapIndex m(msg.submap_x_(), msg.submap_y_(), msg.submap_z_());
  const fleet::FleetMap::MemoryAfter after = map_.memoryAfter(index, m, msg.voxel_count_());
  const std::size_t vehicle_now =
      index >= 0 ? map_.vehicles()[static_cast<std::size_t>(index)].memory_bytes : 0;
  if (after.vehicle_bytes > trust_.vehicle_budget_bytes && after.vehicle_bytes > vehicle_now) {
    return refuse(SubmapRefusal::kVehicleBudget,
                  "from '" + name + "': " + std::to_string(msg.voxel_count_()) +
                      " voxels would take it to " + std::to_string(after.vehicle_bytes) +
                      " bytes, over its budget of " + std::to_string(trust_.vehicle_budget_bytes));
  }
  if (after.fleet_bytes > trust_.fleet_budget_bytes && after.fleet_bytes > map_.memoryBytes()) {
    return refuse(SubmapRefusal::kFleetBudget,
                  "from '" + name + "': " + std::to_string(msg.voxel_count_()) +
                      " voxels would take the merged map to " + std::to_string(after.fleet_bytes) +
                      " bytes, over the fleet's budget of " +
                      std::to_string(trust_.fleet_budget_bytes));
  }
  // 7. The payload.
  DecodedSubmap decoded;
  const std::string problem = decodeSubmapMessage(msg, &decoded);
  if (!problem.empty()) return refuse(SubmapRefusal::kMalformed, "from '" + name + "': " + problem);
  // Accepted: register a newcomer, note a new writer (a restart), apply.
  SubmapIntake out;
  if (index < 0) {
    index = map_.vehicleIndex(name);
    sources_.resize(map_.vehicles().size());
    out.joined = true;
  }
  Source& s = sources_[static_cast<std::size_t>(index)];
  if (!same_writer) {
    if (s.known) {
      ++s.epoch;
      map_.noteRestart(index);
      out.restarted = true;
    }
    s.known = true;
    s.writer = writer;
    s.highest_sequence = msg.sequence_();
  }
  map_.noteReceived(name, serializedSubmapBytes(msg), now_s);
  const std::uint64_t sequence = msg.sequence_();
  if (map_.apply(name, m, sequence, std::move(decoded.records), s.epoch) ==
      fleet::SubmapApply::kOutdated) {
    return refuse(SubmapRefusal::kOutdated, "from '" + name + "': sequence " +
                                                std::to_string(sequence) +
                                                " is not newer than the content held");
  }
  s.highest_sequence = std::max(s.highest_sequence, sequence);
  out.applied = true;
  out.refusal = SubmapRefusal::kMalformed;
  return out;
}

}  // namespace mlmap::dds
