#include "mlmap/planning/esdf_field.h"

#include "mlmap/core/types.h"

#include <cstring>
#include <limits>

namespace mlmap {
namespace {

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

}  // namespace

void EsdfField::reset(const VoxelIndex& min_index, const Eigen::Vector3i& size,
                      double resolution_m) {
  min_index_ = min_index;
  size_ = size;
  resolution_m_ = resolution_m;
  inv_resolution_ = 1.0 / resolution_m_;
  const int nx = size_.x();
  const int ny = size_.y();
  const int nz = size_.z();
  step_z_ = nz > 1 ? 1 : 0;
  step_y_ = ny > 1 ? nz : 0;
  step_x_ = nx > 1 ? static_cast<std::ptrdiff_t>(ny) * nz : 0;
  values_m_.resize(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny) *
                   static_cast<std::size_t>(nz));
  const std::size_t slab_words = (static_cast<std::size_t>(ny) * nz + 63) / 64;
  slab_bits_ = slab_words * 64;
  unknown_bits_.resize(slab_words * static_cast<std::size_t>(nx));
}

void EsdfField::clear() {
  min_index_.setZero();
  size_.setZero();
  step_x_ = step_y_ = step_z_ = 0;
  values_m_.clear();  // capacities are kept
  unknown_bits_.clear();
  slab_bits_ = 0;
}

float EsdfField::distanceAt(const VoxelIndex& world_index) const {
  if (!contains(world_index)) return std::numeric_limits<float>::quiet_NaN();
  return values_m_[boxOffset(min_index_, size_, world_index)];
}

void EsdfField::writeUnknownBits(const std::uint8_t* states, int x) {
  constexpr auto kUnknown = static_cast<std::uint8_t>(Occupancy::kUnknown);
  const std::size_t slab =
      static_cast<std::size_t>(size_.y()) * static_cast<std::size_t>(size_.z());
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

void EsdfField::copyUnknownSlab(int from_x, int to_x) {
  const std::size_t words = slab_bits_ / 64;
  std::memmove(unknown_bits_.data() + static_cast<std::size_t>(to_x) * words,
               unknown_bits_.data() + static_cast<std::size_t>(from_x) * words,
               words * sizeof(std::uint64_t));
}

bool EsdfField::copyCells(const EsdfField& source, const std::vector<std::uint32_t>& offsets) {
  if (source.min_index_ != min_index_ || source.size_ != size_ ||
      source.resolution_m_ != resolution_m_ || source.slab_bits_ != slab_bits_ ||
      source.values_m_.size() != values_m_.size()) {
    return false;
  }
  const std::size_t slab =
      static_cast<std::size_t>(size_.y()) * static_cast<std::size_t>(size_.z());
  for (const std::uint32_t o : offsets) {
    if (o >= values_m_.size()) continue;
    values_m_[o] = source.values_m_[o];
    const std::size_t x = o / slab;
    const std::size_t bit = x * slab_bits_ + (o - x * slab);
    const std::uint64_t mask = std::uint64_t{1} << (bit & 63);
    std::uint64_t& word = unknown_bits_[bit >> 6];
    word = (word & ~mask) | (source.unknown_bits_[bit >> 6] & mask);
  }
  return true;
}

}  // namespace mlmap
