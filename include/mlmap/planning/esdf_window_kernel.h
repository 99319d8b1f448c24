#pragma once
/// @file
/// Part of the ESDF (EsdfMap, esdf.h): the y and z passes of EsdfMap::compute() as windowed
/// min-plus transforms on 16-bit lines, for clamps small enough that every value fits 16 bits.
///
/// A 1D pass maps the signed values S of a line (sign: + non-obstacle, - obstacle; magnitude
/// M(j): the squared distance found by the previous passes, or inf) to, at each position p,
///   out(p) = min( r(p)^2, min over |k| <= cap_d of M(p + k) + k^2 ),
/// signed as S(p), where r(p) is the distance along the line to the nearest voxel of the other
/// kind. This is the exact 1D transform of the envelope code: a voxel j of p's kind within p's
/// run gives M(j) + k^2; the nearest voxel of the other kind gives r^2 (its own distance is 0
/// for p's transform); and every other voxel lies at |k| >= r, so its M(j) + k^2 >= r^2 cannot
/// win, whichever kind it is. Values above cap_sq become inf (cap_sq + 1); positions beyond the
/// clamp (|k| > cap_d) give k^2 > cap_sq and are never needed. Every loop runs across many
/// lines at once over plain 16-bit arrays (the y lines of a slab side by side along z, the z
/// lines side by side along y in a transposed copy), so the compiler vectorises them; there is
/// no branch on the data. The result is bit-identical to the envelope code (both are exact).

#include <cstddef>
#include <cstdint>
#include <vector>

/// Marks a function of the ESDF's passes to be built also for AVX2 and AVX-512 on x86-64 with
/// GCC, the build chosen at load time for the CPU (function multiversioning); elsewhere, the
/// baseline build only, and under AddressSanitizer or ThreadSanitizer (their runtimes are not
/// ready when the ifunc resolvers run at load time: the TSan build crashed before main).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#define MLMAP_ESDF_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define MLMAP_ESDF_CLONES
#endif

namespace mlmap::esdf_kernel {

/// Largest clamp (in voxels) the windowed passes are used for: their cost grows with cap_d,
/// the envelope code's does not.
constexpr std::int32_t kMaxWindowCapCells = 48;

/// Lanes a slab's lines are laid out across in transformSlabY() and transformSlabZ(): `lines`
/// rounded up to a multiple of 16 (one AVX2 vector of 16-bit values), so that the per-line
/// sweeps run in whole vectors with no scalar remainder; the extra lanes hold +inf and are
/// never read back.
[[nodiscard]] constexpr int paddedLanes(int lines) { return (lines + 15) / 16 * 16; }

/// Lanes of the groups of lines EsdfMap::update() transforms again (one vector of 16-bit
/// values): transformLines() is built for this width on its own, its sweeps keeping their
/// state in registers.
constexpr int kGroupLanes = 16;

/// The y pass's input magnitude from an x-pass result d (the signed distance along x; any
/// magnitude above cap_d means beyond the clamp): d^2, or inf = cap_sq + 1 beyond the clamp.
/// The sign of d (obstacle or not) carries over.
[[nodiscard]] inline std::int32_t squaredAlongX(std::int32_t d, std::int32_t cap_d,
                                                std::int32_t inf) {
  const std::int32_t a = d < 0 ? -d : d;
  return a <= cap_d ? a * a : inf;
}

/// True when the windowed passes apply: cap_d <= kMaxWindowCapCells, and inf plus any k^2 of
/// the window fits a 16-bit signed value.
[[nodiscard]] bool windowFits(std::int32_t cap_sq, std::int32_t cap_d);

/// Reusable buffers of one thread (grown on demand, never shrunk).
struct WindowBuffers {
  std::vector<std::int16_t> magnitude;      ///< M of a slab or row, padded by cap_d on each side
  std::vector<std::int16_t> best;           ///< running minimum per voxel
  std::vector<std::int16_t> near_free;      ///< y pass: last / next non-obstacle y per z
  std::vector<std::int16_t> near_obstacle;  ///< y pass: last / next obstacle y per z
  std::vector<std::int32_t> finite_before;  ///< per block of M: blocks before it holding a value
  std::vector<std::int16_t> lines;          ///< lines gathered by the caller of transformLines()
  std::vector<std::int16_t> transposed;     ///< y pass: the slab's lines being transformed
  std::vector<std::int16_t> signed_sq;      ///< the slab z-major: y pass's result, then z pass's
};

/// dst[c * dst_stride + r] = src[r * src_stride + c] for r < rows, c < cols: a transposition of
/// 16-bit values, in 8 x 8 blocks through SSE2 registers where it can.
void transpose16(const std::int16_t* src, std::size_t src_stride, std::int16_t* dst,
                 std::size_t dst_stride, int rows, int cols);

/// Transforms `lanes` lines of n values side by side, in place: values[i * lanes + l] is value
/// i of line l, a signed squared distance (+ non-obstacle, - obstacle) or +-inf (cap_sq + 1).
/// Only positions [out_begin, out_end) are transformed (0 <= out_begin <= out_end <= n); the
/// others keep their input. A part of a line may be given: its outputs are then exact where
/// they lie more than cap_d + 1 from the part's cut ends, so a caller that needs outputs
/// [a, b) gives the inputs [a - cap_d - 1, b + cap_d + 1) and asks for [a, b) only: the
/// window, the costly part, then runs over the outputs alone.
void transformLines(std::int16_t* values, int n, int lanes, int out_begin, int out_end,
                    std::int32_t cap_sq, std::int32_t cap_d, WindowBuffers* buffers);

/// The y pass of one x slab: `pass1` holds ny * nz signed distances along x (z fastest; +d
/// non-obstacle, -d obstacle; any magnitude above cap_d means beyond the clamp). Writes the
/// signed squared distances in the y-x plane (or +-inf, inf = cap_sq + 1) to `pass2` (ny * nz)
/// and to buffers->signed_sq.
void transformSlabY(const std::int8_t* pass1, int ny, int nz, std::int32_t cap_sq,
                    std::int32_t cap_d, std::int16_t* pass2, WindowBuffers* buffers);

/// The z pass of the slab last given to transformSlabY(): replaces buffers->signed_sq (nz rows
/// of paddedLanes(ny) values, y fastest: transposed, so that the z lines run across the vector
/// lanes) by the signed squared distances in 3D (or +-inf).
void transformSlabZ(int ny, int nz, std::int32_t cap_sq, std::int32_t cap_d,
                    WindowBuffers* buffers);

}  // namespace mlmap::esdf_kernel
