#include "mlmap/planning/projected_grid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <utility>
#include <vector>
#include <random>

namespace mlmap {
namespace {

// A window with random unknown / free / occupied voxels.
LocalWindow randomWindow(std::mt19937& rng, double res) {
  LocalWindow w;
  w.min_index = VoxelIndex(-7, 4, -6);
  w.size = Eigen::Vector3i(10, 15, 20);
  w.resolution_m = res;
  std::uniform_int_distribution<int> kind(0, 5);
  std::uniform_int_distribution<int> value(-2000, 3500);
  for (int i = 0; i < w.size.prod(); ++i) {
    const int k = kind(rng);
    w.log_odds.push_back(k <= 2 ? kUnknownLogOdds : static_cast<LogOddsQ>(value(rng)));
  }
  return w;
}

// The definition, voxel by voxel: band voxels are those whose centre height is in the band.
std::int8_t directCell(const LocalWindow& w, int gx, int gy, double z_min, double z_max,
                       bool probability) {
  bool known = false;
  bool occupied = false;
  double highest = 0.0;
  for (int gz = w.min_index.z(); gz < w.min_index.z() + w.size.z(); ++gz) {
    const double zc = (gz + 0.5) * w.resolution_m;
    if (zc < z_min || zc > z_max) continue;
    const VoxelIndex g(gx, gy, gz);
    const Occupancy s = w.state(g);
    if (s == Occupancy::kUnknown) continue;
    const double p = probabilityFromLogOdds(dequantizeLogOdds(w.at(g)));
    highest = known ? std::max(highest, p) : p;
    known = true;
    occupied = occupied || s == Occupancy::kOccupied;
  }
  if (!known) return -1;
  if (probability) return static_cast<std::int8_t>(std::lround(100.0 * highest));
  return occupied ? 100 : 0;
}

void expectMatchesDirect(const LocalWindow& w, const ProjectedGridConfig& c, double body_z) {
  ProjectedGrid grid;
  projectToGrid(w, nullptr, c, body_z, &grid);
  const double offset = c.relative_band ? body_z : 0.0;
  ASSERT_EQ(grid.width, w.size.x());
  ASSERT_EQ(grid.height, w.size.y());
  EXPECT_DOUBLE_EQ(grid.origin_W.x(), w.min_index.x() * w.resolution_m);
  EXPECT_DOUBLE_EQ(grid.origin_W.y(), w.min_index.y() * w.resolution_m);
  int unknown = 0;
  int occupied = 0;
  for (int x = 0; x < grid.width; ++x) {
    for (int y = 0; y < grid.height; ++y) {
      const std::int8_t expected =
          directCell(w, w.min_index.x() + x, w.min_index.y() + y, c.band_min_m + offset,
                     c.band_max_m + offset, c.probability_values);
      ASSERT_EQ(grid.at(x, y), expected) << "cell " << x << " " << y;
      unknown += expected == -1;
      occupied += expected == 100;
    }
  }
  if (!c.probability_values) {
    EXPECT_GT(unknown, 0);  // the scene exercises every value
    EXPECT_GT(occupied, 0);
  }
}

// bandLayers() against the definition, layer by layer, over a range around the band.
TEST(ProjectedGrid, BandLayersAreTheLayersWhoseCentreLiesInTheBand) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> z(-40.0, 40.0);
  for (double res : {0.01, 0.05, 0.1, 0.3, 1.0}) {
    for (int trial = 0; trial < 300; ++trial) {
      double lo = z(rng);
      double hi = trial % 10 == 0 ? lo : z(rng);
      if (lo > hi) std::swap(lo, hi);
      int k0 = 0;
      int k1 = 0;
      bandLayers(lo, hi, res, &k0, &k1);
      const int scan0 = static_cast<int>(std::floor(lo / res)) - 5;
      const int scan1 = static_cast<int>(std::floor(hi / res)) + 5;
      for (int k = scan0; k <= scan1; ++k) {
        const double centre = (k + 0.5) * res;
        EXPECT_EQ(centre >= lo && centre <= hi, k >= k0 && k < k1)
            << "layer " << k << " of band [" << lo << ", " << hi << "] at " << res << " m";
      }
    }
  }
}

// Heights from options or files can be anything: the band's layers stay a short or empty
// range inside +-2^30 and the call returns at once (it used to loop past 2^31).
TEST(ProjectedGrid, AbsurdBandsGiveBoundedLayers) {
  const double nan = std::nan("");
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<std::pair<double, double>> bands = {
      {1e8, 2e8}, {1e300, 1e300 + 1}, {-1e300, 1e300}, {-inf, inf}, {nan, 1.0},
      {1.0, nan}, {2.0, 1.0},         {-2e8, -1e8},    {1e300, inf}};
  for (double res : {0.01, 0.1}) {
    for (const auto& [lo, hi] : bands) {
      int k0 = 7;
      int k1 = 7;
      bandLayers(lo, hi, res, &k0, &k1);
      EXPECT_LE(k0, k1) << lo << " .. " << hi;
      EXPECT_LE(std::abs(static_cast<long long>(k0)), (1LL << 30) + 8) << lo << " .. " << hi;
      EXPECT_LE(std::abs(static_cast<long long>(k1)), (1LL << 30) + 8) << lo << " .. " << hi;
      if (!(lo <= hi)) {
        EXPECT_EQ(k0, k1) << "an inverted or NaN band is empty";
      }
    }
  }
  // A grid projected with such a band is all unknown, and computing it takes no time.
  std::mt19937 rng(3);
  const LocalWindow w = randomWindow(rng, 0.1);
  ProjectedGridConfig c;
  c.relative_band = false;
  c.band_min_m = 1e8;
  c.band_max_m = 2e8;
  ProjectedGrid grid;
  projectToGrid(w, nullptr, c, 0.0, &grid);
  for (std::int8_t v : grid.cells) EXPECT_EQ(v, ProjectedGrid::kUnknown);
}

TEST(ProjectedGrid, MatchesADirectProjectionInBothBandModes) {
  std::mt19937 rng(3);
  for (double res : {0.2, 0.1}) {
    const LocalWindow w = randomWindow(rng, res);
    ProjectedGridConfig relative;  // -0.3..0.3 m around the body
    expectMatchesDirect(w, relative, 0.13);
    expectMatchesDirect(w, relative, -0.41);
    ProjectedGridConfig absolute;
    absolute.relative_band = false;
    absolute.band_min_m = -0.5;
    absolute.band_max_m = 0.1;
    expectMatchesDirect(w, absolute, 7.0);  // the body height does not matter
    absolute.probability_values = true;
    expectMatchesDirect(w, absolute, 0.0);
  }
}

TEST(ProjectedGrid, BandOutsideTheWindowIsUnknownAndLookupsWork) {
  std::mt19937 rng(4);
  const LocalWindow w = randomWindow(rng, 0.2);
  ProjectedGridConfig c;
  c.relative_band = false;
  c.band_min_m = 50.0;
  c.band_max_m = 51.0;
  ProjectedGrid grid;
  projectToGrid(w, nullptr, c, 0.0, &grid);
  for (std::int8_t v : grid.cells) EXPECT_EQ(v, ProjectedGrid::kUnknown);
  EXPECT_EQ(grid.valueAt({-100.0, 0.0}), ProjectedGrid::kUnknown);
}

TEST(ProjectedGrid, GlobalOccupiedVoxelsExtendTheGrid) {
  LocalWindow w;
  w.min_index = VoxelIndex(0, 0, -5);
  w.size = Eigen::Vector3i(10, 10, 10);
  w.resolution_m = 0.2;
  w.log_odds.assign(static_cast<std::size_t>(w.size.prod()), quantizeLogOdds(-1.0));  // all free
  GlobalMap global(Eigen::Vector3i(2, 2, 2), 0.2);
  // Submap (10, 0, 0) holds voxel (21, 1, 0) (centre z 0.1 m, in the band) and submap (10, 0, -2)
  // voxel (20, 0, -4) (centre -0.7 m, below it).
  global.store(SubmapIndex(10, 0, 0), {VoxelRecord{static_cast<std::uint32_t>((1 * 2 + 1) * 2 + 0),
                                                   quantizeLogOdds(2.0)}});
  global.store(SubmapIndex(10, 0, -2), {VoxelRecord{0, quantizeLogOdds(2.0)}});
  ProjectedGridConfig c;
  c.include_global = true;
  ProjectedGrid grid;
  projectToGrid(w, &global, c, 0.0, &grid);
  EXPECT_EQ(grid.width, 22);
  EXPECT_EQ(grid.height, 10);
  EXPECT_EQ(grid.valueAt({21.5 * 0.2, 1.5 * 0.2}), ProjectedGrid::kOccupied);
  EXPECT_EQ(grid.valueAt({20.5 * 0.2, 0.5 * 0.2}), ProjectedGrid::kUnknown);  // below the band
  EXPECT_EQ(grid.valueAt({1.0, 1.0}), ProjectedGrid::kFree);
  EXPECT_EQ(grid.valueAt({3.0, 1.0}), ProjectedGrid::kUnknown);  // between window and submap
  c.include_global = false;
  projectToGrid(w, &global, c, 0.0, &grid);
  EXPECT_EQ(grid.width, 10);
}

}  // namespace
}  // namespace mlmap
