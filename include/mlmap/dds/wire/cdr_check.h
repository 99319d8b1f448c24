#pragma once
/// @file
/// A CDR payload checked against its type's layout before Fast CDR deserialises it.
///
/// Fast CDR 1.0 sizes a sequence from its declared count: it checks only that as many bytes
/// remain as the count (one byte per element), then resizes the vector to the count. A 16 MB
/// /tf sample declaring 16.7 M TransformStamped therefore costs gigabytes before the missing
/// bytes are noticed. checkCdrPayload() walks the payload first, with the alignment rules of
/// plain CDR (XCDR1, as ROS 2 and Fast CDR 1.0 use it) and no allocation: every sequence count
/// is checked against the bytes that remain for its elements' minimum size, every string length
/// against the bytes that remain, bounded sequences and strings against their bound, and every
/// element is walked. Once a payload passes, whatever Fast CDR allocates for it is backed by
/// bytes of the payload. Cost: O(payload bytes); a sequence or array of numbers is skipped in
/// O(1).
///
/// The layouts come from idl/ at build time (tools/idl_cdr_layouts.py): cdrLayoutOf() finds a
/// type's by its DDS type name. CheckedType (entities.h) checks every sample a reader takes, and
/// the bag decoders (mlmap/bag/ros_messages.h) every message they decode.

#include <cstddef>
#include <cstdint>
#include <string>

namespace mlmap::dds {

/// What one value of a member is on the wire.
enum class CdrValueKind : std::uint8_t {
  kNumber,  ///< a fixed-size number or bool, aligned to its size (CdrMemberLayout::number_bytes)
  kString,  ///< uint32 length (the NUL included), then that many bytes
  kStruct,  ///< another struct's members in order, no padding of its own (CdrMemberLayout::type)
};

/// How many values a member holds.
enum class CdrContainer : std::uint8_t {
  kSingle,    ///< one value
  kArray,     ///< `count` values, no length on the wire
  kSequence,  ///< a uint32 count, then that many values (at most `count` when `count` > 0)
};

struct CdrStructLayout;

/// One member of a struct, as its IDL declares it.
struct CdrMemberLayout {
  const char* name;             ///< the ROS field name, e.g. "transforms"
  CdrValueKind kind;            ///< what each value is
  std::uint8_t number_bytes;    ///< kNumber: size and alignment of one value (1, 2, 4, 8)
  CdrContainer container;       ///< single value, fixed array or sequence
  std::uint32_t count;          ///< kArray: its length; kSequence: its bound (0: unbounded)
  std::uint32_t string_bound;   ///< kString: most characters, the NUL not counted (0: unbounded)
  const CdrStructLayout* type;  ///< kStruct: the nested struct's layout
};

/// A struct of idl/, its members in wire order.
struct CdrStructLayout {
  const char* dds_type;            ///< e.g. "tf2_msgs::msg::dds_::TFMessage_"
  const CdrMemberLayout* members;  ///< `member_count` members in declaration order
  std::size_t member_count;        ///< members of the struct
  std::uint32_t min_bytes;         ///< least bytes one value takes on the wire, padding not counted
  std::uint32_t fixed_bytes;       ///< a struct of numbers only: bytes a value takes when it starts
                                   ///< at a multiple of fixed_align (walked whole); else 0
  std::uint32_t fixed_align;       ///< its largest number's size (1 when fixed_bytes is 0)
};

/// The outcome of checkCdrPayload().
struct CdrCheck {
  bool ok = false;                 ///< the payload is well-formed for the layout
  std::size_t consumed_bytes = 0;  ///< when ok: bytes the value takes, the 4-byte header included
  /// When not ok: the type, the failing member and what is wrong there, e.g.
  /// "tf2_msgs::msg::dds_::TFMessage_ `transforms`: sequence declares 16777216 elements of >= 72
  /// bytes, 12 bytes remain".
  std::string error;
};

/// Checks `size_bytes` bytes at `data`, a serialized sample (the 4-byte encapsulation header
/// first: CDR or PL_CDR, big or little endian, as Fast CDR accepts them), against `layout`. ok
/// when Fast CDR's generated code can read the sample with no allocation beyond what its bytes
/// back; bytes after the value are allowed (writers pad). Allocates nothing unless it fails.
CdrCheck checkCdrPayload(const CdrStructLayout& layout, const std::uint8_t* data,
                         std::size_t size_bytes);

/// The layout of the idl/ struct whose DDS type name is `dds_type` (e.g.
/// "tf2_msgs::msg::dds_::TFMessage_"), nullptr when idl/ has no such struct.
const CdrStructLayout* cdrLayoutOf(const std::string& dds_type);

/// Every struct of idl/, sorted by DDS type name: `count` layouts at the returned address.
const CdrStructLayout* const* cdrLayouts(std::size_t* count);

}  // namespace mlmap::dds
