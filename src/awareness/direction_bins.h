#pragma once
/// @file
/// The cube-map direction bins of the awareness stage's carving (private to the stage): a bin's
/// index, in which a bin's parent is index >> 2, and the sort that brings a frame's ends into
/// bin order, so that every level of bins is built by one pass over the level below.

#include <cstdint>
#include <vector>

namespace mlmap {

/// A direction bin's index on the level with 2^lg bins per cube-face side (lg <= 15): the face
/// (0..5) in the bits above 2 lg, then the bits of iu and iv (each in [0, 2^lg)) interleaved,
/// iu's above iv's. Distinct bins have distinct indices, the bin (face, iu / 2, iv / 2) of the
/// next coarser level has index >> 2, and the children of a bin are consecutive in index order.
inline std::uint32_t binKey(int face, int iu, int iv, int lg) {
  auto spread = [](std::uint32_t x) {  // bit k of x (k < 16) to bit 2k
    x = (x | (x << 8)) & 0x00FF00FFu;
    x = (x | (x << 4)) & 0x0F0F0F0Fu;
    x = (x | (x << 2)) & 0x33333333u;
    x = (x | (x << 1)) & 0x55555555u;
    return x;
  };
  return (static_cast<std::uint32_t>(face) << (2 * lg)) |
         (spread(static_cast<std::uint32_t>(iu)) << 1) | spread(static_cast<std::uint32_t>(iv));
}

/// Sorts `entries` by their upper 32 bits, of which only the low `key_bits` (<= 32) may be set,
/// keeping the order of equal keys: a least-significant-digit radix sort, 11 bits a pass (two
/// passes for the 19 bits of 6 x 256^2 bins), through `scratch` (resized; its contents are lost).
void sortByKey(int key_bits, std::vector<std::uint64_t>* entries,
               std::vector<std::uint64_t>* scratch);

}  // namespace mlmap
