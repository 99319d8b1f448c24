#pragma once
/// @file
/// The fleet's merged map (mlmap_fleet): every vehicle's latest content of every submap, fused
/// voxel by voxel.
///
/// Each vehicle sends a submap's content whenever it changes (mlmap_msgs/Submap): its own
/// evidence there (fleet::ownEvidence(): its occupied voxels' log-odds, less what other vehicles
/// gave it as priors, and the negative change its rays made to prior voxels they lowered); its
/// latest content replaces that vehicle's previous contribution to that submap, so evidence is
/// never counted twice. A fused voxel's log-odds is the sum of the vehicles' contributions,
/// clamped to the engine's bounds (LogOddsConfig clamp_min, clamp_max): independent observers add
/// their evidence as the engine adds its frames', and a vehicle that took another's voxel as a
/// prior and saw through it brings the sum to its own value, as one engine fed both vehicles'
/// frames in that order would hold. The fused map keeps the occupied voxels, each with a bit per
/// vehicle whose contribution to it is positive (provenance). Memory grows with the voxels sent:
/// 8 bytes per voxel and vehicle sending it, 16 per occupied fused voxel, plus a few per submap.

#include "mlmap/core/log_odds.h"
#include "mlmap/global/global_map.h"
#include "mlmap/local/map_state.h"
#include "mlmap/planning/projected_grid.h"

#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

namespace mlmap::fleet {

/// An occupied fused voxel: its offset in the submap, the clamped sum of the vehicles'
/// contributions, and bit v set for each vehicle v (FleetMap::vehicles() index) whose
/// contribution is positive.
struct FleetVoxel {
  std::uint32_t offset = 0;
  LogOddsQ log_odds = 0;
  std::uint64_t vehicles = 0;
};

/// The colour of vehicle `index` (FleetMap::vehicles() order) in the merged map's pictures and
/// PointCloud2 `rgb`: 0xRRGGBB, eight distinct colours, repeating.
std::uint32_t vehicleColourRgb(int index);

/// What the merger knows of one vehicle.
struct FleetVehicle {
  std::string name;
  std::uint64_t samples = 0;           ///< submap samples received (applied or not)
  std::uint64_t bytes = 0;             ///< their payload bytes
  std::uint64_t samples_applied = 0;   ///< samples that changed its contribution
  std::uint64_t samples_outdated = 0;  ///< older than (or as old as) the content held: ignored
  std::uint64_t submaps = 0;           ///< submaps where it holds occupied voxels
  std::uint64_t voxels = 0;            ///< voxels it contributes evidence for
  std::uint64_t memory_bytes = 0;      ///< bytes its contributions hold
  std::uint64_t restarts = 0;          ///< times its samples came from a new source (epoch)
  double last_seen_s = -std::numeric_limits<double>::infinity();  ///< caller's clock [s]
};

/// How FleetMap::apply() took a sample.
enum class SubmapApply {
  kApplied,          ///< the vehicle's contribution to the submap was replaced
  kOutdated,         ///< its sequence is not newer than the one held: ignored
  kTooManyVehicles,  ///< a new vehicle beyond kMaxVehicles: ignored
};

/// The merged map. Not thread-safe.
class FleetMap {
 public:
  /// Vehicles with a provenance bit.
  static constexpr std::size_t kMaxVehicles = 64;

  /// `log_odds`: the clamping bounds and occupancy threshold (the vehicles' engine config).
  explicit FleetMap(const LogOddsConfig& log_odds = {});

  /// Adopts the grid of the first sample (voxel edge, voxels per submap and axis) and returns
  /// true; afterwards true only for the same grid (a fleet shares one world grid; a sample of
  /// another is refused by the caller).
  bool acceptGeometry(double resolution_m, const Eigen::Vector3i& submap_cells);
  /// A grid was adopted.
  [[nodiscard]] bool hasGeometry() const { return has_geometry_; }

  /// The vehicle's index, registered on first use (-1 beyond kMaxVehicles).
  int vehicleIndex(const std::string& name);
  /// The vehicle's index, or -1 when it is not registered (registers nothing).
  [[nodiscard]] int findVehicle(const std::string& name) const;
  /// Counts a restart of vehicle `index` (FleetVehicle::restarts).
  void noteRestart(int index);
  /// Counts a received sample of `vehicle` (`bytes` of payload) at `now_s` (caller's clock).
  void noteReceived(const std::string& vehicle, std::size_t bytes, double now_s);

  /// Replaces `vehicle`'s content of submap `m` by `records` (ascending offsets inside the
  /// submap; empty: it holds nothing there now), when `sequence` is newer than the one held
  /// for that vehicle and submap or `epoch` differs from the held content's (the vehicle
  /// restarted: a new source whose sequence numbers are not comparable with the old one's),
  /// and fuses the submap again.
  SubmapApply apply(const std::string& vehicle, const SubmapIndex& m, std::uint64_t sequence,
                    std::vector<VoxelRecord>&& records, std::uint32_t epoch = 0);

  /// Bytes held after a change, as memoryAfter() foresees it.
  struct MemoryAfter {
    std::size_t vehicle_bytes = 0;  ///< the vehicle's contributions (FleetVehicle::memory_bytes)
    std::size_t fleet_bytes = 0;    ///< the whole map (memoryBytes()), an upper bound
  };
  /// What vehicle `index` (-1: a vehicle not registered yet) and the map would hold if its
  /// content of submap `m` became `voxels` voxels: computed from the sizes alone, before
  /// anything is allocated. The submap's fused voxels are counted as one per offset any
  /// contribution would hold, at most the submap's voxels (an upper bound).
  [[nodiscard]] MemoryAfter memoryAfter(int index, const SubmapIndex& m, std::size_t voxels) const;
  /// Bytes one vehicle's content of one submap of `voxels` voxels holds.
  static std::size_t contributionBytes(std::size_t voxels);

  /// Calls f(world voxel index, fused log-odds, vehicle bits) for every fused voxel (all occupied).
  template <typename F>
  void forEachOccupied(F&& f) const {
    const auto plane = static_cast<std::uint32_t>(submap_cells_.y() * submap_cells_.z());
    for (const auto& [key, entry] : submaps_) {
      const VoxelIndex base = submapOf(key).cwiseProduct(submap_cells_);
      for (const FleetVoxel& v : entry.fused) {  // fuse() keeps occupied voxels only
        const int x = static_cast<int>(v.offset / plane);
        const int rest = static_cast<int>(v.offset % plane);
        f(VoxelIndex(base.x() + x, base.y() + rest / submap_cells_.z(),
                     base.z() + rest % submap_cells_.z()),
          v.log_odds, v.vehicles);
      }
    }
  }

  /// The fused occupied voxels as the global map keeps them: submaps by ascending index (x, then
  /// y, then z), each with its voxels by ascending offset; submaps with none left out.
  [[nodiscard]] std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> occupiedSubmaps()
      const;

  /// The 2D grid of the occupied voxels whose centres lie in [band_min_z_m, band_max_z_m]:
  /// 100 where one is, -1 (unknown) elsewhere (free space does not travel), over the occupied
  /// voxels' extent (an empty grid when there are none).
  [[nodiscard]] ProjectedGrid projectGrid(double band_min_z_m, double band_max_z_m) const;

  [[nodiscard]] const std::vector<FleetVehicle>& vehicles() const { return vehicles_; }
  [[nodiscard]] std::size_t voxelCount() const { return voxel_count_; }
  [[nodiscard]] std::size_t submapCount() const { return submaps_.size(); }
  /// Bytes held by the contributions, the fused voxels and the hash map's nodes and buckets
  /// (kept as the map changes: O(1)).
  [[nodiscard]] std::size_t memoryBytes() const;
  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  [[nodiscard]] const Eigen::Vector3i& submapCells() const { return submap_cells_; }
  [[nodiscard]] const LogOddsModel& model() const { return model_; }
  [[nodiscard]] const LogOddsConfig& logOddsConfig() const { return log_odds_; }
  /// Changes of the fused map so far (equal values: nothing changed).
  [[nodiscard]] std::uint64_t changes() const { return changes_; }

 private:
  /// One vehicle's content of one submap (empty after it sent an empty one: its sequence stays).
  struct Contribution {
    int vehicle = 0;
    std::uint64_t sequence = 0;
    std::uint32_t epoch = 0;
    std::vector<VoxelRecord> records;
  };
  struct Entry {
    std::vector<Contribution> contributions;
    std::vector<FleetVoxel> fused;
  };
  static SubmapIndex submapOf(std::uint64_t key);
  void fuse(Entry* entry);

  LogOddsConfig log_odds_;
  LogOddsModel model_;
  bool has_geometry_ = false;
  double resolution_m_ = 0.0;
  Eigen::Vector3i submap_cells_ = Eigen::Vector3i::Ones();
  std::vector<FleetVehicle> vehicles_;
  std::unordered_map<std::string, int> vehicle_index_;
  std::unordered_map<std::uint64_t, Entry> submaps_;
  std::size_t voxel_count_ = 0;
  std::size_t held_bytes_ = 0;  // contributions, fused voxels, hash nodes (not buckets)
  std::uint64_t changes_ = 0;
};

/// The merged map as a map file holds it (mlmap/map_io/map_file.h): every fused occupied voxel
/// in the global layer with its log-odds, no local window (a node that loads it places one where
/// it starts), the fleet's voxel size, a window of kSubmapsPerAxis of the fleet's submaps per
/// axis, and `fleet`'s log-odds model. Throws std::runtime_error when no sample has given the
/// fleet a grid yet, or when the state would not be sound (mapStateProblems()).
[[nodiscard]] MapState fleetMapState(const FleetMap& fleet);

}  // namespace mlmap::fleet
