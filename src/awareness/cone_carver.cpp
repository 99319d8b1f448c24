#include "mlmap/awareness/cone_carver.h"

#include <algorithm>
#include <cmath>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define MLMAP_HAVE_AVX2_SLABS 1
#include <immintrin.h>
#endif

namespace mlmap {
namespace {
constexpr double kEdgeEpsilon = 1e-9;  // a cone only touching a voxel face does not mark it
constexpr std::uint64_t kAllBits = ~std::uint64_t{0};

// Sets bits z0..z1 (z0 <= z1) of a z row that spans several words (out of line: rare, and its
// loop would take the registers of the slab walk).
[[gnu::noinline]] void markLongRun(std::uint64_t* row, int z0, int z1) {
  const int w0 = z0 >> 6;
  const int w1 = z1 >> 6;
  row[w0] |= kAllBits << (z0 & 63);
  for (int w = w0 + 1; w < w1; ++w) row[w] = kAllBits;
  row[w1] |= kAllBits >> (63 - (z1 & 63));
}

// Sets bits z0..z1 of `rows` rows `stride` words apart.
inline void markRuns(std::uint64_t* row, std::size_t stride, int rows, int z0, int z1) {
  const int w0 = z0 >> 6;
  if (w0 != (z1 >> 6)) {
    for (int r = 0; r < rows; ++r, row += stride) markLongRun(row, z0, z1);
    return;
  }
  const std::uint64_t mask = (kAllBits << (z0 & 63)) & (kAllBits >> (63 - (z1 & 63)));
  row += w0;
  if (rows <= 2) {
    // One or two rows (nearly every slab of a thin cone): the first and the last, the same row
    // twice when there is one (an OR is idempotent), so no loop whose count the CPU mispredicts.
    row[0] |= mask;
    row[static_cast<std::size_t>(rows - 1) * stride] |= mask;
    return;
  }
  for (int r = 0; r < rows; ++r, row += stride) *row |= mask;
}

// Two doubles (an SSE2 / NEON register, as GCC and Clang vector extensions), with the selects
// written as bit masks so that both compilers keep them in the vector unit.
using V2 = double __attribute__((vector_size(16)));
using M2 = long long __attribute__((vector_size(16)));
using I2 = int __attribute__((vector_size(8)));

#if defined(__SSE2__)
// One instruction each: minpd(x, y) is x < y ? x : y and maxpd(x, y) is x > y ? x : y per lane,
// so with the operands swapped they are std::min and std::max exactly (NaN and signed zeros
// included); the masks below take four.
inline V2 vmin(V2 a, V2 b) { return (V2)_mm_min_pd((__m128d)b, (__m128d)a); }  // std::min per lane
inline V2 vmax(V2 a, V2 b) { return (V2)_mm_max_pd((__m128d)b, (__m128d)a); }  // std::max per lane
#else
inline V2 select(M2 mask, V2 a, V2 b) { return (V2)((mask & (M2)a) | (~mask & (M2)b)); }
inline V2 vmin(V2 a, V2 b) { return select(b < a, b, a); }  // std::min per lane
inline V2 vmax(V2 a, V2 b) { return select(a < b, b, a); }  // std::max per lane
#endif
// floorToInt per lane (|x| < 2^31), as doubles.
inline V2 vfloor(V2 x) {
  const V2 t = __builtin_convertvector(__builtin_convertvector(x, I2), V2);
  const V2 one = {1.0, 1.0};
  return t - (V2)((x < t) & (M2)one);
}

// The cone's walk along its dominant axis A; b = A + 1 and c = A + 2 (mod 3) are the section's
// axes. The section's extent on b and c at parameter s is o + s * [lo, hi], so for slab i, which
// the cone overlaps for s in [s_lo, s_hi], the bounds on b are o_b + min(s_lo lo_b, s_hi lo_b)
// and o_b + max(s_lo hi_b, s_hi hi_b), and likewise on c. The lanes hold (b, c); the high
// bounds are kept negated, so that they too take a minimum and a floor: ceil(x - e) =
// -floor(-x + e), and negation is exact, so the lanes give the voxels of the scalar formulas.
//
// Where neither s0 nor 1 clamps a slab's [s_lo, s_hi] (every slab but the first and last few),
// each of the four bounds takes the same end of that interval from slab to slab, so it is affine
// in i: the slab loop then evaluates first = floor(a + b i) and last = floor(a' + b' i) with the
// edge epsilon folded in, two multiply-adds instead of the eight products and four minima of the
// general formula. The two differ by rounding (~1e-13 voxel) only, far inside kEdgeEpsilon, and
// `last` is floor(x - e) rather than ceil(x - e) - 1, one voxel more where x - e is a whole
// number: a cone exactly that far only touching a face.
struct Walk {
  double oa;
  double inv_na, inv_fa;  // 1 / near face, 1 / far face offset along A
  double off_lo, off_hi;  // slab i overlaps s in [(i + off_lo - oa) / fa, (i + off_hi - oa) / na]
  double s0;
  V2 base_lo, coef_lo, limit_lo;  // (o_b, o_c), (lo_b, lo_c), (first b, first c) marked
  V2 base_hi, coef_hi, limit_hi;  // (-o_b, -o_c), (-hi_b, -hi_c), -(end b, end c) marked
  // Unclamped slabs: (b, c) of o + s lo + e and of o + s hi - e as a + i * slope.
  V2 first_at0, first_slope;
  V2 last_at0, last_slope, last_limit;  // last_limit: (end b, end c) - 0.5
};

// Marks slab i's rectangle of voxels (b in [j0, j1], c in [k0, k1]; none when empty).
template <int A>
inline void markSlab(int i, I2 first, I2 last, std::uint64_t* words, std::size_t stride_x,
                     std::size_t stride_y) {
  const int j0 = first[0];
  const int k0 = first[1];
  const int j1 = last[0];
  const int k1 = last[1];
  if (j0 > j1 || k0 > k1) return;
  const std::size_t ui = static_cast<std::size_t>(i);
  if constexpr (A == 0) {  // b = y, c = z
    markRuns(words + ui * stride_x + static_cast<std::size_t>(j0) * stride_y, stride_y, j1 - j0 + 1,
             k0, k1);
  } else if constexpr (A == 1) {  // b = z, c = x
    markRuns(words + static_cast<std::size_t>(k0) * stride_x + ui * stride_y, stride_x, k1 - k0 + 1,
             j0, j1);
  } else {  // b = x, c = y: one bit of each row
    const std::uint64_t bit = std::uint64_t{1} << (i & 63);
    std::uint64_t* column = words + (ui >> 6) + static_cast<std::size_t>(j0) * stride_x;
    for (int j = j0; j <= j1; ++j, column += stride_x) {
      std::uint64_t* word = column + static_cast<std::size_t>(k0) * stride_y;
      for (int k = k0; k <= k1; ++k, word += stride_y) *word |= bit;
    }
  }
}

// Slab i's overlap [s_lo, s_hi] with the cone's parameter before clamping to [s0, 1]; each end
// is monotonic in i (a sum and a product by a constant, both rounded monotonically), so the
// slabs where neither clamps are one run.
inline V2 freeOverlap(const Walk& w, int i) {
  return V2{(static_cast<double>(i) + w.off_lo - w.oa) * w.inv_fa,
            (static_cast<double>(i) + w.off_hi - w.oa) * w.inv_na};
}
inline bool unclamped(const Walk& w, V2 s) { return s[0] >= w.s0 && s[1] <= 1.0; }

#ifdef MLMAP_HAVE_AVX2_SLABS
#define MLMAP_AVX2 __attribute__((target("avx2"), always_inline)) inline

// Lane k of v in all four lanes.
MLMAP_AVX2 __m256d lane4(V2 v, int k) { return _mm256_set1_pd(v[k]); }

// Four slabs' `first` of the scalar loop: vmax(at0 + vi * slope, floor) truncated, where
// vmax(x, y) is maxpd with the operands swapped.
MLMAP_AVX2 __m128i firstOf4(__m256d vi, __m256d at0, __m256d slope, __m256d floor) {
  return _mm256_cvttpd_epi32(_mm256_max_pd(floor, _mm256_add_pd(at0, _mm256_mul_pd(vi, slope))));
}

// Four slabs' `last` of the scalar loop: vmax(vmin(at0 + vi * slope, limit), -1) + 1,
// truncated, less one.
MLMAP_AVX2 __m128i lastOf4(__m256d vi, __m256d at0, __m256d slope, __m256d limit) {
  const __m256d x = _mm256_min_pd(limit, _mm256_add_pd(at0, _mm256_mul_pd(vi, slope)));
  const __m256d up = _mm256_add_pd(_mm256_max_pd(_mm256_set1_pd(-1.0), x), _mm256_set1_pd(1.0));
  return _mm_sub_epi32(_mm256_cvttpd_epi32(up), _mm_set1_epi32(1));
}

// Unclamped slabs i_begin..i_end of a cone along x (A = 0) or y (A = 1), four at a time in
// AVX2; returns the first slab it left (i_begin for a box too big for it, else past i_end).
// Each lane computes a bound as the scalar loop does (the same product and sum: no fused
// multiply-add, "avx2" only; the same truncation), so the slabs are the same rectangles. Their z
// masks are made four at a time too, and a rectangle of one or two rows within one word of z
// (nearly all) is marked by two ORs with no branch; any other goes to markSlab().
template <int A>
__attribute__((target("avx2"))) int walkRunAvx2(const Walk& w, V2 first_floor, int i_begin,
                                                int i_end, std::uint64_t* words,
                                                std::size_t stride_x, std::size_t stride_y) {
  static_assert(A == 0 || A == 1, "along z a slab marks one bit per row");
  const __m256d first_at0_b = lane4(w.first_at0, 0), first_at0_c = lane4(w.first_at0, 1);
  const __m256d first_slope_b = lane4(w.first_slope, 0), first_slope_c = lane4(w.first_slope, 1);
  const __m256d first_floor_b = lane4(first_floor, 0), first_floor_c = lane4(first_floor, 1);
  const __m256d last_at0_b = lane4(w.last_at0, 0), last_at0_c = lane4(w.last_at0, 1);
  const __m256d last_slope_b = lane4(w.last_slope, 0), last_slope_c = lane4(w.last_slope, 1);
  const __m256d last_limit_b = lane4(w.last_limit, 0), last_limit_c = lane4(w.last_limit, 1);
  const __m256d four = _mm256_set1_pd(4.0);
  const __m128i one_i = _mm_set1_epi32(1);
  const __m128i low6 = _mm_set1_epi32(63);
  const __m256i all = _mm256_set1_epi64x(-1);
  // Rows along `row_stride` (y for A = 0, x for A = 1), bits along z; slab i's plane at i * plane.
  const std::size_t row_stride = A == 0 ? stride_y : stride_x;
  const std::size_t plane = A == 0 ? stride_x : stride_y;
  if ((plane | row_stride) >> 32 != 0) return i_begin;  // a box too big for 32-bit factors
  const __m256i plane4 = _mm256_set1_epi64x(static_cast<long long>(plane));
  const __m256i row_stride4 = _mm256_set1_epi64x(static_cast<long long>(row_stride));
  alignas(32) std::uint64_t masks[4];
  alignas(32) std::uint64_t first_words[4];
  alignas(32) std::uint64_t last_words[4];
  const double d0 = static_cast<double>(i_begin);
  __m256d vi = _mm256_setr_pd(d0, d0 + 1.0, d0 + 2.0, d0 + 3.0);
  // The last group's lanes past i_end repeat slab i_end (marking a slab twice changes nothing),
  // so the whole run goes four slabs at a time.
  const __m256d last_slab = _mm256_set1_pd(static_cast<double>(i_end));
  const __m128i last_slab_i = _mm_set1_epi32(i_end);
  int i = i_begin;
  for (; i <= i_end; i += 4, vi = _mm256_add_pd(vi, four)) {
    const __m256d vs = _mm256_min_pd(vi, last_slab);
    const __m128i j0 = firstOf4(vs, first_at0_b, first_slope_b, first_floor_b);
    const __m128i k0 = firstOf4(vs, first_at0_c, first_slope_c, first_floor_c);
    const __m128i j1 = lastOf4(vs, last_at0_b, last_slope_b, last_limit_b);
    const __m128i k1 = lastOf4(vs, last_at0_c, last_slope_c, last_limit_c);
    const __m128i r0 = A == 0 ? j0 : k0;  // rows
    const __m128i r1 = A == 0 ? j1 : k1;
    const __m128i z0 = A == 0 ? k0 : j0;  // bits
    const __m128i z1 = A == 0 ? k1 : j1;
    // Empty: r0 > r1 or z0 > z1. Simple: at most two rows, one word of z.
    const __m128i empty = _mm_or_si128(_mm_cmpgt_epi32(r0, r1), _mm_cmpgt_epi32(z0, z1));
    const __m128i simple =
        _mm_andnot_si128(_mm_cmpgt_epi32(_mm_sub_epi32(r1, r0), one_i),
                         _mm_cmpeq_epi32(_mm_srai_epi32(z0, 6), _mm_srai_epi32(z1, 6)));
    const __m256i from = _mm256_cvtepi32_epi64(_mm_and_si128(z0, low6));
    const __m256i to = _mm256_cvtepi32_epi64(_mm_sub_epi32(low6, _mm_and_si128(z1, low6)));
    _mm256_store_si256(reinterpret_cast<__m256i*>(masks),
                       _mm256_and_si256(_mm256_sllv_epi64(all, from), _mm256_srlv_epi64(all, to)));
    const int empty_bits = _mm_movemask_ps(_mm_castsi128_ps(empty));
    const int simple_bits = _mm_movemask_ps(_mm_castsi128_ps(simple)) & ~empty_bits;
    if (simple_bits == 0xF) {
      // Each slab's word in its first row, slab * plane + r0 * row_stride + z0 / 64, and in its
      // last, r1 - r0 (0 or 1) rows on: all four in 64 bits (the factors are non-negative and
      // below 2^32 here, as mul_epu32 takes them).
      const __m128i slab =
          _mm_min_epi32(_mm_add_epi32(_mm_set1_epi32(i), _mm_setr_epi32(0, 1, 2, 3)), last_slab_i);
      const __m256i first_word = _mm256_add_epi64(
          _mm256_add_epi64(_mm256_mul_epu32(_mm256_cvtepi32_epi64(slab), plane4),
                           _mm256_mul_epu32(_mm256_cvtepi32_epi64(r0), row_stride4)),
          _mm256_cvtepi32_epi64(_mm_srai_epi32(z0, 6)));
      const __m256i last_word = _mm256_add_epi64(
          first_word, _mm256_mul_epu32(_mm256_cvtepi32_epi64(_mm_sub_epi32(r1, r0)), row_stride4));
      _mm256_store_si256(reinterpret_cast<__m256i*>(first_words), first_word);
      _mm256_store_si256(reinterpret_cast<__m256i*>(last_words), last_word);
      for (int l = 0; l < 4; ++l) {
        words[first_words[l]] |= masks[l];
        words[last_words[l]] |= masks[l];
      }
      continue;
    }
    alignas(16) std::int32_t b0[4], c0[4], b1[4], c1[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(b0), j0);
    _mm_store_si128(reinterpret_cast<__m128i*>(c0), k0);
    _mm_store_si128(reinterpret_cast<__m128i*>(b1), j1);
    _mm_store_si128(reinterpret_cast<__m128i*>(c1), k1);
    for (int l = 0; l < std::min(4, i_end - i + 1); ++l) {
      if ((empty_bits >> l) & 1) continue;
      markSlab<A>(i + l, I2{b0[l], c0[l]}, I2{b1[l], c1[l]}, words, stride_x, stride_y);
    }
  }
  return i;
}
#undef MLMAP_AVX2
#endif

// Marks slabs i_begin..i_end (inside the box along A). Templated on A so that each slab's
// rectangle maps to whole z runs (or, along z, to one bit per row) with no per-voxel index math.
// The run of unclamped slabs is found from its two ends (the clamped slabs are the first and
// last few) and walked without the clamp test.
template <int A, bool kClipX>
void walkSlabs(const Walk& w, int i_begin, int i_end, std::uint64_t* words, std::size_t stride_x,
               std::size_t stride_y, bool avx2) {
  const V2 eps = {kEdgeEpsilon, kEdgeEpsilon};
  const V2 one = {1.0, 1.0};
  const V2 first_floor = kClipX ? w.limit_lo : V2{0.0, 0.0};  // the first voxels marked
  // A clamped slab (its overlap `s` before clamping): the general formula.
  const auto clampedSlab = [&](int i, V2 s) {
    const double s_lo = std::max(s[0], w.s0);
    const double s_hi = std::min(s[1], 1.0);
    if (!(s_lo <= s_hi)) return;
    const V2 lo_s = {s_lo, s_lo};
    const V2 hi_s = {s_hi, s_hi};
    const V2 low =
        vmax(vfloor(w.base_lo + vmin(lo_s * w.coef_lo, hi_s * w.coef_lo) + eps), w.limit_lo);
    const V2 high =
        vmax(vfloor(w.base_hi + vmin(lo_s * w.coef_hi, hi_s * w.coef_hi) + eps), w.limit_hi);
    markSlab<A>(i, __builtin_convertvector(low, I2), -__builtin_convertvector(high, I2) - 1, words,
                stride_x, stride_y);
  };
  // The clamped slabs before the run and after it, each marked where the search meets it.
  int run_begin = i_begin;
  for (; run_begin <= i_end; ++run_begin) {
    const V2 s = freeOverlap(w, run_begin);
    if (unclamped(w, s)) break;
    clampedSlab(run_begin, s);
  }
  int run_end = i_end;
  for (; run_end >= run_begin; --run_end) {
    const V2 s = freeOverlap(w, run_end);
    if (unclamped(w, s)) break;
    clampedSlab(run_end, s);
  }
  int i_scalar = run_begin;
#ifdef MLMAP_HAVE_AVX2_SLABS
  if constexpr (A != 2) {
    // Runs of four slabs or more: a shorter one costs less than the walk's set-up in scalar.
    if (avx2 && run_end - run_begin >= 3)
      i_scalar = walkRunAvx2<A>(w, first_floor, run_begin, run_end, words, stride_x, stride_y);
  }
#endif
  static_cast<void>(avx2);
  for (int i = i_scalar; i <= run_end; ++i) {
    // Unclamped: the bounds are affine in i. Truncation is floor here: `first` is clamped to
    // the first voxel marked (>= 0) first, `last` to >= -1 and shifted by one.
    const V2 vi = {static_cast<double>(i), static_cast<double>(i)};
    const I2 first =
        __builtin_convertvector(vmax(w.first_at0 + vi * w.first_slope, first_floor), I2);
    const V2 x_last = vmax(vmin(w.last_at0 + vi * w.last_slope, w.last_limit), -one) + one;
    markSlab<A>(i, first, __builtin_convertvector(x_last, I2) - 1, words, stride_x, stride_y);
  }
}

// The cone along its dominant axis A (the box lies on one side of the origin along A): its
// walk's constants, then its slabs. Templated on A so that the set-up indexes the coordinates
// with constants (about a quarter of a scan's cones' set-up went into computed indices and their
// spills).
template <int A, bool kClipX>
std::size_t carveAlong(const Eigen::Vector3d& origin, const Eigen::Vector3d& lo,
                       const Eigen::Vector3d& hi, double s_min, const Eigen::Vector3i& first_marked,
                       const Eigen::Vector3i& end_marked, std::uint64_t* words,
                       std::size_t stride_x, std::size_t stride_y, bool avx2) {
  const int a = A;  // constant expressions, indexing the coordinates
  const int b = (A + 1) % 3;
  const int c = (A + 2) % 3;
  const bool forward = lo[a] > 0.0;
  // Along a the extent is monotonic in s: near face `na`, far face `fa` (both same sign).
  const double na = forward ? lo[a] : hi[a];
  const double fa = forward ? hi[a] : lo[a];
  Walk w{};
  w.oa = origin[a];
  w.inv_na = 1.0 / na;
  w.inv_fa = 1.0 / fa;
  w.off_lo = forward ? 0.0 : 1.0;
  w.off_hi = forward ? 1.0 : 0.0;
  w.s0 = std::max(s_min, 0.0);
  w.base_lo = V2{origin[b], origin[c]};
  w.coef_lo = V2{lo[b], lo[c]};
  w.limit_lo = V2{static_cast<double>(first_marked[b]), static_cast<double>(first_marked[c])};
  w.base_hi = V2{-origin[b], -origin[c]};
  w.coef_hi = V2{-hi[b], -hi[c]};
  w.limit_hi = V2{-static_cast<double>(end_marked[b]), -static_cast<double>(end_marked[c])};
  // Unclamped slab i: s_lo = i / fa + (off_lo - oa) / fa and s_hi = i / na + (off_hi - oa) / na.
  // The section's low bound on an axis takes s_lo where lo >= 0 (its minimum over [s_lo, s_hi]),
  // s_hi otherwise; the high bound s_hi where hi >= 0, s_lo otherwise.
  const double s_lo_at0 = (w.off_lo - w.oa) * w.inv_fa;
  const double s_hi_at0 = (w.off_hi - w.oa) * w.inv_na;
  const int bc[2] = {b, c};
  for (int lane = 0; lane < 2; ++lane) {
    const int k = bc[lane];
    const bool lo_takes_s_lo = lo[k] >= 0.0;
    const bool hi_takes_s_lo = hi[k] < 0.0;
    w.first_at0[lane] = origin[k] + (lo[k] * (lo_takes_s_lo ? s_lo_at0 : s_hi_at0) + kEdgeEpsilon);
    w.first_slope[lane] = lo[k] * (lo_takes_s_lo ? w.inv_fa : w.inv_na);
    w.last_at0[lane] = origin[k] + (hi[k] * (hi_takes_s_lo ? s_lo_at0 : s_hi_at0) - kEdgeEpsilon);
    w.last_slope[lane] = hi[k] * (hi_takes_s_lo ? w.inv_fa : w.inv_na);
    w.last_limit[lane] = static_cast<double>(end_marked[k]) - 0.5;
  }
  // Slabs from the one holding s0 to the one holding the far face; at least the first (when s0
  // lies beyond the far face).
  const int i_first = floorToInt(w.oa + w.s0 * na);
  const int i_last = floorToInt(w.oa + fa - (forward ? kEdgeEpsilon : -kEdgeEpsilon));
  const int i_far = forward ? std::max(i_last, i_first) : std::min(i_last, i_first);
  const std::size_t slabs = static_cast<std::size_t>(std::abs(i_far - i_first)) + 1;
  const int i_begin = std::max(std::min(i_first, i_far), first_marked[a]);
  const int i_end = std::min(std::max(i_first, i_far), end_marked[a] - 1);
  walkSlabs<A, kClipX>(w, i_begin, i_end, words, stride_x, stride_y, avx2);
  return slabs;
}

// carveCone() on box x in [x_begin, x_end); kClipX false: the whole box (x_begin 0, x_end the
// box's), the hot path, where the limits fold into constants.
template <bool kClipX>
std::size_t carveConeIn(const Eigen::Vector3d& origin, const VoxelSpaceBox& box, double s_min,
                        int x_begin, int x_end, VoxelBitset* free, bool avx2) {
  const Eigen::Vector3i& dims = free->dims();
  if constexpr (kClipX) {
    x_begin = std::max(x_begin, 0);
    x_end = std::min(x_end, dims.x());
  } else {
    x_begin = 0;
    x_end = dims.x();
  }
  // The voxels marked along each axis: [first, end).
  const Eigen::Vector3i first_marked(x_begin, 0, 0);
  const Eigen::Vector3i end_marked(x_end, dims.y(), dims.z());
  // Per axis, the section at s spans [o + s * lo, o + s * hi].
  const Eigen::Vector3d lo = box.min.cast<double>() - origin;
  const Eigen::Vector3d hi = box.max.cast<double>() - origin;
  // Dominant axis: the one along which the box lies entirely on one side of the origin, farthest
  // (the first of equals); none when the box holds the origin on every axis. Selects, not
  // branches: the axis changes from cone to cone.
  double reach[3];
  for (int k = 0; k < 3; ++k) {
    const bool one_side = lo[k] > 0.0 || hi[k] < 0.0;
    reach[k] = one_side ? std::max(std::abs(lo[k]), std::abs(hi[k])) : 0.0;
  }
  int a = reach[1] > reach[0] ? 1 : 0;
  a = reach[2] > reach[a] ? 2 : a;
  if (!(reach[a] > 0.0)) a = -1;
  std::uint64_t* words = free->data();
  const std::size_t stride_y = free->wordsPerRow();
  const std::size_t stride_x = stride_y * static_cast<std::size_t>(dims.y());
  if (a < 0) {
    // The origin lies inside the box: the cone is the box's hull with the origin; mark the
    // voxels of the box (a sensor inside an end voxel).
    const Eigen::Vector3i v0 = box.min.array().floor().cast<int>().max(first_marked.array());
    const Eigen::Vector3i v1 = box.max.array().floor().cast<int>().min(end_marked.array() - 1);
    if (v0.y() > v1.y() || v0.z() > v1.z()) return 1;
    for (int x = v0.x(); x <= v1.x(); ++x)
      markRuns(words + free->rowWord(x, v0.y()), stride_y, v1.y() - v0.y() + 1, v0.z(), v1.z());
    return 1;
  }
  if (a == 0) {
    return carveAlong<0, kClipX>(origin, lo, hi, s_min, first_marked, end_marked, words, stride_x,
                                 stride_y, avx2);
  }
  if (a == 1) {
    return carveAlong<1, kClipX>(origin, lo, hi, s_min, first_marked, end_marked, words, stride_x,
                                 stride_y, avx2);
  }
  return carveAlong<2, kClipX>(origin, lo, hi, s_min, first_marked, end_marked, words, stride_x,
                               stride_y, avx2);
}

const bool kAvx2Supported = [] {
#ifdef MLMAP_HAVE_AVX2_SLABS
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}();

}  // namespace

bool coneCarverAvx2Supported() { return kAvx2Supported; }

std::size_t carveCone(const Eigen::Vector3d& origin, const VoxelSpaceBox& box, double s_min,
                      VoxelBitset* free) {
  return carveConeIn<false>(origin, box, s_min, 0, 0, free, kAvx2Supported);
}

std::size_t carveCone(const Eigen::Vector3d& origin, const VoxelSpaceBox& box, double s_min,
                      VoxelBitset* free, ConeCarverIsa isa) {
  return carveConeIn<false>(origin, box, s_min, 0, 0, free, isa == ConeCarverIsa::kAvx2);
}

std::size_t carveCone(const Eigen::Vector3d& origin, const VoxelSpaceBox& box, double s_min,
                      int x_begin, int x_end, VoxelBitset* free) {
  return carveConeIn<true>(origin, box, s_min, x_begin, x_end, free, kAvx2Supported);
}

std::size_t carveCone(const Eigen::Vector3d& origin, const Eigen::Vector3i& end,
                      VoxelBitset* free) {
  const Eigen::Vector3f lo = end.cast<float>();
  // Just inside the far faces: a point on a far face belongs to the next voxel.
  const Eigen::Vector3f hi = lo + Eigen::Vector3f::Constant(1.0f - 1e-6f);
  return carveCone(origin, VoxelSpaceBox{lo, hi}, 0.0, free);
}

}  // namespace mlmap
