#include "mlmap/planning/esdf.h"

#include "mlmap/planning/esdf_window_kernel.h"

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <type_traits>

namespace mlmap {
namespace {

/// Rows (y) swept together by the x pass.
constexpr int kRowBlock = 32;
/// The same where the x pass's results are kept in 8 bits (the windowed passes): its 32-bit
/// work buffer over the whole x extent of that many rows stays in the L2 cache.
constexpr int kNarrowRowBlock = 8;
/// Largest metres lookup table (entries); larger caps use sqrt directly.
constexpr std::size_t kMaxLookupEntries = std::size_t{1} << 16;
/// Largest accepted |index| of the box corners (keeps grid coordinates far from int overflow).
constexpr std::int64_t kMaxAbsIndex = std::int64_t{1} << 30;

const EsdfConfig& validated(const EsdfConfig& config) {
  std::vector<std::string> errors;
  config.validate(&errors);
  throwIfInvalid(errors, "ESDF configuration");
  return config;
}

bool wellFormed(const OccupancyBox& box) {
  for (int a = 0; a < 3; ++a) {
    if (box.size[a] < 1 || box.size[a] > EsdfMap::kMaxCellsPerAxis) return false;
    const std::int64_t lo = box.min_index[a];
    if (lo < -kMaxAbsIndex || lo + box.size[a] > kMaxAbsIndex) return false;
  }
  const std::int64_t cells = std::int64_t{box.size.x()} * box.size.y() * box.size.z();
  return cells <= EsdfMap::kMaxCells && box.states.size() == static_cast<std::size_t>(cells) &&
         std::isfinite(box.resolution_m) && box.resolution_m > 0.0;
}

/// Runs work(thread, begin, end) over [0, count) cut into `threads` contiguous ranges; the
/// caller's thread takes range 0. Deterministic: a range's result does not depend on the others.
template <typename Work>
void parallelFor(int count, int threads, const Work& work) {
  threads = std::max(1, std::min(threads, count));
  const auto begin = [&](int t) {
    return static_cast<int>(static_cast<std::int64_t>(count) * t / threads);
  };
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(threads - 1));
  for (int t = 1; t < threads; ++t) {
    const int b = begin(t);
    const int e = begin(t + 1);
    try {
      pool.emplace_back([&work, t, b, e] { work(t, b, e); });
    } catch (const std::system_error&) {
      work(t, b, e);  // no thread available: do that range here (it owns scratch t alone)
    }
  }
  work(0, 0, begin(1));
  for (std::thread& thread : pool) thread.join();
}

/// Bit i set when byte i of p[0..8) is 0 (Occupancy::kUnknown).
inline std::uint64_t zeroBytes8(const std::uint8_t* p) {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
  std::uint64_t t = 0;
  std::memcpy(&t, p, sizeof(t));
  constexpr std::uint64_t kLow7 = 0x7F7F7F7F7F7F7F7FULL;
  const std::uint64_t nonzero = ((t & kLow7) + kLow7) | t;  // high bit of a byte: byte != 0
  const std::uint64_t zero = (~nonzero >> 7) & 0x0101010101010101ULL;
  return (zero * 0x0102040810204080ULL) >> 56;  // bit 8i -> bit i
#else
  std::uint64_t bits = 0;
  for (int b = 0; b < 8; ++b) bits |= static_cast<std::uint64_t>(p[b] == 0 ? 1 : 0) << b;
  return bits;
#endif
}

// ---- Pass 1 (x): two sweeps of the 1D distance to the nearest voxel of the other kind ----

/// A voxel's kind, all that pass 1 reads of its state: an obstacle when occupied, or unknown
/// with `unknown_is_obstacle` (1: unknown as occupied, 0: as free). Branch-free, so that the
/// sweeps vectorise.
inline __attribute__((always_inline)) bool isObstacle(std::int32_t state,
                                                      std::int32_t unknown_is_obstacle) {
  constexpr auto kUnknown = static_cast<std::int32_t>(Occupancy::kUnknown);
  constexpr auto kOccupied = static_cast<std::int32_t>(Occupancy::kOccupied);
  return ((state == kOccupied ? 1 : 0) | ((state == kUnknown ? 1 : 0) & unknown_is_obstacle)) != 0;
}

/// Forward sweep over `n` consecutive voxels (a run of z, and of y when rows are blocked) at x:
/// updates the last non-obstacle / obstacle x of each and writes the signed distance to the last
/// voxel of the other kind (negative for obstacles). Branch-free, so it vectorises.
inline __attribute__((always_inline)) void sweepForward(const std::uint8_t* __restrict states,
                                                        std::int32_t* __restrict a,
                                                        std::int32_t* __restrict last_free,
                                                        std::int32_t* __restrict last_obstacle,
                                                        int n, std::int32_t x,
                                                        std::int32_t unknown_is_obstacle) {
  for (int z = 0; z < n; ++z) {
    const bool obstacle = isObstacle(states[z], unknown_is_obstacle);
    const std::int32_t lf = last_free[z];
    const std::int32_t lo = last_obstacle[z];
    last_free[z] = obstacle ? lf : x;
    last_obstacle[z] = obstacle ? x : lo;
    a[z] = obstacle ? lf - x : x - lo;  // signed: negative for obstacles
  }
}

/// Backward sweep of pass 1: the same towards higher x, keeping the nearer side, capped (+-inf
/// beyond cap_d). The distance is left unsquared (the y pass squares it).
inline __attribute__((always_inline)) void sweepBackward(std::int32_t* __restrict a,
                                                         std::int32_t* __restrict next_free,
                                                         std::int32_t* __restrict next_obstacle,
                                                         int n, std::int32_t x,
                                                         std::int32_t cap_d, std::int32_t inf) {
  for (int z = 0; z < n; ++z) {
    // Branch-free so that it vectorises: m is all ones for an obstacle, 0 otherwise.
    const std::int32_t left = a[z];
    const std::int32_t m = -static_cast<std::int32_t>(left < 0);
    const std::int32_t nf = next_free[z];
    const std::int32_t no = next_obstacle[z];
    next_free[z] = (nf & m) | (x & ~m);
    next_obstacle[z] = (x & m) | (no & ~m);
    const std::int32_t from_left = (left ^ m) - m;  // |left|
    const std::int32_t from_right = ((nf & m) | (no & ~m)) - x;
    const std::int32_t d = std::min(from_left, from_right);
    const std::int32_t v = d <= cap_d ? d : inf;  // distance, not squared: the y pass squares it
    a[z] = (v ^ m) - m;                            // -v for obstacles
  }
}

// ---- Passes 2 (y) and 3 (z): exact 1D transforms by lower envelopes of parabolas ----

/// One line of the work buffer with a stride between its voxels (the y pass).
struct StridedLine {
  std::int32_t* base;
  std::ptrdiff_t stride;
  std::int32_t& operator[](std::ptrdiff_t i) const { return base[i * stride]; }
};

/// One thread's envelope buffers, each at least one longer than the longest line.
template <typename Key>
struct LineBuffers {
  std::int32_t* runs;       ///< starts of the same-sign runs of the line
  std::int32_t* out_sites;  ///< outside-transform envelope: positions ...
  Key* out_keys;            ///< ... and f(q) + q^2
  std::int32_t* in_sites;   ///< inside-transform envelope
  Key* in_keys;
};

/// Adds the parabola (x - q)^2 + f, stored as key = f + q^2, to a lower envelope whose sites
/// are increasing and < q, dropping the parabolas it hides (Felzenszwalb & Huttenlocher, with
/// the intersection test cross-multiplied so that it needs no division).
template <typename Key>
inline void pushParabola(std::int32_t* sites, Key* keys, int* count, std::int32_t q, Key key) {
  int m = *count;
  while (m >= 2) {
    const Key top = keys[m - 1];
    // intersection(q, top) <= intersection(below, top): `top` is nowhere the lowest.
    if ((key - top) * static_cast<Key>(sites[m - 1] - sites[m - 2]) <=
        (top - keys[m - 2]) * static_cast<Key>(q - sites[m - 1])) {
      --m;
    } else {
      break;
    }
  }
  sites[m] = q;
  keys[m] = key;
  *count = m + 1;
}

/// Writes the envelope's minimum at the positions of the runs [runs[r], runs[r + 1]) for
/// r = first, first + 2, ... (the runs of one sign), times `sign` (+1 or -1). Positions where
/// the minimum exceeds `cap` are skipped: they hold no site, so they already hold +-inf.
/// sites[count], keys[count] must hold a sentinel that never wins, at position >= n + cap_d.
template <typename Key, typename Line>
inline void evaluateRuns(Line line, const std::int32_t* runs, int run_count, int first,
                         const std::int32_t* sites, const Key* keys, std::int32_t cap,
                         std::int32_t cap_d, std::int32_t sign) {
  int k = 0;
  for (int r = first; r < run_count; r += 2) {
    const int end = runs[r + 1];
    int p = runs[r];
    while (p < end) {
      const Key two_p = 2 * static_cast<Key>(p);
      Key best = keys[k] - two_p * sites[k];
      for (;;) {
        const Key next = keys[k + 1] - two_p * sites[k + 1];
        if (next > best) break;
        best = next;
        ++k;
      }
      const Key d = best + static_cast<Key>(p) * p;
      if (d <= cap) {
        line[p] = sign * static_cast<std::int32_t>(d);
        ++p;
        continue;
      }
      // Nothing within reach here. Parabolas before k lose to k from here on, k itself (when
      // p >= sites[k]) only grows, and the others are more than cap_d away until their site is
      // within cap_d: jump there.
      const int next_site = p < sites[k] ? sites[k] : sites[k + 1];
      p = std::max(p + 1, next_site - cap_d);
    }
  }
}

/// The exact 1D transform of one line of n signed values, in place: each non-obstacle value
/// becomes min over j of f_out(j) + (p - j)^2 and each obstacle value -(min over j of
/// f_in(j) + (p - j)^2), capped (+-inf above cap).
/// - Outside transform: its sites are the non-obstacle voxels with a finite value, and the
///   obstacle voxels (f = 0) next to a non-obstacle voxel of the line (the inner voxels of an
///   obstacle run are never nearer to a non-obstacle voxel than the run's ends). It is evaluated
///   at non-obstacle voxels only.
/// - Inside transform: the same with the roles swapped.
/// With kSquare the finite inputs are distances (the x pass's output), else squared distances.
template <typename Key, typename Line, bool kSquare>
void transformLine(Line line, int n, std::int32_t cap, std::int32_t cap_d,
                   const LineBuffers<Key>& buffers) {
  std::int32_t* runs = buffers.runs;
  std::int32_t* out_sites = buffers.out_sites;
  Key* out_keys = buffers.out_keys;
  std::int32_t* in_sites = buffers.in_sites;
  Key* in_keys = buffers.in_keys;
  const std::int32_t inf = cap + 1;
  int out_count = 0;
  int in_count = 0;
  int run_count = 0;
  int j = 0;
  while (j < n) {
    const int l = j;
    runs[run_count++] = l;
    if (line[j] > 0) {
      if (l > 0) pushParabola<Key>(in_sites, in_keys, &in_count, l, static_cast<Key>(l) * l);
      for (; j < n && line[j] > 0; ++j) {
        const std::int32_t v = line[j];
        if (v < inf) {
          const Key f = kSquare ? static_cast<Key>(v) * v : static_cast<Key>(v);
          pushParabola<Key>(out_sites, out_keys, &out_count, j, static_cast<Key>(j) * j + f);
        }
      }
      const int r = j - 1;
      if (j < n && (r != l || l == 0)) {
        pushParabola<Key>(in_sites, in_keys, &in_count, r, static_cast<Key>(r) * r);
      }
    } else {
      if (l > 0) pushParabola<Key>(out_sites, out_keys, &out_count, l, static_cast<Key>(l) * l);
      for (; j < n && line[j] < 0; ++j) {
        const std::int32_t v = line[j];
        if (v > -inf) {
          const Key f = kSquare ? static_cast<Key>(v) * v : -static_cast<Key>(v);
          pushParabola<Key>(in_sites, in_keys, &in_count, j, static_cast<Key>(j) * j + f);
        }
      }
      const int r = j - 1;
      if (j < n && (r != l || l == 0)) {
        pushParabola<Key>(out_sites, out_keys, &out_count, r, static_cast<Key>(r) * r);
      }
    }
  }
  runs[run_count] = n;
  const int first_free = line[0] > 0 ? 0 : 1;
  // Sentinel: far right and above every real value at every position of the line.
  const int sentinel_site = n + cap_d + 1;
  const Key sentinel_key = static_cast<Key>(cap) + static_cast<Key>(n) * n +
                           2 * static_cast<Key>(n) * sentinel_site + 1;
  if (out_count > 0) {
    out_sites[out_count] = sentinel_site;
    out_keys[out_count] = sentinel_key;
    evaluateRuns<Key, Line>(line, runs, run_count, first_free, out_sites, out_keys, cap, cap_d, 1);
  }
  if (in_count > 0) {
    in_sites[in_count] = sentinel_site;
    in_keys[in_count] = sentinel_key;
    evaluateRuns<Key, Line>(line, runs, run_count, 1 - first_free, in_sites, in_keys, cap, cap_d,
                            -1);
  }
}

/// Pass 1 over a block of `n` consecutive voxels of every x slab (one or more y rows, z
/// fastest): states at states + x * state_stride, results at out + x * out_stride; with
/// `narrow`, each x's results are also written there in 8 bits (narrow + x * narrow_stride;
/// inf must then fit). Built for AVX2 / AVX-512 too (MLMAP_ESDF_CLONES): its sweeps vectorise.
MLMAP_ESDF_CLONES
void sweepBlock(const std::uint8_t* states, std::size_t state_stride, std::int32_t* out,
                std::size_t out_stride, int nx, int n, std::int32_t* near_free,
                std::int32_t* near_obstacle, std::int32_t unknown_is_obstacle, std::int32_t cap_d,
                std::int32_t inf, std::int8_t* narrow = nullptr, std::size_t narrow_stride = 0) {
  constexpr std::int32_t kFar = std::int32_t{1} << 24;  // beyond any cap_d
  std::fill(near_free, near_free + n, -kFar);
  std::fill(near_obstacle, near_obstacle + n, -kFar);
  for (int x = 0; x < nx; ++x) {
    sweepForward(states + static_cast<std::size_t>(x) * state_stride,
                 out + static_cast<std::size_t>(x) * out_stride, near_free, near_obstacle, n, x,
                 unknown_is_obstacle);
  }
  std::fill(near_free, near_free + n, nx - 1 + kFar);
  std::fill(near_obstacle, near_obstacle + n, nx - 1 + kFar);
  for (int x = nx - 1; x >= 0; --x) {
    std::int32_t* a = out + static_cast<std::size_t>(x) * out_stride;
    sweepBackward(a, near_free, near_obstacle, n, x, cap_d, inf);
    if (narrow == nullptr) continue;
    std::int8_t* to = narrow + static_cast<std::size_t>(x) * narrow_stride;
    for (int z = 0; z < n; ++z) to[z] = static_cast<std::int8_t>(a[z]);
  }
}

/// Shifts a box-shaped array (x-major, z fastest) of `size` voxels so that new voxel v holds
/// old voxel v + delta; voxels with no old counterpart get `unseen`. In place: each position is
/// read (as the source of position p - offset) before it is written.
template <typename T>
void shiftBox(std::vector<T>* values, const Eigen::Vector3i& size, const VoxelIndex& delta,
              T unseen) {
  const std::ptrdiff_t nx = size.x();
  const std::ptrdiff_t ny = size.y();
  const std::ptrdiff_t nz = size.z();
  const std::ptrdiff_t offset = (delta.x() * ny + delta.y()) * nz + delta.z();
  if (offset == 0) return;
  T* v = values->data();
  const std::ptrdiff_t z_lo = std::max<std::ptrdiff_t>(0, -delta.z());
  const std::ptrdiff_t z_hi = std::min<std::ptrdiff_t>(nz, nz - delta.z());
  const auto run = [&](std::ptrdiff_t x, std::ptrdiff_t y) {
    T* dst = v + (x * ny + y) * nz;
    const std::ptrdiff_t sx = x + delta.x();
    const std::ptrdiff_t sy = y + delta.y();
    if (sx < 0 || sx >= nx || sy < 0 || sy >= ny || z_lo >= z_hi) {
      std::fill(dst, dst + nz, unseen);
      return;
    }
    std::memmove(dst + z_lo, dst + z_lo + offset, static_cast<std::size_t>(z_hi - z_lo) * sizeof(T));
    std::fill(dst, dst + z_lo, unseen);
    std::fill(dst + z_hi, dst + nz, unseen);
  };
  if (offset > 0) {
    for (std::ptrdiff_t x = 0; x < nx; ++x)
      for (std::ptrdiff_t y = 0; y < ny; ++y) run(x, y);
  } else {
    for (std::ptrdiff_t x = nx - 1; x >= 0; --x)
      for (std::ptrdiff_t y = ny - 1; y >= 0; --y) run(x, y);
  }
}

/// Kept-state value of a voxel that was not in the kept box (differs from every state).
constexpr std::uint8_t kUnseenState = 0xFF;
/// Pass-buffer value of a voxel that was not in the kept box (no pass produces it).
constexpr std::int32_t kUnseenPass = std::numeric_limits<std::int32_t>::min();
/// Field value of a voxel that was not in the kept box (beyond any clamp).
constexpr float kUnseenField = std::numeric_limits<float>::lowest();
/// The same for the x pass's 8-bit results (at most cap_d + 1 <= 49 in magnitude) ...
constexpr std::int8_t kUnseenNarrow1 = std::numeric_limits<std::int8_t>::min();
/// ... and the y pass's 16-bit ones (at most cap_sq + 1 < 16384 in magnitude).
constexpr std::int16_t kUnseenNarrow2 = std::numeric_limits<std::int16_t>::min();
/// update() recomputes the whole field when more than 1 / kFullFraction of the voxels changed.
constexpr std::size_t kFullFraction = 16;

/// The part of a line of `length` positions that changed inputs over [lo, hi] reach (see
/// EsdfMap::updateChanged()): the outputs [out_begin, out_end), within `reach` of them, and the
/// inputs those depend on, [in_begin, in_end), within twice that.
struct ReachedPart {
  int in_begin;
  int in_end;
  int out_begin;
  int out_end;
};

inline ReachedPart reachedPart(int lo, int hi, int reach, int length) {
  return {std::max(0, lo - 2 * reach), std::min(length, hi + 2 * reach + 1),
          std::max(0, lo - reach), std::min(length, hi + reach + 1)};
}

}  // namespace

EsdfMap::EsdfMap(const EsdfConfig& config) : config_(validated(config)) {}

void EsdfMap::clear() {
  min_index_.setZero();
  size_.setZero();
  step_x_ = step_y_ = step_z_ = 0;
  field_.clear();  // capacities are kept
  unknown_bits_.clear();
  slab_bits_ = 0;
  kept_ = false;
  changed_cells_.clear();
}

void EsdfMap::prepare(const OccupancyBox& box) {
  min_index_ = box.min_index;
  size_ = box.size;
  resolution_m_ = box.resolution_m;
  inv_resolution_ = 1.0 / resolution_m_;
  const int nx = size_.x();
  const int ny = size_.y();
  const int nz = size_.z();
  step_z_ = nz > 1 ? 1 : 0;
  step_y_ = ny > 1 ? nz : 0;
  step_x_ = nx > 1 ? static_cast<std::ptrdiff_t>(ny) * nz : 0;

  // Squared voxel distances above cap_sq_ are beyond max_distance_m (cap_sq_ > (max / res)^2),
  // or beyond anything the box holds; the work buffers store them as inf_.
  const double max_cells = config_.max_distance_m / resolution_m_;
  const double box_sq = static_cast<double>(nx - 1) * (nx - 1) +
                        static_cast<double>(ny - 1) * (ny - 1) +
                        static_cast<double>(nz - 1) * (nz - 1);
  cap_sq_ = static_cast<std::int32_t>(std::min(std::floor(max_cells * max_cells), box_sq) + 1.0);
  inf_ = cap_sq_ + 1;
  const std::int64_t longest_line = std::max(ny, nz);
  narrow_keys_ = (cap_sq_ + longest_line * longest_line) * longest_line < (std::int64_t{1} << 29);
  cap_d_ = static_cast<std::int32_t>(std::sqrt(static_cast<double>(cap_sq_)));
  while (std::int64_t{cap_d_ + 1} * (cap_d_ + 1) <= cap_sq_) ++cap_d_;
  while (std::int64_t{cap_d_} * cap_d_ > cap_sq_) --cap_d_;
  window_kernel_ = !envelope_only_ && esdf_kernel::windowFits(cap_sq_, cap_d_);
  if (2 * static_cast<std::size_t>(inf_) + 1 <= kMaxLookupEntries) {
    metres_table_.resize(2 * static_cast<std::size_t>(inf_) + 1);
    for (std::size_t i = 0; i < metres_table_.size(); ++i) {
      metres_table_[i] = slowMetres(static_cast<std::int32_t>(i) - inf_);
    }
  } else {
    metres_table_.clear();
  }

  // Buffers (grown only).
  const int threads = std::max(1, config_.num_threads);
  const std::size_t cells = box.states.size();
  field_.resize(cells);
  const std::size_t slab_words = (static_cast<std::size_t>(ny) * nz + 63) / 64;
  slab_bits_ = slab_words * 64;
  unknown_bits_.resize(slab_words * static_cast<std::size_t>(nx));
  // Pass 1's results in 8 bits (+-(cap_d_ + 1) beyond the cap) and pass 2's in 16 where the
  // windowed passes apply (they fit), in 32 otherwise; the other buffers stay empty.
  if (window_kernel_) {
    pass1_.clear();
    pass2_.clear();
    pass1_narrow_.resize(cells);
    pass2_narrow_.resize(cells);
  } else {
    pass1_narrow_.clear();
    pass2_narrow_.clear();
    pass1_.resize(cells);
    pass2_.resize(cells);
  }
  kept_states_.resize(cells);
  resetLineMarks();
  if (scratch_.size() < static_cast<std::size_t>(threads)) {
    scratch_.resize(static_cast<std::size_t>(threads));
  }
  const std::size_t longest = static_cast<std::size_t>(std::max(ny, nz)) + 1;
  const std::size_t row_block =
      static_cast<std::size_t>(std::min(kRowBlock, ny)) * static_cast<std::size_t>(nz);
  for (Scratch& s : scratch_) {
    if (s.near_free.size() < row_block) {
      s.near_free.resize(row_block);
      s.near_obstacle.resize(row_block);
    }
    if (window_kernel_) {
      const std::size_t narrow_block =
          static_cast<std::size_t>(std::min(kNarrowRowBlock, ny)) * static_cast<std::size_t>(nz);
      if (s.sweep.size() < narrow_block * static_cast<std::size_t>(nx)) {
        s.sweep.resize(narrow_block * static_cast<std::size_t>(nx));
      }
    }
    if (s.runs.size() >= longest) continue;
    for (std::vector<std::int32_t>* v :
         {&s.runs, &s.out_sites, &s.in_sites, &s.out_keys32, &s.in_keys32, &s.line}) {
      v->resize(longest);
    }
    s.out_keys64.resize(longest);
    s.in_keys64.resize(longest);
  }
}

bool EsdfMap::compute(const OccupancyBox& box) {
  if (!wellFormed(box)) {
    clear();
    return false;
  }
  try {
    prepare(box);
  } catch (...) {
    clear();
    throw;
  }
  const int threads = std::max(1, config_.num_threads);
  const auto* states = reinterpret_cast<const std::uint8_t*>(box.states.data());
  std::memcpy(kept_states_.data(), states, box.states.size());
  parallelFor(size_.y(), threads, [this, states](int t, int b, int e) {
    sweepRows(states, b, e, &scratch_[static_cast<std::size_t>(t)]);
  });
  parallelFor(size_.x(), threads, [this, states](int t, int b, int e) {
    transformSlabs(states, b, e, &scratch_[static_cast<std::size_t>(t)]);
  });
  kept_ = true;
  last_update_ = UpdateStats{};
  last_update_.changed_states = box.states.size();
  last_update_.rows_swept = static_cast<std::size_t>(size_.y());
  last_update_.y_lines = static_cast<std::size_t>(size_.x()) * static_cast<std::size_t>(size_.z());
  last_update_.z_lines = static_cast<std::size_t>(size_.x()) * static_cast<std::size_t>(size_.y());
  last_update_.changed_cells = box.states.size();
  changed_cells_.clear();
  return true;
}

bool EsdfMap::update(const OccupancyBox& box) { return updateWithin(box, nullptr); }

bool EsdfMap::update(const OccupancyBox& box, const std::vector<Region>& may_have_changed) {
  return updateWithin(box, &may_have_changed);
}

bool EsdfMap::updateWithin(const OccupancyBox& box, const std::vector<Region>* regions) {
  if (!kept_ || !wellFormed(box) || box.size != size_ || box.resolution_m != resolution_m_) {
    return compute(box);
  }
  const VoxelIndex delta = box.min_index - min_index_;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(delta[a]) >= size_[a]) return compute(box);
  }
  last_update_ = UpdateStats{};
  last_update_.full = false;
  // A moved box, where the windowed passes apply: moved along z, every z line reaches a new
  // or a removed face within the clamp (the box is shallow), so it is computed whole. Moved
  // along x or y, the kept box is first brought to the new place with its kept states (see
  // moveWindowed()), then the states that changed there go through the unmoved path below.
  const bool moved_windowed = !delta.isZero() && window_kernel_;
  if (moved_windowed && delta.z() != 0) return compute(box);
  // Until this update is through, the kept state is not the box's: were it cut short (an
  // allocation failing), the next update computes the field whole.
  kept_ = false;
  if (moved_windowed) {
    moveWindowed(box, delta);
  } else if (!delta.isZero()) {
    shiftKept(delta);
    min_index_ = box.min_index;
    last_update_.shifted = true;
  }
  // The changed voxels; many of them (unmoved box): the full compute is cheaper (and uses
  // every thread).
  const std::size_t cells = box.states.size();
  const std::size_t budget = last_update_.shifted ? cells : cells / kFullFraction;
  if (!collectChangedStates(box, budget, delta.isZero() ? regions : nullptr)) return compute(box);
  updateChanged(box, moved_windowed ? VoxelIndex::Zero() : delta);
  if (moved_windowed) {  // every cell may have moved: a copy must take the field whole
    last_update_.shifted = true;
    last_update_.changed_cells = cells;
    changed_cells_.clear();
  }
  kept_ = true;
  return true;
}

bool EsdfMap::collectChangedStates(const OccupancyBox& box, std::size_t budget,
                                   const std::vector<Region>* regions) {
  const auto* now = reinterpret_cast<const std::uint8_t*>(box.states.data());
  const std::uint8_t* kept = kept_states_.data();
  changed_states_.clear();
  // Appends the changed voxels of [i, end), 64 at a time.
  const auto compare = [&](std::size_t i, std::size_t end) {
    while (i < end) {
      const std::size_t n = std::min<std::size_t>(64, end - i);
      if (std::memcmp(now + i, kept + i, n) != 0) {
        for (std::size_t j = i; j < i + n; ++j) {
          if (now[j] != kept[j]) changed_states_.push_back(static_cast<std::uint32_t>(j));
        }
      }
      i += n;
    }
  };
  if (regions == nullptr) {
    const std::size_t cells = box.states.size();
    for (std::size_t i = 0; i < cells; i += 4096) {
      compare(i, std::min(cells, i + 4096));
      if (changed_states_.size() > budget) return false;
    }
    return true;
  }
  const auto ny = static_cast<std::size_t>(size_.y());
  const auto nz = static_cast<std::size_t>(size_.z());
  // Clipped, and regions stacked along z over the same x and y extents merged (submaps one
  // above the other): a column is then compared in one run instead of several short ones.
  std::vector<Region>& merged = merged_regions_;
  merged.clear();
  for (const Region& r : *regions) {
    const Region clipped{r.lo.cwiseMax(0), r.hi.cwiseMin(size_)};
    if ((clipped.hi.array() > clipped.lo.array()).all()) merged.push_back(clipped);
  }
  const auto key = [](const Region& r) {
    return std::array<int, 5>{r.lo.x(), r.lo.y(), r.hi.x(), r.hi.y(), r.lo.z()};
  };
  std::sort(merged.begin(), merged.end(),
            [&](const Region& a, const Region& b) { return key(a) < key(b); });
  std::size_t merged_count = 0;
  for (const Region& r : merged) {
    Region* last = merged_count > 0 ? &merged[merged_count - 1] : nullptr;
    if (last != nullptr && last->lo.head<2>() == r.lo.head<2>() &&
        last->hi.head<2>() == r.hi.head<2>() && r.lo.z() <= last->hi.z()) {
      last->hi.z() = std::max(last->hi.z(), r.hi.z());
    } else {
      merged[merged_count++] = r;
    }
  }
  merged.resize(merged_count);
  for (const Region& r : merged) {
    const Eigen::Vector3i& lo = r.lo;
    const Eigen::Vector3i& hi = r.hi;
    for (int x = lo.x(); x < hi.x(); ++x) {
      for (int y = lo.y(); y < hi.y(); ++y) {
        const std::size_t column = (static_cast<std::size_t>(x) * ny + static_cast<std::size_t>(y)) * nz;
        compare(column + static_cast<std::size_t>(lo.z()), column + static_cast<std::size_t>(hi.z()));
      }
    }
    if (changed_states_.size() > budget) return false;
  }
  // Overlapping regions list a voxel once (most callers' regions are disjoint submaps: then
  // there is nothing to sort).
  const auto overlap = [](const Region& a, const Region& b) {
    return (a.lo.array() < b.hi.array()).all() && (b.lo.array() < a.hi.array()).all();
  };
  bool any_overlap = false;
  for (std::size_t i = 0; i < merged.size() && !any_overlap; ++i) {
    for (std::size_t j = i + 1; j < merged.size() && !any_overlap; ++j) {
      any_overlap = overlap(merged[i], merged[j]);
    }
  }
  if (any_overlap) {
    std::sort(changed_states_.begin(), changed_states_.end());
    changed_states_.erase(std::unique(changed_states_.begin(), changed_states_.end()),
                          changed_states_.end());
  }
  return true;
}

void EsdfMap::resetLineMarks() {
  const auto nx = static_cast<std::size_t>(size_.x());
  const auto ny = static_cast<std::size_t>(size_.y());
  const auto nz = static_cast<std::size_t>(size_.z());
  dirty_y_lo_.assign(nx * nz, size_.y());
  dirty_y_hi_.assign(nx * nz, -1);
  dirty_z_lo_.assign(nx * ny, size_.z());
  dirty_z_hi_.assign(nx * ny, -1);
}

void EsdfMap::moveWindowed(const OccupancyBox& box, const VoxelIndex& delta) {
  const int nx = size_.x();
  const int ny = size_.y();
  const int nz = size_.z();
  const int dx = delta.x();
  const int dy = delta.y();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  const auto* now = reinterpret_cast<const std::uint8_t*>(box.states.data());
  Scratch* scratch = &scratch_[0];
  const auto kept_slab = [&](int x) { return x + dx >= 0 && x + dx < nx; };
  // The kept slabs' states and results (x pass, y pass, field) moved to their new place, in the
  // order that reads each source slab before it is overwritten; the new rows of a kept slab
  // get the new box's states and values no pass produces, so that they differ from the fresh
  // ones below. The new slabs take the new box's states after that (their place may have been
  // a source). This box of states, B', differs from the new one only where the kept part
  // changed, which update() then handles as for an unmoved box. The unknown bits move with the
  // slabs where the rows do not move, and are written again where they do.
  std::uint8_t* kept = kept_states_.data();
  const std::size_t words = slab_bits_ / 64;
  const int row_lo = std::max(0, -dy);
  const int row_hi = std::min(ny, ny - dy);
  const auto kept_rows = static_cast<std::size_t>(row_hi - row_lo) * static_cast<std::size_t>(nz);
  const auto moveSlab = [&](auto* values, int x, auto unseen) {
    auto* slab_values = values + static_cast<std::size_t>(x) * slab;
    std::memmove(slab_values + static_cast<std::size_t>(row_lo) * nz,
                 values + static_cast<std::size_t>(x + dx) * slab +
                     static_cast<std::size_t>(row_lo + dy) * nz,
                 kept_rows * sizeof(*values));
    std::fill(slab_values, slab_values + static_cast<std::size_t>(row_lo) * nz, unseen);
    std::fill(slab_values + static_cast<std::size_t>(row_hi) * nz, slab_values + slab, unseen);
  };
  for (int i = 0; i < nx; ++i) {
    const int x = dx >= 0 ? i : nx - 1 - i;
    if (!kept_slab(x)) continue;
    const std::size_t first = static_cast<std::size_t>(x) * slab;
    std::memmove(kept + first + static_cast<std::size_t>(row_lo) * nz,
                 kept + static_cast<std::size_t>(x + dx) * slab +
                     static_cast<std::size_t>(row_lo + dy) * nz,
                 kept_rows);
    std::memcpy(kept + first, now + first, static_cast<std::size_t>(row_lo) * nz);
    const std::size_t high = static_cast<std::size_t>(row_hi) * nz;
    std::memcpy(kept + first + high, now + first + high, slab - high);
    moveSlab(pass1_narrow_.data(), x, kUnseenNarrow1);
    moveSlab(pass2_narrow_.data(), x, kUnseenNarrow2);
    moveSlab(field_.data(), x, kUnseenField);
    if (dy == 0) {
      std::memmove(unknown_bits_.data() + static_cast<std::size_t>(x) * words,
                   unknown_bits_.data() + static_cast<std::size_t>(x + dx) * words,
                   words * sizeof(std::uint64_t));
    } else {
      writeUnknownBits(kept, x);
    }
  }
  for (int x = 0; x < nx; ++x) {
    if (kept_slab(x)) continue;
    const std::size_t first = static_cast<std::size_t>(x) * slab;
    std::memcpy(kept + first, now + first, slab);
  }
  min_index_ = box.min_index;
  // The x pass of B', a block of rows at a time. In the kept slabs, a result that differs from
  // the moved one (next to a new or removed x face, or in a new row) marks its y line, as a
  // changed state's would; the removed y face marks every kept y line (its neighbours there are
  // gone, with no changed input). The new slabs are transformed whole. updateChanged() then
  // transforms the marked lines.
  const int face = dy > 0 ? 0 : ny - 1;
  const std::int32_t unknown_is_obstacle = config_.unknown_as == UnknownAs::kOccupied ? 1 : 0;
  std::vector<std::int8_t>& narrow_rows = scratch->narrow_rows;
  narrow_rows.resize(static_cast<std::size_t>(std::min(kNarrowRowBlock, ny)) * nz);
  std::int8_t* narrow = narrow_rows.data();
  // In a kept row, the x pass changed only within the clamp of a new or removed x face: the
  // bands [0, low_end) and [high_begin, nx), each swept over a part that reaches cap_d + 1
  // beyond it (its results there are then exact: a voxel farther than cap_d is beyond the cap).
  const int reach = cap_d_ + 1;
  const int low_end = dx == 0 ? 0 : std::min(nx, (dx < 0 ? -dx : 0) + reach);
  const int high_begin = dx == 0 ? nx : std::max(0, nx - (dx > 0 ? dx : 0) - reach);
  const bool split = low_end + reach < high_begin - reach;
  // Writes the fresh results of slab x (`from`, n values of the row block at y0) over the kept
  // ones, marking the y lines where a kept slab's differ.
  const auto merge = [&](int x, const std::int32_t* from, int y0, int n) {
    for (int i = 0; i < n; ++i) narrow[i] = static_cast<std::int8_t>(from[i]);
    std::int8_t* to =
        pass1_narrow_.data() + static_cast<std::size_t>(x) * slab + static_cast<std::size_t>(y0) * nz;
    if (kept_slab(x) && std::memcmp(to, narrow, static_cast<std::size_t>(n)) != 0) {
      int* lo = dirty_y_lo_.data() + static_cast<std::size_t>(x) * nz;
      int* hi = dirty_y_hi_.data() + static_cast<std::size_t>(x) * nz;
      for (int i = 0; i < n; ++i) {
        if (narrow[i] == to[i]) continue;
        const int y = y0 + i / nz;
        const int z = i % nz;
        lo[z] = std::min(lo[z], y);
        hi[z] = std::max(hi[z], y);
      }
    }
    std::memcpy(to, narrow, static_cast<std::size_t>(n));
  };
  // Sweeps the x range [b, e) of the row block at y0 and merges the results of [out_b, out_e).
  const auto sweepPart = [&](int y0, int n, int b, int e, int out_b, int out_e) {
    std::int32_t* fresh = scratch->sweep.data();
    sweepBlock(kept + static_cast<std::size_t>(b) * slab + static_cast<std::size_t>(y0) * nz, slab,
               fresh, static_cast<std::size_t>(n), e - b, n, scratch->near_free.data(),
               scratch->near_obstacle.data(), unknown_is_obstacle, cap_d_, pass1Inf());
    for (int x = out_b; x < out_e; ++x) {
      merge(x, fresh + static_cast<std::size_t>(x - b) * static_cast<std::size_t>(n), y0, n);
    }
  };
  for (int y0 = 0; y0 < ny; y0 += kNarrowRowBlock) {
    const int rows = std::min(kNarrowRowBlock, ny - y0);
    const int n = rows * nz;
    const bool new_rows = y0 < row_lo || y0 + rows > row_hi;
    if (new_rows || !split) {
      sweepPart(y0, n, 0, nx, 0, nx);
      last_update_.rows_swept += static_cast<std::size_t>(rows);
      continue;
    }
    if (low_end > 0 || high_begin < nx) last_update_.rows_swept += static_cast<std::size_t>(rows);
    if (low_end > 0) sweepPart(y0, n, 0, low_end + reach, 0, low_end);
    if (high_begin < nx) sweepPart(y0, n, high_begin - reach, nx, high_begin, nx);
  }
  for (int x = 0; x < nx; ++x) {
    if (!kept_slab(x)) {
      transformSlabs(kept, x, x + 1, scratch);
      last_update_.y_lines += static_cast<std::size_t>(nz);
      last_update_.z_lines += static_cast<std::size_t>(ny);
      continue;
    }
    if (dy == 0) continue;
    int* lo = dirty_y_lo_.data() + static_cast<std::size_t>(x) * nz;
    int* hi = dirty_y_hi_.data() + static_cast<std::size_t>(x) * nz;
    for (int z = 0; z < nz; ++z) {
      lo[z] = std::min(lo[z], face);
      hi[z] = std::max(hi[z], face);
    }
  }
}

void EsdfMap::shiftKept(const VoxelIndex& delta) {
  shiftBox(&kept_states_, size_, delta, kUnseenState);
  shiftBox(&pass1_, size_, delta, kUnseenPass);
  shiftBox(&pass2_, size_, delta, kUnseenPass);
  shiftBox(&field_, size_, delta, kUnseenField);
}

void EsdfMap::updateChanged(const OccupancyBox& box, const VoxelIndex& shift) {
  const int nx = size_.x();
  const int ny = size_.y();
  const int nz = size_.z();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  const std::size_t cells = box.states.size();
  const auto* states = reinterpret_cast<const std::uint8_t*>(box.states.data());
  constexpr auto kUnknown = static_cast<std::uint8_t>(Occupancy::kUnknown);
  Scratch* scratch = &scratch_[0];
  UpdateStats& u = last_update_;
  changed_cells_.clear();
  // A changed input at i changes outputs within reach = cap_d_ + 1 of it (a site's parabola
  // within the cap, or a run boundary next to it); those outputs depend on inputs within reach
  // of them. So lines are transformed again over [lo - 2 reach, hi + 2 reach] and compared over
  // [lo - reach, hi + reach]: the parabolas cut off at the ends lie beyond the cap there.
  const int reach = cap_d_ + 1;
  // After a shift along y (z), the voxels removed on one side change the y (z) pass's results
  // next to that face, with no changed input there: that face counts as changed.
  if (shift.y() != 0) {
    const int face = shift.y() > 0 ? 0 : ny - 1;
    for (std::size_t i = 0; i < dirty_y_lo_.size(); ++i) {
      dirty_y_lo_[i] = std::min(dirty_y_lo_[i], face);
      dirty_y_hi_[i] = std::max(dirty_y_hi_[i], face);
    }
  }
  if (shift.z() != 0) {
    const int face = shift.z() > 0 ? 0 : nz - 1;
    for (std::size_t i = 0; i < dirty_z_lo_.size(); ++i) {
      dirty_z_lo_[i] = std::min(dirty_z_lo_[i], face);
      dirty_z_hi_[i] = std::max(dirty_z_hi_[i], face);
    }
  }
  row_buffer_.resize(static_cast<std::size_t>(nx) * static_cast<std::size_t>(nz));

  // Changed states: the rows of those whose kind changed (obstacle or not: all pass 1 reads) are
  // swept again over the z range of the row's changes; their unknown bits follow (all of them
  // after a shift, whose bits were not shifted). Most of a frame's changes are unknown voxels
  // seen free: with unknown as free, no kind changes there, and no row is swept for them.
  const std::int32_t unknown_is_obstacle = config_.unknown_as == UnknownAs::kOccupied ? 1 : 0;
  // A kept voxel a shift left unseen (kUnseenState) has no pass 1 result yet: always swept.
  const auto kind_changed = [&](std::uint8_t now, std::uint8_t before) {
    return before == kUnseenState ||
           isObstacle(now, unknown_is_obstacle) != isObstacle(before, unknown_is_obstacle);
  };
  std::uint8_t* kept = kept_states_.data();
  row_z_lo_.assign(static_cast<std::size_t>(ny), nz);
  row_z_hi_.assign(static_cast<std::size_t>(ny), -1);
  // x range of a row's changes; after a shift along x the face it removed counts as changed.
  const int x_face = shift.x() > 0 ? 0 : nx - 1;
  row_x_lo_.assign(static_cast<std::size_t>(ny), shift.x() != 0 ? x_face : nx);
  row_x_hi_.assign(static_cast<std::size_t>(ny), shift.x() != 0 ? x_face : -1);
  for (const std::uint32_t c : changed_states_) {
    const std::size_t i = c;
    const std::size_t x = i / slab;
    const std::size_t r = i - x * slab;
    const std::size_t y = r / static_cast<std::size_t>(nz);
    const int z = static_cast<int>(r - y * static_cast<std::size_t>(nz));
    if (kind_changed(states[i], kept[i])) {
      row_z_lo_[y] = std::min(row_z_lo_[y], z);
      row_z_hi_[y] = std::max(row_z_hi_[y], z);
      row_x_lo_[y] = std::min(row_x_lo_[y], static_cast<int>(x));
      row_x_hi_[y] = std::max(row_x_hi_[y], static_cast<int>(x));
    }
    if (!u.shifted && (states[i] == kUnknown) != (kept[i] == kUnknown)) {
      unknown_bits_[(x * slab_bits_ + r) >> 6] ^= std::uint64_t{1} << ((x * slab_bits_ + r) & 63);
      changed_cells_.push_back(c);
    }
    kept[i] = states[i];
  }
  u.changed_states = changed_states_.size();
  if (u.shifted) {
    for (int x = 0; x < nx; ++x) writeUnknownBits(states, x);
  }

  // Pass 1, row by row over the changed z range and the x range the changes reach (as for the
  // lines below); changed results mark their y lines.
  for (int y = 0; y < ny; ++y) {
    const int z_lo = row_z_lo_[static_cast<std::size_t>(y)];
    const int z_hi = row_z_hi_[static_cast<std::size_t>(y)];
    if (z_hi < z_lo) continue;
    ++u.rows_swept;
    const int n = z_hi - z_lo + 1;
    const std::size_t row = static_cast<std::size_t>(y) * nz + static_cast<std::size_t>(z_lo);
    const int x_lo = row_x_lo_[static_cast<std::size_t>(y)];
    const int x_hi = row_x_hi_[static_cast<std::size_t>(y)];
    const ReachedPart xs = reachedPart(x_lo, x_hi, reach, nx);
    const int x_begin = xs.in_begin;
    sweepBlock(states + static_cast<std::size_t>(x_begin) * slab + row, slab, row_buffer_.data(),
               static_cast<std::size_t>(n), xs.in_end - x_begin, n, scratch->near_free.data(),
               scratch->near_obstacle.data(), unknown_is_obstacle, cap_d_, pass1Inf());
    // Writes the fresh results over the kept ones (32 or 8 bits), marking the changed ones.
    const auto merge = [&](auto* kept_pass1, int x) {
      const std::int32_t* fresh =
          row_buffer_.data() + static_cast<std::size_t>(x - x_begin) * static_cast<std::size_t>(n);
      auto* old = kept_pass1 + static_cast<std::size_t>(x) * slab + row;
      int* lo = dirty_y_lo_.data() + static_cast<std::size_t>(x) * nz + z_lo;
      int* hi = dirty_y_hi_.data() + static_cast<std::size_t>(x) * nz + z_lo;
      // Most of the row's results are unchanged: checked first without a branch (it vectorises).
      int differ = 0;
      for (int z = 0; z < n; ++z) differ |= static_cast<int>(fresh[z] != old[z]);
      if (differ == 0) return;
      for (int z = 0; z < n; ++z) {
        if (fresh[z] != old[z]) {
          old[z] = static_cast<std::remove_reference_t<decltype(old[z])>>(fresh[z]);
          lo[z] = std::min(lo[z], y);
          hi[z] = std::max(hi[z], y);
        }
      }
    };
    for (int x = xs.out_begin; x < xs.out_end; ++x) {
      if (window_kernel_) {
        merge(pass1_narrow_.data(), x);
      } else {
        merge(pass1_.data(), x);
      }
    }
  }

  if (window_kernel_) {
    updateLinesWindowed(reach, scratch);
  } else {
    updateLinesEnvelope(reach, scratch);
  }
  u.changed_cells = u.shifted ? cells : changed_cells_.size();
}

void EsdfMap::updateLinesEnvelope(int reach, Scratch* scratch) {
  const int nx = size_.x();
  const int ny = size_.y();
  const int nz = size_.z();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  // Pass 2, the marked y lines; changed results mark their z lines.
  UpdateStats& u = last_update_;
  std::int32_t* line = scratch->line.data();
  for (int x = 0; x < nx; ++x) {
    int* dirty_lo = dirty_y_lo_.data() + static_cast<std::size_t>(x) * nz;
    int* dirty_hi = dirty_y_hi_.data() + static_cast<std::size_t>(x) * nz;
    std::int32_t* slab_values = pass2_.data() + static_cast<std::size_t>(x) * slab;
    int* mark_lo = dirty_z_lo_.data() + static_cast<std::size_t>(x) * ny;
    int* mark_hi = dirty_z_hi_.data() + static_cast<std::size_t>(x) * ny;
    for (int z = 0; z < nz; ++z) {
      if (dirty_hi[z] < dirty_lo[z]) continue;
      const int lo = dirty_lo[z];
      const int hi = dirty_hi[z];
      dirty_lo[z] = ny;  // the marks are left clear (see resetLineMarks())
      dirty_hi[z] = -1;
      ++u.y_lines;
      const ReachedPart part = reachedPart(lo, hi, reach, ny);
      transformYLine(x, z, part.in_begin, part.in_end, line, scratch);
      for (int y = part.out_begin; y < part.out_end; ++y) {
        std::int32_t& old = slab_values[static_cast<std::size_t>(y) * nz + z];
        const std::int32_t fresh = line[y - part.in_begin];
        if (fresh != old) {
          old = fresh;
          mark_lo[y] = std::min(mark_lo[y], z);
          mark_hi[y] = std::max(mark_hi[y], z);
        }
      }
    }
  }

  // Pass 3, the marked z lines, into the field.
  for (int x = 0; x < nx; ++x) {
    int* mark_lo = dirty_z_lo_.data() + static_cast<std::size_t>(x) * ny;
    int* mark_hi = dirty_z_hi_.data() + static_cast<std::size_t>(x) * ny;
    for (int y = 0; y < ny; ++y) {
      if (mark_hi[y] < mark_lo[y]) continue;
      const int lo = mark_lo[y];
      const int hi = mark_hi[y];
      mark_lo[y] = nz;
      mark_hi[y] = -1;
      ++u.z_lines;
      const ReachedPart part = reachedPart(lo, hi, reach, nz);
      transformZLine(x, y, part.in_begin, part.in_end, line, scratch);
      const std::size_t first = static_cast<std::size_t>(x) * slab + static_cast<std::size_t>(y) * nz;
      float* field = field_.data() + first;
      for (int z = part.out_begin; z < part.out_end; ++z) {
        const float m = metres(line[z - part.in_begin]);
        if (m != field[z]) {
          field[z] = m;
          changed_cells_.push_back(static_cast<std::uint32_t>(first + static_cast<std::size_t>(z)));
        }
      }
    }
  }
}

namespace {

/// update()'s windowed passes take their marked lines kGroupLanes at a time.
constexpr auto kGroupWidth = static_cast<std::size_t>(esdf_kernel::kGroupLanes);

/// Floats in a 64-byte cache line (the step of the z pass's prefetches).
constexpr int kFloatsPerCacheLine = 16;

/// Takes the lines marked in lo / hi (per x slab, `per_slab` lines of `length` positions; a
/// line is marked where hi >= 0, unmarked at lo = length, hi = -1), leaving them unmarked, and
/// orders them by the start of their changed range into `sorted` (a counting sort over the
/// possible starts, stable): lines taken kGroupWidth at a time then share most of their ranges.
template <typename Line>
void takeMarkedLines(std::vector<int>* lo, std::vector<int>* hi, int nx, int per_slab, int length,
                     std::vector<Line>* marked, std::vector<Line>* sorted,
                     std::vector<int>* starts) {
  marked->clear();
  // Most lines are unmarked: looked at kScan at a time without a branch first (it vectorises).
  constexpr int kScan = 16;
  int* const lo_at = lo->data();
  int* const hi_at = hi->data();
  for (int x = 0; x < nx; ++x) {
    const std::size_t first = static_cast<std::size_t>(x) * static_cast<std::size_t>(per_slab);
    for (int a0 = 0; a0 < per_slab; a0 += kScan) {
      const int a_end = std::min(per_slab, a0 + kScan);
      int any = 0;
      for (int a = a0; a < a_end; ++a) any |= static_cast<int>(hi_at[first + a] >= 0);
      if (any == 0) continue;
      for (int a = a0; a < a_end; ++a) {
        const std::size_t i = first + static_cast<std::size_t>(a);
        if (hi_at[i] < 0) continue;
        marked->push_back({x, a, lo_at[i], hi_at[i]});
        lo_at[i] = length;
        hi_at[i] = -1;
      }
    }
  }
  std::vector<int>& at = *starts;
  at.assign(static_cast<std::size_t>(length) + 1, 0);
  for (const Line& l : *marked) ++at[static_cast<std::size_t>(l.lo) + 1];
  for (std::size_t i = 1; i < at.size(); ++i) at[i] += at[i - 1];
  sorted->resize(marked->size());
  for (const Line& l : *marked) {
    (*sorted)[static_cast<std::size_t>(at[static_cast<std::size_t>(l.lo)]++)] = l;
  }
}

/// Where a group of marked lines (sorted by start) is transformed along a line of `length`:
/// the part the union of their changed ranges reaches.
template <typename Line>
ReachedPart groupSpan(const Line* group, std::size_t count, int reach, int length) {
  int hi = -1;
  for (std::size_t l = 0; l < count; ++l) hi = std::max(hi, group[l].hi);
  return reachedPart(group[0].lo, hi, reach, length);  // sorted by start
}

/// The part one marked line's changed range reaches.
template <typename Line>
ReachedPart linePart(const Line& line, int reach, int length) {
  return reachedPart(line.lo, line.hi, reach, length);
}

}  // namespace

void EsdfMap::updateLinesWindowed(int reach, Scratch* scratch) {
  // The marked lines of the whole box, ordered by the start of their changed range and taken
  // kGroupWidth at a time, side by side (one lane each) over the union of the group's ranges:
  // a group's lines come from any slab, so that few lanes are idle and the union stays close to
  // each line's own range. Each line's outputs within its own range are exact (a part of a
  // line, see updateChanged()).
  updateYLinesWindowed(reach, scratch);
  updateZLinesWindowed(reach, scratch);
}

void EsdfMap::updateYLinesWindowed(int reach, Scratch* scratch) {
  const int ny = size_.y();
  const auto nz = static_cast<std::size_t>(size_.z());
  const std::size_t slab = static_cast<std::size_t>(ny) * nz;
  std::vector<MarkedLine>& sorted = scratch->sorted;
  takeMarkedLines(&dirty_y_lo_, &dirty_y_hi_, size_.x(), size_.z(), ny, &scratch->marked, &sorted,
                  &scratch->starts);
  last_update_.y_lines = sorted.size();
  // The x pass's signed distance (8 bits, indexed by its byte) -> the y pass's signed input.
  std::array<std::int16_t, 256> square{};
  for (std::size_t byte = 0; byte < square.size(); ++byte) {
    const std::int32_t v = static_cast<std::int8_t>(static_cast<std::uint8_t>(byte));
    const std::int32_t sq = esdf_kernel::squaredAlongX(v, cap_d_, inf_);
    square[byte] = static_cast<std::int16_t>(v < 0 ? -sq : sq);
  }
  esdf_kernel::WindowBuffers* buffers = &scratch->window;
  const auto keptY = [&](const MarkedLine& line) {  // the line's kept y pass results, nz apart
    return pass2_narrow_.data() + static_cast<std::size_t>(line.x) * slab +
           static_cast<std::size_t>(line.across);
  };
  for (std::size_t g = 0; g < sorted.size(); g += kGroupWidth) {
    const std::size_t count = std::min(kGroupWidth, sorted.size() - g);
    const MarkedLine* group = sorted.data() + g;
    const ReachedPart span = groupSpan(group, count, reach, ny);
    const auto n = static_cast<std::size_t>(span.in_end - span.in_begin);
    if (buffers->lines.size() < n * kGroupWidth) buffers->lines.resize(n * kGroupWidth);
    std::int16_t* values = buffers->lines.data();
    // A y line is strided (nz apart): gathered value by value into its lane; idle lanes +inf.
    for (std::size_t l = 0; l < kGroupWidth; ++l) {
      if (l >= count) {
        for (std::size_t i = 0; i < n; ++i) {
          values[i * kGroupWidth + l] = static_cast<std::int16_t>(inf_);
        }
        continue;
      }
      const std::int8_t* in = pass1_narrow_.data() + static_cast<std::size_t>(group[l].x) * slab +
                              static_cast<std::size_t>(span.in_begin) * nz +
                              static_cast<std::size_t>(group[l].across);
      for (std::size_t i = 0; i < n; ++i) {
        values[i * kGroupWidth + l] = square[static_cast<std::uint8_t>(in[i * nz])];
      }
      // The kept results this line's outputs are compared with lie a line apart (a cache line
      // each): fetched now, while the group is transformed.
      const std::int16_t* kept = keptY(group[l]);
      const ReachedPart part = linePart(group[l], reach, ny);
      for (int y = part.out_begin; y < part.out_end; ++y) {
        __builtin_prefetch(kept + static_cast<std::size_t>(y) * nz, 1);
      }
    }
    esdf_kernel::transformLines(values, static_cast<int>(n), esdf_kernel::kGroupLanes,
                                span.out_begin - span.in_begin, span.out_end - span.in_begin,
                                cap_sq_, cap_d_, buffers);
    // Changed results are kept and mark their z lines.
    for (std::size_t l = 0; l < count; ++l) {
      const MarkedLine& line = group[l];
      const auto x = static_cast<std::size_t>(line.x);
      std::int16_t* kept = keptY(line);
      int* mark_lo = dirty_z_lo_.data() + x * static_cast<std::size_t>(ny);
      int* mark_hi = dirty_z_hi_.data() + x * static_cast<std::size_t>(ny);
      const ReachedPart part = linePart(line, reach, ny);
      for (int y = part.out_begin; y < part.out_end; ++y) {
        std::int16_t& old = kept[static_cast<std::size_t>(y) * nz];
        const auto i = static_cast<std::size_t>(y - span.in_begin);
        const std::int16_t fresh = values[i * kGroupWidth + l];
        if (fresh != old) {
          old = fresh;
          mark_lo[y] = std::min(mark_lo[y], line.across);
          mark_hi[y] = std::max(mark_hi[y], line.across);
        }
      }
    }
  }
}

void EsdfMap::updateZLinesWindowed(int reach, Scratch* scratch) {
  const int nz = size_.z();
  const std::size_t slab = static_cast<std::size_t>(size_.y()) * static_cast<std::size_t>(nz);
  std::vector<MarkedLine>& sorted = scratch->sorted;
  takeMarkedLines(&dirty_z_lo_, &dirty_z_hi_, size_.x(), size_.y(), nz, &scratch->marked, &sorted,
                  &scratch->starts);
  last_update_.z_lines = sorted.size();
  // The metres table is there: windowFits() keeps 2 inf_ + 1 below its limit.
  const float* table = metres_table_.data() + inf_;
  esdf_kernel::WindowBuffers* buffers = &scratch->window;
  std::vector<std::int16_t>& gathered = scratch->gathered;
  const auto first = [&](const MarkedLine& line) {
    return static_cast<std::size_t>(line.x) * slab +
           static_cast<std::size_t>(line.across) * static_cast<std::size_t>(nz);
  };
  for (std::size_t g = 0; g < sorted.size(); g += kGroupWidth) {
    const std::size_t count = std::min(kGroupWidth, sorted.size() - g);
    const MarkedLine* group = sorted.data() + g;
    const ReachedPart span = groupSpan(group, count, reach, nz);
    const int rows = span.in_end - span.in_begin;
    const auto n = static_cast<std::size_t>(rows);
    if (buffers->lines.size() < n * kGroupWidth) buffers->lines.resize(n * kGroupWidth);
    if (gathered.size() < n * kGroupWidth) gathered.resize(n * kGroupWidth);
    std::int16_t* values = buffers->lines.data();
    // A z line is contiguous: the group's lines are copied one after another (idle lanes +inf),
    // then transposed to lie side by side (and back).
    for (std::size_t l = 0; l < kGroupWidth; ++l) {
      std::int16_t* to = gathered.data() + l * n;
      if (l < count) {
        const std::int16_t* in =
            pass2_narrow_.data() + first(group[l]) + static_cast<std::size_t>(span.in_begin);
        std::copy(in, in + n, to);
        // The field cells this line writes (a few cache lines anywhere in the box): fetched
        // now, while the group is transformed.
        const float* field = field_.data() + first(group[l]);
        const ReachedPart part = linePart(group[l], reach, nz);
        for (int z = part.out_begin; z < part.out_end; z += kFloatsPerCacheLine) {
          __builtin_prefetch(field + z, 1);
        }
        __builtin_prefetch(field + part.out_end - 1, 1);
      } else {
        std::fill(to, to + n, static_cast<std::int16_t>(inf_));
      }
    }
    esdf_kernel::transpose16(gathered.data(), n, values, kGroupWidth, esdf_kernel::kGroupLanes,
                             rows);
    esdf_kernel::transformLines(values, rows, esdf_kernel::kGroupLanes,
                                span.out_begin - span.in_begin, span.out_end - span.in_begin,
                                cap_sq_, cap_d_, buffers);
    esdf_kernel::transpose16(values, kGroupWidth, gathered.data(), n, rows,
                             static_cast<int>(count));
    // Into the field, branch-free: every cell written and listed, the list advanced past the
    // changed ones.
    for (std::size_t l = 0; l < count; ++l) {
      const MarkedLine& line = group[l];
      const std::size_t row = first(line);
      float* field = field_.data() + row;
      const std::int16_t* fresh = gathered.data() + l * n;
      const ReachedPart part = linePart(line, reach, nz);
      const std::size_t listed = changed_cells_.size();
      changed_cells_.resize(listed + static_cast<std::size_t>(part.out_end - part.out_begin));
      std::uint32_t* next = changed_cells_.data() + listed;
      for (int z = part.out_begin; z < part.out_end; ++z) {
        const float m = table[fresh[z - span.in_begin]];
        const bool changed = m != field[z];
        field[z] = m;
        *next = static_cast<std::uint32_t>(row + static_cast<std::size_t>(z));
        next += changed ? 1 : 0;
      }
      changed_cells_.resize(static_cast<std::size_t>(next - changed_cells_.data()));
    }
  }
}

void EsdfMap::sweepRows(const std::uint8_t* states, int y_begin, int y_end, Scratch* scratch) {
  const int nz = size_.z();
  const std::size_t slab = static_cast<std::size_t>(size_.y()) * static_cast<std::size_t>(nz);
  const std::int32_t unknown_is_obstacle = config_.unknown_as == UnknownAs::kOccupied ? 1 : 0;
  if (window_kernel_) {
    // kNarrowRowBlock rows at a time through the scratch buffer, out in 8 bits.
    for (int y0 = y_begin; y0 < y_end; y0 += kNarrowRowBlock) {
      const std::size_t row = static_cast<std::size_t>(y0) * nz;
      const int n = std::min(kNarrowRowBlock, y_end - y0) * nz;
      sweepBlock(states + row, slab, scratch->sweep.data(), static_cast<std::size_t>(n),
                 size_.x(), n, scratch->near_free.data(), scratch->near_obstacle.data(),
                 unknown_is_obstacle, cap_d_, pass1Inf(), pass1_narrow_.data() + row, slab);
    }
    return;
  }
  // kRowBlock rows (y) at a time: each x step then reads one contiguous run of the arrays.
  for (int y0 = y_begin; y0 < y_end; y0 += kRowBlock) {
    const std::size_t row = static_cast<std::size_t>(y0) * nz;
    const int n = std::min(kRowBlock, y_end - y0) * nz;
    sweepBlock(states + row, slab, pass1_.data() + row, slab, size_.x(), n,
               scratch->near_free.data(), scratch->near_obstacle.data(), unknown_is_obstacle,
               cap_d_, inf_);
  }
}

void EsdfMap::transformYLine(int x, int z, int begin, int end, std::int32_t* line,
                             Scratch* scratch) const {
  const int ny = end - begin;
  const int nz = size_.z();
  const std::int32_t* in = pass1_.data() +
                           (static_cast<std::size_t>(x) * size_.y() + begin) * nz + z;
  for (int y = 0; y < ny; ++y) line[y] = in[static_cast<std::ptrdiff_t>(y) * nz];
  if (narrow_keys_) {
    transformLine<std::int32_t, std::int32_t*, true>(
        line, ny, cap_sq_, cap_d_,
        {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys32.data(),
         scratch->in_sites.data(), scratch->in_keys32.data()});
  } else {
    transformLine<std::int64_t, std::int32_t*, true>(
        line, ny, cap_sq_, cap_d_,
        {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys64.data(),
         scratch->in_sites.data(), scratch->in_keys64.data()});
  }
}

void EsdfMap::transformZLine(int x, int y, int begin, int end, std::int32_t* line,
                             Scratch* scratch) const {
  const int nz = end - begin;
  std::memcpy(line,
              pass2_.data() + (static_cast<std::size_t>(x) * size_.y() + y) * size_.z() + begin,
              static_cast<std::size_t>(nz) * sizeof(std::int32_t));
  if (size_.z() == 1) return;  // (as compute(): no z pass)
  if (narrow_keys_) {
    transformLine<std::int32_t, std::int32_t*, false>(
        line, nz, cap_sq_, cap_d_,
        {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys32.data(),
         scratch->in_sites.data(), scratch->in_keys32.data()});
  } else {
    transformLine<std::int64_t, std::int32_t*, false>(
        line, nz, cap_sq_, cap_d_,
        {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys64.data(),
         scratch->in_sites.data(), scratch->in_keys64.data()});
  }
}

void EsdfMap::transformSlabs(const std::uint8_t* states, int x_begin, int x_end,
                             Scratch* scratch) {
  const int ny = size_.y();
  const int nz = size_.z();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  const float* table = metres_table_.empty() ? nullptr : metres_table_.data() + inf_;
  std::int32_t* line = scratch->line.data();
  for (int x = x_begin; x < x_end; ++x) {
    const std::size_t first = static_cast<std::size_t>(x) * slab;
    float* field = field_.data() + first;
    if (window_kernel_) {
      // Both passes on 16-bit copies of the slab (see esdf_window_kernel.h); the metres table
      // is there (windowFits() keeps 2 inf_ + 1 below its limit).
      esdf_kernel::WindowBuffers* buffers = &scratch->window;
      esdf_kernel::transformSlabY(pass1_narrow_.data() + first, ny, nz, cap_sq_, cap_d_,
                                  pass2_narrow_.data() + first, buffers);
      esdf_kernel::transformSlabZ(ny, nz, cap_sq_, cap_d_, buffers);
      const std::int16_t* values = buffers->signed_sq.data();  // z-major
      const auto lanes = static_cast<std::size_t>(esdf_kernel::paddedLanes(ny));
      for (int y = 0; y < ny; ++y) {
        float* out = field + static_cast<std::size_t>(y) * nz;
        for (int z = 0; z < nz; ++z) out[z] = table[values[static_cast<std::size_t>(z) * lanes + y]];
      }
      writeUnknownBits(states, x);
      continue;
    }
    // Pass 2 in place on a copy of pass 1's slab (the slab stays in cache).
    std::int32_t* a = pass2_.data() + first;
    std::memcpy(a, pass1_.data() + first, slab * sizeof(std::int32_t));
    for (int z = 0; z < nz; ++z) {
      const StridedLine y_line{a + z, nz};
      if (narrow_keys_) {
        transformLine<std::int32_t, StridedLine, true>(
            y_line, ny, cap_sq_, cap_d_,
            {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys32.data(),
             scratch->in_sites.data(), scratch->in_keys32.data()});
      } else {
        transformLine<std::int64_t, StridedLine, true>(
            y_line, ny, cap_sq_, cap_d_,
            {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys64.data(),
             scratch->in_sites.data(), scratch->in_keys64.data()});
      }
    }
    // Pass 3 line by line, into the field in metres.
    for (int y = 0; y < ny; ++y) {
      transformZLine(x, y, 0, nz, line, scratch);
      float* out = field + static_cast<std::size_t>(y) * nz;
      if (table != nullptr) {
        for (int z = 0; z < nz; ++z) out[z] = table[line[z]];
      } else {
        for (int z = 0; z < nz; ++z) out[z] = slowMetres(line[z]);
      }
    }
    writeUnknownBits(states, x);
  }
}

void EsdfMap::writeUnknownBits(const std::uint8_t* states, int x) {
  constexpr auto kUnknown = static_cast<std::uint8_t>(Occupancy::kUnknown);
  const std::size_t slab = static_cast<std::size_t>(size_.y()) * static_cast<std::size_t>(size_.z());
  const std::uint8_t* slab_states = states + static_cast<std::size_t>(x) * slab;
  std::uint64_t* words = unknown_bits_.data() + static_cast<std::size_t>(x) * (slab_bits_ / 64);
  std::size_t i = 0;
  for (; i + 64 <= slab; i += 64) {
    std::uint64_t word = 0;
    for (std::size_t g = 0; g < 64; g += 8) word |= zeroBytes8(slab_states + i + g) << g;
    words[i / 64] = word;
  }
  if (i < slab) {
    std::uint64_t word = 0;
    for (std::size_t b = 0; i + b < slab; ++b) {
      word |= static_cast<std::uint64_t>(slab_states[i + b] == kUnknown ? 1 : 0) << b;
    }
    words[i / 64] = word;
  }
}

void EsdfMap::copyFrom(const EsdfMap& source) {
  config_ = source.config_;
  min_index_ = source.min_index_;
  size_ = source.size_;
  resolution_m_ = source.resolution_m_;
  inv_resolution_ = source.inv_resolution_;
  step_x_ = source.step_x_;
  step_y_ = source.step_y_;
  step_z_ = source.step_z_;
  cap_sq_ = source.cap_sq_;
  inf_ = source.inf_;
  cap_d_ = source.cap_d_;
  narrow_keys_ = source.narrow_keys_;
  field_ = source.field_;
  unknown_bits_ = source.unknown_bits_;
  slab_bits_ = source.slab_bits_;
  kept_ = false;
  last_update_ = source.last_update_;
  changed_cells_.clear();
}

bool EsdfMap::copyCells(const EsdfMap& source, const std::vector<std::uint32_t>& offsets) {
  if (source.min_index_ != min_index_ || source.size_ != size_ ||
      source.resolution_m_ != resolution_m_ || source.slab_bits_ != slab_bits_ ||
      source.field_.size() != field_.size()) {
    return false;
  }
  const std::size_t slab = static_cast<std::size_t>(size_.y()) * static_cast<std::size_t>(size_.z());
  for (const std::uint32_t o : offsets) {
    if (o >= field_.size()) continue;
    field_[o] = source.field_[o];
    const std::size_t x = o / slab;
    const std::size_t bit = x * slab_bits_ + (o - x * slab);
    const std::uint64_t mask = std::uint64_t{1} << (bit & 63);
    std::uint64_t& word = unknown_bits_[bit >> 6];
    word = (word & ~mask) | (source.unknown_bits_[bit >> 6] & mask);
  }
  return true;
}

float EsdfMap::slowMetres(std::int32_t value) const {
  const float max_m = static_cast<float>(config_.max_distance_m);
  const std::int32_t magnitude = value < 0 ? -value : value;
  const float m =
      magnitude >= inf_
          ? max_m
          : std::min(static_cast<float>(std::sqrt(static_cast<double>(magnitude)) * resolution_m_),
                     max_m);
  return value < 0 ? -m : m;
}

float EsdfMap::distanceAt(const VoxelIndex& world_index) const {
  if (!contains(world_index)) return std::numeric_limits<float>::quiet_NaN();
  return field_[offsetOf(world_index)];
}

std::size_t EsdfMap::memoryBytes() const {
  std::size_t bytes = field_.capacity() * sizeof(float) +
                      unknown_bits_.capacity() * sizeof(std::uint64_t) +
                      (pass1_.capacity() + pass2_.capacity() + row_buffer_.capacity()) *
                          sizeof(std::int32_t) +
                      pass2_narrow_.capacity() * sizeof(std::int16_t) +
                      pass1_narrow_.capacity() * sizeof(std::int8_t) +
                      kept_states_.capacity() +
                      (dirty_y_lo_.capacity() + dirty_y_hi_.capacity() + dirty_z_lo_.capacity() +
                       dirty_z_hi_.capacity()) * sizeof(int) +
                      (changed_cells_.capacity() + changed_states_.capacity()) * sizeof(std::uint32_t) +
                      merged_regions_.capacity() * sizeof(Region) +
                      (row_z_lo_.capacity() + row_z_hi_.capacity() + row_x_lo_.capacity() +
                       row_x_hi_.capacity()) * sizeof(int) +
                      metres_table_.capacity() * sizeof(float) +
                      scratch_.capacity() * sizeof(Scratch);
  for (const Scratch& s : scratch_) {
    bytes += (s.runs.capacity() + s.out_sites.capacity() + s.in_sites.capacity() +
              s.out_keys32.capacity() + s.in_keys32.capacity() + s.near_free.capacity() +
              s.near_obstacle.capacity() + s.line.capacity() + s.sweep.capacity()) *
                 sizeof(std::int32_t) +
             (s.out_keys64.capacity() + s.in_keys64.capacity()) * sizeof(std::int64_t) +
             (s.marked.capacity() + s.sorted.capacity()) * sizeof(MarkedLine) +
             s.starts.capacity() * sizeof(int) + s.gathered.capacity() * sizeof(std::int16_t) +
             s.narrow_rows.capacity() +
             (s.window.magnitude.capacity() + s.window.best.capacity() +
              s.window.near_free.capacity() + s.window.near_obstacle.capacity() +
              s.window.lines.capacity() + s.window.transposed.capacity() +
              s.window.signed_sq.capacity()) *
                 sizeof(std::int16_t);
  }
  return bytes;
}

}  // namespace mlmap
