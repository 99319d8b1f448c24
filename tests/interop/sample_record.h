#pragma once
/// @file
/// A canonical record of one received or sent message, shared by the Fast DDS talker and the
/// Cyclone DDS peer of the interoperability tests (no middleware in here, so both can include it).
///
/// Every field is written in declaration order, one per line, as `name value`: integers in
/// decimal, floating-point values as their exact bit pattern (hex, then the value for humans),
/// strings and byte sequences as their length followed by the raw bytes. Two records are equal
/// byte for byte exactly when the two messages are, so `cmp` on the files is the whole check.

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

namespace mlmap::interop {

class SampleRecord {
 public:
  explicit SampleRecord(const std::string& dds_type_name) : text_("type " + dds_type_name + "\n") {}

  void add(const char* name, std::int64_t value) { line(name, std::to_string(value)); }
  void addUnsigned(const char* name, std::uint64_t value) { line(name, std::to_string(value)); }
  void addBool(const char* name, bool value) { line(name, value ? "true" : "false"); }
  void addFloat(const char* name, float value) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &value, sizeof(bits));
    char buf[64];
    std::snprintf(buf, sizeof(buf), "0x%08x (%.9g)", bits, static_cast<double>(value));
    line(name, buf);
  }
  void addDouble(const char* name, double value) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &value, sizeof(bits));
    char buf[80];
    std::snprintf(buf, sizeof(buf), "0x%016llx (%.17g)", static_cast<unsigned long long>(bits),
                  value);
    line(name, buf);
  }
  /// A string of `size` bytes (a null `data` with size 0 is the empty string).
  void addString(const char* name, const char* data, std::size_t size) {
    addBytes(name, data, size);
  }
  /// A byte sequence: its length, a newline, the raw bytes, a newline.
  void addBytes(const char* name, const void* data, std::size_t size) {
    text_ += name;
    text_ += ' ';
    text_ += std::to_string(size);
    text_ += '\n';
    if (size > 0) text_.append(static_cast<const char*>(data), size);
    text_ += '\n';
  }

  [[nodiscard]] const std::string& text() const { return text_; }
  /// Writes the record to `path` (replacing it). False when the file cannot be written.
  [[nodiscard]] bool writeTo(const std::string& path) const {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(text_.data(), static_cast<std::streamsize>(text_.size()));
    return static_cast<bool>(out);
  }

 private:
  void line(const char* name, const std::string& value) {
    text_ += name;
    text_ += ' ';
    text_ += value;
    text_ += '\n';
  }

  std::string text_;
};

/// File name of a record: `<kind>_<sec>_<nanosec>.rec` (the header stamp names the message).
inline std::string recordFileName(const std::string& kind, std::int32_t sec,
                                  std::uint32_t nanosec) {
  return kind + "_" + std::to_string(sec) + "_" + std::to_string(nanosec) + ".rec";
}

}  // namespace mlmap::interop
