#include "mlmap/fleet/fleet_map.h"

#include "mlmap/fleet/submap_share.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace mlmap::fleet {

FleetMap::FleetMap(const LogOddsConfig& log_odds) : log_odds_(log_odds), model_(log_odds) {}

bool FleetMap::acceptGeometry(double resolution_m, const Eigen::Vector3i& submap_cells) {
  if (!has_geometry_) {
    if (!(resolution_m > 0.0) || !std::isfinite(resolution_m) || (submap_cells.array() < 1).any()) {
      return false;
    }
    has_geometry_ = true;
    resolution_m_ = resolution_m;
    submap_cells_ = submap_cells;
    return true;
  }
  return resolution_m == resolution_m_ && submap_cells == submap_cells_;
}

int FleetMap::vehicleIndex(const std::string& name) {
  const auto it = vehicle_index_.find(name);
  if (it != vehicle_index_.end()) return it->second;
  if (vehicles_.size() >= kMaxVehicles) return -1;
  const int index = static_cast<int>(vehicles_.size());
  vehicles_.push_back(FleetVehicle{});
  vehicles_.back().name = name;
  vehicle_index_.emplace(name, index);
  return index;
}

int FleetMap::findVehicle(const std::string& name) const {
  const auto it = vehicle_index_.find(name);
  return it == vehicle_index_.end() ? -1 : it->second;
}

void FleetMap::noteRestart(int index) {
  if (index >= 0 && static_cast<std::size_t>(index) < vehicles_.size()) {
    ++vehicles_[static_cast<std::size_t>(index)].restarts;
  }
}

void FleetMap::noteReceived(const std::string& vehicle, std::size_t bytes, double now_s) {
  const int v = vehicleIndex(vehicle);
  if (v < 0) return;
  FleetVehicle& info = vehicles_[static_cast<std::size_t>(v)];
  ++info.samples;
  info.bytes += bytes;
  info.last_seen_s = std::max(info.last_seen_s, now_s);
}

std::uint32_t vehicleColourRgb(int index) {
  static constexpr std::uint32_t kPalette[] = {0xe6194b, 0x3cb44b, 0x4363d8, 0xf58231,
                                               0x911eb4, 0x46f0f0, 0xf032e6, 0xbcf60c};
  return kPalette[static_cast<std::size_t>(std::max(index, 0)) % 8];
}

SubmapIndex FleetMap::submapOf(std::uint64_t key) { return unpackSubmap(key); }

namespace {
/// Bytes of one hash map node of the submaps (key, entry, next pointer, cached hash).
template <typename Entry>
constexpr std::size_t nodeBytes() {
  return sizeof(std::uint64_t) + sizeof(Entry) + 2 * sizeof(void*);
}
}  // namespace

std::size_t FleetMap::contributionBytes(std::size_t voxels) {
  return sizeof(Contribution) + voxels * sizeof(VoxelRecord);
}

FleetMap::MemoryAfter FleetMap::memoryAfter(int index, const SubmapIndex& m,
                                            std::size_t voxels) const {
  MemoryAfter after;
  const auto it = submaps_.find(packSubmap(m));
  std::size_t held_records = 0, other_records = 0, fused_now = 0;
  if (it != submaps_.end()) {
    fused_now = it->second.fused.size();
    for (const Contribution& c : it->second.contributions) {
      (c.vehicle == index ? held_records : other_records) += c.records.size();
    }
  }
  const bool contributes =
      it != submaps_.end() &&
      std::any_of(it->second.contributions.begin(), it->second.contributions.end(),
                  [index](const Contribution& c) { return c.vehicle == index; });
  const std::size_t held_bytes = contributes ? contributionBytes(held_records) : 0;
  const std::size_t vehicle_now = index >= 0 && static_cast<std::size_t>(index) < vehicles_.size()
                                      ? vehicles_[static_cast<std::size_t>(index)].memory_bytes
                                      : 0;
  // The fused voxels of the submap afterwards: at most one per offset any contribution holds.
  const auto submap_voxels = static_cast<std::size_t>(submap_cells_.x()) *
                             static_cast<std::size_t>(submap_cells_.y()) *
                             static_cast<std::size_t>(submap_cells_.z());
  const std::size_t fused_max = std::min(submap_voxels, other_records + voxels);
  const std::size_t fused_growth = fused_max > fused_now ? fused_max - fused_now : 0;
  after.vehicle_bytes = vehicle_now - held_bytes + contributionBytes(voxels);
  // A new submap may rehash the table: libstdc++ grows it to the next prime past twice its
  // buckets, below three per submap.
  const std::size_t buckets = it == submaps_.end()
                                  ? std::max(submaps_.bucket_count(), 3 * (submaps_.size() + 1))
                                  : submaps_.bucket_count();
  after.fleet_bytes = held_bytes_ - held_bytes + contributionBytes(voxels) +
                      fused_growth * sizeof(FleetVoxel) +
                      (it == submaps_.end() ? nodeBytes<Entry>() : 0) + buckets * sizeof(void*);
  return after;
}

SubmapApply FleetMap::apply(const std::string& vehicle, const SubmapIndex& m,
                            std::uint64_t sequence, std::vector<VoxelRecord>&& records,
                            std::uint32_t epoch) {
  const int v = vehicleIndex(vehicle);
  if (v < 0) return SubmapApply::kTooManyVehicles;
  FleetVehicle& info = vehicles_[static_cast<std::size_t>(v)];
  const std::uint64_t key = packSubmap(m);
  auto it = submaps_.find(key);
  // An empty sample for a new submap still creates it: its sequence orders later samples.
  if (it == submaps_.end()) {
    it = submaps_.emplace(key, Entry{}).first;
    held_bytes_ += nodeBytes<Entry>();
  }
  Entry& entry = it->second;
  auto c = std::find_if(entry.contributions.begin(), entry.contributions.end(),
                        [v](const Contribution& x) { return x.vehicle == v; });
  if (c != entry.contributions.end() && c->epoch == epoch && sequence <= c->sequence) {
    ++info.samples_outdated;
    return SubmapApply::kOutdated;
  }
  if (c == entry.contributions.end()) {
    entry.contributions.push_back(Contribution{v, 0, epoch, {}});
    c = entry.contributions.end() - 1;
    held_bytes_ += contributionBytes(0);
    info.memory_bytes += contributionBytes(0);
  }
  const std::size_t before = c->records.size();
  held_bytes_ = held_bytes_ - before * sizeof(VoxelRecord) + records.size() * sizeof(VoxelRecord);
  info.memory_bytes =
      info.memory_bytes - before * sizeof(VoxelRecord) + records.size() * sizeof(VoxelRecord);
  info.voxels = info.voxels - before + records.size();
  if (before == 0 && !records.empty()) ++info.submaps;
  if (before != 0 && records.empty()) --info.submaps;
  c->sequence = sequence;
  c->epoch = epoch;
  c->records = std::move(records);
  c->records.shrink_to_fit();
  ++info.samples_applied;
  voxel_count_ -= entry.fused.size();
  held_bytes_ -= entry.fused.size() * sizeof(FleetVoxel);
  fuse(&entry);
  voxel_count_ += entry.fused.size();
  held_bytes_ += entry.fused.size() * sizeof(FleetVoxel);
  ++changes_;
  return SubmapApply::kApplied;
}

void FleetMap::fuse(Entry* entry) {
  // Every contribution's voxels, by offset: sums and bits per offset.
  struct Item {
    std::uint32_t offset;
    LogOddsQ log_odds;
    int vehicle;
  };
  std::vector<Item> items;
  for (const Contribution& c : entry->contributions) {
    for (const VoxelRecord& r : c.records) items.push_back({r.offset, r.log_odds, c.vehicle});
  }
  std::sort(items.begin(), items.end(),
            [](const Item& a, const Item& b) { return a.offset < b.offset; });
  entry->fused.clear();
  for (std::size_t i = 0; i < items.size();) {
    int sum = 0;
    std::uint64_t bits = 0;
    std::size_t j = i;
    for (; j < items.size() && items[j].offset == items[i].offset; ++j) {
      sum += items[j].log_odds;
      // A vehicle whose evidence lowers the voxel (free evidence) is no provenance of it.
      if (items[j].log_odds > 0) bits |= std::uint64_t{1} << items[j].vehicle;
    }
    const auto clamped =
        static_cast<LogOddsQ>(std::clamp<int>(sum, model_.clampMin(), model_.clampMax()));
    // Only occupied fused voxels are kept: the map holds what the fleet claims occupied.
    if (model_.isOccupied(clamped)) entry->fused.push_back({items[i].offset, clamped, bits});
    i = j;
  }
  entry->fused.shrink_to_fit();
}

ProjectedGrid FleetMap::projectGrid(double band_min_z_m, double band_max_z_m) const {
  ProjectedGrid grid;
  grid.resolution_m = resolution_m_;
  grid.band_min_z_m = band_min_z_m;
  grid.band_max_z_m = band_max_z_m;
  int k0 = 0, k1 = 0;
  bandLayers(band_min_z_m, band_max_z_m, resolution_m_, &k0, &k1);
  std::vector<Eigen::Vector2i> cells;
  Eigen::Vector2i lo(std::numeric_limits<int>::max(), std::numeric_limits<int>::max());
  Eigen::Vector2i hi(std::numeric_limits<int>::min(), std::numeric_limits<int>::min());
  forEachOccupied([&](const VoxelIndex& g, LogOddsQ, std::uint64_t) {
    if (g.z() < k0 || g.z() >= k1) return;
    const Eigen::Vector2i c(g.x(), g.y());
    cells.push_back(c);
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
  });
  if (cells.empty()) return grid;
  grid.origin_W = lo.cast<double>() * resolution_m_;
  grid.width = hi.x() - lo.x() + 1;
  grid.height = hi.y() - lo.y() + 1;
  grid.cells.assign(static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height),
                    ProjectedGrid::kUnknown);
  for (const Eigen::Vector2i& c : cells) {
    const Eigen::Vector2i r = c - lo;
    grid.cells[static_cast<std::size_t>(r.y()) * static_cast<std::size_t>(grid.width) +
               static_cast<std::size_t>(r.x())] = ProjectedGrid::kOccupied;
  }
  return grid;
}

std::size_t FleetMap::memoryBytes() const {
  return held_bytes_ + submaps_.bucket_count() * sizeof(void*);
}

std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> FleetMap::occupiedSubmaps() const {
  std::vector<std::pair<SubmapIndex, std::vector<VoxelRecord>>> out;
  for (const auto& [key, entry] : submaps_) {
    if (entry.fused.empty()) continue;
    std::vector<VoxelRecord> records;  // fuse() keeps occupied voxels only, by offset
    records.reserve(entry.fused.size());
    for (const FleetVoxel& v : entry.fused) records.push_back({v.offset, v.log_odds});
    out.emplace_back(submapOf(key), std::move(records));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return std::make_tuple(a.first.x(), a.first.y(), a.first.z()) <
           std::make_tuple(b.first.x(), b.first.y(), b.first.z());
  });
  return out;
}

MapState fleetMapState(const FleetMap& fleet) {
  if (!fleet.hasGeometry()) {
    throw std::runtime_error("no vehicle has shared a submap yet: nothing to save");
  }
  MapState state;
  state.local_map.resolution_m = fleet.resolution_m();
  state.local_map.size_cells = fleet.submapCells() * LocalMapConfig::kSubmapsPerAxis;
  state.log_odds = fleet.logOddsConfig();
  state.global_submaps = fleet.occupiedSubmaps();
  const std::vector<std::string> problems = mapStateProblems(state);
  if (!problems.empty()) {
    std::ostringstream m;
    m << "the merged map cannot be saved:";
    for (const std::string& p : problems) m << " " << p << ";";
    throw std::runtime_error(m.str());
  }
  return state;
}

}  // namespace mlmap::fleet
