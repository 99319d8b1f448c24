// mlmap_bench_esdf: cost of a full ESDF update (EsdfMap::compute) on the local map's box, and
// of distance + gradient queries. The box is the simulator's default room rasterised around a
// point of the default flight: occupied where a static solid touches the voxel, free elsewhere,
// unknown beyond a plane 5 m ahead (x), below the floor slab and outside the room's footprint
// (never seen), so both unknown policies have work to do. Figures, not pass/fail.

#include "mlmap/core/stopwatch.h"
#include "mlmap/planning/esdf.h"
#include "mlmap/sim/world.h"
#include "../support/random_draws.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
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
  double min_ms = 0.0;
  double median_ms = 0.0;
  double p99_ms = 0.0;
  std::size_t memory_bytes = 0;
  double mqueries_random = 0.0;  ///< M queries/s at random points of the box
  double mqueries_path = 0.0;    ///< M queries/s along 2 m segments
  double checksum = 0.0;
};

Row run(const std::string& name, const OccupancyBox& box, UnknownAs unknown_as, int threads,
        int repeats, int queries) {
  EsdfConfig config;
  config.unknown_as = unknown_as;
  config.num_threads = threads;
  EsdfMap map(config);
  Row row{name, toString(unknown_as), threads};
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
  const auto throughput = [&](const std::vector<Eigen::Vector3d>& points, double* checksum) {
    double sum = 0.0;
    const std::size_t mask = points.size() - 1;
    const Clock::time_point start = Clock::now();
    for (int i = 0; i < queries; ++i) {
      const EsdfMap::Query q = map.query(points[static_cast<std::size_t>(i) & mask]);
      sum += q.distance_m + q.gradient.sum() + (q.valid ? 1.0 : 0.0);
    }
    const double seconds = msSince(start) / 1e3;
    *checksum += sum;
    return queries / seconds / 1e6;
  };
  row.mqueries_random = throughput(random_points, &row.checksum);
  row.mqueries_path = throughput(path_points, &row.checksum);
  return row;
}

void print(const Row& r, std::FILE* json, bool last) {
  if (json == nullptr) {
    std::printf("%-24s %-9s %7d %7.3f %7.3f %7.3f %7.2f %8.1f %8.1f   (checksum %.6g)\n",
                r.name.c_str(), r.unknown_as.c_str(), r.threads, r.min_ms, r.median_ms, r.p99_ms,
                static_cast<double>(r.memory_bytes) / 1e6, r.mqueries_random, r.mqueries_path,
                r.checksum);
    return;
  }
  std::fprintf(json,
               "  {\"case\": \"%s\", \"unknown_as\": \"%s\", \"threads\": %d, "
               "\"compute_ms\": {\"min\": %.4f, \"median\": %.4f, \"p99\": %.4f}, "
               "\"memory_bytes\": %zu, \"mqueries_per_s\": {\"random\": %.2f, \"path\": %.2f}}%s\n",
               r.name.c_str(), r.unknown_as.c_str(), r.threads, r.min_ms, r.median_ms, r.p99_ms,
               r.memory_bytes, r.mqueries_random, r.mqueries_path, last ? "" : ",");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlmap ESDF benchmark: full-update time and query throughput on the default room"};
  int repeats = 30;
  int queries = 10000000;
  std::string json_path;
  app.add_option("--repeats", repeats, "timed compute() calls per case")
      ->check(CLI::Range(1, 10000))->capture_default_str();
  app.add_option("--queries", queries, "timed queries per case and column")
      ->check(CLI::Range(1, 1000000000))->capture_default_str();
  app.add_option("--json", json_path, "also write the figures as JSON");
  CLI11_PARSE(app, argc, argv);

  const sim::World world = sim::World::defaultRoom();
  const Eigen::Vector3d center_W(14.5, 4.5, 1.5);  // on the first leg of the default flight
  const double unknown_beyond_x_m = center_W.x() + 5.0;
  struct Scene {
    std::string name;
    OccupancyBox box;
  };
  std::vector<Scene> scenes;
  scenes.push_back({"room 0.2 m 95x95x35",
                    rasterise(world, center_W, 0.2, {95, 95, 35}, unknown_beyond_x_m)});
  scenes.push_back({"room 0.1 m 190x190x70",
                    rasterise(world, center_W, 0.1, {190, 190, 70}, unknown_beyond_x_m)});
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
  std::printf("max_distance_m %.1f, %d timed compute() per case, %d queries per column, "
              "%u hardware threads\n\n",
              EsdfConfig{}.max_distance_m, repeats, queries, std::thread::hardware_concurrency());
  std::printf("%-24s %-9s %7s %23s %7s %17s\n", "", "", "", "compute() ms", "memory",
              "M queries/s");
  std::printf("%-24s %-9s %7s %7s %7s %7s %7s %8s %8s\n", "case", "unknown", "threads", "min",
              "median", "p99", "MB", "random", "paths");

  std::vector<Row> rows;
  for (const Scene& s : scenes) {
    for (const UnknownAs policy : {UnknownAs::kOccupied, UnknownAs::kFree}) {
      for (const int threads : {1, 2}) {
        rows.push_back(run(s.name, s.box, policy, threads, repeats, queries));
        print(rows.back(), nullptr, false);
      }
    }
  }
  if (!json_path.empty()) {
    std::FILE* json = std::fopen(json_path.c_str(), "w");
    if (json == nullptr) {
      std::fprintf(stderr, "%s: cannot write\n", json_path.c_str());
      return 1;
    }
    std::fprintf(json, "[\n");
    for (std::size_t i = 0; i < rows.size(); ++i) print(rows[i], json, i + 1 == rows.size());
    std::fprintf(json, "]\n");
    std::fclose(json);
  }
  return 0;
}
