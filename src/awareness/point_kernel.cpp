#include "mlmap/awareness/point_kernel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define MLMAP_HAVE_AVX2_KERNEL 1
#include <immintrin.h>
#endif

namespace mlmap {
namespace {

inline int floorToIntVec(double x) {  // floorToInt in a form the vectoriser takes
  const int i = static_cast<int>(x);
  return x < static_cast<double>(i) ? i - 1 : i;
}

// kMayCut false: every point of the block is known to be finite and within the maximum range
// (the common depth-camera block), so the square root and division that cut the others are left
// out (the two comparisons stay: cheap, and the same code for both); the results are the same
// bits.
template <bool kMayCut>
[[gnu::always_inline]] inline void classifyPointsImpl(const PointKernel& k, const float* xs,
                                                      const float* ys, const float* zs,
                                                      std::size_t n, std::uint32_t* keys,
                                                      float* coords) {
  // Locals, so that the compiler knows the stores below do not change them.
  const double m0 = k.m[0], m1 = k.m[1], m2 = k.m[2], m3 = k.m[3], m4 = k.m[4], m5 = k.m[5];
  const double m6 = k.m[6], m7 = k.m[7], m8 = k.m[8];
  const double o0 = k.o[0], o1 = k.o[1], o2 = k.o[2];
  const double bo0 = k.box_origin[0], bo1 = k.box_origin[1], bo2 = k.box_origin[2];
  const std::uint32_t d0 = k.dims[0], d1 = k.dims[1], d2 = k.dims[2];
  const double max_range = k.max_range;
  const double max_range2 = max_range * max_range;
  const double min_range2 = k.min_range2;
  for (std::size_t i = 0; i < n; ++i) {
    double x = xs[i];
    double y = ys[i];
    double z = zs[i];
    const double r2 = x * x + y * y + z * z;
    const bool finite = r2 <= std::numeric_limits<double>::max();  // false for NaN and Inf
    const bool cut = r2 > max_range2;
    if constexpr (kMayCut) {
      // min(1, max / |p|): exactly 1 for every point within range (and for NaN), branch-free.
      const double q = max_range / std::sqrt(r2);
      const double scale = q < 1.0 ? q : 1.0;
      // A non-finite point becomes the origin, so that the float -> int conversions below stay
      // defined (its key says kPointNonFiniteKey and nothing reads its coordinates).
      x = finite ? x * scale : 0.0;
      y = finite ? y * scale : 0.0;
      z = finite ? z * scale : 0.0;
    }
    // World voxel units first, as the awareness stage's worldPoint() computes them, then
    // box-relative.
    const double b0 = (o0 + m0 * x + m1 * y + m2 * z) - bo0;
    const double b1 = (o1 + m3 * x + m4 * y + m5 * z) - bo1;
    const double b2 = (o2 + m6 * x + m7 * y + m8 * z) - bo2;
    const std::uint32_t ix = static_cast<std::uint32_t>(floorToIntVec(b0));
    const std::uint32_t iy = static_cast<std::uint32_t>(floorToIntVec(b1));
    const std::uint32_t iz = static_cast<std::uint32_t>(floorToIntVec(b2));
    const bool inside = (ix < d0) & (iy < d1) & (iz < d2);
    const std::uint32_t cut_flag = cut ? kPointCutFlag : 0u;
    const std::uint32_t voxel = ((ix * d1 + iy) * d2 + iz) | cut_flag;
    // kPointOutsideCutKey when cut.
    const std::uint32_t outside = kPointOutsideHitKey - (cut ? 1u : 0u);
    const std::uint32_t valid = r2 <= min_range2 ? kPointTooCloseKey : inside ? voxel : outside;
    keys[i] = finite ? valid : kPointNonFiniteKey;
    coords[4 * i + 0] = static_cast<float>(b0);
    coords[4 * i + 1] = static_cast<float>(b1);
    coords[4 * i + 2] = static_cast<float>(b2);
    coords[4 * i + 3] = 0.0f;
  }
}

// Whether every point is finite and within the maximum range (NaN fails the comparison). No
// AVX2 clone: a CPU with AVX2 runs classifyPointsAvx2 instead.
bool allWithinRange(const float* xs, const float* ys, const float* zs, std::size_t n,
                    double max_range2) {
  int beyond = 0;  // an OR reduction, which the compiler vectorises
  for (std::size_t i = 0; i < n; ++i) {
    const double x = xs[i];
    const double y = ys[i];
    const double z = zs[i];
    beyond |= x * x + y * y + z * z <= max_range2 ? 0 : 1;
  }
  return beyond == 0;
}

inline bool depthMmHasData(std::uint16_t r) {  // neither 0 nor 0xFFFF, in one comparison
  return static_cast<std::uint16_t>(r - 1u) < 0xFFFEu;
}

// Every pixel converted and written at the next free place, which advances only past a pixel
// with data: no branch on the data (a RealSense's pixels with data alternate with holes one or
// two at a time, where a branch mispredicts about every other pixel).
std::size_t packDepthPixelsMmPortable(const std::uint16_t* __restrict raw,
                                      const float* __restrict ray_x, float ray_y, std::size_t count,
                                      float* __restrict xs, float* __restrict ys,
                                      float* __restrict zs) {
  std::size_t n = 0;
  for (std::size_t k = 0; k < count; ++k) {
    const float z = static_cast<float>(raw[k]) * 0.001f;
    xs[n] = ray_x[k] * z;
    ys[n] = ray_y * z;
    zs[n] = z;
    n += depthMmHasData(raw[k]) ? 1 : 0;
  }
  return n;
}

void classifyPointsPortable(const PointKernel& k, const float* xs, const float* ys, const float* zs,
                            std::size_t n, std::uint32_t* keys, float* coords) {
  if (allWithinRange(xs, ys, zs, n, k.max_range * k.max_range)) {
    classifyPointsImpl<false>(k, xs, ys, zs, n, keys, coords);
  } else {
    classifyPointsImpl<true>(k, xs, ys, zs, n, keys, coords);
  }
}

// One run's box: the first point's coordinates, then the minimum and maximum of each with the
// others' (std::min and std::max, one point at a time).
void groupPointRunsPortable(const std::uint32_t* keys, const float* coords, std::size_t n,
                            PointRuns* runs) {
  std::uint32_t* first = runs->first.data();
  float* box = runs->box.data();
  std::size_t count = 0;
  std::size_t i = 0;
  while (i < n) {
    const std::uint32_t key = keys[i];
    first[count] = static_cast<std::uint32_t>(i);
    float* lo = box + 8 * count;
    float* hi = lo + 4;
    for (int k = 0; k < 4; ++k) lo[k] = hi[k] = coords[4 * i + k];
    for (++i; i < n && keys[i] == key; ++i) {
      for (int k = 0; k < 4; ++k) {
        lo[k] = std::min(lo[k], coords[4 * i + k]);
        hi[k] = std::max(hi[k], coords[4 * i + k]);
      }
    }
    ++count;
  }
  first[count] = static_cast<std::uint32_t>(n);
  runs->count = count;
}

#ifdef MLMAP_HAVE_AVX2_KERNEL
#define MLMAP_AVX2 __attribute__((target("avx2"), always_inline)) inline

// 0 <= f < d per lane (false for NaN).
MLMAP_AVX2 __m256d within(__m256d f, __m256d d) {
  return _mm256_and_pd(_mm256_cmp_pd(f, _mm256_setzero_pd(), _CMP_GE_OQ),
                       _mm256_cmp_pd(f, d, _CMP_LT_OQ));
}

// o + m_a x + m_b y + m_c z - box origin, added left to right as classifyPointsImpl does.
MLMAP_AVX2 __m256d boxUnits(__m256d o, __m256d ma, __m256d mb, __m256d mc, __m256d bo, __m256d x,
                            __m256d y, __m256d z) {
  const __m256d w =
      _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(o, _mm256_mul_pd(ma, x)), _mm256_mul_pd(mb, y)),
                    _mm256_mul_pd(mc, z));
  return _mm256_sub_pd(w, bo);
}

// classifyPointsImpl, four points at a time. The square root and the division run only for a
// group with a point to cut or a non-finite one: whole image regions have none, and every other
// point's scale is exactly 1, so both ways give the same bits.
__attribute__((target("avx2"))) void classifyPointsAvx2(const PointKernel& k, const float* xs,
                                                        const float* ys, const float* zs,
                                                        std::size_t n, std::uint32_t* keys,
                                                        float* coords) {
  const __m256d m0 = _mm256_set1_pd(k.m[0]);
  const __m256d m1 = _mm256_set1_pd(k.m[1]);
  const __m256d m2 = _mm256_set1_pd(k.m[2]);
  const __m256d m3 = _mm256_set1_pd(k.m[3]);
  const __m256d m4 = _mm256_set1_pd(k.m[4]);
  const __m256d m5 = _mm256_set1_pd(k.m[5]);
  const __m256d m6 = _mm256_set1_pd(k.m[6]);
  const __m256d m7 = _mm256_set1_pd(k.m[7]);
  const __m256d m8 = _mm256_set1_pd(k.m[8]);
  const __m256d o0 = _mm256_set1_pd(k.o[0]);
  const __m256d o1 = _mm256_set1_pd(k.o[1]);
  const __m256d o2 = _mm256_set1_pd(k.o[2]);
  const __m256d bo0 = _mm256_set1_pd(k.box_origin[0]);
  const __m256d bo1 = _mm256_set1_pd(k.box_origin[1]);
  const __m256d bo2 = _mm256_set1_pd(k.box_origin[2]);
  const __m256d max_range = _mm256_set1_pd(k.max_range);
  const __m256d max_range2 = _mm256_set1_pd(k.max_range * k.max_range);
  const __m256d min_range2 = _mm256_set1_pd(k.min_range2);
  const __m256d largest = _mm256_set1_pd(std::numeric_limits<double>::max());
  const __m256d one = _mm256_set1_pd(1.0);
  const __m256d dd0 = _mm256_set1_pd(static_cast<double>(k.dims[0]));
  const __m256d dd1 = _mm256_set1_pd(static_cast<double>(k.dims[1]));
  const __m256d dd2 = _mm256_set1_pd(static_cast<double>(k.dims[2]));
  // The keys as the signed integers of their bits (see below).
  static_assert(kPointCutFlag == 0x80000000u && kPointOutsideHitKey == 0xFFFFFFFDu &&
                    kPointTooCloseKey == 0xFFFFFFFEu && kPointNonFiniteKey == 0xFFFFFFFFu,
                "the signed forms below");
  const __m256d cut_flag = _mm256_set1_pd(2147483648.0);
  const __m256d outside_hit = _mm256_set1_pd(-3.0);  // and -4, kPointOutsideCutKey, when cut
  const __m256d too_close_key = _mm256_set1_pd(-2.0);
  const __m256d non_finite_key = _mm256_set1_pd(-1.0);
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    __m256d x = _mm256_cvtps_pd(_mm_loadu_ps(xs + i));
    __m256d y = _mm256_cvtps_pd(_mm_loadu_ps(ys + i));
    __m256d z = _mm256_cvtps_pd(_mm_loadu_ps(zs + i));
    const __m256d r2 =
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(x, x), _mm256_mul_pd(y, y)), _mm256_mul_pd(z, z));
    const __m256d finite = _mm256_cmp_pd(r2, largest, _CMP_LE_OQ);
    const __m256d cut = _mm256_cmp_pd(r2, max_range2, _CMP_GT_OQ);
    if (_mm256_movemask_pd(_mm256_andnot_pd(cut, finite)) != 0xF) {
      const __m256d q = _mm256_div_pd(max_range, _mm256_sqrt_pd(r2));
      const __m256d scale = _mm256_blendv_pd(one, q, _mm256_cmp_pd(q, one, _CMP_LT_OQ));
      x = _mm256_and_pd(finite, _mm256_mul_pd(x, scale));
      y = _mm256_and_pd(finite, _mm256_mul_pd(y, scale));
      z = _mm256_and_pd(finite, _mm256_mul_pd(z, scale));
    }
    const __m256d b0 = boxUnits(o0, m0, m1, m2, bo0, x, y, z);
    const __m256d b1 = boxUnits(o1, m3, m4, m5, bo1, x, y, z);
    const __m256d b2 = boxUnits(o2, m6, m7, m8, bo2, x, y, z);
    // The voxel in doubles: whole numbers, exact (an inside voxel's index is below 2^31), and
    // the same integers as the portable kernel's. The key too is chosen in doubles and converted
    // once, as a signed 32-bit integer whose bits are the key: a cut voxel's key (index | 2^31)
    // is index - 2^31, the four keys outside the box are -4 .. -1. A lane outside the box (or
    // NaN) fails a comparison and gets another key before the conversion.
    const __m256d f0 = _mm256_floor_pd(b0);
    const __m256d f1 = _mm256_floor_pd(b1);
    const __m256d f2 = _mm256_floor_pd(b2);
    const __m256d inside =
        _mm256_and_pd(_mm256_and_pd(within(f0, dd0), within(f1, dd1)), within(f2, dd2));
    const __m256d voxel =
        _mm256_add_pd(_mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(f0, dd1), f1), dd2), f2);
    __m256d key = _mm256_blendv_pd(_mm256_sub_pd(outside_hit, _mm256_and_pd(cut, one)),
                                   _mm256_sub_pd(voxel, _mm256_and_pd(cut, cut_flag)), inside);
    key = _mm256_blendv_pd(key, too_close_key, _mm256_cmp_pd(r2, min_range2, _CMP_LE_OQ));
    key = _mm256_blendv_pd(non_finite_key, key, finite);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(keys + i), _mm256_cvttpd_epi32(key));
    // Rounded to nearest, as static_cast<float>; then four (x, y, z, 0) rows: (x | z) and
    // (y | 0) interleaved give (x0 y0 x1 y1 | z0 0 z1 0), whose 64-bit lanes in the order
    // 0 2 1 3 are points 0 and 1.
    const __m256 xz =
        _mm256_insertf128_ps(_mm256_castps128_ps256(_mm256_cvtpd_ps(b0)), _mm256_cvtpd_ps(b2), 1);
    const __m256 y0 = _mm256_zextps128_ps256(_mm256_cvtpd_ps(b1));
    const __m256d p01 = _mm256_castps_pd(_mm256_unpacklo_ps(xz, y0));
    const __m256d p23 = _mm256_castps_pd(_mm256_unpackhi_ps(xz, y0));
    _mm256_storeu_ps(coords + 4 * i, _mm256_castpd_ps(_mm256_permute4x64_pd(p01, 0xD8)));
    _mm256_storeu_ps(coords + 4 * i + 8, _mm256_castpd_ps(_mm256_permute4x64_pd(p23, 0xD8)));
  }
  classifyPointsImpl<true>(k, xs + i, ys + i, zs + i, n - i, keys + i, coords + 4 * i);
}

// For each 8-bit mask of lanes with data, the indices of those lanes in order (then zeros), one
// byte each: the permutation that packs them to the front of a vector.
struct PackTable {
  std::array<std::uint64_t, 256> lanes{};
  PackTable() {
    for (unsigned mask = 0; mask < 256; ++mask) {
      std::uint64_t v = 0;
      int next = 0;
      for (unsigned lane = 0; lane < 8; ++lane) {
        if ((mask >> lane) & 1u) v |= static_cast<std::uint64_t>(lane) << (8 * next++);
      }
      lanes[mask] = v;
    }
  }
};
const PackTable kPackTable;

// packDepthPixelsMmPortable, eight pixels at a time: each converted as the portable form does
// (an exact int -> float conversion, then the same IEEE products), its lanes with data moved to
// the front by one permutation and all eight stored at the next free place.
__attribute__((target("avx2,popcnt"))) std::size_t packDepthPixelsMmAvx2(
    const std::uint16_t* raw, const float* ray_x, float ray_y, std::size_t count, float* xs,
    float* ys, float* zs) {
  const __m256 milli = _mm256_set1_ps(0.001f);
  const __m256 ry = _mm256_set1_ps(ray_y);
  const __m128i zero = _mm_setzero_si128();
  const __m128i ones = _mm_set1_epi16(-1);
  std::size_t n = 0;
  std::size_t k = 0;
  for (; k + 8 <= count; k += 8) {
    const __m128i r = _mm_loadu_si128(reinterpret_cast<const __m128i*>(raw + k));
    const __m128i no_data = _mm_or_si128(_mm_cmpeq_epi16(r, zero), _mm_cmpeq_epi16(r, ones));
    const unsigned mask =
        ~static_cast<unsigned>(_mm_movemask_epi8(_mm_packs_epi16(no_data, zero))) & 0xFFu;
    if (mask == 0) continue;
    const __m256 z = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(r)), milli);
    const __m256 x = _mm256_mul_ps(_mm256_loadu_ps(ray_x + k), z);
    const __m256 y = _mm256_mul_ps(ry, z);
    const __m256i perm =
        _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(static_cast<long long>(kPackTable.lanes[mask])));
    _mm256_storeu_ps(xs + n, _mm256_permutevar8x32_ps(x, perm));
    _mm256_storeu_ps(ys + n, _mm256_permutevar8x32_ps(y, perm));
    _mm256_storeu_ps(zs + n, _mm256_permutevar8x32_ps(z, perm));
    n += static_cast<std::size_t>(__builtin_popcount(mask));
  }
  return n +
         packDepthPixelsMmPortable(raw + k, ray_x + k, ray_y, count - k, xs + n, ys + n, zs + n);
}

// groupPointRunsPortable in two passes. The run starts: eight keys at a time compared with the
// keys one before, the lanes that differ packed to the front through the permutation table and
// all eight stored at the next free place. The boxes: eight points a step (a run's first point
// stands in for the lanes past its end), so that a run of up to eight points takes one step with
// no branch per point; a block of mostly one-point runs goes a point a step instead. The minima and
// maxima are exact, so the order does not change them.
__attribute__((target("avx2,popcnt"))) void groupPointRunsAvx2(const std::uint32_t* keys,
                                                               const float* coords, std::size_t n,
                                                               PointRuns* runs) {
  std::uint32_t* first = runs->first.data();
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; i += 8) {
    const __m256i k = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(keys + i));
    // The keys one before; for the first group, lane 0 compares with itself and starts a run.
    const __m256i before =
        i == 0 ? _mm256_permutevar8x32_epi32(k, _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6))
               : _mm256_loadu_si256(reinterpret_cast<const __m256i*>(keys + i - 1));
    unsigned mask = ~static_cast<unsigned>(
                        _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(k, before)))) &
                    0xFFu;
    if (i == 0) mask |= 1u;
    if (n - i < 8) mask &= (1u << (n - i)) - 1u;
    const __m256i lanes =
        _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(static_cast<long long>(kPackTable.lanes[mask])));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(first + count),
                        _mm256_add_epi32(lanes, _mm256_set1_epi32(static_cast<int>(i))));
    count += static_cast<std::size_t>(__builtin_popcount(mask));
  }
  first[count] = static_cast<std::uint32_t>(n);
  runs->count = count;
  // Lanes 0-3 of a register hold one point, lanes 4-7 the next: point j of a step is valid when
  // j is below the points left in the run.
  const __m256i point01 = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
  const __m256i point23 = _mm256_setr_epi32(2, 2, 2, 2, 3, 3, 3, 3);
  const __m256i point45 = _mm256_setr_epi32(4, 4, 4, 4, 5, 5, 5, 5);
  const __m256i point67 = _mm256_setr_epi32(6, 6, 6, 6, 7, 7, 7, 7);
  float* box = runs->box.data();
  if (2 * count > n) {
    // Mostly runs of one point (a LiDAR's scan): a point a step, with nothing to blend.
    for (std::size_t r = 0; r < count; ++r) {
      const float* c = coords + 4 * static_cast<std::size_t>(first[r]);
      __m128 lo = _mm_loadu_ps(c);
      __m128 hi = lo;
      for (std::uint32_t p = first[r] + 1; p < first[r + 1]; ++p) {
        c += 4;
        lo = _mm_min_ps(lo, _mm_loadu_ps(c));
        hi = _mm_max_ps(hi, _mm_loadu_ps(c));
      }
      _mm_storeu_ps(box + 8 * r, lo);
      _mm_storeu_ps(box + 8 * r + 4, hi);
    }
    return;
  }
  for (std::size_t r = 0; r < count; ++r) {
    const std::uint32_t end = first[r + 1];
    const float* c = coords + 4 * static_cast<std::size_t>(first[r]);
    const __m256 f = _mm256_broadcast_ps(reinterpret_cast<const __m128*>(c));
    __m256 lo = f;
    __m256 hi = f;
    for (std::uint32_t p = first[r]; p < end; p += 8, c += 32) {
      const __m256i left = _mm256_set1_epi32(static_cast<int>(end - p));
      const __m256 a0 = _mm256_blendv_ps(f, _mm256_loadu_ps(c),
                                         _mm256_castsi256_ps(_mm256_cmpgt_epi32(left, point01)));
      const __m256 a1 = _mm256_blendv_ps(f, _mm256_loadu_ps(c + 8),
                                         _mm256_castsi256_ps(_mm256_cmpgt_epi32(left, point23)));
      const __m256 a2 = _mm256_blendv_ps(f, _mm256_loadu_ps(c + 16),
                                         _mm256_castsi256_ps(_mm256_cmpgt_epi32(left, point45)));
      const __m256 a3 = _mm256_blendv_ps(f, _mm256_loadu_ps(c + 24),
                                         _mm256_castsi256_ps(_mm256_cmpgt_epi32(left, point67)));
      lo = _mm256_min_ps(lo, _mm256_min_ps(_mm256_min_ps(a0, a1), _mm256_min_ps(a2, a3)));
      hi = _mm256_max_ps(hi, _mm256_max_ps(_mm256_max_ps(a0, a1), _mm256_max_ps(a2, a3)));
    }
    _mm_storeu_ps(box + 8 * r,
                  _mm_min_ps(_mm256_castps256_ps128(lo), _mm256_extractf128_ps(lo, 1)));
    _mm_storeu_ps(box + 8 * r + 4,
                  _mm_max_ps(_mm256_castps256_ps128(hi), _mm256_extractf128_ps(hi, 1)));
  }
}
#undef MLMAP_AVX2
#endif

const bool kAvx2Supported = [] {
#ifdef MLMAP_HAVE_AVX2_KERNEL
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}();

}  // namespace

bool pointKernelAvx2Supported() { return kAvx2Supported; }

void classifyPoints(const PointKernel& kernel, const float* xs, const float* ys, const float* zs,
                    std::size_t n, std::uint32_t* keys, float* coords, PointKernelIsa isa) {
#ifdef MLMAP_HAVE_AVX2_KERNEL
  if (isa == PointKernelIsa::kAvx2) {
    classifyPointsAvx2(kernel, xs, ys, zs, n, keys, coords);
    return;
  }
#endif
  classifyPointsPortable(kernel, xs, ys, zs, n, keys, coords);
}

void classifyPoints(const PointKernel& kernel, const float* xs, const float* ys, const float* zs,
                    std::size_t n, std::uint32_t* keys, float* coords) {
  classifyPoints(kernel, xs, ys, zs, n, keys, coords,
                 kAvx2Supported ? PointKernelIsa::kAvx2 : PointKernelIsa::kPortable);
}

void groupPointRuns(const std::uint32_t* keys, const float* coords, std::size_t n, PointRuns* runs,
                    PointKernelIsa isa) {
#ifdef MLMAP_HAVE_AVX2_KERNEL
  if (isa == PointKernelIsa::kAvx2) {
    groupPointRunsAvx2(keys, coords, n, runs);
    return;
  }
#endif
  groupPointRunsPortable(keys, coords, n, runs);
}

void groupPointRuns(const std::uint32_t* keys, const float* coords, std::size_t n,
                    PointRuns* runs) {
  groupPointRuns(keys, coords, n, runs,
                 kAvx2Supported ? PointKernelIsa::kAvx2 : PointKernelIsa::kPortable);
}

std::size_t packDepthPixelsMm(const std::uint16_t* raw, const float* ray_x, float ray_y,
                              std::size_t count, float* xs, float* ys, float* zs,
                              PointKernelIsa isa) {
#ifdef MLMAP_HAVE_AVX2_KERNEL
  if (isa == PointKernelIsa::kAvx2) {
    return packDepthPixelsMmAvx2(raw, ray_x, ray_y, count, xs, ys, zs);
  }
#endif
  return packDepthPixelsMmPortable(raw, ray_x, ray_y, count, xs, ys, zs);
}

std::size_t packDepthPixelsMm(const std::uint16_t* raw, const float* ray_x, float ray_y,
                              std::size_t count, float* xs, float* ys, float* zs) {
  return packDepthPixelsMm(raw, ray_x, ray_y, count, xs, ys, zs,
                           kAvx2Supported ? PointKernelIsa::kAvx2 : PointKernelIsa::kPortable);
}

}  // namespace mlmap
