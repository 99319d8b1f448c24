// mlmap_bench_esdf: cost of a full ESDF update (EsdfMap::compute) on the local map's box, and
// of distance + gradient queries. The box is the simulator's default room rasterised around a
// point of the default flight: occupied where a static solid touches the voxel, free elsewhere,
// unknown beyond a plane 5 m ahead (x), below the floor slab and outside the room's footprint
// (never seen), so both unknown policies have work to do.
//
// Then the streamed part: the engine maps the default flight (depth camera, moving person) at
// 0.2 m and 0.1 m over a 19 x 19 x 7 m window; the window's states after every frame are kept,
// and the ESDF is brought from one frame's box to the next by EsdfMap::update() (incremental,
// the window's moves included), by compute() (whole, one thread) and, where built with it, by
// DynamicEDT3D fed the same obstacle changes (only between frames where the window stays, as it
// cannot move its grid). Distances are compared cell by cell. Each side is timed on its own work
// only: update() is given the box as a map engine has just filled it (the window's changed
// submaps copied in, untimed) and finds its changed voxels itself; DynamicEDT3D is given its list
// of changed voxels (prepared untimed). Figures, not pass/fail.

#include "mlmap/core/stopwatch.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/eval/sim_flight.h"
#include "mlmap/planning/esdf.h"
#include "mlmap/planning/esdf_query_grid.h"
#include "mlmap/sim/world.h"
#include "../support/random_draws.h"

#include <CLI/CLI.hpp>

#if defined(MLMAP_HAVE_DYNAMICEDT3D)
#include <dynamicEDT3D/dynamicEDT3D.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numeric>
#include <random>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace mlmap;
using Clock = SteadyClock;

/// Nearest-rank percentile of the samples (sorted in place).
double percentile(std::vector<double>* samples, double fraction) {
  std::sort(samples->begin(), samples->end());
  const double rank = std::ceil(fraction * static_cast<double>(samples->size()));
  const std::size_t i = static_cast<std::size_t>(std::max(rank, 1.0)) - 1;
  return (*samples)[std::min(i, samples->size() - 1)];
}

/// The default room rasterised into a box of `size` voxels centred on `center_W`.
OccupancyBox rasterise(const sim::World& world, const Eigen::Vector3d& center_W, double res,
                       const Eigen::Vector3i& size, double unknown_beyond_x_m) {
  OccupancyBox box;
  box.reset(voxelIndexOf(center_W, res) - size / 2, size, res, Occupancy::kFree);
  const Eigen::Vector3d shrink = Eigen::Vector3d::Constant(1e-6);
  const Eigen::AlignedBox3d room = world.bounds();  // footprint and floor slab of the room
  for (int x = 0; x < size.x(); ++x) {
    for (int y = 0; y < size.y(); ++y) {
      for (int z = 0; z < size.z(); ++z) {
        const VoxelIndex g = box.min_index + VoxelIndex(x, y, z);
        const Eigen::Vector3d lo = g.cast<double>() * res;
        const Eigen::Vector3d hi = lo + Eigen::Vector3d::Constant(res);
        const Eigen::Vector3d c = voxelCenter(g, res);
        Occupancy& s = box.at(g);
        if (c.x() > unknown_beyond_x_m || c.z() < room.min().z() || c.x() < room.min().x() ||
            c.x() > room.max().x() || c.y() < room.min().y() || c.y() > room.max().y()) {
          s = Occupancy::kUnknown;
        } else if (world.intersectsBox(lo + shrink, hi - shrink, 0.0)) {
          s = Occupancy::kOccupied;
        }
      }
    }
  }
  return box;
}

struct Row {
  std::string name;
  std::string unknown_as;
  int threads = 1;
  std::string passes;  ///< "windowed" (the default where it applies) or "envelope" (forced)
  double min_ms = 0.0;
  double median_ms = 0.0;
  double p99_ms = 0.0;
  std::size_t memory_bytes = 0;
  double mqueries_random = 0.0;  ///< M queries/s at random points of the box
  double mqueries_path = 0.0;    ///< M queries/s along 2 m segments
  double mqueries_batch = 0.0;   ///< M queries/s at random points, queryBatch() of 256
  double checksum = 0.0;
  double random_checksum = 0.0;   ///< query()'s sum at the random points
  double batch_checksum = 0.0;    ///< queryBatch()'s at the same points (equal)
  double grid_build_ms = 0.0;     ///< EsdfQueryGrid::build() from the map, median
  std::size_t grid_bytes = 0;     ///< the query grid's memory
  double grid_random = 0.0;       ///< M queries/s of EsdfQueryGrid::query() at the random points
  double grid_path = 0.0;         ///< ... along the segments
  double grid_batch = 0.0;        ///< ... EsdfQueryGrid::queryBatch() at the random points
  double grid_max_error_m = 0.0;  ///< largest |grid - exact| distance at the random points
};

Row run(const std::string& name, const OccupancyBox& box, UnknownAs unknown_as, int threads,
        bool envelope_only, int repeats, int queries) {
  EsdfConfig config;
  config.unknown_as = unknown_as;
  config.num_threads = threads;
  EsdfMap map(config);
  map.setEnvelopeOnly(envelope_only);
  Row row{name, toString(unknown_as), threads, envelope_only ? "envelope" : "windowed"};
  if (!map.compute(box)) {  // warm-up: first-time allocation is not measured
    std::fprintf(stderr, "%s: box rejected\n", name.c_str());
    return row;
  }
  std::vector<double> samples;
  for (int r = 0; r < repeats; ++r) {
    const Clock::time_point start = Clock::now();
    const bool ok = map.compute(box);
    samples.push_back(msSince(start));
    if (!ok) return row;
  }
  row.min_ms = percentile(&samples, 0.0);
  row.median_ms = percentile(&samples, 0.5);
  row.p99_ms = percentile(&samples, 0.99);
  row.memory_bytes = map.memoryBytes();

  // Queries (one thread) cycling over 64k points: uniformly random in the box, then along random
  // 2 m segments sampled every 5 cm (how a planner checks a trajectory).
  std::mt19937 rng(1);
  const Eigen::Vector3d lo = map.minCorner_W();
  const Eigen::Vector3d extent = map.maxCorner_W() - lo;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> random_points(1 << 16);
  for (Eigen::Vector3d& p : random_points) {
    p = lo + test::draw3(u, rng).cwiseProduct(extent) * 0.999999;
  }
  std::vector<Eigen::Vector3d> path_points;
  while (path_points.size() < random_points.size()) {
    const Eigen::Vector3d start = lo + test::draw3(u, rng).cwiseProduct(extent);
    const Eigen::Vector3d dir = (test::draw3(u, rng) - Eigen::Vector3d::Constant(0.5)).normalized();
    for (int i = 0; i < 40 && path_points.size() < random_points.size(); ++i) {
      path_points.push_back(start + dir * (0.05 * i));
    }
  }
  const auto throughput = [&](const auto& source, const std::vector<Eigen::Vector3d>& points,
                              double* checksum) {
    double sum = 0.0;
    const std::size_t mask = points.size() - 1;
    const Clock::time_point start = Clock::now();
    for (int i = 0; i < queries; ++i) {
      const EsdfMap::Query q = source.query(points[static_cast<std::size_t>(i) & mask]);
      sum += q.distance_m + q.gradient.sum() + (q.valid ? 1.0 : 0.0);
    }
    const double seconds = msSince(start) / 1e3;
    *checksum += sum;
    return queries / seconds / 1e6;
  };
  // The same random points through queryBatch(), 256 at a time; its checksum must equal the
  // loop's (the same results).
  const auto batch_throughput = [&](const auto& source, double* checksum) {
    constexpr std::size_t kBatch = 256;
    std::vector<EsdfMap::Query> results(kBatch);
    double sum = 0.0;
    const std::size_t mask = random_points.size() - 1;
    const Clock::time_point start = Clock::now();
    for (std::size_t i = 0; i < static_cast<std::size_t>(queries); i += kBatch) {
      const std::size_t n = std::min(kBatch, static_cast<std::size_t>(queries) - i);
      source.queryBatch(random_points.data() + (i & mask), n, results.data());
      for (std::size_t j = 0; j < n; ++j) {
        sum += results[j].distance_m + results[j].gradient.sum() + (results[j].valid ? 1.0 : 0.0);
      }
    }
    const double seconds = msSince(start) / 1e3;
    *checksum = sum;
    return queries / seconds / 1e6;
  };
  row.mqueries_random = throughput(map, random_points, &row.random_checksum);
  row.mqueries_path = throughput(map, path_points, &row.checksum);
  row.mqueries_batch = batch_throughput(map, &row.batch_checksum);

  // The quantised query grid: its build from the map, its queries at the same points.
  EsdfQueryGrid grid;
  std::vector<double> build_ms;
  for (int r = 0; r < std::max(3, repeats / 4); ++r) {
    const Clock::time_point start = Clock::now();
    grid.build(map);
    build_ms.push_back(msSince(start));
  }
  row.grid_build_ms = percentile(&build_ms, 0.5);
  row.grid_bytes = grid.memoryBytes();
  double grid_checksum = 0.0;
  row.grid_random = throughput(grid, random_points, &grid_checksum);
  row.grid_path = throughput(grid, path_points, &grid_checksum);
  row.grid_batch = batch_throughput(grid, &grid_checksum);
  for (const Eigen::Vector3d& p : random_points) {
    row.grid_max_error_m = std::max(row.grid_max_error_m,
                                    std::abs(grid.query(p).distance_m - map.query(p).distance_m));
  }
  return row;
}

void print(const Row& r, std::FILE* json, bool last) {
  if (json == nullptr) {
    std::printf(
        "%-24s %-9s %-8s %7d %7.3f %7.3f %7.3f %7.2f %8.1f %8.1f %8.1f   (checksums "
        "%.6g, random %.6g, batch %.6g)\n",
        r.name.c_str(), r.unknown_as.c_str(), r.passes.c_str(), r.threads, r.min_ms, r.median_ms,
        r.p99_ms, static_cast<double>(r.memory_bytes) / 1e6, r.mqueries_random, r.mqueries_path,
        r.mqueries_batch, r.checksum, r.random_checksum, r.batch_checksum);
    std::printf(
        "%-24s   query grid: build %.3f ms, %.1f MB, M queries/s random %.1f, paths %.1f, "
        "batch %.1f; max distance error %.1f um\n",
        "", r.grid_build_ms, static_cast<double>(r.grid_bytes) / 1e6, r.grid_random, r.grid_path,
        r.grid_batch, r.grid_max_error_m * 1e6);
    return;
  }
  std::fprintf(json,
               "  {\"case\": \"%s\", \"unknown_as\": \"%s\", \"passes\": \"%s\", "
               "\"threads\": %d, "
               "\"compute_ms\": {\"min\": %.4f, \"median\": %.4f, \"p99\": %.4f}, "
               "\"memory_bytes\": %zu, \"mqueries_per_s\": {\"random\": %.2f, \"path\": %.2f, "
               "\"random_batch\": %.2f}, \"query_grid\": {\"build_ms\": %.4f, \"bytes\": %zu, "
               "\"mqueries_per_s\": {\"random\": %.2f, \"path\": %.2f, \"random_batch\": %.2f}, "
               "\"max_error_m\": %.7f}}%s\n",
               r.name.c_str(), r.unknown_as.c_str(), r.passes.c_str(), r.threads, r.min_ms,
               r.median_ms, r.p99_ms, r.memory_bytes, r.mqueries_random, r.mqueries_path,
               r.mqueries_batch, r.grid_build_ms, r.grid_bytes, r.grid_random, r.grid_path,
               r.grid_batch, r.grid_max_error_m, last ? "" : ",");
}

/// The window's states after each frame of the default flight mapped at `res` over a
/// 19 x 19 x 7 m window (the first `frames` frames).
/// The window's states after each streamed frame, and where they may have changed since the
/// frame before: the window's submaps with a later state stamp (what a map engine knows; the
/// ESDF box of mlmap_node is filled from the same stamps).
struct Streamed {
  std::vector<OccupancyBox> boxes;
  std::vector<std::vector<EsdfMap::Region>> changed;  ///< per box, in its coordinates
};

Streamed streamedBoxes(double res, int frames) {
  const datasets::Scenario scenario = datasets::defaultScenario();
  MapConfig config;
  config.local_map.resolution_m = res;
  const int n = static_cast<int>(std::lround(19.0 / res / 5.0)) * 5;
  config.local_map.size_cells = {n, n, static_cast<int>(std::lround(7.0 / res / 5.0)) * 5};
  config.pipeline.planning_layers = false;
  MapEngine engine(config);
  Streamed out;
  LocalWindow window;
  std::uint64_t clock = 0;
  eval::FlightOptions options;
  options.max_frames = frames;
  options.progress = [&](int, int) {
    const LocalMap& local = engine.localMap();
    local.copyWindow(&window);
    OccupancyBox box;
    box.reset(window.min_index, window.size, window.resolution_m);
    for (std::size_t i = 0; i < box.states.size(); ++i) {
      box.states[i] = window.model.state(window.log_odds[i]);
    }
    out.boxes.push_back(std::move(box));
    std::vector<EsdfMap::Region> changed;
    const Eigen::Vector3i cells = config.local_map.submap_cells();
    const int half = LocalMapConfig::kSubmapsPerAxis / 2;
    for (int x = -half; x <= half; ++x)
      for (int y = -half; y <= half; ++y)
        for (int z = -half; z <= half; ++z) {
          const SubmapIndex m = local.centerSubmap() + SubmapIndex(x, y, z);
          if (local.submapStateChangedAt(m) <= clock) continue;
          const Eigen::Vector3i lo =
              Eigen::Vector3i(x + half, y + half, z + half).cwiseProduct(cells);
          changed.push_back({lo, lo + cells});
        }
    out.changed.push_back(std::move(changed));
    clock = local.changeClock();
  };
  eval::flyScenario(scenario, engine, options);
  return out;
}

/// Copies the voxels of `regions` (box coordinates, clipped) from `from` into `to` (same geometry).
void copyRegions(const OccupancyBox& from, const std::vector<EsdfMap::Region>& regions,
                 OccupancyBox* to) {
  for (const EsdfMap::Region& r : regions) {
    const Eigen::Vector3i lo = r.lo.cwiseMax(0);
    const Eigen::Vector3i hi = r.hi.cwiseMin(from.size);
    if ((hi.array() <= lo.array()).any()) continue;
    for (int x = lo.x(); x < hi.x(); ++x) {
      for (int y = lo.y(); y < hi.y(); ++y) {
        const std::size_t first =
            (static_cast<std::size_t>(x) * from.size.y() + y) * from.size.z() + lo.z();
        std::copy_n(from.states.begin() + static_cast<std::ptrdiff_t>(first), hi.z() - lo.z(),
                    to->states.begin() + static_cast<std::ptrdiff_t>(first));
      }
    }
  }
}

bool isObstacle(Occupancy s, UnknownAs unknown_as) {
  return s == Occupancy::kOccupied ||
         (s == Occupancy::kUnknown && unknown_as == UnknownAs::kOccupied);
}

struct StreamRow {
  std::string name;
  std::string unknown_as;
  int updates = 0;
  int shifted = 0;
  int full = 0;
  double changed_states = 0.0;  ///< median per frame
  double rows = 0.0;            ///< median rows swept again per frame
  double y_lines = 0.0;         ///< median y lines transformed again per frame
  double z_lines = 0.0;         ///< median z lines transformed again per frame
  double update_median_ms = 0.0;
  double update_p99_ms = 0.0;
  double update_max_ms = 0.0;
  double full_median_ms = 0.0;
  double full_p99_ms = 0.0;
  int moves = 0;                ///< frames where the window moved
  double move_median_ms = 0.0;  ///< update() on those frames
  double move_p99_ms = 0.0;
  double move_full_median_ms = 0.0;  ///< compute() on the same frames
  double grid_sync_median_ms = 0.0;  ///< EsdfQueryGrid::sync() after update(), per frame
  double grid_sync_p99_ms = 0.0;
  int mismatched_frames = 0;  ///< frames where update() differs from compute() (must be 0)
  int fill_mismatches = 0;    ///< frames whose box the changed submaps did not make (must be 0)
  int edt_updates = 0;
  double edt_median_ms = -1.0;
  double edt_p99_ms = -1.0;
  double same_box_median_ms = 0.0;  ///< update() on the frames DynamicEDT3D is timed on
  double edt_total_ms = 0.0;        ///< DynamicEDT3D over all its timed updates
  double same_box_total_ms = 0.0;   ///< update() over the same frames
  std::size_t edt_compared = 0;
  std::size_t edt_mismatched = 0;
  double edt_max_error_m = 0.0;
};

#if defined(MLMAP_HAVE_DYNAMICEDT3D)
/// DynamicEDT3D over one box's geometry, its obstacles set from the box.
std::unique_ptr<DynamicEDT3D> edtFor(const OccupancyBox& box, UnknownAs unknown_as, int cap_sq) {
  auto edt = std::make_unique<DynamicEDT3D>(cap_sq);
  edt->initializeEmpty(box.size.x(), box.size.y(), box.size.z(), true);
  for (int x = 0; x < box.size.x(); ++x)
    for (int y = 0; y < box.size.y(); ++y)
      for (int z = 0; z < box.size.z(); ++z)
        if (isObstacle(
                box.states[(static_cast<std::size_t>(x) * box.size.y() + y) * box.size.z() + z],
                unknown_as)) {
          edt->occupyCell(x, y, z);
        }
  edt->update(true);
  return edt;
}
#endif

StreamRow stream(const std::string& name, const Streamed& streamed, UnknownAs unknown_as,
                 bool with_edt, bool with_hints, int edt_compare_every) {
  const std::vector<OccupancyBox>& boxes = streamed.boxes;
  StreamRow row{name, toString(unknown_as)};
  EsdfConfig config;
  config.unknown_as = unknown_as;
  EsdfMap incremental(config);
  EsdfMap full(config);
  if (boxes.size() < 2 || !incremental.update(boxes[0]) || !full.compute(boxes[0])) return row;
  EsdfQueryGrid grid;  // kept up to date with the incremental field
  grid.build(incremental);
  std::vector<double> sync_ms;
  std::vector<double> update_ms;
  std::vector<double> full_ms;
  std::vector<double> move_ms;
  std::vector<double> move_full_ms;
  std::vector<double> same_box_ms;
  std::vector<double> edt_ms;
  std::vector<double> changed;
  std::vector<double> rows;
  std::vector<double> y_lines;
  std::vector<double> z_lines;
#if defined(MLMAP_HAVE_DYNAMICEDT3D)
  const double cap_cells = config.max_distance_m / boxes[0].resolution_m;
  const int cap_sq = static_cast<int>(std::lround(cap_cells * cap_cells));
  std::unique_ptr<DynamicEDT3D> edt;
  if (with_edt) edt = edtFor(boxes[0], unknown_as, cap_sq);
#else
  (void)with_edt;
  (void)edt_compare_every;
#endif
  // The box update() is given, filled as a map engine fills it before each update (untimed: it
  // is the engine's work, not the ESDF's): unmoved, the changed submaps are copied in, so they
  // are in the caches as in the engine; moved, the whole box.
  OccupancyBox live = boxes[0];
  for (std::size_t f = 1; f < boxes.size(); ++f) {
    const OccupancyBox& box = boxes[f];
    // Unmoved, both are told where the states may have changed (the window's changed submaps).
    const bool hinted = with_hints && box.min_index == boxes[f - 1].min_index;
    if (box.min_index == live.min_index && box.size == live.size) {
      copyRegions(box, streamed.changed[f], &live);
    } else {
      live = box;
    }
    Clock::time_point start = Clock::now();
    if (!(hinted ? incremental.update(live, streamed.changed[f]) : incremental.update(live))) {
      return row;
    }
    update_ms.push_back(msSince(start));
    if (live.states != box.states) ++row.fill_mismatches;  // the hints missed a change
    start = Clock::now();
    grid.sync(incremental);
    sync_ms.push_back(msSince(start));
    const EsdfMap::UpdateStats& u = incremental.lastUpdate();
    row.shifted += u.shifted ? 1 : 0;
    row.full += u.full ? 1 : 0;
    changed.push_back(static_cast<double>(u.changed_states));
    rows.push_back(static_cast<double>(u.rows_swept));
    y_lines.push_back(static_cast<double>(u.y_lines));
    z_lines.push_back(static_cast<double>(u.z_lines));
    start = Clock::now();
    if (!full.compute(box)) return row;
    full_ms.push_back(msSince(start));
    if (box.min_index != boxes[f - 1].min_index) {
      move_ms.push_back(update_ms.back());
      move_full_ms.push_back(full_ms.back());
    }
    row.mismatched_frames += incremental.distances() == full.distances() ? 0 : 1;
#if defined(MLMAP_HAVE_DYNAMICEDT3D)
    if (!with_edt) continue;
    const OccupancyBox& before = boxes[f - 1];
    if (box.min_index != before.min_index || box.size != before.size) {
      edt = edtFor(box, unknown_as, cap_sq);  // the window moved: a new grid (not timed)
      continue;
    }
    same_box_ms.push_back(update_ms.back());
    // Its changes, listed beforehand (not timed: only its own work is), whereas update() finds
    // ours itself.
    std::vector<std::pair<Eigen::Vector3i, bool>> changes;  // voxel, obstacle now
    for (std::size_t i = 0; i < box.states.size(); ++i) {
      const bool now = isObstacle(box.states[i], unknown_as);
      if (now == isObstacle(before.states[i], unknown_as)) continue;
      const int x = static_cast<int>(i / (static_cast<std::size_t>(box.size.y()) * box.size.z()));
      const int y = static_cast<int>((i / box.size.z()) % box.size.y());
      const int z = static_cast<int>(i % box.size.z());
      changes.emplace_back(Eigen::Vector3i(x, y, z), now);
    }
    start = Clock::now();
    for (const auto& [v, now] : changes) {
      if (now) {
        edt->occupyCell(v.x(), v.y(), v.z());
      } else {
        edt->clearCell(v.x(), v.y(), v.z());
      }
    }
    edt->update(true);
    edt_ms.push_back(msSince(start));
    if (edt_compare_every <= 0 ||
        edt_ms.size() % static_cast<std::size_t>(edt_compare_every) != 0) {
      continue;
    }
    // Distances to obstacles at the non-obstacle voxels (DynamicEDT3D's field), both clamped.
    const float max_m = static_cast<float>(config.max_distance_m);
    for (int x = 0; x < box.size.x(); ++x) {
      for (int y = 0; y < box.size.y(); ++y) {
        for (int z = 0; z < box.size.z(); ++z) {
          const std::size_t i = (static_cast<std::size_t>(x) * box.size.y() + y) * box.size.z() + z;
          if (isObstacle(box.states[i], unknown_as)) continue;
          const float theirs = std::min(
              static_cast<float>(std::sqrt(static_cast<double>(edt->getSQCellDistance(x, y, z))) *
                                 box.resolution_m),
              max_m);
          const float ours = incremental.distances()[i];
          const double error = std::abs(static_cast<double>(theirs) - ours);
          ++row.edt_compared;
          if (error > 1e-5) ++row.edt_mismatched;
          row.edt_max_error_m = std::max(row.edt_max_error_m, error);
        }
      }
    }
#endif
  }
  row.updates = static_cast<int>(update_ms.size());
  row.changed_states = percentile(&changed, 0.5);
  row.rows = percentile(&rows, 0.5);
  row.y_lines = percentile(&y_lines, 0.5);
  row.z_lines = percentile(&z_lines, 0.5);
  row.update_median_ms = percentile(&update_ms, 0.5);
  row.update_p99_ms = percentile(&update_ms, 0.99);
  row.update_max_ms = percentile(&update_ms, 1.0);
  row.full_median_ms = percentile(&full_ms, 0.5);
  row.full_p99_ms = percentile(&full_ms, 0.99);
  if (!move_ms.empty()) {
    row.moves = static_cast<int>(move_ms.size());
    row.move_median_ms = percentile(&move_ms, 0.5);
    row.move_p99_ms = percentile(&move_ms, 0.99);
    row.move_full_median_ms = percentile(&move_full_ms, 0.5);
  }
  row.grid_sync_median_ms = percentile(&sync_ms, 0.5);
  row.grid_sync_p99_ms = percentile(&sync_ms, 0.99);
  if (!edt_ms.empty()) {
    row.edt_updates = static_cast<int>(edt_ms.size());
    row.edt_median_ms = percentile(&edt_ms, 0.5);
    row.edt_p99_ms = percentile(&edt_ms, 0.99);
    row.same_box_median_ms = percentile(&same_box_ms, 0.5);
    row.edt_total_ms = std::accumulate(edt_ms.begin(), edt_ms.end(), 0.0);
    row.same_box_total_ms = std::accumulate(same_box_ms.begin(), same_box_ms.end(), 0.0);
  }
  return row;
}

void printStream(const StreamRow& r, std::FILE* json, bool last) {
  if (json == nullptr) {
    std::printf(
        "%-10s %-9s %4d %4d %4d %8.0f %7.3f %7.3f %7.3f %7.3f %7.3f %4d | %4d %8.3f %8.3f "
        "%7.3f %6.1fx  all %d: %.1f / %.1f ms (%.1fx); mismatched %zu of %zu (max %.3f m); "
        "lines %.0f %.0f %.0f; query grid sync %.3f / %.3f ms; %d moves: update() %.3f / "
        "%.3f ms, compute() %.3f ms\n",
        r.name.c_str(), r.unknown_as.c_str(), r.updates, r.shifted, r.full, r.changed_states,
        r.update_median_ms, r.update_p99_ms, r.update_max_ms, r.full_median_ms, r.full_p99_ms,
        r.mismatched_frames, r.edt_updates, r.edt_median_ms, r.edt_p99_ms, r.same_box_median_ms,
        r.same_box_median_ms > 0.0 ? r.edt_median_ms / r.same_box_median_ms : 0.0, r.edt_updates,
        r.edt_total_ms, r.same_box_total_ms,
        r.same_box_total_ms > 0.0 ? r.edt_total_ms / r.same_box_total_ms : 0.0, r.edt_mismatched,
        r.edt_compared, r.edt_max_error_m, r.rows, r.y_lines, r.z_lines, r.grid_sync_median_ms,
        r.grid_sync_p99_ms, r.moves, r.move_median_ms, r.move_p99_ms, r.move_full_median_ms);
    return;
  }
  std::fprintf(
      json,
      "  {\"case\": \"%s\", \"unknown_as\": \"%s\", \"updates\": %d, \"shifted\": %d, "
      "\"full\": %d, \"changed_states_median\": %.0f, "
      "\"lines_median\": {\"x_rows\": %.0f, \"y\": %.0f, \"z\": %.0f}, "
      "\"update_ms\": {\"median\": %.4f, \"p99\": %.4f, \"max\": %.4f}, "
      "\"compute_ms\": {\"median\": %.4f, \"p99\": %.4f}, "
      "\"moves\": %d, \"move_update_ms\": {\"median\": %.4f, \"p99\": %.4f}, "
      "\"move_compute_median_ms\": %.4f, "
      "\"query_grid_sync_ms\": {\"median\": %.4f, \"p99\": %.4f}, \"mismatched_frames\": %d, "
      "\"dynamicedt3d\": {\"updates\": %d, \"median_ms\": %.4f, \"p99_ms\": %.4f, "
      "\"ours_same_frames_median_ms\": %.4f, \"total_ms\": %.3f, "
      "\"ours_same_frames_total_ms\": %.3f, \"compared\": %zu, \"mismatched\": %zu, "
      "\"max_error_m\": %.4f}}%s\n",
      r.name.c_str(), r.unknown_as.c_str(), r.updates, r.shifted, r.full, r.changed_states, r.rows,
      r.y_lines, r.z_lines, r.update_median_ms, r.update_p99_ms, r.update_max_ms, r.full_median_ms,
      r.full_p99_ms, r.moves, r.move_median_ms, r.move_p99_ms, r.move_full_median_ms,
      r.grid_sync_median_ms, r.grid_sync_p99_ms, r.mismatched_frames, r.edt_updates,
      r.edt_median_ms, r.edt_p99_ms, r.same_box_median_ms, r.edt_total_ms, r.same_box_total_ms,
      r.edt_compared, r.edt_mismatched, r.edt_max_error_m, last ? "" : ",");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap ESDF benchmark: full-update time and query throughput on the default room"};
  int repeats = 30;
  int queries = 10000000;
  std::string json_path;
  app.add_option("--repeats", repeats, "timed compute() calls per case")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  app.add_option("--queries", queries, "timed queries per case and column")
      ->check(CLI::Range(1, 1000000000))
      ->capture_default_str();
  app.add_option("--json", json_path, "also write the figures as JSON");
  int frames = 150;
  bool with_edt = true;
  int edt_compare_every = 10;
  bool only_streamed = false;
  bool with_hints = true;
  app.add_option("--frames", frames, "streamed frames of the default flight (0: none)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  app.add_flag("!--no-dynamicedt3d", with_edt, "skip DynamicEDT3D in the streamed part");
  app.add_option("--compare-every", edt_compare_every,
                 "compare with DynamicEDT3D's distances every N of its updates (0: never)")
      ->capture_default_str();
  app.add_flag("--streamed-only", only_streamed, "skip the single-box part");
  app.add_flag("!--no-hints", with_hints,
               "compare each streamed box whole, not only in the window's changed submaps");
  std::vector<double> resolutions{0.2, 0.1};
  app.add_option("--resolution", resolutions, "resolutions in metres (0.2, 0.1 or both)")
      ->check(CLI::IsMember({0.2, 0.1}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  const auto wanted = [&](double res) {
    return std::find(resolutions.begin(), resolutions.end(), res) != resolutions.end();
  };

  const sim::World world = sim::World::defaultRoom();
  const Eigen::Vector3d center_W(14.5, 4.5, 1.5);  // on the first leg of the default flight
  const double unknown_beyond_x_m = center_W.x() + 5.0;
  struct Scene {
    std::string name;
    OccupancyBox box;
  };
  std::vector<Scene> scenes;
  if (wanted(0.2)) {
    scenes.push_back(
        {"room 0.2 m 95x95x35", rasterise(world, center_W, 0.2, {95, 95, 35}, unknown_beyond_x_m)});
  }
  if (wanted(0.1)) {
    scenes.push_back({"room 0.1 m 190x190x70",
                      rasterise(world, center_W, 0.1, {190, 190, 70}, unknown_beyond_x_m)});
  }
  for (const Scene& s : scenes) {
    std::size_t occupied = 0;
    std::size_t unknown = 0;
    for (const Occupancy o : s.box.states) {
      occupied += o == Occupancy::kOccupied ? 1 : 0;
      unknown += o == Occupancy::kUnknown ? 1 : 0;
    }
    const double n = static_cast<double>(s.box.states.size());
    std::printf("%s: %zu voxels, %.1f%% occupied, %.1f%% unknown\n", s.name.c_str(),
                s.box.states.size(), 100.0 * static_cast<double>(occupied) / n,
                100.0 * static_cast<double>(unknown) / n);
  }
  std::printf(
      "max_distance_m %.1f, %d timed compute() per case, %d queries per column, "
      "%u hardware threads\n\n",
      EsdfConfig{}.max_distance_m, repeats, queries, std::thread::hardware_concurrency());
  std::printf("%-24s %-9s %-8s %7s %23s %7s %26s\n", "", "", "", "", "compute() ms", "memory",
              "M queries/s");
  std::printf("%-24s %-9s %-8s %7s %7s %7s %7s %7s %8s %8s %8s\n", "case", "unknown", "passes",
              "threads", "min", "median", "p99", "MB", "random", "paths", "batch");

  std::vector<Row> rows;
  for (const Scene& s : only_streamed ? std::vector<Scene>{} : scenes) {
    for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
      for (const int threads : {1, 2}) {
        rows.push_back(run(s.name, s.box, policy, threads, false, repeats, queries));
        print(rows.back(), nullptr, false);
      }
      // compute() with the envelope code for the y and z passes, for the ratio in this run.
      rows.push_back(run(s.name, s.box, policy, 1, true, repeats, queries));
      print(rows.back(), nullptr, false);
    }
  }

  std::vector<StreamRow> stream_rows;
  if (frames > 0) {
#if !defined(MLMAP_HAVE_DYNAMICEDT3D)
    with_edt = false;
    std::printf("\n(built without DynamicEDT3D: install libdynamicedt3d-dev and reconfigure)\n");
#endif
    std::printf(
        "\nStreamed: %d frames of the default flight, 19 x 19 x 7 m window; per frame "
        "(one thread)\n",
        frames);
    std::printf("%-10s %-9s %4s %4s %4s %8s %23s %15s %4s | %s\n", "", "", "", "", "", "changed",
                "update() ms", "compute() ms", "", "DynamicEDT3D (same frames)");
    std::printf("%-10s %-9s %4s %4s %4s %8s %7s %7s %7s %7s %7s %4s | %4s %8s %8s %7s %7s\n", "res",
                "unknown", "n", "move", "full", "states", "median", "p99", "max", "median", "p99",
                "diff", "n", "median", "p99", "ours", "ratio");
    for (const double res : {0.2, 0.1}) {
      if (!wanted(res)) continue;
      const Streamed streamed = streamedBoxes(res, frames);
      char name[32];
      std::snprintf(name, sizeof(name), "%.1f m", res);
      for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
        stream_rows.push_back(
            stream(name, streamed, policy, with_edt, with_hints, edt_compare_every));
        printStream(stream_rows.back(), nullptr, false);
        if (stream_rows.back().fill_mismatches > 0) {
          std::printf("  error: in %d frames the changed submaps missed a changed state\n",
                      stream_rows.back().fill_mismatches);
        }
      }
    }
  }
  if (!json_path.empty()) {
    std::FILE* json = std::fopen(json_path.c_str(), "w");
    if (json == nullptr) {
      std::fprintf(stderr, "%s: cannot write\n", json_path.c_str());
      return 1;
    }
    std::fprintf(json, "{\"boxes\": [\n");
    for (std::size_t i = 0; i < rows.size(); ++i) print(rows[i], json, i + 1 == rows.size());
    std::fprintf(json, "], \"streamed\": [\n");
    for (std::size_t i = 0; i < stream_rows.size(); ++i) {
      printStream(stream_rows[i], json, i + 1 == stream_rows.size());
    }
    std::fprintf(json, "]}\n");
    std::fclose(json);
  }
  return 0;
}
