#include "mlmap/local/local_map.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <new>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace mlmap {
namespace {
constexpr int kHalfWindow = LocalMapConfig::kSubmapsPerAxis / 2;  // 2 submaps on each side
constexpr int kMaxShiftsPerCall = 8;
constexpr std::size_t kPageBytes = 4096;
}  // namespace

void LocalMap::writeFirst(std::size_t first, std::size_t count) {
  const auto base = reinterpret_cast<std::uintptr_t>(cells_.get());
  const std::size_t first_page = (base % kPageBytes + first * sizeof(LogOddsQ)) / kPageBytes;
  const std::size_t last_page =
      (base % kPageBytes + (first + count) * sizeof(LogOddsQ) - 1) / kPageBytes;
  for (std::size_t page = first_page; page <= last_page; ++page) {
    std::uint64_t& word = page_written_[page >> 6];
    const std::uint64_t bit = std::uint64_t{1} << (page & 63);
    if ((word & bit) != 0) continue;
    word |= bit;
    // A cell of the page within [first, first + count): the first one, or the page's first.
    const std::size_t page_first_cell =
        page == first_page ? first : (page * kPageBytes - base % kPageBytes) / sizeof(LogOddsQ);
    __atomic_fetch_add(&cells_[page_first_cell], LogOddsQ{0}, __ATOMIC_RELAXED);
  }
}

bool LocalMap::missRun(LogOddsQ* column, int base, std::uint64_t bits, std::uint64_t now,
                       std::uint64_t* changed_at, std::uint64_t* state_changed_at) const {
  const int nz = size_.z();
  bool any_changed = false;
  // One voxel, the rule as written (what the eight-lane step below must equal).
  auto missOne = [&](int t) {
    const LogOddsQ old = flipUnknown(column[t]);
    LogOddsQ v = old;
    const Occupancy before = model_.state(v);
    model_.miss(v);
    column[t] = flipUnknown(v);
    if (v != old) {
      const std::size_t m = submap_of_torus_z_[static_cast<std::size_t>(t)];
      changed_at[m] = now;
      if (before != model_.state(v)) state_changed_at[m] = now;
      any_changed = true;
    }
  };
#if defined(__SSE2__)
  // Eight voxels at a time (a run of free voxels in a column is usually longer: 20 per word on
  // a LiDAR frame), as long as all eight lie in the column.
  const __m128i lane_bits = _mm_setr_epi16(1, 2, 4, 8, 16, 32, 64, 128);
  const __m128i sign_bit = _mm_set1_epi16(kUnknownLogOdds);  // stored <-> value, see flipUnknown()
  const __m128i unknown = _mm_set1_epi16(kUnknownLogOdds);
  const __m128i miss = _mm_set1_epi16(model_.missStep());
  const __m128i lo = _mm_set1_epi16(model_.clampMin());
  const __m128i hi = _mm_set1_epi16(model_.clampMax());
  const __m128i occupied = _mm_set1_epi16(model_.occupiedThreshold());
  const __m128i zero = _mm_setzero_si128();
  // Submaps at least eight voxels high: eight consecutive torus z (never across the column's
  // end, see below) span at most two, as the column holds whole submaps.
  const bool two_submaps_per_8_lanes = submap_.z() >= 8;
  while (bits != 0) {
    const int k = __builtin_ctzll(bits);
    const int t = base + k;
    if (t + 8 > nz) {
      missOne(t);
      bits &= bits - 1;
      continue;
    }
    const int lanes = static_cast<int>((bits >> k) & 0xFFu);
    bits &= ~(std::uint64_t{0xFF} << k);
    LogOddsQ* p = column + t;
    const __m128i v = _mm_xor_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)), sign_bit);
    const __m128i selected = _mm_cmpeq_epi16(
        _mm_and_si128(_mm_set1_epi16(static_cast<short>(lanes)), lane_bits), lane_bits);
    const __m128i was_unknown = _mm_cmpeq_epi16(v, unknown);
    // Unknown counts as 0; a saturating sum, so that the clamps see what the int sum would be.
    const __m128i updated = _mm_min_epi16(
        _mm_max_epi16(_mm_adds_epi16(_mm_andnot_si128(was_unknown, v), miss), lo), hi);
    const __m128i out =
        _mm_or_si128(_mm_and_si128(selected, updated), _mm_andnot_si128(selected, v));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(p), _mm_xor_si128(out, sign_bit));
    const __m128i changed = _mm_andnot_si128(_mm_cmpeq_epi16(out, v), selected);
    int changed8 = _mm_movemask_epi8(_mm_packs_epi16(changed, zero));
    if (changed8 == 0) continue;  // all saturated already: the common case in mapped space
    any_changed = true;
    // Unknown -> known, or across the occupied threshold (unknown is never above it).
    const __m128i crossed =
        _mm_xor_si128(_mm_cmpgt_epi16(v, occupied), _mm_cmpgt_epi16(out, occupied));
    const int state8 = _mm_movemask_epi8(
        _mm_packs_epi16(_mm_and_si128(changed, _mm_or_si128(was_unknown, crossed)), zero));
    const std::uint8_t* lane_submap = submap_of_torus_z_.data() + t;
    if (two_submaps_per_8_lanes) {
      // The eight lanes lie in at most two submaps, lower lanes in the lower one: the submaps of
      // the lowest and the highest lane of a set are all the set's submaps.
      changed_at[lane_submap[__builtin_ctz(static_cast<unsigned>(changed8))]] = now;
      changed_at[lane_submap[31 - __builtin_clz(static_cast<unsigned>(changed8))]] = now;
      if (state8 != 0) {
        state_changed_at[lane_submap[__builtin_ctz(static_cast<unsigned>(state8))]] = now;
        state_changed_at[lane_submap[31 - __builtin_clz(static_cast<unsigned>(state8))]] = now;
      }
      continue;
    }
    while (changed8 != 0) {
      const int b = __builtin_ctz(static_cast<unsigned>(changed8));
      changed8 &= changed8 - 1;
      const std::size_t m = lane_submap[b];
      changed_at[m] = now;
      if ((state8 >> b) & 1) state_changed_at[m] = now;
    }
  }
#else
  while (bits != 0) {
    missOne(base + __builtin_ctzll(bits));
    bits &= bits - 1;
  }
#endif
  return any_changed;
}

bool LocalMap::anyOccupied(const LogOddsQ* column) const {
  // Unknown is the smallest value, never above the threshold: one comparison per voxel, eight
  // voxels at a time (a 750 x 750 x 75 LiDAR window is 562,500 columns, most without an
  // occupied voxel).
  const int nz = size_.z();
  const LogOddsQ threshold = model_.occupiedThreshold();
  int k = 0;
#if defined(__SSE2__)
  const __m128i above = _mm_set1_epi16(threshold);
  const __m128i sign_bit = _mm_set1_epi16(kUnknownLogOdds);
  __m128i any = _mm_setzero_si128();
  for (; k + 8 <= nz; k += 8) {
    const __m128i v =
        _mm_xor_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(column + k)), sign_bit);
    any = _mm_or_si128(any, _mm_cmpgt_epi16(v, above));
  }
  if (_mm_movemask_epi8(any) != 0) return true;
#endif
  for (; k < nz; ++k) {
    if (flipUnknown(column[k]) > threshold) return true;
  }
  return false;
}

LocalMap::LocalMap(const LocalMapConfig& config, const LogOddsConfig& log_odds)
    : config_(config),
      model_(log_odds),
      size_(config.size_cells),
      submap_(config.submap_cells()),
      cell_count_(static_cast<std::size_t>(size_.x()) * static_cast<std::size_t>(size_.y()) *
                  static_cast<std::size_t>(size_.z())),
      // Zeroed: every voxel unknown (flipUnknown()); calloc leaves fresh pages untouched.
      cells_(static_cast<LogOddsQ*>(std::calloc(cell_count_, sizeof(LogOddsQ)))),
      submap_changed_at_(static_cast<std::size_t>(LocalMapConfig::kSubmapsPerAxis) *
                             LocalMapConfig::kSubmapsPerAxis * LocalMapConfig::kSubmapsPerAxis,
                         0),
      submap_state_changed_at_(submap_changed_at_.size(), 0),
      submap_written_(submap_changed_at_.size(), 0),
      column_changed_at_(static_cast<std::size_t>(size_.x()) * static_cast<std::size_t>(size_.y()),
                         0),
      submap_of_torus_x_(static_cast<std::size_t>(size_.x())),
      submap_of_torus_y_(static_cast<std::size_t>(size_.y())),
      submap_of_torus_z_(static_cast<std::size_t>(size_.z())),
      may_hold_occupied_((column_changed_at_.size() + 63) / 64, 0),
      page_written_((cell_count_ * sizeof(LogOddsQ) / kPageBytes + 1 + 63) / 64, 0) {
  if (cells_ == nullptr) throw std::bad_alloc();
  for (int x = 0; x < size_.x(); ++x) {
    submap_of_torus_x_[static_cast<std::size_t>(x)] = static_cast<std::uint8_t>(x / submap_.x());
  }
  for (int y = 0; y < size_.y(); ++y) {
    submap_of_torus_y_[static_cast<std::size_t>(y)] = static_cast<std::uint8_t>(y / submap_.y());
  }
  for (int z = 0; z < size_.z(); ++z) {
    submap_of_torus_z_[static_cast<std::size_t>(z)] = static_cast<std::uint8_t>(z / submap_.z());
  }
}

SubmapIndex LocalMap::submapOf(const VoxelIndex& index) const {
  SubmapIndex m;
  for (int a = 0; a < 3; ++a) {
    const int q = index[a] / submap_[a];
    m[a] = (index[a] % submap_[a] < 0) ? q - 1 : q;
  }
  return m;
}

bool LocalMap::contains(const VoxelIndex& index) const {
  if (!placed_) return false;
  const VoxelIndex d = index - min_index_;
  return static_cast<unsigned>(d.x()) < static_cast<unsigned>(size_.x()) &&
         static_cast<unsigned>(d.y()) < static_cast<unsigned>(size_.y()) &&
         static_cast<unsigned>(d.z()) < static_cast<unsigned>(size_.z());
}

Occupancy LocalMap::state(const VoxelIndex& index) const {
  return contains(index) ? model_.state(flipUnknown(cells_[slot(index)])) : Occupancy::kUnknown;
}

bool LocalMap::logOdds(const VoxelIndex& index, double* log_odds) const {
  if (!contains(index)) return false;
  const LogOddsQ v = flipUnknown(cells_[slot(index)]);
  if (v == kUnknownLogOdds) return false;
  *log_odds = dequantizeLogOdds(v);
  return true;
}

void LocalMap::retireSubmap(const SubmapIndex& m, GlobalMap* global) {
  scratch_.clear();
  const int n = LocalMapConfig::kSubmapsPerAxis;
  const Eigen::Vector3i t0(floorMod(m.x(), n) * submap_.x(), floorMod(m.y(), n) * submap_.y(),
                           floorMod(m.z(), n) * submap_.z());
  const std::size_t submap_slot = submapSlot(m);
  // Nothing written since the slot was last cleared: every cell is unknown already, none is read
  // (only the column marks below are looked at).
  const bool written = submap_written_[submap_slot] != 0;
  std::uint32_t offset = 0;
  // The submap's part of a column is a short run (15 voxels at 0.1 m) one column (150 bytes)
  // after the last: fetched a few columns ahead, as the hardware does not for such strides.
  constexpr int kAhead = 8;
  const std::size_t nz = static_cast<std::size_t>(size_.z());
  for (int x = 0; x < submap_.x(); ++x) {
    for (int y = 0; y < submap_.y(); ++y) {
      LogOddsQ* row = cells_.get() +
                      (static_cast<std::size_t>(t0.x() + x) * static_cast<std::size_t>(size_.y()) +
                       static_cast<std::size_t>(t0.y() + y)) *
                          nz +
                      static_cast<std::size_t>(t0.z());
      if (written && y + kAhead < submap_.y()) __builtin_prefetch(row + kAhead * nz, 1);
      for (int z = 0; written && z < submap_.z(); ++z, ++offset) {
        if (row[z] == 0)
          continue;  // unknown already: never written, so a page never touched stays so
        const LogOddsQ v = flipUnknown(row[z]);
        if (model_.isOccupied(v)) scratch_.push_back({offset, v});
        row[z] = 0;  // unknown, stored
      }
      // A marked column left with nothing occupied (its other submaps above and below included)
      // is unmarked: over a long flight the occupied listing keeps reading only the columns
      // that hold something. A restored submap marks its columns again.
      const std::size_t torus_column = static_cast<std::size_t>(row - cells_.get()) / nz;
      if (columnMarked(torus_column) && !anyOccupied(cells_.get() + torus_column * nz)) {
        may_hold_occupied_[torus_column >> 6] &= ~(std::uint64_t{1} << (torus_column & 63));
      }
    }
  }
  submap_written_[submap_slot] = 0;
  global->store(m, std::vector<VoxelRecord>(scratch_.begin(), scratch_.end()));
  stampSubmap(submap_slot, ++change_clock_);
  ++counters_.submaps_retired;
}

void LocalMap::stampSubmap(std::size_t slot, std::uint64_t clock) {
  submap_changed_at_[slot] = clock;
  submap_state_changed_at_[slot] = clock;
  // Its columns too (whole torus columns: a copy then takes the other submaps above and below).
  constexpr auto kN = static_cast<std::size_t>(LocalMapConfig::kSubmapsPerAxis);
  const std::size_t x0 = slot / (kN * kN) * static_cast<std::size_t>(submap_.x());
  const std::size_t y0 = slot / kN % kN * static_cast<std::size_t>(submap_.y());
  const std::size_t ny = static_cast<std::size_t>(size_.y());
  for (std::size_t x = x0; x < x0 + static_cast<std::size_t>(submap_.x()); ++x) {
    std::uint64_t* row = column_changed_at_.data() + x * ny + y0;
    std::fill(row, row + submap_.y(), clock);
  }
}

void LocalMap::stampAllSubmaps() {
  const std::uint64_t clock = ++change_clock_;
  std::fill(submap_changed_at_.begin(), submap_changed_at_.end(), clock);
  std::fill(submap_state_changed_at_.begin(), submap_state_changed_at_.end(), clock);
  std::fill(column_changed_at_.begin(), column_changed_at_.end(), clock);
}

void LocalMap::restoreSubmap(const SubmapIndex& m, GlobalMap* global) {
  stampSubmap(submapSlot(m), ++change_clock_);  // entered the window, restored or not
  if (!global->take(m, &scratch_)) return;
  if (!scratch_.empty()) submap_written_[submapSlot(m)] = 1;
  const int n = LocalMapConfig::kSubmapsPerAxis;
  const Eigen::Vector3i t0(floorMod(m.x(), n) * submap_.x(), floorMod(m.y(), n) * submap_.y(),
                           floorMod(m.z(), n) * submap_.z());
  const std::uint32_t plane = static_cast<std::uint32_t>(submap_.y() * submap_.z());
  for (const VoxelRecord& r : scratch_) {
    const int x = static_cast<int>(r.offset / plane);
    const int y = static_cast<int>((r.offset % plane) / static_cast<std::uint32_t>(submap_.z()));
    const int z = static_cast<int>(r.offset % static_cast<std::uint32_t>(submap_.z()));
    const std::size_t torus_column =
        static_cast<std::size_t>(t0.x() + x) * static_cast<std::size_t>(size_.y()) +
        static_cast<std::size_t>(t0.y() + y);
    cells_[torus_column * static_cast<std::size_t>(size_.z()) +
           static_cast<std::size_t>(t0.z() + z)] = flipUnknown(r.log_odds);
    markMayHoldOccupied(torus_column);
  }
  ++counters_.submaps_restored;
}

void LocalMap::moveCenter(const SubmapIndex& new_center, GlobalMap* global) {
  const SubmapIndex delta = new_center - center_;
  const int n = LocalMapConfig::kSubmapsPerAxis;
  for (int x = -kHalfWindow; x <= kHalfWindow; ++x) {
    for (int y = -kHalfWindow; y <= kHalfWindow; ++y) {
      for (int z = -kHalfWindow; z <= kHalfWindow; ++z) {
        const SubmapIndex entering = new_center + SubmapIndex(x, y, z);
        SubmapIndex leaving = entering;
        bool changes = false;
        for (int a = 0; a < 3; ++a) {
          if (std::abs(entering[a] - center_[a]) > kHalfWindow) {
            leaving[a] -= n * delta[a];
            changes = true;
          }
        }
        if (!changes) continue;
        retireSubmap(leaving, global);
        restoreSubmap(entering, global);
      }
    }
  }
  center_ = new_center;
  min_index_ = (center_ - SubmapIndex::Constant(kHalfWindow)).cwiseProduct(submap_);
  ++counters_.shifts;
}

void LocalMap::retireAll(GlobalMap* global) {
  if (!placed_) return;
  for (int x = -kHalfWindow; x <= kHalfWindow; ++x) {
    for (int y = -kHalfWindow; y <= kHalfWindow; ++y) {
      for (int z = -kHalfWindow; z <= kHalfWindow; ++z) {
        retireSubmap(center_ + SubmapIndex(x, y, z), global);
      }
    }
  }
}

std::string windowProblem(const LocalWindow& window, const Eigen::Vector3i& size,
                          const Eigen::Vector3i& submap_cells, const LogOddsModel& model) {
  if (window.size.prod() == 0) return "";
  std::ostringstream m;
  if (window.size != size) {
    m << "size " << window.size.transpose() << " voxels, the map has " << size.transpose();
    return m.str();
  }
  if (window.log_odds.size() != static_cast<std::size_t>(size.prod())) {
    m << window.log_odds.size() << " values for " << size.prod() << " voxels";
    return m.str();
  }
  for (int a = 0; a < 3; ++a) {
    const std::int64_t lo = window.min_index[a];
    if (lo < -kMaxAbsWindowVoxelIndex || lo + size[a] > kMaxAbsWindowVoxelIndex) {
      m << "first voxel " << window.min_index.transpose() << " is beyond +-"
        << kMaxAbsWindowVoxelIndex;
      return m.str();
    }
    if (((lo % submap_cells[a]) + submap_cells[a]) % submap_cells[a] != 0) {
      m << "first voxel " << window.min_index.transpose() << " is not on the submap grid ("
        << submap_cells.transpose() << " voxels per submap)";
      return m.str();
    }
  }
  for (std::size_t i = 0; i < window.log_odds.size(); ++i) {
    const LogOddsQ v = window.log_odds[i];
    if (v != kUnknownLogOdds && (v < model.clampMin() || v > model.clampMax())) {
      m << "value " << v << " at window offset " << i << " is outside the clamping bounds ["
        << model.clampMin() << ", " << model.clampMax() << "] (units of 0.001)";
      return m.str();
    }
  }
  return "";
}

std::string LocalMap::windowProblem(const LocalWindow& window) const {
  return mlmap::windowProblem(window, size_, submap_, model_);
}

void LocalMap::restoreWindow(const LocalWindow& window) {
  const std::string problem = windowProblem(window);
  if (!problem.empty()) throw std::invalid_argument("local map window: " + problem);
  if (window.size.prod() == 0) {
    std::fill(cells_.get(), cells_.get() + cell_count_, LogOddsQ{0});  // unknown, stored
    std::fill(may_hold_occupied_.begin(), may_hold_occupied_.end(), 0);
    std::fill(submap_written_.begin(), submap_written_.end(), 0);
    placed_ = false;
    center_ = SubmapIndex::Zero();
    min_index_ = VoxelIndex::Zero();
    stampAllSubmaps();
    return;
  }
  min_index_ = window.min_index;
  center_ = SubmapIndex(window.min_index.x() / submap_.x(), window.min_index.y() / submap_.y(),
                        window.min_index.z() / submap_.z()) +
            SubmapIndex::Constant(kHalfWindow);
  placed_ = true;
  // Box order -> torus slots (the inverse of copyWindow()).
  const LogOddsQ* src = window.log_odds.data();
  for (int x = 0; x < size_.x(); ++x) {
    for (int y = 0; y < size_.y(); ++y) {
      for (int z = 0; z < size_.z(); ++z) {
        cells_[slot(min_index_ + VoxelIndex(x, y, z))] = flipUnknown(*src++);
      }
    }
  }
  // Any column may hold an occupied voxel now, any submap a known voxel.
  std::fill(may_hold_occupied_.begin(), may_hold_occupied_.end(), ~std::uint64_t{0});
  std::fill(submap_written_.begin(), submap_written_.end(), 1);
  stampAllSubmaps();
}

void LocalMap::recenter(const Eigen::Vector3d& body_W, GlobalMap* global) {
  const SubmapIndex body_submap = submapOf(voxelIndexOf(body_W, config_.resolution_m));
  auto place = [&](const SubmapIndex& center) {
    center_ = center;
    min_index_ = (center_ - SubmapIndex::Constant(kHalfWindow)).cwiseProduct(submap_);
    placed_ = true;
    for (int x = -kHalfWindow; x <= kHalfWindow; ++x) {
      for (int y = -kHalfWindow; y <= kHalfWindow; ++y) {
        for (int z = -kHalfWindow; z <= kHalfWindow; ++z) {
          restoreSubmap(center_ + SubmapIndex(x, y, z), global);
        }
      }
    }
  };
  if (!placed_) {
    place(body_submap);
    return;
  }
  const Eigen::Vector3d submap_size_m = submap_.cast<double>() * config_.resolution_m;
  for (int iteration = 0; body_submap != center_; ++iteration) {
    const SubmapIndex diff = body_submap - center_;
    if (diff.cwiseAbs().maxCoeff() > kHalfWindow || iteration >= kMaxShiftsPerCall) {
      retireAll(global);
      place(body_submap);
      ++counters_.resets;
      return;
    }
    // The neighbour (26 directions) whose centre is closest to the body.
    SubmapIndex best = center_;
    double best_d2 = std::numeric_limits<double>::infinity();
    for (int x = -1; x <= 1; ++x) {
      for (int y = -1; y <= 1; ++y) {
        for (int z = -1; z <= 1; ++z) {
          if (x == 0 && y == 0 && z == 0) continue;
          const SubmapIndex candidate = center_ + SubmapIndex(x, y, z);
          const Eigen::Vector3d centre_W =
              (candidate.cast<double>().array() + 0.5).matrix().cwiseProduct(submap_size_m);
          const double d2 = (centre_W - body_W).squaredNorm();
          if (d2 < best_d2) {
            best_d2 = d2;
            best = candidate;
          }
        }
      }
    }
    moveCenter(best, global);
  }
}

void LocalMap::integrate(const MeasurementBatch& batch) {
  if (!placed_) {
    counters_.outside_window += batch.hits.size() + batch.free_count;
    counters_.hits_outside_window += batch.hits.size();
    return;
  }
  const std::uint64_t now = ++change_clock_;
  // A voxel d = g - minIndex() inside the window sits at torus (first + d) per axis, wrapped
  // once: no division per hit (the slot() of a hit and its submap took a dozen).
  const Eigen::Vector3i torus_first(floorMod(min_index_.x(), size_.x()),
                                    floorMod(min_index_.y(), size_.y()),
                                    floorMod(min_index_.z(), size_.z()));
  const auto ny = static_cast<std::size_t>(size_.y());
  const auto nz = static_cast<std::size_t>(size_.z());
  constexpr auto kStride = static_cast<std::size_t>(LocalMapConfig::kSubmapsPerAxis);
  // Hits in chunks: first the chunk's cells, fetched meanwhile (a LiDAR's hits are spread all
  // over the window), then their updates.
  constexpr std::size_t kChunk = 32;
  constexpr std::size_t kOutside = ~std::size_t{0};
  std::array<std::size_t, kChunk> cells{};
  std::array<std::size_t, kChunk> columns{};  // torus column x * size_cells.y + y
  std::array<std::size_t, kChunk> submaps{};  // slot in the submap stamp arrays
  for (std::size_t first = 0; first < batch.hits.size(); first += kChunk) {
    const std::size_t n = std::min(kChunk, batch.hits.size() - first);
    for (std::size_t i = 0; i < n; ++i) {
      const VoxelIndex d = batch.hits[first + i].index - min_index_;
      cells[i] = kOutside;
      if (static_cast<unsigned>(d.x()) >= static_cast<unsigned>(size_.x()) ||
          static_cast<unsigned>(d.y()) >= static_cast<unsigned>(size_.y()) ||
          static_cast<unsigned>(d.z()) >= static_cast<unsigned>(size_.z())) {
        continue;
      }
      Eigen::Vector3i t = torus_first + d;
      for (int a = 0; a < 3; ++a) {
        if (t[a] >= size_[a]) t[a] -= size_[a];
      }
      columns[i] = static_cast<std::size_t>(t.x()) * ny + static_cast<std::size_t>(t.y());
      cells[i] = columns[i] * nz + static_cast<std::size_t>(t.z());
      submaps[i] =
          (static_cast<std::size_t>(submap_of_torus_x_[static_cast<std::size_t>(t.x())]) * kStride +
           submap_of_torus_y_[static_cast<std::size_t>(t.y())]) *
              kStride +
          submap_of_torus_z_[static_cast<std::size_t>(t.z())];
      __builtin_prefetch(&cells_[cells[i]]);
    }
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t cell = cells[i];
      if (cell == kOutside) {
        ++counters_.outside_window;
        ++counters_.hits_outside_window;
        continue;
      }
      writeFirst(cell, 1);
      const LogOddsQ old = flipUnknown(cells_[cell]);
      LogOddsQ v = old;
      const Occupancy before = model_.state(v);
      model_.hit(v);
      cells_[cell] = flipUnknown(v);
      if (v != old) {
        const std::size_t m = submaps[i];
        const std::size_t torus_column = columns[i];
        submap_changed_at_[m] = now;
        if (before != model_.state(v)) {
          submap_state_changed_at_[m] = now;
          if (model_.isOccupied(v)) markMayHoldOccupied(torus_column);
        }
        column_changed_at_[torus_column] = now;
      }
      ++counters_.hits_applied;
    }
  }
  // Free set: only the rows and z words of the bitset that overlap the window are read (what
  // lies outside is batch.free_count minus what was applied here). Along z, a bit's torus index
  // is its offset from the window's first layer, wrapped once: no division per voxel.
  const VoxelBitset& free = batch.free;
  const VoxelIndex& origin = free.origin();
  const Eigen::Vector3i& dims = free.dims();
  // Rows outside the free set's marked ones hold no bit.
  const VoxelBitset::Rows& marked = free.markedRows();
  const Eigen::Vector3i first =
      (min_index_ - origin)
          .cwiseMax(Eigen::Vector3i(marked.x_begin, marked.y_begin, 0));  // box-relative
  const Eigen::Vector3i end =
      (min_index_ + size_ - origin)
          .cwiseMin(Eigen::Vector3i(marked.x_end, marked.y_end, dims.z()));  // exclusive
  const int split = floorMod(min_index_.z(), size_.z());  // torus z of the window's first layer
  const int to_window_z = origin.z() - min_index_.z();    // bit k is window layer k + to_window_z
  std::uint64_t applied = 0;
  const int w_first = first.z() / 64;
  const int w_end = end.z() > first.z() ? (end.z() + 63) / 64 : w_first;  // none: no overlap
  // The bits of each of those words in [first.z, end.z): the same for every row.
  std::vector<std::uint64_t> z_mask(static_cast<std::size_t>(w_end - w_first));
  for (int w = w_first; w < w_end; ++w) {
    const int lo = std::max(first.z() - 64 * w, 0);
    const int hi = std::min(end.z() - 64 * w, 64);
    const std::uint64_t below_hi = hi >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << hi) - 1;
    z_mask[static_cast<std::size_t>(w - w_first)] = below_hi & ~((std::uint64_t{1} << lo) - 1);
  }
  // Row (i, j) of the free set, at torus x sx and torus y sy: its misses.
  auto applyRow = [&](int i, int j, int sx, int sy) {
    const std::uint64_t* row = free.data() + free.rowWord(i, j);
    std::uint64_t any = 0;
    for (int w = w_first; w < w_end; ++w) any |= row[w];
    if (any == 0) return;  // most rows of a frame: nothing seen free there
    const std::size_t torus_column =
        static_cast<std::size_t>(sx) * static_cast<std::size_t>(size_.y()) +
        static_cast<std::size_t>(sy);
    writeFirst(torus_column * static_cast<std::size_t>(size_.z()),
               static_cast<std::size_t>(size_.z()));
    LogOddsQ* column = cells_.get() + torus_column * static_cast<std::size_t>(size_.z());
    // The column's submaps in the stamp arrays (torus slot x, y; z per voxel).
    const std::size_t column_submaps =
        (static_cast<std::size_t>(submap_of_torus_x_[static_cast<std::size_t>(sx)]) * kStride +
         submap_of_torus_y_[static_cast<std::size_t>(sy)]) *
        kStride;
    std::uint64_t* submaps_changed_at = submap_changed_at_.data() + column_submaps;
    std::uint64_t* submaps_state_changed_at = submap_state_changed_at_.data() + column_submaps;
    bool column_changed = false;
    for (int w = w_first; w < w_end; ++w) {
      const std::uint64_t bits = row[w] & z_mask[static_cast<std::size_t>(w - w_first)];
      if (bits == 0) continue;
      applied += static_cast<std::uint64_t>(__builtin_popcountll(bits));
      // Bit k is torus z base + k, or base + k - nz past the wrap (bits outside the window
      // are masked out, so every set bit lands in [0, nz)).
      const int base = split + 64 * w + to_window_z;
      const int wrap = size_.z() - base;  // the first bit past the wrap
      const std::uint64_t before_wrap = wrap >= 64  ? bits
                                        : wrap <= 0 ? 0
                                                    : bits & ((std::uint64_t{1} << wrap) - 1);
      // Past the wrap is rare: no call (and no setting up of its constants) for nothing.
      if (before_wrap != 0) {
        column_changed |=
            missRun(column, base, before_wrap, now, submaps_changed_at, submaps_state_changed_at);
      }
      if (bits != before_wrap) {
        column_changed |= missRun(column, base - size_.z(), bits & ~before_wrap, now,
                                  submaps_changed_at, submaps_state_changed_at);
      }
    }
    if (column_changed) column_changed_at_[torus_column] = now;
  };
  // The torus y of the first row, stepped per row (no division per row).
  const int sy_first = floorMod(origin.y() + first.y(), size_.y());
  for (int i = first.x(); i < end.x(); ++i) {
    const int sx = floorMod(origin.x() + i, size_.x());
    if (!free.rowsInUseValid()) {
      int sy = sy_first - 1;
      for (int j = first.y(); j < end.y(); ++j) {
        if (++sy == size_.y()) sy = 0;
        applyRow(i, j, sx, sy);
      }
      continue;
    }
    // Only the rows that hold a bit, as the awareness stage listed them while counting (about
    // half of the marked rectangle's rows on the LiDAR and depth frames, a third on the tabletop).
    const std::uint64_t* in_use = free.rowsInUse(i);
    for (int w = first.y() / 64; 64 * w < end.y(); ++w) {
      std::uint64_t rows = in_use[w];
      if (first.y() > 64 * w) rows &= ~std::uint64_t{0} << (first.y() - 64 * w);
      if (end.y() - 64 * w < 64) rows &= (std::uint64_t{1} << (end.y() - 64 * w)) - 1;
      for (; rows != 0; rows &= rows - 1) {
        const int j = 64 * w + __builtin_ctzll(rows);
        int sy = sy_first + (j - first.y());  // j - first.y < size.y
        if (sy >= size_.y()) sy -= size_.y();
        applyRow(i, j, sx, sy);
      }
    }
  }
  // A cell leaves unknown only by a change, which stamps its submap with `now`.
  for (std::size_t m = 0; m < submap_written_.size(); ++m) {
    if (submap_changed_at_[m] == now) submap_written_[m] = 1;
  }
  counters_.outside_window += batch.free_count > applied ? batch.free_count - applied : 0;
  counters_.misses_applied += applied;
}

void LocalMap::copyWindow(LocalWindow* out) const {
  out->resolution_m = config_.resolution_m;
  out->model = model_;
  out->change_clock = change_clock_;
  if (!placed_) {
    out->min_index = VoxelIndex::Zero();
    out->size = Eigen::Vector3i::Zero();
    out->log_odds.clear();
    return;
  }
  out->min_index = min_index_;
  out->size = size_;
  out->log_odds.resize(static_cast<std::size_t>(size_.prod()));
  copyColumns(out, /*all=*/true, 0);
}

int LocalMap::updateWindowCopy(LocalWindow* out) const {
  const bool same_place = placed_ && out->change_clock != 0 && out->min_index == min_index_ &&
                          out->size == size_ && out->resolution_m == config_.resolution_m &&
                          out->log_odds.size() == static_cast<std::size_t>(size_.prod());
  if (!same_place) {
    copyWindow(out);
    return placed_ ? size_.x() * size_.y() : 0;
  }
  out->model = model_;
  const int copied = copyColumns(out, /*all=*/false, out->change_clock);
  out->change_clock = change_clock_;
  return copied;
}

int LocalMap::copyColumns(LocalWindow* out, bool all, std::uint64_t changed_after) const {
  const std::size_t nx = static_cast<std::size_t>(size_.x());
  const std::size_t ny = static_cast<std::size_t>(size_.y());
  const std::size_t nz = static_cast<std::size_t>(size_.z());
  // Each torus column is the window's z row rotated by (min z mod nz): two contiguous copies.
  const std::size_t split = static_cast<std::size_t>(floorMod(min_index_.z(), size_.z()));
  // Torus x and y stepped per column, not divided (a window has up to half a million columns).
  const std::size_t sy_first = static_cast<std::size_t>(floorMod(min_index_.y(), size_.y()));
  std::size_t sx = static_cast<std::size_t>(floorMod(min_index_.x(), size_.x()));
  int copied = 0;
  for (std::size_t x = 0; x < nx; ++x) {
    std::size_t sy = sy_first;
    for (std::size_t y = 0; y < ny; ++y) {
      if (all || column_changed_at_[sx * ny + sy] > changed_after) {
        ++copied;
        const LogOddsQ* column = cells_.get() + (sx * ny + sy) * nz;
        LogOddsQ* dst = out->log_odds.data() + (x * ny + y) * nz;
        dst = std::transform(column + split, column + nz, dst, flipUnknown);
        std::transform(column, column + split, dst, flipUnknown);
      }
      if (++sy == ny) sy = 0;
    }
    if (++sx == nx) sx = 0;
  }
  return copied;
}

}  // namespace mlmap
