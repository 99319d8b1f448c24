#include "mlmap/local/local_map.h"

#include "../support/reference.h"
#include "../support/rows_in_use.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <random>
#include <set>

namespace mlmap {
namespace {

LocalMapConfig smallMap() {
  LocalMapConfig c;
  c.resolution_m = 1.0;
  c.size_cells = {10, 15, 5};  // submaps of 2 x 3 x 1 voxels
  return c;
}

/// Calls f(offset) for every voxel offset (x, y, z) of a window of `size` voxels, z fastest.
template <typename F>
void forEachOffset(const Eigen::Vector3i& size, F&& f) {
  for (int x = 0; x < size.x(); ++x)
    for (int y = 0; y < size.y(); ++y)
      for (int z = 0; z < size.z(); ++z) f(VoxelIndex(x, y, z));
}

/// Within 6 voxels (z within 2). The draws are sequenced: the order in which a call's arguments
/// are evaluated is unspecified, and gcc and clang would otherwise fly different paths.
VoxelIndex randomOffset(std::mt19937& rng) {
  std::uniform_int_distribution<int> offset(-6, 6);
  const int x = offset(rng);
  const int y = offset(rng);
  const int z = offset(rng) / 3;
  return {x, y, z};
}

/// A step of the body: x and y within +-xy_m, z within +-z_m, drawn in that order.
Eigen::Vector3d randomStep(double xy_m, double z_m, std::mt19937& rng) {
  std::uniform_real_distribution<double> step(-xy_m, xy_m);
  std::uniform_real_distribution<double> z_step(-z_m, z_m);
  const double x = step(rng);
  const double y = step(rng);
  const double z = z_step(rng);
  return {x, y, z};
}

/// A window shape and how a flight's measurements spread in it.
struct FlightShape {
  const char* name;
  LocalMapConfig config;
  int z_run_max;    // free voxels come in z runs of 1 .. z_run_max voxels
  double z_step_m;  // the body's random walk along z per frame, at most
  LogOddsConfig log_odds{};
};

/// The small window (columns of 5: every miss takes the one-voxel path), and a tall one whose
/// columns of 75 take runs of free voxels eight at a time, across two bitset words per row,
/// submap borders (every 15 voxels) and the torus wrap; the tall one with the most extreme
/// sensor model the configuration allows (a miss then goes below what 16 bits hold before the
/// clamp); and one of lower submaps.
std::vector<FlightShape> flightShapes() {
  LocalMapConfig tall;
  tall.resolution_m = 1.0;
  tall.size_cells = {10, 10, 75};  // submaps of 2 x 2 x 15 voxels
  LogOddsConfig extreme;
  extreme.hit = 10.0;
  extreme.miss = -10.0;
  extreme.clamp_min = -30.0;
  extreme.clamp_max = 30.0;
  // Submaps 7 voxels high: eight consecutive voxels of a run can span three submaps, whose stamps
  // the eight-voxel miss step then sets lane by lane (the paper's 0.2 m window, 35 voxels high).
  LocalMapConfig low = tall;
  low.size_cells = {10, 10, 35};
  return {{"small", smallMap(), 1, 0.45},
          {"tall", tall, 40, 6.0},
          {"tall, extreme log-odds", tall, 40, 6.0, extreme},
          {"submaps 7 high", low, 30, 4.0}};
}

/// A batch of these hits and misses. The free set's box has rows of three words and three words
/// of rows in use per x (the window's y straddles the first boundary); with `list_rows_in_use`
/// its rows in use are listed (VoxelBitset::rowsInUse(), as the awareness stage lists them), so
/// that the local map reads only those rows, else it reads every row.
MeasurementBatch makeBatch(const Eigen::Vector3d& body, const std::vector<VoxelIndex>& hits,
                           const std::vector<VoxelIndex>& frees, bool list_rows_in_use = false) {
  MeasurementBatch b;
  b.T_W_B.translation() = body;
  const VoxelIndex origin = voxelIndexOf(body, 1.0) - VoxelIndex(20, 66, 80);
  b.free.reset(origin, Eigen::Vector3i(41, 133, 161));
  for (const VoxelIndex& h : hits) b.hits.push_back({h, h.cast<double>()});
  for (const VoxelIndex& f : frees) {
    const VoxelIndex r = f - origin;
    if (b.free.contains(r.x(), r.y(), r.z()) && !b.free.testAndSet(r.x(), r.y(), r.z()))
      ++b.free_count;
  }
  if (list_rows_in_use) test::listRowsInUseSlowly(&b.free);
  return b;
}

/// Up to `n` distinct voxels within 6 voxels of the body (z within 2): the first a hit, the
/// others the first voxels of up to `z_run_max` misses upwards.
void fewUpdatesAround(const Eigen::Vector3d& body, int n, int z_run_max, std::mt19937& rng,
                      std::vector<VoxelIndex>* hits, std::vector<VoxelIndex>* frees) {
  std::uniform_int_distribution<int> run(1, z_run_max);
  std::set<test::Key> seen;
  for (const auto* list : {hits, frees})
    for (const VoxelIndex& v : *list) seen.insert(test::key(v));
  const VoxelIndex b = voxelIndexOf(body, 1.0);
  for (int i = 0; i < n; ++i) {
    const VoxelIndex v = b + randomOffset(rng);
    if (i == 0) {
      if (seen.insert(test::key(v)).second) hits->push_back(v);
      continue;
    }
    const int length = z_run_max > 1 ? run(rng) : 1;  // no draw: the small flights as before
    for (int k = 0; k < length; ++k) {
      const VoxelIndex f = v + VoxelIndex(0, 0, k);
      if (seen.insert(test::key(f)).second) frees->push_back(f);
    }
  }
}

TEST(LogOdds, SaturatesAndReadsThreeStates) {
  LogOddsConfig c;
  const LogOddsModel model(c);
  LogOddsQ v = kUnknownLogOdds;
  EXPECT_EQ(model.state(v), Occupancy::kUnknown);
  model.hit(v);
  EXPECT_NEAR(dequantizeLogOdds(v), 0.85, 1e-9);
  EXPECT_EQ(model.state(v), Occupancy::kOccupied);
  for (int i = 0; i < 20; ++i) model.hit(v);
  EXPECT_NEAR(dequantizeLogOdds(v), c.clamp_max, 1e-9);
  model.miss(v);
  EXPECT_NEAR(dequantizeLogOdds(v), c.clamp_max - 0.4, 1e-9);  // saturation keeps it responsive
  for (int i = 0; i < 40; ++i) model.miss(v);
  EXPECT_NEAR(dequantizeLogOdds(v), c.clamp_min, 1e-9);
  EXPECT_EQ(model.state(v), Occupancy::kFree);
  LogOddsQ u = kUnknownLogOdds;
  model.miss(u);
  EXPECT_NEAR(dequantizeLogOdds(u), -0.4, 1e-9);
  EXPECT_NEAR(probabilityFromLogOdds(0.85), 0.7, 0.001);  // Table 1, natural log
  EXPECT_NEAR(probabilityFromLogOdds(-0.4), 0.4, 0.002);
}

// The torus with submap retirement against a plain std::map of the whole world.
void flyAgainstAWholeWorldReference(const FlightShape& shape) {
  const LocalMapConfig& config = shape.config;
  const LogOddsConfig& lo = shape.log_odds;
  const LogOddsModel model(lo);
  LocalMap map(config, lo);
  GlobalMap global(config.submap_cells(), config.resolution_m);
  std::map<test::Key, LogOddsQ> reference;  // what a perfect sliding map + global store keeps
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> run(1, shape.z_run_max);
  Eigen::Vector3d body(0.5, 0.5, 0.5);
  std::uint64_t outside = 0;       // measurements outside the window
  std::uint64_t hits_outside = 0;  // of them, hits
  for (int frame = 0; frame < 400; ++frame) {
    body += randomStep(1.5, shape.z_step_m, rng);
    if (frame == 200) body += Eigen::Vector3d(40.0, 0.0, 0.0);  // a jump: whole-window reset
    if (frame > 300) body *= 0.9;                               // fly back home
    map.recenter(body, &global);
    // Reference: what left the window keeps only its occupied voxels.
    for (auto it = reference.begin(); it != reference.end();) {
      if (!map.contains(test::index(it->first)) && !model.isOccupied(it->second)) {
        it = reference.erase(it);
      } else {
        ++it;
      }
    }
    std::vector<VoxelIndex> hits;
    std::vector<VoxelIndex> frees;
    std::set<test::Key> seen;
    const VoxelIndex b = voxelIndexOf(body, 1.0);
    for (int i = 0; i < 30; ++i) {
      const VoxelIndex v = b + randomOffset(rng);
      if (i % 3 == 0) {
        if (seen.insert(test::key(v)).second) hits.push_back(v);
        continue;
      }
      const int length = shape.z_run_max > 1 ? run(rng) : 1;
      for (int k = 0; k < length; ++k) {
        const VoxelIndex f = v + VoxelIndex(0, 0, k);
        if (seen.insert(test::key(f)).second) frees.push_back(f);
      }
    }
    map.integrate(makeBatch(body, hits, frees, /*list_rows_in_use=*/frame % 2 == 1));
    for (const auto& v : hits) hits_outside += map.contains(v) ? 0 : 1;
    for (const auto& v : frees) outside += map.contains(v) ? 0 : 1;
    for (const auto& h : hits) {
      if (!map.contains(h)) continue;
      auto [it, inserted] = reference.emplace(test::key(h), kUnknownLogOdds);
      model.hit(it->second);
    }
    for (const auto& f : frees) {
      if (!map.contains(f)) continue;
      auto [it, inserted] = reference.emplace(test::key(f), kUnknownLogOdds);
      model.miss(it->second);
    }
  }
  // Compare everything: inside the window exact log-odds; outside, the global store.
  std::map<test::Key, double> stored;
  global.forEachVoxel([&](const VoxelIndex& g, double l) { stored[test::key(g)] = l; });
  std::size_t compared = 0;
  for (const auto& [k, v] : reference) {
    const VoxelIndex g = test::index(k);
    if (map.contains(g)) {
      double l = 0.0;
      ASSERT_TRUE(map.logOdds(g, &l)) << g.transpose();
      EXPECT_NEAR(l, dequantizeLogOdds(v), 1e-9);
      EXPECT_EQ(stored.count(k), 0u) << "an active voxel must not also sit in the global map";
    } else {
      ASSERT_TRUE(model.isOccupied(v));
      ASSERT_EQ(stored.count(k), 1u) << "retired occupied voxel lost: " << g.transpose();
      EXPECT_NEAR(stored[k], dequantizeLogOdds(v), 1e-9);
    }
    ++compared;
  }
  // Nothing else is known anywhere; forEachOccupied() lists the occupied ones in x, y, z order.
  std::size_t known_in_window = 0;
  std::vector<VoxelIndex> occupied;
  for (int x = 0; x < config.size_cells.x(); ++x)
    for (int y = 0; y < config.size_cells.y(); ++y)
      for (int z = 0; z < config.size_cells.z(); ++z) {
        const VoxelIndex g = map.minIndex() + VoxelIndex(x, y, z);
        if (map.state(g) != Occupancy::kUnknown) {
          ++known_in_window;
          EXPECT_EQ(reference.count(test::key(g)), 1u) << "stale value at " << g.transpose();
        }
        if (map.state(g) == Occupancy::kOccupied) occupied.push_back(g);
      }
  std::vector<VoxelIndex> listed;
  map.forEachOccupied([&](const VoxelIndex& g, double l) {
    listed.push_back(g);
    double stored_l = 0.0;
    EXPECT_TRUE(map.logOdds(g, &stored_l));
    EXPECT_EQ(l, stored_l);
  });
  EXPECT_EQ(listed, occupied);
  EXPECT_GT(occupied.size(), 10u);
  EXPECT_EQ(stored.size() + known_in_window, reference.size());
  EXPECT_EQ(map.counters().outside_window, outside + hits_outside);
  EXPECT_EQ(map.counters().hits_outside_window, hits_outside);
  EXPECT_GT(outside, 1000u);
  EXPECT_GT(hits_outside, 100u);
  EXPECT_GT(compared, 300u);
  EXPECT_GT(map.counters().shifts, 50u);
  EXPECT_GE(map.counters().resets, 1u);  // the jump (flying home fast may add more)
}

TEST(LocalMap, MatchesAWholeWorldReferenceThroughRandomFlights) {
  for (const FlightShape& shape : flightShapes()) {
    SCOPED_TRACE(shape.name);
    flyAgainstAWholeWorldReference(shape);
  }
}

// The change stamps name exactly the submaps whose stored values (states) changed, or that
// entered the window, since the clock was read: what incremental readers (the 2D grid, the ESDF)
// rely on.
void checkChangeStampsThroughAFlight(const FlightShape& shape) {
  const LocalMapConfig& config = shape.config;
  LocalMap map(config, shape.log_odds);
  GlobalMap global(config.submap_cells(), config.resolution_m);
  const Eigen::Vector3i cells = config.submap_cells();
  std::mt19937 rng(11);
  Eigen::Vector3d body(0.5, 0.5, 0.5);
  LocalWindow before;
  LocalWindow after;
  std::size_t stamped = 0;
  std::size_t unstamped = 0;
  std::size_t value_only = 0;  // log-odds changed, states did not
  for (int frame = 0; frame < 300; ++frame) {
    const std::uint64_t clock = map.changeClock();
    map.copyWindow(&before);
    body += randomStep(0.8, 0.5 * shape.z_step_m, rng);
    map.recenter(body, &global);
    std::vector<VoxelIndex> hits;
    std::vector<VoxelIndex> frees;
    // Few updates, some of them misses on saturated free voxels: those change nothing.
    fewUpdatesAround(body, 6, shape.z_run_max, rng, &hits, &frees);
    const VoxelIndex b = voxelIndexOf(body, 1.0);
    if (frame % 5 == 0) {
      for (int i = 0; i < 12; ++i) frees.push_back(b + VoxelIndex(10 + i, 0, 0));  // outside
    }
    map.integrate(makeBatch(body, hits, frees));
    map.copyWindow(&after);
    const SubmapIndex first = map.submapOf(after.min_index);
    for (int sx = 0; sx < LocalMapConfig::kSubmapsPerAxis; ++sx) {
      for (int sy = 0; sy < LocalMapConfig::kSubmapsPerAxis; ++sy) {
        for (int sz = 0; sz < LocalMapConfig::kSubmapsPerAxis; ++sz) {
          const SubmapIndex m = first + SubmapIndex(sx, sy, sz);
          const VoxelIndex m0 = m.cwiseProduct(cells);
          const bool entered = before.size.prod() == 0 || !before.contains(m0);
          bool changed = entered;
          bool state_changed = entered;
          for (int x = 0; x < cells.x(); ++x)
            for (int y = 0; y < cells.y(); ++y)
              for (int z = 0; z < cells.z(); ++z) {
                const VoxelIndex g = m0 + VoxelIndex(x, y, z);
                if (entered) continue;
                changed = changed || before.at(g) != after.at(g);
                state_changed = state_changed || before.state(g) != after.state(g);
              }
          ASSERT_EQ(map.submapChangedAt(m) > clock, changed)
              << "frame " << frame << ", submap " << m.transpose();
          ASSERT_EQ(map.submapStateChangedAt(m) > clock, state_changed)
              << "frame " << frame << ", submap " << m.transpose();
          (changed ? stamped : unstamped) += 1;
          value_only += changed && !state_changed ? 1 : 0;
        }
      }
    }
  }
  EXPECT_GT(stamped, 1000u);
  EXPECT_GT(unstamped, 10000u);
  EXPECT_GT(value_only, 50u);
  EXPECT_GT(map.counters().shifts, 20u);
}

TEST(LocalMap, SubmapChangeStampsNameExactlyTheSubmapsThatChanged) {
  for (const FlightShape& shape : flightShapes()) {
    SCOPED_TRACE(shape.name);
    checkChangeStampsThroughAFlight(shape);
  }
}

// A pooled copy brought up to date with updateWindowCopy() equals a full copy after every frame,
// whichever earlier frame it was made at, while copying only the changed columns.
void checkUpdatedWindowCopiesThroughAFlight(const FlightShape& shape) {
  const LocalMapConfig& config = shape.config;
  LocalMap map(config, shape.log_odds);
  GlobalMap global(config.submap_cells(), config.resolution_m);
  std::mt19937 rng(12);
  Eigen::Vector3d body(0.5, 0.5, 0.5);
  std::vector<LocalWindow> pool(3);  // used in turn, as snapshot buffers are
  LocalWindow full;
  const int columns = config.size_cells.x() * config.size_cells.y();
  long copied = 0;       // by the updates in place
  long incremental = 0;  // updates in place (the window had not moved since the buffer's copy)
  const int frames = 300;
  for (int frame = 0; frame < frames; ++frame) {
    body += randomStep(0.25, 0.075, rng);                       // a shift every few frames
    if (frame == 150) body += Eigen::Vector3d(30.0, 0.0, 0.0);  // a jump: the window is replaced
    map.recenter(body, &global);
    std::vector<VoxelIndex> hits;
    std::vector<VoxelIndex> frees;
    fewUpdatesAround(body, 4, shape.z_run_max, rng, &hits, &frees);
    map.integrate(makeBatch(body, hits, frees));
    LocalWindow& copy = pool[static_cast<std::size_t>(frame % 3)];
    const bool same_place = copy.change_clock != 0 && copy.min_index == map.minIndex();
    const int n = map.updateWindowCopy(&copy);
    if (same_place) {
      copied += n;
      ++incremental;
    } else {
      ASSERT_EQ(n, columns) << "frame " << frame << ": a moved window is copied whole";
    }
    map.copyWindow(&full);
    ASSERT_EQ(copy.min_index, full.min_index) << "frame " << frame;
    ASSERT_EQ(copy.size, full.size) << "frame " << frame;
    ASSERT_EQ(copy.change_clock, full.change_clock) << "frame " << frame;
    ASSERT_TRUE(copy.log_odds == full.log_odds) << "frame " << frame;
  }
  std::printf("%ld columns copied in %ld incremental updates of %d (%d columns a window)\n", copied,
              incremental, frames, columns);
  EXPECT_GT(map.counters().shifts, 20u);
  EXPECT_GT(incremental, frames / 3);
  EXPECT_LT(copied, incremental * columns / 4) << "an update in place copies the changed columns";
}

TEST(LocalMap, UpdatedWindowCopiesEqualFullCopies) {
  for (const FlightShape& shape : flightShapes()) {
    SCOPED_TRACE(shape.name);
    checkUpdatedWindowCopiesThroughAFlight(shape);
  }
}

TEST(LocalMap, RecycledSubmapsStartUnknownAfterAShift) {
  const LocalMapConfig config = smallMap();
  LocalMap map(config, LogOddsConfig{});
  GlobalMap global(config.submap_cells(), 1.0);
  map.recenter({0.5, 0.5, 0.5}, &global);
  // Fill the whole window with free and occupied voxels.
  std::vector<VoxelIndex> hits;
  std::vector<VoxelIndex> frees;
  forEachOffset(config.size_cells, [&](const VoxelIndex& o) {
    (o.sum() % 4 == 0 ? hits : frees).push_back(map.minIndex() + o);
  });
  map.integrate(makeBatch({0.5, 0.5, 0.5}, hits, frees));
  const VoxelIndex old_min = map.minIndex();
  // Leave the centre submap diagonally: a 26-neighbour shift in x, y and z.
  map.recenter({2.5, 3.5, 1.5}, &global);
  EXPECT_EQ(map.centerSubmap(), SubmapIndex(1, 1, 1));
  EXPECT_EQ(map.minIndex(), old_min + VoxelIndex(2, 3, 1));
  std::size_t unknown = 0;
  forEachOffset(config.size_cells, [&](const VoxelIndex& o) {
    const VoxelIndex g = map.minIndex() + o;
    const bool was_inside = (g - old_min).minCoeff() >= 0 && g.x() - old_min.x() < 10 &&
                            g.y() - old_min.y() < 15 && g.z() - old_min.z() < 5;
    if (!was_inside) {
      EXPECT_EQ(map.state(g), Occupancy::kUnknown) << "stale value at " << g.transpose();
      ++unknown;
    } else {
      EXPECT_NE(map.state(g), Occupancy::kUnknown);
    }
  });
  EXPECT_EQ(unknown, 10u * 15u * 5u - 8u * 12u * 4u);
}

// A window move unmarks the columns it left with no occupied voxel: the occupied listing reads
// only marked columns, so over a long flight the marks would otherwise grow to the whole window
// (the listing back to a full scan). After each move the marked columns are exactly the columns
// holding an occupied voxel (counted voxel by voxel; the flight only hits, so no occupied voxel
// was freed in place), and the listing still finds every occupied voxel.
TEST(LocalMap, AWindowMoveUnmarksTheColumnsItEmptied) {
  const LocalMapConfig config = smallMap();
  LocalMap map(config, LogOddsConfig{});
  GlobalMap global(config.submap_cells(), 1.0);
  map.recenter({0.5, 0.5, 0.5}, &global);
  std::vector<VoxelIndex> hits;
  forEachOffset(config.size_cells, [&](const VoxelIndex& o) {
    if (o.sum() % 4 == 0) hits.push_back(map.minIndex() + o);
  });
  map.integrate(makeBatch({0.5, 0.5, 0.5}, hits, {}));
  const auto check = [&](const char* step, std::size_t expected_columns) {
    std::set<std::pair<int, int>> holding;
    std::size_t occupied = 0;
    forEachOffset(config.size_cells, [&](const VoxelIndex& o) {
      if (map.state(map.minIndex() + o) != Occupancy::kOccupied) return;
      holding.insert({o.x(), o.y()});
      ++occupied;
    });
    std::size_t listed = 0;
    map.forEachOccupied([&](const VoxelIndex&, double) { ++listed; });
    EXPECT_EQ(holding.size(), expected_columns) << step;
    EXPECT_EQ(map.markedColumns(), holding.size()) << step;
    EXPECT_EQ(listed, occupied) << step;
  };
  check("filled", 150);
  map.recenter({2.5, 0.5, 0.5}, &global);  // one submap (2 voxels) along +x: a new empty slab
  check("moved along x", std::size_t{8} * 15);
  map.recenter({2.5, 0.5, 1.5}, &global);  // one submap along z: every column keeps 4 layers
  check("moved along z", std::size_t{8} * 15);
  map.recenter({2.5, 0.5, 0.5}, &global);  // back along z: the layer comes back from the global map
  check("back along z", std::size_t{8} * 15);
  map.recenter({0.5, 0.5, 0.5}, &global);  // back along x: the slab comes back, marked again
  check("back along x", 150);
}

// A window loaded with restoreWindow() (as a saved map is) holds exactly the copied values, and
// forEachOccupied() lists every occupied voxel of it, though no hit reached the loaded map: the
// listing skips only columns that cannot hold one. An empty window unplaces the map and forgets
// every value.
TEST(LocalMap, ARestoredWindowListsEveryOccupiedVoxelOfTheCopy) {
  for (const FlightShape& shape : flightShapes()) {
    SCOPED_TRACE(shape.name);
    const LocalMapConfig& config = shape.config;
    LocalMap map(config, shape.log_odds);
    GlobalMap global(config.submap_cells(), config.resolution_m);
    std::mt19937 rng(5);
    Eigen::Vector3d body(0.5, 0.5, 0.5);
    for (int frame = 0; frame < 200; ++frame) {
      body += randomStep(0.8, 0.5 * shape.z_step_m, rng);
      map.recenter(body, &global);
      std::vector<VoxelIndex> hits;
      std::vector<VoxelIndex> frees;
      fewUpdatesAround(body, 12, shape.z_run_max, rng, &hits, &frees);
      map.integrate(makeBatch(body, hits, frees));
    }
    LocalWindow copy;
    map.copyWindow(&copy);
    std::vector<VoxelIndex> occupied;  // the slow reference: every voxel of the copy
    for (int x = 0; x < copy.size.x(); ++x)
      for (int y = 0; y < copy.size.y(); ++y)
        for (int z = 0; z < copy.size.z(); ++z) {
          const VoxelIndex g = copy.min_index + VoxelIndex(x, y, z);
          if (copy.state(g) == Occupancy::kOccupied) occupied.push_back(g);
        }
    ASSERT_GE(occupied.size(), 5u);  // the extreme model's misses erase most of them

    LocalMap loaded(config, shape.log_odds);
    loaded.restoreWindow(copy);
    LocalWindow round_trip;
    loaded.copyWindow(&round_trip);
    EXPECT_EQ(round_trip.min_index, copy.min_index);
    EXPECT_TRUE(round_trip.log_odds == copy.log_odds);
    std::vector<VoxelIndex> listed;
    loaded.forEachOccupied([&](const VoxelIndex& g, double) { listed.push_back(g); });
    EXPECT_EQ(listed, occupied);

    loaded.restoreWindow(LocalWindow{});
    EXPECT_FALSE(loaded.placed());
    GlobalMap empty(config.submap_cells(), config.resolution_m);
    loaded.recenter(body, &empty);
    std::size_t known = 0;
    for (int x = 0; x < config.size_cells.x(); ++x)
      for (int y = 0; y < config.size_cells.y(); ++y)
        for (int z = 0; z < config.size_cells.z(); ++z) {
          known +=
              loaded.state(loaded.minIndex() + VoxelIndex(x, y, z)) != Occupancy::kUnknown ? 1 : 0;
        }
    EXPECT_EQ(known, 0u) << "values survived an empty window";
  }
}

TEST(LocalMap, SlidingRoundTripKeepsOccupiedVoxelsWhereTheyWere) {
  LocalMapConfig config;
  config.resolution_m = 0.2;
  config.size_cells = {25, 25, 10};
  LocalMap map(config, LogOddsConfig{});
  GlobalMap global(config.submap_cells(), config.resolution_m);
  const Eigen::Vector3d home(0.1, 0.1, 0.1);
  map.recenter(home, &global);
  std::vector<VoxelIndex> hits = {{1, 2, 0}, {-3, 4, 1}, {5, -5, -2}, {0, 0, 3}};
  for (int i = 0; i < 3; ++i) map.integrate(makeBatch(home, hits, {}));
  // Fly 60 m away in a loop and come back.
  for (double x = 0.0; x < 60.0; x += 0.5)
    map.recenter(home + Eigen::Vector3d(x, 0.3 * x, 0.0), &global);
  for (const VoxelIndex& h : hits) EXPECT_FALSE(map.contains(h));
  EXPECT_EQ(global.voxelCount(), hits.size());
  for (double x = 60.0; x >= 0.0; x -= 0.5)
    map.recenter(home + Eigen::Vector3d(x, -0.2 * x, 0.0), &global);
  for (const VoxelIndex& h : hits) {
    double l = 0.0;
    ASSERT_TRUE(map.logOdds(h, &l)) << h.transpose();
    EXPECT_NEAR(l, 3 * 0.85, 1e-9);
  }
  EXPECT_EQ(global.voxelCount(), 0u);
}

// Hits beyond the window go to the global map (GlobalMap::addHits): against a std::map of the
// voxels hit, one hit per distinct voxel and call, over calls that hit new and stored voxels of
// the same submaps in any order; hits past the submap index range are counted lost. A submap
// that enters the window brings them into the local map.
TEST(LocalGlobal, HitsBeyondTheWindowReachTheGlobalMapAndComeBackWithTheirSubmap) {
  const LocalMapConfig config = smallMap();
  const LogOddsConfig log_odds;
  const LogOddsModel model(log_odds);
  GlobalMap global(config.submap_cells(), config.resolution_m);
  std::map<test::Key, LogOddsQ> reference;
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> coord(-9, 9);
  std::uint64_t lost = 0;
  std::uint64_t expected_lost = 0;
  for (int call = 0; call < 30; ++call) {
    std::vector<VoxelIndex> hits;
    std::set<test::Key> distinct;
    for (int i = 0; i < 40; ++i) {
      const int x = coord(rng);
      const int y = coord(rng);
      const int z = coord(rng) / 3;
      const VoxelIndex v(x + 40, y, z);  // far from the window placed below
      hits.push_back(v);
      if (i % 7 == 0) hits.push_back(v);  // repeated in a call: one hit
      distinct.insert(test::key(v));
    }
    if (call % 10 == 0) {  // a submap index past the limit: no layer holds it
      hits.emplace_back(2 * GlobalMap::kSubmapIndexLimit * config.submap_cells().x(), 0, 0);
      ++expected_lost;
    }
    std::shuffle(hits.begin(), hits.end(), rng);
    EXPECT_EQ(global.addHits(&hits, model, &lost), distinct.size());
    EXPECT_TRUE(hits.empty());
    for (const test::Key& k : distinct) {
      auto it = reference.emplace(k, kUnknownLogOdds).first;
      model.hit(it->second);
    }
  }
  EXPECT_EQ(lost, expected_lost);
  ASSERT_EQ(global.voxelCount(), reference.size());
  std::map<test::Key, LogOddsQ> stored;
  global.forEachSubmap([&](const SubmapIndex& m, const std::vector<VoxelRecord>& records) {
    EXPECT_TRUE(std::is_sorted(
        records.begin(), records.end(),
        [](const VoxelRecord& a, const VoxelRecord& b) { return a.offset < b.offset; }));
    const Eigen::Vector3i n = config.submap_cells();
    for (const VoxelRecord& r : records) {
      const int x = static_cast<int>(r.offset) / (n.y() * n.z());
      const int y = static_cast<int>(r.offset) / n.z() % n.y();
      const int z = static_cast<int>(r.offset) % n.z();
      stored[test::key(m.cwiseProduct(n) + VoxelIndex(x, y, z))] = r.log_odds;
    }
  });
  EXPECT_EQ(stored, reference);
  // The window flies there: every stored hit is in the local map, as the reference has it.
  LocalMap map(config, log_odds);
  map.recenter(Eigen::Vector3d(40.5, 0.5, 0.5), &global);
  for (const auto& [k, v] : reference) {
    if (!map.contains(test::index(k))) continue;
    double l = 0.0;
    ASSERT_TRUE(map.logOdds(test::index(k), &l));
    EXPECT_EQ(l, dequantizeLogOdds(v));
  }
}

TEST(LocalGlobal, GlobalMemoryGrowsWithOccupiedVoxelsNotWithTheAreaFlown) {
  LocalMapConfig config;
  config.resolution_m = 0.2;
  config.size_cells = {25, 25, 10};
  LocalMap map(config, LogOddsConfig{});
  GlobalMap global(config.submap_cells(), config.resolution_m);
  Eigen::Vector3d body(0.1, 0.1, 0.1);
  map.recenter(body, &global);
  // 500 m through free space: every voxel seen is free.
  std::vector<VoxelIndex> frees;
  for (int i = -10; i < 10; ++i) frees.push_back(VoxelIndex(i, 0, 0));
  for (double x = 0.0; x < 500.0; x += 0.5) {
    body.x() = x;
    map.recenter(body, &global);
    const VoxelIndex b = voxelIndexOf(body, 0.2);
    std::vector<VoxelIndex> f;
    f.reserve(frees.size());
    for (const auto& v : frees) f.push_back(b + v);
    map.integrate(makeBatch(body, {}, f));
  }
  EXPECT_EQ(global.voxelCount(), 0u);
  EXPECT_LT(global.memoryBytes(), 4096u);
  // The same flight along a wall (4 voxels high, one voxel per 0.2 m): memory follows the
  // occupied voxels.
  std::size_t obstacles = 0;
  for (double x = 500.1; x < 1000.0; x += 0.2) {
    body.x() = x;
    map.recenter(body, &global);
    const VoxelIndex b = voxelIndexOf(body, 0.2);
    std::vector<VoxelIndex> hits;
    hits.reserve(4);
    for (int z = 0; z < 4; ++z) hits.push_back(b + VoxelIndex(0, 5, z));
    obstacles += hits.size();
    map.integrate(makeBatch(body, hits, {}));
  }
  map.recenter(body + Eigen::Vector3d(100.0, 0.0, 0.0), &global);  // retire everything
  EXPECT_EQ(global.voxelCount(), obstacles);
  const double bytes_per_voxel =
      static_cast<double>(global.memoryBytes()) / static_cast<double>(obstacles);
  EXPECT_LT(bytes_per_voxel, 16.0) << "global map bytes per occupied voxel";
  std::printf("global map: %zu occupied voxels in %zu bytes (%.1f B/voxel)\n", obstacles,
              global.memoryBytes(), bytes_per_voxel);
}

}  // namespace
}  // namespace mlmap
