#pragma once
/// @file
/// The cube-map direction bins of the awareness stage's carving (private to the stage): a bin's
/// index, in which a bin's parent is index >> 2, the sort that brings a frame's ends into bin
/// order, and the levels built from the sorted ends, each by one pass over the level below.

#include <algorithm>
#include <cstddef>
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

/// The bins of every level from entries sorted by their finest bin (sortByKey(); an entry is
/// the finest bin's binKey() in the upper 32 bits, the caller's item in the lower). Level 0 has a
/// bin per run of equal keys, level L + 1 a bin per run of level L's bins with equal index >> 2,
/// each a copy of `empty` with its `index`, the nearest of its members' `near` and the count of
/// its `children` (items on level 0, bins of the level below above it); so every level is in
/// index order. A bin's `parent` becomes its parent's place in the next level, and
/// `enter(item, place)` is called with every item's place in level 0. `levels` is resized to
/// `level_count` (>= 1) levels; their previous bins are dropped. Bin has the members
/// `std::uint32_t index, parent, children` and `double near`; `near_of(item)` is an item's
/// distance.
template <typename Bin, typename NearOf, typename Enter>
void buildBinLevels(const std::vector<std::uint64_t>& sorted, std::size_t level_count,
                    const Bin& empty, NearOf near_of, Enter enter,
                    std::vector<std::vector<Bin>>* levels) {
  auto newBin = [&empty](std::uint32_t key, double near) {
    Bin bin = empty;
    bin.index = key;
    bin.near = near;
    bin.children = 1;
    return bin;
  };
  levels->resize(level_count);
  for (std::vector<Bin>& bins : *levels) bins.clear();
  std::vector<Bin>& finest = (*levels)[0];
  for (const std::uint64_t entry : sorted) {
    const auto key = static_cast<std::uint32_t>(entry >> 32);
    const auto item = static_cast<std::uint32_t>(entry);
    const double near = near_of(item);
    if (finest.empty() || finest.back().index != key) {
      finest.push_back(newBin(key, near));
    } else {
      finest.back().near = std::min(finest.back().near, near);
      ++finest.back().children;
    }
    enter(item, static_cast<std::uint32_t>(finest.size() - 1));
  }
  for (std::size_t level = 1; level < level_count; ++level) {
    std::vector<Bin>& bins = (*levels)[level];
    for (Bin& child : (*levels)[level - 1]) {
      const std::uint32_t key = child.index >> 2;
      if (bins.empty() || bins.back().index != key) {
        bins.push_back(newBin(key, child.near));
      } else {
        bins.back().near = std::min(bins.back().near, child.near);
        ++bins.back().children;
      }
      child.parent = static_cast<std::uint32_t>(bins.size() - 1);
    }
  }
}

}  // namespace mlmap
