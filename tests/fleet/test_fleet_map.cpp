// The merged map against a slow reference: every (vehicle, submap)'s latest content by sequence
// in a std::map, fused voxel by voxel in another, on random streams with replacements, empties,
// duplicates and versions arriving out of order.
#include "mlmap/fleet/fleet_map.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"
#include "mlmap/pipeline/map_engine.h"

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <random>
#include <tuple>

namespace mlmap::fleet {
namespace {

using Key3 = std::tuple<int, int, int>;

struct Reference {
  /// (vehicle, submap) -> (sequence, records)
  std::map<std::pair<std::string, Key3>, std::pair<std::uint64_t, std::vector<VoxelRecord>>> latest;

  void apply(const std::string& v, const SubmapIndex& m, std::uint64_t seq,
             const std::vector<VoxelRecord>& records) {
    auto& slot = latest[{v, Key3{m.x(), m.y(), m.z()}}];
    if (slot.first != 0 && seq <= slot.first) return;
    slot = {seq, records};
  }
  /// world voxel -> (clamped sum, vehicle bits), occupied only.
  std::map<Key3, std::pair<LogOddsQ, std::uint64_t>> fused(const std::vector<std::string>& order,
                                                           const Eigen::Vector3i& cells,
                                                           const LogOddsModel& model) const {
    std::map<Key3, std::pair<int, std::uint64_t>> sums;
    for (const auto& [key, value] : latest) {
      const int bit =
          static_cast<int>(std::find(order.begin(), order.end(), key.first) - order.begin());
      const auto& [mx, my, mz] = key.second;
      for (const VoxelRecord& r : value.second) {
        const int o = static_cast<int>(r.offset);
        const int plane = cells.y() * cells.z();
        const Key3 g{mx * cells.x() + o / plane, my * cells.y() + (o % plane) / cells.z(),
                     mz * cells.z() + o % cells.z()};
        sums[g].first += r.log_odds;
        sums[g].second |= std::uint64_t{1} << bit;
      }
    }
    std::map<Key3, std::pair<LogOddsQ, std::uint64_t>> out;
    for (const auto& [g, s] : sums) {
      const auto v =
          static_cast<LogOddsQ>(std::clamp<int>(s.first, model.clampMin(), model.clampMax()));
      if (model.isOccupied(v)) out[g] = {v, s.second};
    }
    return out;
  }
};

TEST(FleetMap, FusesLikeTheSlowReferenceOnRandomStreams) {
  const Eigen::Vector3i cells(4, 4, 3);
  const LogOddsConfig config;
  for (std::uint32_t seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    FleetMap map(config);
    ASSERT_TRUE(map.acceptGeometry(0.1, cells));
    Reference reference;
    const std::vector<std::string> names = {"uav1", "uav2", "ugv", "uav4"};
    std::vector<std::string> order;  // vehicles in order of first sample (their bit)
    std::uniform_int_distribution<int> vehicle(0, 3), coord(-2, 2), count(0, 20);
    std::uniform_int_distribution<int> value(1, 3500), offset(0, cells.prod() - 1), jitter(0, 9);
    std::map<std::pair<int, Key3>, std::uint64_t> next_seq;
    for (int step = 0; step < 600; ++step) {
      const int v = vehicle(rng);
      const SubmapIndex m(coord(rng), coord(rng), coord(rng) / 2);
      std::uint64_t& seq = next_seq[{v, Key3{m.x(), m.y(), m.z()}}];
      seq += 1 + static_cast<std::uint64_t>(jitter(rng) % 3);
      // Out of order: now and then an older version (or a repeat) arrives after a newer one.
      const std::uint64_t sent_seq = jitter(rng) == 0 && seq > 3 ? seq - 3 : seq;
      std::map<std::uint32_t, LogOddsQ> voxels;
      const int n = jitter(rng) == 1 ? 0 : count(rng);  // an empty submap now and then
      for (int i = 0; i < n; ++i) {
        voxels[static_cast<std::uint32_t>(offset(rng))] = static_cast<LogOddsQ>(value(rng));
      }
      std::vector<VoxelRecord> records;
      records.reserve(voxels.size());
      for (const auto& [o, l] : voxels) records.push_back({o, l});
      if (std::find(order.begin(), order.end(), names[v]) == order.end()) order.push_back(names[v]);
      reference.apply(names[v], m, sent_seq, records);
      const SubmapApply applied =
          map.apply(names[v], m, sent_seq, std::vector<VoxelRecord>(records));
      EXPECT_NE(applied, SubmapApply::kTooManyVehicles);
    }
    const auto expected = reference.fused(order, cells, map.model());
    std::map<Key3, std::pair<LogOddsQ, std::uint64_t>> got;
    map.forEachOccupied([&](const VoxelIndex& g, LogOddsQ l, std::uint64_t bits) {
      got[Key3{g.x(), g.y(), g.z()}] = {l, bits};
    });
    ASSERT_EQ(got, expected) << "seed " << seed;
    // Per-vehicle counts agree with the latest contents.
    for (const FleetVehicle& info : map.vehicles()) {
      std::uint64_t voxels = 0, submaps = 0;
      for (const auto& [key, latest] : reference.latest) {
        if (key.first != info.name) continue;
        voxels += latest.second.size();
        submaps += latest.second.empty() ? 0 : 1;
      }
      EXPECT_EQ(info.voxels, voxels) << info.name;
      EXPECT_EQ(info.submaps, submaps) << info.name;
    }
  }
}

TEST(FleetMap, AReplacedContributionIsNotCountedTwiceAndEmptiesRemoveIt) {
  FleetMap map;
  ASSERT_TRUE(map.acceptGeometry(0.1, {4, 4, 4}));
  EXPECT_FALSE(map.acceptGeometry(0.2, {4, 4, 4}));
  EXPECT_FALSE(map.acceptGeometry(0.1, {8, 8, 8}));
  const SubmapIndex m(0, 0, 0);
  EXPECT_EQ(map.apply("a", m, 1, {{5, 850}}), SubmapApply::kApplied);
  EXPECT_EQ(map.apply("a", m, 2, {{5, 1700}}), SubmapApply::kApplied);
  EXPECT_EQ(map.apply("b", m, 1, {{5, 850}, {6, 850}}), SubmapApply::kApplied);
  std::map<std::uint32_t, std::pair<LogOddsQ, std::uint64_t>> got;
  auto read = [&] {
    got.clear();
    map.forEachOccupied([&](const VoxelIndex& g, LogOddsQ l, std::uint64_t bits) {
      got[static_cast<std::uint32_t>(g.x() * 16 + g.y() * 4 + g.z())] = {l, bits};
    });
  };
  read();
  EXPECT_EQ(got.at(5).first, 2550);  // 1700 + 850, the first 850 of "a" replaced
  EXPECT_EQ(got.at(5).second, 3u);
  EXPECT_EQ(got.at(6).second, 2u);
  EXPECT_EQ(map.apply("a", m, 2, {{5, 3500}}), SubmapApply::kOutdated);  // a repeat
  EXPECT_EQ(map.apply("b", m, 3, {{5, 3500}}), SubmapApply::kApplied);
  read();
  EXPECT_EQ(got.at(5).first, 3500);  // clamped as the engine clamps
  EXPECT_EQ(got.count(6), 0u);
  EXPECT_EQ(map.apply("a", m, 3, {}), SubmapApply::kApplied);
  EXPECT_EQ(map.apply("b", m, 4, {}), SubmapApply::kApplied);
  read();
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(map.voxelCount(), 0u);
  EXPECT_EQ(map.vehicles()[0].voxels, 0u);
}

TEST(FleetMap, GridMarksTheBandsOccupiedColumnsAndMemoryFollowsVoxels) {
  FleetMap map;
  ASSERT_TRUE(map.acceptGeometry(0.5, {4, 4, 4}));
  // Voxel (1, 2, 2) at z 1.0..1.5 (centre 1.25) and (3, 0, 7) at centre 3.75 (outside the band).
  map.apply("a", {0, 0, 0}, 1, {{static_cast<std::uint32_t>(1 * 16 + 2 * 4 + 2), 2000}});
  map.apply("a", {0, 0, 1}, 1, {{static_cast<std::uint32_t>(3 * 16 + 0 * 4 + 3), 2000}});
  const ProjectedGrid grid = map.projectGrid(0.5, 2.0);
  ASSERT_EQ(grid.width, 1);
  ASSERT_EQ(grid.height, 1);
  EXPECT_EQ(grid.at(0, 0), ProjectedGrid::kOccupied);
  EXPECT_DOUBLE_EQ(grid.origin_W.x(), 0.5);
  EXPECT_DOUBLE_EQ(grid.origin_W.y(), 1.0);
  const std::size_t small = map.memoryBytes();
  for (int i = 0; i < 200; ++i) {
    std::vector<VoxelRecord> wall;
    for (std::uint32_t o = 0; o < 64; ++o) wall.push_back({o, 3500});
    map.apply("a", {i, 5, 0}, 1, std::move(wall));
  }
  const double per_voxel =
      static_cast<double>(map.memoryBytes() - small) / static_cast<double>(200 * 64);
  EXPECT_LT(per_voxel, 40.0);
  std::printf("fleet map: %.1f B per occupied voxel of one vehicle\n", per_voxel);
}

// mlmap_fleet --save-map: the merged map as a map file, read back by the map file's own decoder
// and by an engine (what mlmap_node's map_file.load_path does), holds every fused occupied voxel
// of the slow reference with its log-odds, and nothing else.
TEST(FleetMapFile, TheSavedMergedMapHoldsEveryFusedVoxelWithItsLogOddsAndAnEngineLoadsIt) {
  const Eigen::Vector3i cells(3, 3, 2);  // the submaps of a 15 x 15 x 10 window
  LogOddsConfig log_odds;
  log_odds.clamp_max = 2.5;  // a model other than the default travels with the map
  FleetMap map(log_odds);
  EXPECT_THROW((void)fleetMapState(map), std::runtime_error) << "nothing merged yet";
  ASSERT_TRUE(map.acceptGeometry(0.1, cells));
  Reference reference;
  const std::vector<std::string> order = {"uav1", "uav2", "uav3"};
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> coord(-3, 3), value(-1500, 2500), offset(0, cells.prod() - 1);
  for (int step = 0; step < 300; ++step) {
    const std::string& vehicle = order[static_cast<std::size_t>(step) % order.size()];
    const SubmapIndex m(coord(rng), coord(rng), coord(rng) / 3);
    std::map<std::uint32_t, LogOddsQ> voxels;
    for (int i = 0; i < 8; ++i) {
      voxels[static_cast<std::uint32_t>(offset(rng))] = static_cast<LogOddsQ>(value(rng));
    }
    std::vector<VoxelRecord> records;
    records.reserve(voxels.size());
    for (const auto& [o, l] : voxels) records.push_back({o, l});
    const std::uint64_t sequence = static_cast<std::uint64_t>(step) + 1;
    reference.apply(vehicle, m, sequence, records);
    (void)map.apply(vehicle, m, sequence, std::move(records));
  }
  const auto expected = reference.fused(order, cells, map.model());
  ASSERT_GT(expected.size(), 100u);

  const MapState saved = fleetMapState(map);
  EXPECT_EQ(saved.local_map.resolution_m, 0.1);
  EXPECT_EQ(saved.local_map.size_cells, Eigen::Vector3i(15, 15, 10));
  EXPECT_EQ(saved.log_odds.clamp_max, 2.5);
  const MapState loaded = io::decodeMapFile(io::encodeMapFile(saved), "fleet.mlmap");
  EXPECT_TRUE(mapStateProblems(loaded).empty());
  std::map<Key3, double> in_file;
  for (const io::OccupiedVoxel& v : io::occupiedVoxels(loaded)) {
    in_file[Key3{v.index.x(), v.index.y(), v.index.z()}] = v.log_odds;
  }
  ASSERT_EQ(in_file.size(), expected.size());
  for (const auto& [g, fused] : expected) {
    ASSERT_EQ(in_file.count(g), 1u);
    EXPECT_DOUBLE_EQ(in_file[g], dequantizeLogOdds(fused.first));
  }

  MapConfig config;
  config.local_map = saved.local_map;
  config.log_odds = log_odds;
  io::checkMapMatchesConfig(loaded, config, "fleet.mlmap");
  MapEngine engine(config);
  engine.restoreState(loaded);
  std::set<Key3> in_engine;
  for (const VoxelIndex& v : engine.occupiedVoxels()) in_engine.insert(Key3{v.x(), v.y(), v.z()});
  std::set<Key3> expected_keys;
  for (const auto& entry : expected) expected_keys.insert(entry.first);
  EXPECT_EQ(in_engine, expected_keys);
}

}  // namespace
}  // namespace mlmap::fleet
