#include "direction_bins.h"

#include <array>
#include <cstddef>

namespace mlmap {

void sortByKey(int key_bits, std::vector<std::uint64_t>* entries,
               std::vector<std::uint64_t>* scratch) {
  constexpr int kDigitBits = 11;
  constexpr std::uint64_t kDigitMask = (std::uint64_t{1} << kDigitBits) - 1;
  scratch->resize(entries->size());
  std::array<std::uint32_t, std::size_t{1} << kDigitBits> count{};
  for (int shift = 32; shift < 32 + key_bits; shift += kDigitBits) {
    count.fill(0);
    for (const std::uint64_t e : *entries) ++count[(e >> shift) & kDigitMask];
    std::uint32_t sum = 0;
    for (std::uint32_t& c : count) {  // each digit's first place
      const std::uint32_t n = c;
      c = sum;
      sum += n;
    }
    for (const std::uint64_t e : *entries) (*scratch)[count[(e >> shift) & kDigitMask]++] = e;
    entries->swap(*scratch);
  }
}

}  // namespace mlmap
