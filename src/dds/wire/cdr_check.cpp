#include "mlmap/dds/wire/cdr_check.h"

#include <algorithm>
#include <cstring>
#include <iterator>
#include <string_view>
#include <utility>

#include "mlmap_cdr_layouts.h"  // generated from idl/ at build time

namespace mlmap::dds {
namespace {

constexpr std::size_t kEncapsulationBytes = 4;

/// Walks one payload (after its encapsulation header) as Fast CDR 1.0's generated code reads
/// it: numbers aligned to their size relative to the byte after the header, a sequence or array
/// of no elements not aligned at all, strings and bools unaligned after their length.
class Walker {
 public:
  Walker(const std::uint8_t* body, std::size_t size_bytes, bool swap)
      : body_(body), size_(size_bytes), swap_(swap) {}

  bool walkStruct(const CdrStructLayout& layout) {
    // A struct of numbers only, aligned to its largest: its size is known (walked member by
    // member when its bytes are missing, to name where).
    if (layout.fixed_bytes > 0 && pos_ % layout.fixed_align == 0 &&
        layout.fixed_bytes <= remaining()) {
      pos_ += layout.fixed_bytes;
      return true;
    }
    for (std::size_t i = 0; i < layout.member_count; ++i) {
      const CdrMemberLayout& m = layout.members[i];
      if (!walkMember(m)) {
        prefix(m.name);
        return false;
      }
    }
    return true;
  }

  /// Bytes walked so far, from the byte after the encapsulation header.
  [[nodiscard]] std::size_t position() const { return pos_; }

  /// The failing member's path and what is wrong there, e.g. "`transforms[2].header.frame_id`:
  /// string of 9 bytes, 3 bytes remain".
  [[nodiscard]] std::string describe() const {
    return path_.empty() ? error_ : "`" + path_ + "`: " + error_;
  }

 private:
  [[nodiscard]] std::size_t remaining() const { return size_ - pos_; }

  bool fail(std::string what) {
    error_ = std::move(what);
    return false;
  }

  bool truncated() {
    return fail("truncated at byte " + std::to_string(pos_ + kEncapsulationBytes));
  }

  /// Prepends member `name` to the failing path.
  void prefix(const std::string& name) {
    path_ = name + (path_.empty() || path_.front() == '[' ? "" : ".") + path_;
  }

  /// Prepends element `index` to the failing path.
  void prefixIndex(std::uint64_t index) {
    path_ = "[" + std::to_string(index) + "]" + (path_.empty() || path_.front() == '[' ? "" : ".") +
            path_;
  }

  bool align(std::size_t bytes) {
    const std::size_t pad = (bytes - pos_ % bytes) % bytes;
    if (pad > remaining()) return truncated();
    pos_ += pad;
    return true;
  }

  bool readU32(std::uint32_t* value) {
    if (!align(4)) return false;
    if (remaining() < 4) return truncated();
    std::uint8_t b[4];
    std::memcpy(b, body_ + pos_, 4);
    if (swap_) {
      std::swap(b[0], b[3]);
      std::swap(b[1], b[2]);
    }
    std::memcpy(value, b, 4);
    pos_ += 4;
    return true;
  }

  bool walkMember(const CdrMemberLayout& m) {
    switch (m.container) {
      case CdrContainer::kSingle:
        return walkValues(m, 1);
      case CdrContainer::kArray:
        return walkValues(m, m.count);
      case CdrContainer::kSequence: {
        std::uint32_t count = 0;
        if (!readU32(&count)) return false;
        if (m.count > 0 && count > m.count) {
          return fail("sequence declares " + std::to_string(count) + " elements, its bound is " +
                      std::to_string(m.count));
        }
        if (count == 0) return true;
        const std::uint64_t least = static_cast<std::uint64_t>(count) * minValueBytes(m);
        if (least > remaining()) {
          return fail("sequence declares " + std::to_string(count) +
                      " elements of >= " + std::to_string(minValueBytes(m)) + " bytes, " +
                      std::to_string(remaining()) + " bytes remain");
        }
        return walkValues(m, count);
      }
    }
    return fail("unknown container");
  }

  /// The least bytes one value of `m` takes (at least 1, as Fast CDR assumes).
  static std::uint64_t minValueBytes(const CdrMemberLayout& m) {
    switch (m.kind) {
      case CdrValueKind::kNumber:
        return m.number_bytes;
      case CdrValueKind::kString:
        return 4;
      case CdrValueKind::kStruct:
        return std::max<std::uint64_t>(1, m.type->min_bytes);
    }
    return 1;
  }

  bool walkValues(const CdrMemberLayout& m, std::uint64_t count) {
    switch (m.kind) {
      case CdrValueKind::kNumber: {
        if (count == 0) return true;  // Fast CDR aligns only when there are values
        if (!align(m.number_bytes)) return false;
        const std::uint64_t bytes = count * m.number_bytes;
        if (bytes > remaining()) {
          return fail("truncated at byte " + std::to_string(pos_ + kEncapsulationBytes) + ": " +
                      std::to_string(bytes) + " bytes of numbers, " + std::to_string(remaining()) +
                      " bytes remain");
        }
        pos_ += static_cast<std::size_t>(bytes);
        return true;
      }
      case CdrValueKind::kString:
        for (std::uint64_t i = 0; i < count; ++i) {
          if (!walkString(m)) {
            if (m.container != CdrContainer::kSingle) prefixIndex(i);
            return false;
          }
        }
        return true;
      case CdrValueKind::kStruct: {
        const CdrStructLayout& type = *m.type;
        if (type.fixed_bytes > 0 && type.fixed_bytes % type.fixed_align == 0 &&
            pos_ % type.fixed_align == 0 && count * type.fixed_bytes <= remaining()) {
          pos_ += static_cast<std::size_t>(count * type.fixed_bytes);  // each element stays aligned
          return true;
        }
        for (std::uint64_t i = 0; i < count; ++i) {
          if (!walkStruct(type)) {
            if (m.container != CdrContainer::kSingle) prefixIndex(i);
            return false;
          }
        }
        return true;
      }
    }
    return fail("unknown value kind");
  }

  bool walkString(const CdrMemberLayout& m) {
    std::uint32_t length = 0;  // the NUL included
    if (!readU32(&length)) return false;
    if (length > remaining()) {
      return fail("string of " + std::to_string(length) + " bytes, " + std::to_string(remaining()) +
                  " bytes remain");
    }
    if (m.string_bound > 0 && length > static_cast<std::uint64_t>(m.string_bound) + 1) {
      return fail("string of " + std::to_string(length) + " bytes, its bound is " +
                  std::to_string(m.string_bound) + " characters");
    }
    pos_ += length;
    return true;
  }

  const std::uint8_t* body_;
  std::size_t size_;
  bool swap_;
  std::size_t pos_ = 0;
  std::string error_;
  std::string path_;
};

bool hostIsLittleEndian() {
  const std::uint16_t one = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

}  // namespace

CdrCheck checkCdrPayload(const CdrStructLayout& layout, const std::uint8_t* data,
                         std::size_t size_bytes) {
  CdrCheck check;
  if (size_bytes < kEncapsulationBytes) {
    check.error = "payload of " + std::to_string(size_bytes) + " bytes has no encapsulation header";
    return check;
  }
  // Fast CDR 1.0 (DDS_CDR): a zero byte, then the kind: bit 0 little endian, bit 1 a parameter
  // list (read as plain CDR by the generated code all the same); then two option bytes.
  if (data[0] != 0 || (data[1] & ~0x3U) != 0) {
    check.error =
        "unknown encapsulation " + std::to_string(data[0]) + " " + std::to_string(data[1]);
    return check;
  }
  const bool little = (data[1] & 0x1U) != 0;
  Walker walker(data + kEncapsulationBytes, size_bytes - kEncapsulationBytes,
                little != hostIsLittleEndian());
  if (!walker.walkStruct(layout)) {
    check.error = layout.dds_type + std::string(" ") + walker.describe();
    return check;
  }
  check.ok = true;
  check.consumed_bytes = kEncapsulationBytes + walker.position();
  return check;
}

const CdrStructLayout* cdrLayoutOf(const std::string& dds_type) {
  for (const CdrStructLayout* layout : generated::kCdrLayouts) {
    if (std::string_view(layout->dds_type) == dds_type) return layout;
  }
  return nullptr;
}

const CdrStructLayout* const* cdrLayouts(std::size_t* count) {
  *count = std::size(generated::kCdrLayouts);
  return generated::kCdrLayouts;
}

}  // namespace mlmap::dds
