#pragma once
/// @file
/// A dense bit per voxel over a box of the world grid, used per frame to keep each voxel to at
/// most one measurement. Rows along z are padded to whole 64-bit words so iteration needs no
/// division.

#include "mlmap/core/types.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace mlmap {

/// One bit per voxel of the box [origin, origin + dims). Indices (i, j, k) are box-relative.
class VoxelBitset {
 public:
  /// Resizes to the box and clears every bit; memory is reused between frames. When the size
  /// stays, only the rows in use (rowsInUse(), when valid) or else the rows of the marked
  /// rectangle (markedRows()) are cleared: the others hold no set bit. Afterwards the marked
  /// rectangle is the whole box again and the rows in use are not known.
  void reset(const VoxelIndex& origin, const Eigen::Vector3i& dims) {
    const std::size_t words_per_row = static_cast<std::size_t>((dims.z() + 63) / 64);
    const std::size_t words =
        static_cast<std::size_t>(dims.x()) * static_cast<std::size_t>(dims.y()) * words_per_row;
    if (dims == dims_ && bits_.size() == words && rows_.valid(dims)) {
      if (rows_in_use_valid_) {
        clearRowsInUse();
      } else {
        for (int i = rows_.x_begin; i < rows_.x_end; ++i) {
          std::uint64_t* first = bits_.data() + rowWord(i, rows_.y_begin);
          std::fill(first,
                    first + static_cast<std::size_t>(rows_.y_end - rows_.y_begin) * words_per_row_,
                    std::uint64_t{0});
        }
      }
    } else {
      bits_.assign(words, 0);
    }
    origin_ = origin;
    dims_ = dims;
    words_per_row_ = words_per_row;
    rows_ = {0, dims.x(), 0, dims.y()};
    in_use_words_per_x_ = static_cast<std::size_t>((dims.y() + 63) / 64);
    rows_in_use_.resize(static_cast<std::size_t>(dims.x()) * in_use_words_per_x_);
    rows_in_use_valid_ = false;
  }

  /// A rectangle of (i, j) rows, [x_begin, x_end) x [y_begin, y_end), box-relative.
  struct Rows {
    int x_begin = 0;
    int x_end = 0;
    int y_begin = 0;
    int y_end = 0;
    /// True when it lies inside a box of `dims` (an empty one does too).
    [[nodiscard]] bool valid(const Eigen::Vector3i& dims) const {
      return 0 <= x_begin && x_begin <= x_end && x_end <= dims.x() && 0 <= y_begin &&
             y_begin <= y_end && y_end <= dims.y();
    }
  };
  /// The rows that may hold set bits: the whole box, unless the writer said less with
  /// setMarkedRows(). Readers need look only there.
  [[nodiscard]] const Rows& markedRows() const { return rows_; }
  /// Declares that no bit outside `rows` is set (clamped to the box); the caller's promise,
  /// which reset() relies on to clear only those rows.
  void setMarkedRows(const Rows& rows) {
    rows_in_use_valid_ = false;
    rows_.x_begin = std::clamp(rows.x_begin, 0, dims_.x());
    rows_.x_end = std::clamp(rows.x_end, rows_.x_begin, dims_.x());
    rows_.y_begin = std::clamp(rows.y_begin, 0, dims_.y());
    rows_.y_end = std::clamp(rows.y_end, rows_.y_begin, dims_.y());
  }

  /// Which (i, j) rows hold a set bit, one bit a row: bit j & 63 of word j / 64 of row i's
  /// rowsInUseWordsPerX() words. Written by whoever counts the bits (the awareness stage, every
  /// word of every i), who then declares it with setRowsInUseValid(); setMarkedRows(),
  /// testAndSet() and reset() make it unknown again. Readers use it only while valid: a row
  /// whose bit is clear holds no set bit, so they skip it; reset() then clears only those rows.
  [[nodiscard]] std::uint64_t* rowsInUse(int i) {
    return rows_in_use_.data() + static_cast<std::size_t>(i) * in_use_words_per_x_;
  }
  [[nodiscard]] const std::uint64_t* rowsInUse(int i) const {
    return rows_in_use_.data() + static_cast<std::size_t>(i) * in_use_words_per_x_;
  }
  /// Words of rowsInUse() per i: (dims.y + 63) / 64.
  [[nodiscard]] std::size_t rowsInUseWordsPerX() const { return in_use_words_per_x_; }
  /// Declares rowsInUse() written for every i: each set bit of the box lies in a row marked there.
  void setRowsInUseValid() { rows_in_use_valid_ = true; }
  /// True between setRowsInUseValid() and the next setMarkedRows(), testAndSet() or reset().
  [[nodiscard]] bool rowsInUseValid() const { return rows_in_use_valid_; }

  /// First voxel of the box (world index).
  [[nodiscard]] const VoxelIndex& origin() const { return origin_; }
  /// Box size in voxels.
  [[nodiscard]] const Eigen::Vector3i& dims() const { return dims_; }
  /// True when the box-relative index lies inside the box.
  [[nodiscard]] bool contains(int i, int j, int k) const {
    return static_cast<unsigned>(i) < static_cast<unsigned>(dims_.x()) &&
           static_cast<unsigned>(j) < static_cast<unsigned>(dims_.y()) &&
           static_cast<unsigned>(k) < static_cast<unsigned>(dims_.z());
  }
  /// Bit of a box-relative voxel (must be inside).
  [[nodiscard]] bool test(int i, int j, int k) const {
    return (bits_[word(i, j, k)] >> (k & 63)) & 1u;
  }
  /// Sets a bit (must be inside); returns its previous value.
  bool testAndSet(int i, int j, int k) {
    rows_in_use_valid_ = false;
    std::uint64_t& w = bits_[word(i, j, k)];
    const std::uint64_t mask = std::uint64_t{1} << (k & 63);
    const bool was = (w & mask) != 0;
    w |= mask;
    return was;
  }
  /// Word holding the start of row (i, j); bit k of the row is bit (k & 63) of word row + k / 64.
  [[nodiscard]] std::size_t rowWord(int i, int j) const {
    return (static_cast<std::size_t>(i) * static_cast<std::size_t>(dims_.y()) +
            static_cast<std::size_t>(j)) *
           words_per_row_;
  }
  /// 64-bit words per (i, j) row.
  [[nodiscard]] std::size_t wordsPerRow() const { return words_per_row_; }
  /// Raw words (for fast row-wise access).
  std::uint64_t* data() { return bits_.data(); }
  [[nodiscard]] const std::uint64_t* data() const { return bits_.data(); }

  /// Calls f(i, j, k) for every set bit, in (i, j, k) order.
  template <typename F>
  void forEach(F&& f) const {
    for (int i = 0; i < dims_.x(); ++i) {
      for (int j = 0; j < dims_.y(); ++j) {
        const std::uint64_t* row = bits_.data() + rowWord(i, j);
        for (std::size_t w = 0; w < words_per_row_; ++w) {
          std::uint64_t bits = row[w];
          while (bits != 0) {
            const int k = static_cast<int>(w * 64) + __builtin_ctzll(bits);
            f(i, j, k);
            bits &= bits - 1;
          }
        }
      }
    }
  }

  /// Number of set bits.
  [[nodiscard]] std::size_t count() const {
    std::size_t n = 0;
    for (std::uint64_t w : bits_) n += static_cast<std::size_t>(__builtin_popcountll(w));
    return n;
  }
  /// Bytes held.
  [[nodiscard]] std::size_t memoryBytes() const {
    return (bits_.capacity() + rows_in_use_.capacity()) * sizeof(std::uint64_t);
  }

 private:
  // Clears the rows marked in rowsInUse() (of the marked rectangle's i, where they all lie).
  void clearRowsInUse() {
    for (int i = rows_.x_begin; i < rows_.x_end; ++i) {
      const std::uint64_t* in_use = rowsInUse(i);
      for (std::size_t w = 0; w < in_use_words_per_x_; ++w) {
        for (std::uint64_t rows = in_use[w]; rows != 0; rows &= rows - 1) {
          const int j = static_cast<int>(w * 64) + __builtin_ctzll(rows);
          std::uint64_t* row = bits_.data() + rowWord(i, j);
          std::fill(row, row + words_per_row_, std::uint64_t{0});
        }
      }
    }
  }

  [[nodiscard]] std::size_t word(int i, int j, int k) const {
    return rowWord(i, j) + static_cast<std::size_t>(k >> 6);
  }

  VoxelIndex origin_ = VoxelIndex::Zero();
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  std::size_t words_per_row_ = 0;
  std::vector<std::uint64_t> bits_;
  Rows rows_;                               ///< no bit set outside (markedRows())
  std::vector<std::uint64_t> rows_in_use_;  ///< rowsInUse()
  std::size_t in_use_words_per_x_ = 0;
  bool rows_in_use_valid_ = false;
};

}  // namespace mlmap
